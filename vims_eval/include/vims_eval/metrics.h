#pragma once
/// @file metrics.h
/// @brief Absolute and relative trajectory errors, defined as evo defines them.
///
///  - ATE (translation):  e_i = |p_gt_i - p_est_aligned_i|               (evo_ape -r trans_part)
///  - rotation error:     angle of R_gt_i^T R_est_aligned_i, in degrees  (evo_ape -r angle_deg)
///  - RPE per delta metres of ground-truth path: pairs (i, j) chosen on the ground truth as
///    evo's filter_pairs_by_path with all_pairs=false (a pose index is kept each time the path
///    accumulated since the previous kept index reaches delta; consecutive kept indices form
///    the pairs); error pose E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j) with Q ground truth and P the
///    estimate; translation error |t(E)|, rotation error angle(R(E)) in degrees
///    (evo_rpe --delta 10 --delta_unit m --pairs_from_reference).

#include <string>
#include <utility>
#include <vector>

#include "vims_eval/alignment.h"
#include "vims_eval/association.h"

namespace vims {
namespace eval {

/// Summary statistics of a list of non-negative errors (evo's statistics; std is the
/// population standard deviation). count == 0 means "no data" and every value is 0.
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std = 0.0;
  double min = 0.0;
  double max = 0.0;

  static ErrorStats compute(const std::vector<double>& errors);
};

/// Sum of the distances between consecutive positions [m].
double pathLength(const std::vector<StampedPose>& poses);

/// |p_gt_i - p_est_i| for equal-length lists [m].
std::vector<double> translationErrors(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est);
/// Angle of R_gt_i^T R_est_i [deg], in [0, 180].
std::vector<double> rotationErrorsDeg(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est);
/// Tilt error [deg] per pose: the angle between the world's vertical seen from the true body and
/// from the estimated body (R^T e_z), i.e. the roll/pitch part of the attitude error. A rotation of
/// the estimate about the vertical (yaw alignment) does not change it.
std::vector<double> tiltErrorsDeg(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est);
/// |z_est_i - z_gt_i| for equal-length lists [m]: the vertical part of the translation error.
std::vector<double> heightErrors(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est);
/// Rotation angle of a unit quaternion [deg], in [0, 180].
double rotationAngleDeg(const Eigen::Quaterniond& q);

/// Index pairs (i, j), i < j, about delta_m of `reference` path apart (evo, consecutive pairs).
std::vector<std::pair<std::size_t, std::size_t>> pairsByPathLength(const std::vector<StampedPose>& reference,
                                                                   double delta_m);

struct RpeResult {
  double delta_m = 0.0;
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::vector<double> trans_errors_m;
  std::vector<double> rot_errors_deg;
  ErrorStats trans;  ///< [m] per delta_m of ground-truth path
  ErrorStats rot;    ///< [deg]
};

/// RPE of `est` against `gt` (equal length, associated) with pairs from the ground truth.
/// Invariant to a rigid alignment of `est`; a scale error shows up in full.
RpeResult computeRpe(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est, double delta_m);

/// Errors of one estimate after one kind of alignment.
struct AlignedErrors {
  AlignmentMode mode = AlignmentMode::kSe3;
  Similarity3 S_w_v;                     ///< the alignment applied to the estimate
  std::vector<StampedPose> est_aligned;  ///< T_w_b of the estimate in the ground-truth world
  std::vector<double> trans_errors_m;
  std::vector<double> rot_errors_deg;
  ErrorStats ate;             ///< translation ATE [m]
  double ate_rmse_pct = 0.0;  ///< ate.rmse as a percentage of the ground-truth distance travelled
  ErrorStats rot;             ///< rotation error [deg]
  ErrorStats tilt;            ///< tilt (roll/pitch) error [deg], tiltErrorsDeg
  /// Height error [m], heightErrors. After the posyaw alignment it shows a vertical drift, which an
  /// SE3 fit hides by tilting the whole estimate (and then reports as a rotation error).
  ErrorStats height;
  RpeResult rpe;
};

struct TrajectoryEvalOptions {
  AssociationOptions association;
  /// Alignments to evaluate; the first is the "primary" one used for the generic summary
  /// fields (rot_rmse_deg, rpe) and the plots.
  std::vector<AlignmentMode> alignments{AlignmentMode::kSe3, AlignmentMode::kSim3, AlignmentMode::kPosYaw,
                                        AlignmentMode::kNone};
  double rpe_delta_m = 10.0;
};

struct TrajectoryEvaluation {
  std::string label;
  AssociatedTrajectories associated;
  double gt_distance_m = 0.0;          ///< ground-truth path length over the associated poses
  double duration_s = 0.0;             ///< time between the first and the last associated pose
  std::vector<AlignedErrors> results;  ///< one per requested alignment, in the requested order

  const AlignedErrors& primary() const { return results.front(); }
  /// nullptr when that alignment was not requested.
  const AlignedErrors* find(AlignmentMode mode) const;
};

/// Associates, aligns and computes every metric. Throws std::runtime_error on an empty
/// association or when an alignment is impossible (too few or motionless poses).
TrajectoryEvaluation evaluateTrajectory(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                                        const TrajectoryEvalOptions& options, const std::string& label = "est");

/// Errors of already associated lists under one alignment.
AlignedErrors evaluateAligned(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                              AlignmentMode mode, double rpe_delta_m);

}  // namespace eval
}  // namespace vims
