#pragma once
/// @file relocalisation.h
/// @brief Teach and repeat, scored: how soon a repeat run relocalised into the teach run's saved
/// map, whether it relocalised at the right place, and how well the repeat run is placed in the
/// map's frame (docs/evaluation.md, "Relocalisation").
///
/// The map's frame is the teach run's global frame. Its relation to the world comes from the
/// teach run itself: its global trajectory aligned to its ground truth by position and yaw (the
/// four directions a visual-inertial map leaves free). The repeat run's global trajectory is then
/// compared with its own ground truth through that same transform, without aligning it again:
/// an error of the relocalisation stays in the figures.
///
///  - Entering the map: the first repeat ground-truth sample within map_radius_m (horizontally)
///    of the teach run's ground-truth track: over the mapped ground, not beside it.
///  - Relocalised: the run's first accepted loop into the loaded map (summary.yaml,
///    pose_graph.relocalised_t). Correct when the repeat pose at that time is within
///    correct_tol_m of the truth in the map's frame.
///  - Loops into the map: the repeat run's accepted loops whose match is a keyframe of the map
///    (loops.csv match_in_map), scored against the teach run's truth at t_match.
///  - ATE in the map's frame: RMSE and maximum of the position error of the repeat poses from the
///    relocalisation on, beside the teach run's own ATE (same alignment, its own poses).

#include <yaml-cpp/yaml.h>

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "vims_common/trajectory_io.h"
#include "vims_eval/loops.h"

namespace vims {
namespace eval {

struct RelocalisationOptions {
  /// The repeat run has entered the map within this of the teach track (1 m: at the lowest
  /// altitude, 2 m, the narrow side of the default camera's footprint is 2.3 m, so the two images
  /// share at least half of it)
  double map_radius_m = 1.0;
  double correct_tol_m = 0.5;  ///< a relocalisation further off than this is wrong
  double max_dt_s = 0.05;      ///< estimate-to-ground-truth association tolerance (interpolated)
};

/// What the repeat run reported about its relocalisation (summary.yaml of vims_offline).
struct RelocalisationReport {
  bool relocalised = false;
  double t_relocalised = 0.0;
};

struct RelocalisationEvaluation {
  std::optional<double> t_entered;  ///< first repeat truth sample over the teach track (none: never)
  bool relocalised = false;
  double t_relocalised = 0.0;
  double delay_s = 0.0;  ///< t_relocalised - t_entered (when both exist)
  double error_at_relocalisation_m = 0.0;
  bool correct = false;           ///< relocalised and within correct_tol_m
  std::size_t poses_after = 0;    ///< repeat poses from t_relocalised on, with ground truth
  double ate_after_rmse_m = 0.0;  ///< their position error in the map's frame
  double ate_after_max_m = 0.0;
  double teach_ate_rmse_m = 0.0;      ///< the teach run's own, after the same alignment
  std::size_t map_loops_correct = 0;  ///< accepted loops into the map within the scoring tolerance
  std::size_t map_loops_wrong = 0;    ///< ... and outside it
  /// ate_after_rmse_m / teach_ate_rmse_m (0 when either is missing).
  double ratio() const { return teach_ate_rmse_m > 0.0 && poses_after > 0 ? ate_after_rmse_m / teach_ate_rmse_m : 0.0; }
  /// "VIMS_EVAL_RELOC relocalised=.. correct=.. t_entered=.. delay_s=.. ..."
  std::string summaryLine() const;
};

/// Scores one repeat run; `repeat_loops` (scoreLoops of its loops.csv with the teach truth as
/// map_gt) adds the loops into the map. Throws std::runtime_error when the teach run's trajectory cannot be
/// aligned (fewer than two associated poses, no horizontal spread).
RelocalisationEvaluation evaluateRelocalisation(
    const std::vector<StampedPose>& teach_gt, const std::vector<StampedPose>& teach_global,
    const std::vector<StampedPose>& repeat_gt, const std::vector<StampedPose>& repeat_global,
    const RelocalisationReport& report, const RelocalisationOptions& options, const LoopScore* repeat_loops = nullptr);

/// The human-readable report (what `vims_eval relocalisation` prints before its summary line).
void printRelocalisationReport(std::ostream& out, const RelocalisationEvaluation& ev,
                               const RelocalisationOptions& options);
/// The figures as written to relocalisation.yaml.
YAML::Node relocalisationToYaml(const RelocalisationEvaluation& ev);

/// Reads pose_graph.relocalised / relocalised_t from a vims_offline summary.yaml. Throws
/// std::runtime_error naming the file and key when it is missing or malformed.
RelocalisationReport readRelocalisationReport(const std::string& summary_path);

}  // namespace eval
}  // namespace vims
