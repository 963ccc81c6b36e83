#pragma once
/// @file signature_csv_writer.h
/// @brief Writes magnetic signatures as `mag_signatures.csv` (columns documented in
/// docs/frontends.md): header row `t,E,N,U,snr,valid,coil,invalid_reason`; t is the window
/// centre [s, bag clock], E/N/U the signed amplitude [T], snr the coil-bin power ratio, valid 0/1,
/// coil the coil's index in the sequence's list, invalid_reason the SignatureFlag names joined by '|' (empty when
/// valid).

#include <fstream>
#include <string>

#include "vims_magnetometer/signature_extractor.h"

namespace vims {

class SignatureCsvWriter {
 public:
  /// Creates (truncates) the file and writes the header. Throws std::runtime_error if it cannot.
  explicit SignatureCsvWriter(const std::string& path);
  /// Appends one row. Throws std::runtime_error on an I/O error.
  void write(const SignatureWindow& signature);
  void flush();
  const std::string& path() const { return path_; }
  static const char* header();

 private:
  std::string path_;
  std::ofstream out_;
};

}  // namespace vims
