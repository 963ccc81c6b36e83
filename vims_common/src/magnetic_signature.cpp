#include "vims_common/magnetic_signature.h"

#include <algorithm>

namespace vims {

std::string signatureFlagsToString(unsigned flags) {
  std::string out;
  auto add = [&](unsigned bit, const char* name) {
    if (flags & bit) out += (out.empty() ? "" : "|") + std::string(name);
  };
  add(kSignatureGap, "gap");
  add(kSignatureNonFinite, "non_finite");
  add(kSignatureNoAttitude, "no_attitude");
  add(kSignatureLowSnr, "low_snr");
  return out;
}

Eigen::Vector3d canonicalSignature(const Eigen::Vector3d& amplitude) {
  Eigen::Index dominant = 0;
  amplitude.cwiseAbs().maxCoeff(&dominant);
  return amplitude[dominant] < 0.0 ? Eigen::Vector3d(-amplitude) : amplitude;
}

double signatureDistance(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::min((a - b).norm(), (a + b).norm());
}

Eigen::Vector3d alignedSignature(const Eigen::Vector3d& s, const Eigen::Vector3d& reference) {
  return s.dot(reference) < 0.0 ? Eigen::Vector3d(-s) : s;
}

}  // namespace vims
