#pragma once
/// @file report.h
/// @brief Human-readable tables, one-line machine-readable summaries, eval.yaml content and
/// PNG plots of trajectory and loop evaluations (format documented in docs/evaluation.md).

#include <yaml-cpp/yaml.h>

#include <ostream>
#include <string>
#include <vector>

#include "vims_eval/metrics.h"
#include "vims_eval/revisit.h"

namespace vims {
namespace eval {

/// Table of every requested alignment: ATE statistics, rotation error, RPE, scale.
void printTrajectoryReport(std::ostream& out, const TrajectoryEvaluation& ev);

/// `VIMS_EVAL label=<label> align=<primary> poses=<n> dist_m=... duration_s=...
///  ate_<mode>_m=... ate_<mode>_pct=... (per requested alignment) [scale=... when sim3]
///  rot_rmse_deg=... rpe<delta>_trans_m=... rpe<delta>_trans_pct=... rpe<delta>_rot_deg=...
///  rpe<delta>_pairs=...`; rot and rpe use the primary alignment; a value without data is `nan`.
/// Fixed-point text of a number with `decimals` digits, "nan" for a non-finite value, so tables
/// and summary lines stay parseable (Python's float() and awk both read "nan").
std::string formatFixed(double v, int decimals);

std::string trajectorySummaryLine(const TrajectoryEvaluation& ev);

YAML::Node trajectoryToYaml(const TrajectoryEvaluation& ev);

/// The global trajectory against the odometry of the same run: translation and rotation RMSE of
/// global over those of the VIO (primary alignment). Above 1 the loops and the pose graph made
/// the trajectory worse than the odometry they started from.
struct GlobalVsVio {
  double trans_ratio = 0.0;
  double rot_ratio = 0.0;
  bool globalBetter() const { return trans_ratio <= 1.0; }
};
GlobalVsVio compareGlobalWithVio(const TrajectoryEvaluation& global, const TrajectoryEvaluation& vio);
/// `VIMS_EVAL_GLOBAL_VS_VIO trans_ratio=... rot_ratio=... global_better=yes|no`
std::string globalVsVioSummaryLine(const GlobalVsVio& ratio);

/// Writes `<dir>/<label>_top.png` (x-y view of ground truth and the estimate after the primary
/// alignment, start/end markers) and `<dir>/<label>_ate.png` (translation error over time, one
/// curve per alignment). Creates `dir`. Returns the written paths.
std::vector<std::string> writeTrajectoryPlots(const TrajectoryEvaluation& ev, const std::string& dir);

void printLoopReport(std::ostream& out, const LoopEvaluation& ev, const LoopScoringOptions& loop_options,
                     const RevisitOptions& revisit_options);

/// `VIMS_EVAL_LOOPS verifications=... accepted=... correct=... wrong=... accepted_no_gt=...
///  rejected_correct=... precision=... revisit_events=... closed=... closed_pct=...`
std::string loopSummaryLine(const LoopEvaluation& ev);

YAML::Node loopsToYaml(const LoopEvaluation& ev, const LoopScoringOptions& loop_options,
                       const RevisitOptions& revisit_options);

/// `== revisit events near the coils ...` and one line per coil.
void printCoilRevisits(std::ostream& out, const std::vector<CoilRevisits>& coils, double radius_m);
/// `VIMS_EVAL_COILS coils=N coil0_events=... coil0_closed=... coil1_events=... ...`
std::string coilRevisitsSummaryLine(const std::vector<CoilRevisits>& coils);
/// A list of {coil, position_enu, events, closed}.
YAML::Node coilRevisitsToYaml(const std::vector<CoilRevisits>& coils);

/// Writes `<dir>/loops_top.png`: ground truth, revisit events, accepted loops drawn between
/// the ground-truth positions of query and match (green correct, red wrong). Creates `dir`.
std::vector<std::string> writeLoopPlots(const std::vector<StampedPose>& gt, const LoopEvaluation& ev,
                                        const std::string& dir);

/// Emits a node as block YAML (numbers were stored with 15 significant digits).
std::string emitYaml(const YAML::Node& node);
/// Writes emitYaml(node) to `path`; throws std::runtime_error on I/O failure.
void writeYamlFile(const std::string& path, const YAML::Node& node);

}  // namespace eval
}  // namespace vims
