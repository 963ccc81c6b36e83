#include "vims_magnetometer/signature_csv_writer.h"

#include <cstdio>
#include <stdexcept>

namespace vims {

const char* SignatureCsvWriter::header() { return "t,E,N,U,snr,valid,coil,invalid_reason"; }

SignatureCsvWriter::SignatureCsvWriter(const std::string& path) : path_(path), out_(path) {
  if (!out_) throw std::runtime_error("cannot write '" + path + "'");
  out_ << header() << "\n";
}

void SignatureCsvWriter::write(const SignatureWindow& s) {
  // Amplitudes in scientific notation with 6 significant digits (0.1 pT at 1 uT); the
  // extractor never produces non-finite values.
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%.6f,%.6e,%.6e,%.6e,%.4g,%d,%d,", s.t, s.amplitude_enu.x(), s.amplitude_enu.y(),
                s.amplitude_enu.z(), s.snr, s.valid ? 1 : 0, s.coil);
  out_ << buf << signatureFlagsToString(s.flags) << '\n';
  if (!out_) throw std::runtime_error("failed while writing '" + path_ + "'");
}

void SignatureCsvWriter::flush() {
  out_.flush();
  if (!out_) throw std::runtime_error("failed while writing '" + path_ + "'");
}

}  // namespace vims
