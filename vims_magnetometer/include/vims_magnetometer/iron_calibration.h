#pragma once
/// @file iron_calibration.h
/// @brief Hard- and soft-iron calibration of the magnetometer: the correction the front end
/// applies to every sample, and the fit that finds it from a calibration manoeuvre or a
/// mission's own turns (vims_mag_calib).
///
/// Model. The vehicle's iron turns the outside field h into the measurement
/// m = W h + b: b the hard iron (a constant field of magnetised parts, tesla), W the soft iron
/// (induced magnetisation, I plus a few percent). The correction is h = K (m - b), K = W^-1.
/// Everything the magnetometer measures passes through it, the geomagnetic field and the coil's
/// alternating field alike, so an uncorrected soft iron scales and skews the place signatures and
/// an uncorrected hard iron biases the geomagnetic yaw by up to asin(|b_h| / B_h).
///
/// Fit. Turning the vehicle through the constant geomagnetic field, the corrected field keeps one
/// magnitude: the measurements lie on an ellipsoid whose centre is b and whose shape is W.
///  - Full (3D): when the field directions cover the sphere (a calibration manoeuvre: pitch and
///    roll as well as heading, e.g. the vehicle turned by hand on deck or tumbled at the surface),
///    the residual |K (m - b)| - F is minimised over b (3), the symmetric K (6) and F.
///  - Horizontal: a mission's level turns only sweep the heading. In the level frame (up, the
///    body's up direction from the accelerometer, so a few degrees of pitch and roll are levelled
///    and not fitted as iron) the corrected field keeps its horizontal magnitude and its vertical
///    component: |up x K (m - b)| = B_h and up.K (m - b) = B_z, fitted over b (3; b_z shows
///    through the tilt), K's x-y block (trace kept), its cross terms K_xz = K_zx and K_yz = K_zy
///    (a heading-dependent vertical component), B_h and B_z. K_zz stays 1: with the vertical
///    field constant, a vertical gain looks like another vertical field.
/// Without a reference the field's overall scale is not observable: F (or B_h) is fitted with
/// trace(K) fixed (to 3, or 2 in the horizontal block), which keeps the sensor's mean gain. The
/// site's total field (a World Magnetic Model value) may be given instead, and then sets F and
/// frees the trace (full fit only).

#include <Eigen/Core>
#include <string>
#include <vector>

#include "vims_common/sensor_data.h"

namespace vims {

/// h = K (m - b): applied to each magnetometer sample before anything else.
struct IronCorrection {
  Eigen::Vector3d hard_iron_t = Eigen::Vector3d::Zero();            ///< b [T], in the mag frame
  Eigen::Matrix3d soft_iron_inverse = Eigen::Matrix3d::Identity();  ///< K = W^-1
  bool isIdentity() const { return hard_iron_t.isZero(0.0) && soft_iron_inverse.isIdentity(0.0); }
  Eigen::Vector3d apply(const Eigen::Vector3d& m) const { return soft_iron_inverse * (m - hard_iron_t); }
};

/// One block of the calibration data: the mean field and, when the IMU was there, the mean
/// specific force (at rest it points up, contract), both in the mag frame.
struct IronFitSample {
  Eigen::Vector3d field_t = Eigen::Vector3d::Zero();
  Eigen::Vector3d specific_force = Eigen::Vector3d::Zero();
  bool has_specific_force = false;
};

/// Averages the magnetometer and IMU over blocks of `block_s` seconds: the coil's line, the
/// thrusters' lines and the noise average out, the turns (< 0.1 Hz) stay. A block's specific
/// force is used only when | |f| - gravity | < accel_gate (the vehicle not accelerating).
class IronFitSampler {
 public:
  /// `R_b_m` (the rotation of T_b_m) turns the body's specific force into the mag frame.
  IronFitSampler(double block_s, double gravity, double accel_gate_mps2,
                 const Eigen::Matrix3d& R_b_m = Eigen::Matrix3d::Identity());
  void feedImu(const ImuSample& sample);
  void feedMag(const MagSample& sample);
  /// Closes the last block; the samples so far, in time order.
  std::vector<IronFitSample> finish();

 private:
  void closeBlock();
  double block_s_, gravity_, accel_gate_;
  Eigen::Matrix3d R_m_b_;
  double block_start_ = 0.0;
  bool open_ = false;
  Eigen::Vector3d mag_sum_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d force_sum_ = Eigen::Vector3d::Zero();
  long mag_count_ = 0, force_count_ = 0;
  std::vector<IronFitSample> samples_;
};

enum class IronFitModel { kFull, kHorizontal };

struct IronFitOptions {
  /// The full fit needs field directions in every dimension: the smallest eigenvalue of the
  /// fields' covariance over the largest at least this (a uniform sphere gives 1, level turns
  /// ~0.001: the tilt's few degrees). Below it the horizontal fit is used.
  double min_full_spread_ratio = 0.05;
  /// The horizontal fit needs the heading turned through at least this [deg] (the largest gap
  /// between the blocks' horizontal field directions at most 360 minus it).
  double min_heading_coverage_deg = 270.0;
  /// The site's total field [T] when known (World Magnetic Model): sets F of the full fit.
  /// 0: F is fitted with trace(K) = 3.
  double site_field_t = 0.0;
  int max_iterations = 100;
};

struct IronFitResult {
  bool ok = false;
  std::string why;  ///< when !ok: what the data lack
  IronFitModel model = IronFitModel::kFull;
  IronCorrection correction;
  int samples = 0;
  double field_t = 0.0;           ///< fitted F (full) or B_h (horizontal) [T]
  double vertical_field_t = 0.0;  ///< fitted B_z (horizontal model) [T]
  double spread_ratio = 0.0;      ///< the fields' covariance, smallest over largest eigenvalue
  double heading_coverage_deg = 0.0;
  /// rms of the magnitude (horizontal: of the horizontal magnitude and the vertical component)
  /// about its mean, raw; and the fit's residual rms, corrected
  double rms_before_t = 0.0;
  double rms_after_t = 0.0;
};

/// Fits the correction; never throws on data (too few samples or too little turning: ok = false
/// and `why` says what manoeuvre is missing).
IronFitResult fitIronCorrection(const std::vector<IronFitSample>& samples, const IronFitOptions& options);

const char* ironFitModelName(IronFitModel model);

/// The fit as a system-configuration file holding only `magnetometer.iron_correction` (what
/// vims_mag_calib writes; pass it as one more --config / config_file after the others), headed by
/// comments giving the fit's model, samples and residuals.
std::string ironCorrectionConfigYaml(const IronFitResult& fit);

/// `VIMS_MAG_CALIB ok=... model=... samples=... spread=... heading_coverage_deg=... rms_before_nt=...
///  rms_after_nt=... field_ut=... hard_iron_ut=x,y,z gains=g1,g2,g3` (gains: K's eigenvalues).
std::string ironFitSummaryLine(const IronFitResult& fit);

}  // namespace vims
