#pragma once
/// @file signature_csv_writer.h
/// @brief Writes magnetic signatures as `mag_signatures.csv` (columns documented in
/// docs/frontends.md): header row `t,E,N,U,snr,valid,coil,invalid_reason`; t is the window
/// centre [s, bag clock], E/N/U the signed amplitude [T], snr the coil-bin power ratio, valid 0/1,
/// coil the coil's index in the sequence's list, invalid_reason the SignatureFlag names joined by '|' (empty when
/// valid).

#include <string>

#include "vims_common/csv_writer.h"
#include "vims_magnetometer/signature_extractor.h"

namespace vims {

/// The format of `mag_signatures.csv` (CsvWriter).
struct SignatureCsv {
  using Row = SignatureWindow;
  static const char* header();
  static std::string row(const SignatureWindow& signature);
};
using SignatureCsvWriter = CsvWriter<SignatureCsv>;

}  // namespace vims
