#include "vims_magnetometer/signature_csv_writer.h"

#include <cstdio>

namespace vims {

const char* SignatureCsv::header() { return "t,E,N,U,snr,valid,coil,invalid_reason"; }

std::string SignatureCsv::row(const SignatureWindow& s) {
  // Amplitudes in scientific notation with 6 significant digits (0.1 pT at 1 uT); the
  // extractor never produces non-finite values.
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%.6f,%.6e,%.6e,%.6e,%.4g,%d,%d,", s.t, s.amplitude_enu.x(), s.amplitude_enu.y(),
                s.amplitude_enu.z(), s.snr, s.valid ? 1 : 0, s.coil);
  return buf + signatureFlagsToString(s.flags);
}

}  // namespace vims
