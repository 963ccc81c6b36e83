#pragma once
/// @file association.h
/// @brief Pairs estimated poses with ground-truth poses by timestamp.
///
/// Two modes:
///  - nearest stamp (evo's `associate_trajectories`): the shorter trajectory's stamps are
///    matched to the nearest stamp of the longer one, a pair is kept when |dt| <= max_dt_s.
///    Unlike evo, a stamp of either trajectory is used at most once: when two stamps pick
///    the same partner, the closer pair wins (so a 10 Hz estimate against 50 Hz ground
///    truth, or the reverse, never counts one ground-truth pose twice).
///  - interpolation: every estimate stamp inside the ground truth's time span gets a ground
///    truth pose interpolated between its two neighbours (linear position, slerp rotation),
///    unless those neighbours are more than max_gt_gap_s apart (a ground-truth dropout).

#include <optional>
#include <string>
#include <vector>

#include "vims_common/trajectory_io.h"

namespace vims {
namespace eval {

struct AssociationOptions {
  double max_dt_s = 0.01;     ///< nearest-stamp tolerance (evo's --t_max_diff default)
  bool interpolate = false;   ///< interpolate ground truth at the estimate's stamps
  double max_gt_gap_s = 0.5;  ///< interpolation never bridges a ground-truth gap longer than this
};

/// Equal-length, time-ordered pose lists: gt[i] (T_w_b, ground truth world w) and est[i]
/// (T_v_b, the estimator's own world v) belong to the same instant.
struct AssociatedTrajectories {
  std::vector<StampedPose> gt;
  std::vector<StampedPose> est;
  std::size_t gt_total = 0;   ///< poses in the ground-truth file
  std::size_t est_total = 0;  ///< poses in the estimate file
  double max_abs_dt_s = 0.0;  ///< largest |t_gt - t_est| among the pairs (0 when interpolated)

  std::size_t size() const { return est.size(); }
  bool empty() const { return est.empty(); }
};

/// Associates `est` with `gt` (both sorted by time, as readTumFile guarantees).
/// Throws std::runtime_error when no pair is found, with the two time spans in the message,
/// because an empty association almost always means wrong files or a clock offset.
AssociatedTrajectories associate(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                                 const AssociationOptions& options);

/// Pose of `traj` (sorted by time) at time t: linear position and slerp between the two
/// neighbouring samples. A sample within 1e-9 s of t is returned as is. Returns nullopt when t
/// is outside [front.t, back.t] or the neighbours are more than max_gap_s apart.
std::optional<StampedPose> interpolatePose(const std::vector<StampedPose>& traj, double t, double max_gap_s);

}  // namespace eval
}  // namespace vims
