#pragma once
/// @file magnetic_signature.h
/// @brief The magnetic front end's outputs (vims_magnetometer's SignatureExtractor) and the one
/// way to compare signatures, as the pose graph, the ROS conversions and the evaluation use them.
/// Here, not in vims_magnetometer, so the back ends depend on the results and not on the front end.

#include <Eigen/Core>
#include <string>

namespace vims {

/// Reasons a window is invalid (bit flags).
enum SignatureFlag : unsigned {
  kSignatureGap = 1u << 0,         ///< missing samples
  kSignatureNonFinite = 1u << 1,   ///< a NaN/inf sample
  kSignatureNoAttitude = 1u << 2,  ///< no attitude (not initialised yet, IMU gap)
  kSignatureLowSnr = 1u << 3,      ///< SNR below min_snr
};
/// "gap|no_attitude|..." ("" when valid).
std::string signatureFlagsToString(unsigned flags);

/// One spectral window's magnetic signature.
struct SignatureWindow {
  double t = 0.0;        ///< window centre [s]
  double t_start = 0.0;  ///< first sample of the window [s]
  double t_end = 0.0;    ///< last sample of the window [s]
  /// The coil this window measures: its index in the sequence's coil_frequency_hz list (0 for
  /// the first or only coil). Signatures of different coils are never compared.
  int coil = 0;
  double frequency_hz = 0.0;
  Eigen::Vector3d amplitude_enu = Eigen::Vector3d::Zero();     ///< signed peak amplitude [T], ENU
  Eigen::Vector3d geomagnetic_body = Eigen::Vector3d::Zero();  ///< mean geomagnetic field [T], body
  double snr = 0.0;
  bool valid = false;
  unsigned flags = 0;  ///< SignatureFlag bits (0 when valid)
};

/// The low-passed geomagnetic field in the body frame.
struct GeomagneticSample {
  double t = 0.0;                                     ///< centre of the moving average [s]
  Eigen::Vector3d field_b = Eigen::Vector3d::Zero();  ///< [T]
  double std_per_axis = 0.0;                          ///< noise of the average: noise_std / sqrt(N) [T]
};

/// The extractor's sign convention applied to any amplitude vector (e.g. an analytic peak field,
/// for evaluation): the vector or its negative, whichever has a positive dominant (largest |.|) component.
Eigen::Vector3d canonicalSignature(const Eigen::Vector3d& amplitude);

/// A signature is a field amplitude up to sign (the coil's phase is unknown): the convention
/// above flips the whole vector wherever the dominant axis changes (e.g. |E| = |N| on the path),
/// so two windows of the same place may carry opposite signs. Compare and average signatures
/// only through these two functions.
/// Distance of two signatures: min(|a - b|, |a + b|) [T].
double signatureDistance(const Eigen::Vector3d& a, const Eigen::Vector3d& b);
/// `s` or -s, whichever is nearer to `reference` (to average signatures of one place).
Eigen::Vector3d alignedSignature(const Eigen::Vector3d& s, const Eigen::Vector3d& reference);

}  // namespace vims
