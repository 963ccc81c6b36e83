#pragma once
/// @file loops.h
/// @brief Reading the loop-closure log `loops.csv` and scoring each verification attempt
/// against the ground truth.
///
/// loops.csv: a header row naming the columns (order free, extra columns ignored), then one
/// row per loop verification attempt:
///   t_query, t_match   stamps [s] of the query keyframe and of the matched keyframe
///   accepted           1/0 or true/false: whether the loop was added to the pose graph
///   x,y,z,qx,qy,qz,qw  T_match_query: the query body frame in the matched keyframe's body
///                      frame (Hamilton quaternion); must be finite for every row
///   inliers            integer; may be empty (then -1)
///   mag_distance, bow_score  diagnostic numbers; may be empty or "nan" (then NaN)
///   stage              free text without commas (which check accepted/rejected it)
/// '#' lines and blank lines are skipped.

#include <Eigen/Geometry>
#include <istream>
#include <string>
#include <vector>

#include "vims_common/trajectory_io.h"

namespace vims {
namespace eval {

struct LoopRecord {
  int line = 0;  ///< line in the CSV (1-based), for messages
  double t_query = 0.0;
  double t_match = 0.0;
  bool accepted = false;
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  int inliers = -1;
  double mag_distance = 0.0;
  double bow_score = 0.0;
  std::string stage;
  /// The match is a keyframe of a loaded map (column match_in_map, 0 when absent): t_match is on
  /// the map's run's clock and its truth is that run's.
  bool match_in_map = false;
};

/// Parses a loop log. Throws std::runtime_error "<source>:<line>: <problem>" for a missing
/// header column, a wrong field count, a non-number, a non-finite pose or a zero quaternion.
std::vector<LoopRecord> parseLoopCsv(std::istream& in, const std::string& source_name);
/// Same for a file; throws when it cannot be opened.
std::vector<LoopRecord> readLoopCsv(const std::string& path);

struct LoopScoringOptions {
  double trans_tol_m = 0.5;   ///< |t_est - t_gt| of T_match_query below which a loop is correct
  double rot_tol_deg = 5.0;   ///< angle(R_gt^T R_est) of T_match_query below which a loop is correct
  double max_gt_gap_s = 0.5;  ///< ground truth is interpolated only across gaps up to this
};

struct ScoredLoop {
  LoopRecord record;
  bool has_gt = false;  ///< false when either stamp is outside the ground truth (or in a gap)
  Eigen::Isometry3d T_match_query_gt = Eigen::Isometry3d::Identity();
  Eigen::Vector3d p_w_query_gt = Eigen::Vector3d::Zero();  ///< ground-truth positions, for plots
  Eigen::Vector3d p_w_match_gt = Eigen::Vector3d::Zero();
  double trans_error_m = 0.0;
  double rot_error_deg = 0.0;
  bool within_tolerance = false;  ///< the relative pose is right (whether accepted or not)
};

struct LoopScore {
  std::size_t verifications = 0;  ///< rows of the log (verification attempts)
  std::size_t accepted = 0;
  std::size_t correct = 0;           ///< accepted and within tolerance
  std::size_t wrong = 0;             ///< accepted and outside tolerance
  std::size_t accepted_no_gt = 0;    ///< accepted, but no ground truth at a stamp (not scored)
  std::size_t rejected_correct = 0;  ///< rejected although the relative pose was within tolerance
  std::vector<ScoredLoop> loops;     ///< one per row, in file order

  /// correct / accepted (1 when nothing was accepted: no false loop was made).
  double precision() const;
};

/// Scores each row against the ground truth: the query's pose from `gt`, the match's from `gt`
/// too, or from `map_gt` (the loaded map's run) for a row whose match is in a loaded map. Without
/// `map_gt` such rows have no ground truth (counted in accepted_no_gt, not scored).
LoopScore scoreLoops(const std::vector<LoopRecord>& records, const std::vector<StampedPose>& gt,
                     const LoopScoringOptions& options, const std::vector<StampedPose>* map_gt = nullptr);

/// How far the accepted loops' relative poses are from the ground truth's (the loop edges the
/// pose graph got; wrong ones included): median and 90th percentile of the translation error
/// and median of the rotation error. NaN when no accepted loop has ground truth.
struct LoopAccuracy {
  std::size_t loops = 0;
  double trans_error_median_m = 0.0;
  double trans_error_p90_m = 0.0;
  double rot_error_median_deg = 0.0;
};
LoopAccuracy loopAccuracy(const LoopScore& score);

}  // namespace eval
}  // namespace vims
