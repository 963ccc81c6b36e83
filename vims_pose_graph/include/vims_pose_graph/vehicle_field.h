#pragma once
/// @file vehicle_field.h
/// @brief The vehicle's own magnetic field at its magnetometer, estimated online from the mission
/// and taken out of the geomagnetic field before the yaw gate (docs/pose_graph.md, "Vehicle field").
///
/// The thrusters' motors and their supply cables carry a current that follows the thrust, and a
/// current makes a field: at the magnetometer it is a body-fixed offset growing with the thrust
/// (a thrust-following hard iron, several uT on a small AUV). Low-passing does not remove it: it
/// changes as slowly as the vehicle's speed. The thrust an AUV needs balances the hull's drag
/// (linear and quadratic in the forward speed v) and its inertia (its forward acceleration a), so
/// the offset is modelled as
///   field_b = R_odom_b^T F_odom + b0 + b_v v + b_vv v|v| + b_a a + noise,
/// with F_odom the geomagnetic field in the VIO's odometry frame (one per VIO session) and the
/// four body-frame vectors b0 (the vehicle's constant hard iron), b_v, b_vv, b_a the unknowns.
/// The VIO gives R_odom_b and the forward motion; the model is linear in every unknown, so it is
/// a least-squares fit of normal equations accumulated sample by sample (the sessions' fields
/// eliminated in closed form since R R^T = I), with older samples forgotten over memory_s and a
/// prior of zero vehicle field (prior_ut) that settles what the motion does not observe: flying
/// level, b0's vertical part is the same as the field's; on one heading, its horizontal part is a
/// constant heading error no magnetometer can tell from the site's declination.

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

namespace vims {

template <typename Options>
class OptionTable;

struct VehicleFieldOptions {
  /// false: the measured field goes to the gate as it is.
  bool enabled = true;
  /// [s] Samples older than this weigh 1/e as much as a new one: long enough to see the thrust
  /// change many times (every turn, every leg), short against the VIO's yaw drift (which the
  /// session's field absorbs only as a constant).
  double memory_s = 600.0;
  /// [T] (key prior_ut) Prior standard deviation of each of the model's vectors (the field per
  /// unit of its regressor): a small AUV's motors make a few uT at the magnetometer.
  double prior_tesla = 20e-6;
  /// [T] (key residual_nt) What the model leaves per axis: the VIO's attitude error (0.1 deg of a
  /// 50 uT field: 90 nT) and the low-passed noise. It weighs the prior against the data.
  double residual_tesla = 100e-9;
  /// The correction is applied from this many samples on (20 s of keyframes: before, the fit
  /// rests on a few seconds of one heading and speed).
  int min_samples = 50;
  /// ... and only while the fit explains at least this fraction of the samples' spread about the
  /// sessions' fields (explainedFraction). A vehicle with a field of its own: 0.99 and more (a
  /// 3 uT thrust-following offset); a clean one: 0.4-0.6 (the model then fits the VIO's attitude
  /// errors, tens of nT); a disturbed site's field is not the vehicle's and fits as badly.
  double min_explained_fraction = 0.9;

  static const OptionTable<VehicleFieldOptions>& optionTable();
};

/// The vehicle's forward motion at a keyframe, from the VIO (the model's regressors).
struct ForwardMotion {
  double speed_mps = 0.0;   ///< v: velocity along the body's x (forward) axis
  double accel_mps2 = 0.0;  ///< a: acceleration along it
};

/// A keyframe's time and position in the odometry frame.
struct TimedPosition {
  double t = 0.0;
  Eigen::Vector3d p_odom = Eigen::Vector3d::Zero();
};

/// The forward motion at time t of a keyframe with attitude R_odom_b, from keyframes of its VIO
/// session around it: the first and second derivatives at t of the parabola fitted to their
/// positions by least squares. nullopt with fewer than three distinct times.
std::optional<ForwardMotion> forwardMotion(const std::vector<TimedPosition>& positions, double t,
                                           const Eigen::Matrix3d& R_odom_b);

class VehicleFieldEstimator {
 public:
  static constexpr int kRegressors = 4;  ///< 1, v, v|v|, a
  static constexpr int kUnknowns = 3 * kRegressors;
  using Vector = Eigen::Matrix<double, kUnknowns, 1>;
  using Matrix = Eigen::Matrix<double, kUnknowns, kUnknowns>;

  explicit VehicleFieldEstimator(const VehicleFieldOptions& options);

  /// Adds a measured body-frame field at time t (non-decreasing) of a node of VIO session
  /// `session` with attitude R_odom_b and forward motion `motion`. Non-finite inputs are ignored.
  void add(uint32_t session, double t, const Eigen::Matrix3d& R_odom_b, const Eigen::Vector3d& field_b,
           const ForwardMotion& motion);
  /// Whether the fit is used: enabled, min_samples reached, min_explained_fraction explained.
  bool applied() const;
  /// The vehicle's field [T, body] at `motion` under the current fit; zero while not applied().
  Eigen::Vector3d vehicleField(const ForwardMotion& motion) const;
  /// The current fit at `motion`, applied or not.
  Eigen::Vector3d fittedField(const ForwardMotion& motion) const;
  /// The fitted vectors [b0, b_v, b_vv, b_a] stacked (T, T/(m/s), T/(m/s)^2, T/(m/s^2)).
  const Vector& parameters() const { return parameters_; }
  /// The fit's RMS residual per axis over the samples it rests on (weighted) [T]; NaN before.
  double residualRms() const;
  size_t numSamples() const { return num_samples_; }
  /// 1 - (the fit's residual sum of squares) / (that of the sessions' fields alone): how much of
  /// the samples' disagreement the vehicle's field explains (0 before any sample).
  double explainedFraction() const;

  /// The regressors' row (1, v, v|v|, a).
  static Eigen::Matrix<double, kRegressors, 1> regressors(const ForwardMotion& motion);

 private:
  /// Normal equations of one session's samples, its field not yet eliminated.
  struct SessionSums {
    double weight = 0.0;  ///< sum w (A_FF = weight I)
    Eigen::Matrix<double, 3, kUnknowns> A_Ftheta = Eigen::Matrix<double, 3, kUnknowns>::Zero();
    Eigen::Vector3d b_F = Eigen::Vector3d::Zero();
  };
  void forget(double t);
  void solve();
  /// The minimiser of theta^T H theta - 2 g^T theta with the three thrust-following vectors
  /// parallel (one current makes them: b_v, b_vv, b_a = c_v d, c_vv d, c_a d).
  static Vector rankOneThrustFit(const Matrix& H, const Vector& g);

  VehicleFieldOptions options_;
  std::map<uint32_t, SessionSums> sessions_;
  Matrix A_theta_ = Matrix::Zero();  ///< sum w Phi^T Phi over every session
  Vector b_theta_ = Vector::Zero();  ///< sum w Phi^T y
  double yy_ = 0.0;                  ///< sum w y^T y (for the residual)
  double total_weight_ = 0.0;
  double latest_t_ = -1e300;
  Vector parameters_ = Vector::Zero();
  double residual_sum_ = 0.0;                 ///< weighted residual sum of squares at the last solve
  double constant_field_residual_sum_ = 0.0;  ///< the same with no vehicle field
  size_t num_samples_ = 0;
};

}  // namespace vims
