#pragma once
/// @file alignment.h
/// @brief Aligning an estimated trajectory (in its own world frame v) to the ground truth
/// (world frame w) before computing absolute errors.
///
/// All alignments are least squares on the associated positions only (as evo `-a` / `-as`,
/// which align with every associated pose):
///  - se3:    Umeyama rotation + translation, no scale.
///  - sim3:   Umeyama rotation + translation + scale (for monocular-like scale drift).
///  - posyaw: yaw about world z + translation (4-DoF), the unobservable directions of a
///            visual-inertial estimator whose roll and pitch are fixed by gravity.
///  - none:   the estimate is compared as is.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "vims_common/trajectory_io.h"

namespace vims {
namespace eval {

enum class AlignmentMode { kNone, kSe3, kSim3, kPosYaw };

/// "none", "se3", "sim3", "posyaw".
const char* alignmentModeName(AlignmentMode mode);
/// Parses a name of alignmentModeName; throws std::invalid_argument listing the valid names.
AlignmentMode parseAlignmentMode(const std::string& name);

/// A similarity transform S_w_v mapping points of the estimate's world frame v into the
/// ground-truth world frame w: p_w = scale * R_w_v * p_v + t_w_v.
struct Similarity3 {
  double scale = 1.0;
  Eigen::Matrix3d R_w_v = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_w_v = Eigen::Vector3d::Zero();

  Eigen::Vector3d transformPoint(const Eigen::Vector3d& p_v) const { return scale * R_w_v * p_v + t_w_v; }
  /// T_v_b -> T_w_b: the position is mapped by the similarity, the orientation rotated by R_w_v
  /// (scale does not act on rotations, as in evo).
  StampedPose transformPose(const StampedPose& T_v_b) const;
  std::vector<StampedPose> transformPoses(const std::vector<StampedPose>& poses_v) const;
};

/// Umeyama (1991) least-squares alignment: minimises sum |p_w_i - (s R p_v_i + t)|^2 with
/// s = 1 unless with_scale. Needs >= 3 pairs and non-zero spread of p_v (throws
/// std::runtime_error otherwise); a reflection is never returned.
Similarity3 umeyamaAlignment(const std::vector<Eigen::Vector3d>& points_v, const std::vector<Eigen::Vector3d>& points_w,
                             bool with_scale);

/// Closed-form 4-DoF alignment: minimises sum |p_w_i - (R_z(yaw) p_v_i + t)|^2. Needs >= 2 pairs
/// and horizontal spread of p_v (throws std::runtime_error otherwise).
Similarity3 positionYawAlignment(const std::vector<Eigen::Vector3d>& points_v,
                                 const std::vector<Eigen::Vector3d>& points_w);

/// Alignment of `est` (T_v_b) to `gt` (T_w_b), equal length, by `mode`.
Similarity3 computeAlignment(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                             AlignmentMode mode);

}  // namespace eval
}  // namespace vims
