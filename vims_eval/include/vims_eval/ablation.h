#pragma once
/// @file ablation.h
/// @brief The paper's ablation study (Table "Quantitative Results of Ablation Study") as one
/// command: run `vims_offline` once per variant, evaluate every run with the library's own
/// trajectory and loop scoring, and format the table (console, markdown, CSV).
/// docs/evaluation.md, "Ablation".

#include <ostream>
#include <string>
#include <vector>

#include "vims_common/trajectory_io.h"
#include "vims_eval/eval_options.h"

namespace vims {
namespace eval {

/// The six variants in the paper's row order.
const std::vector<std::string>& ablationModes();
/// The paper's row name of a mode ("VI-SLAM", "w/o Sonar", ..., "Full VIMS"); the mode itself
/// for an unknown name.
std::string ablationMethodName(const std::string& mode);

/// One row of the table: the evaluation of one variant's run, or why it has none.
struct AblationRow {
  std::string mode;
  bool ok = false;
  std::string error;  ///< why the variant has no figures (when !ok)

  bool has_loops = false;  ///< loops.csv was present and scored
  std::size_t verifications = 0;
  std::size_t accepted = 0;
  std::size_t correct = 0;
  std::size_t wrong = 0;
  std::size_t revisit_events = 0;
  std::size_t revisit_closed = 0;

  double trans_rmse_m = 0.0;      ///< global.tum ATE RMSE after SE3 alignment
  double trans_pct = 0.0;         ///< of the ground-truth distance
  double rot_rmse_deg = 0.0;      ///< global.tum rotation error RMSE after SE3 alignment
  double vio_trans_rmse_m = 0.0;  ///< vio.tum ATE RMSE (SE3), NaN when absent
  /// Query stamps of the correct accepted loops, in file order (magneticStageRecall).
  std::vector<double> correct_loop_query_times;
  double real_time_factor = 0.0;  ///< from summary.yaml, NaN when absent

  /// trans_rmse_m / vio_trans_rmse_m: above 1 the loops and the pose graph made the trajectory
  /// worse than the odometry (NaN without vio.tum).
  double globalOverVio() const { return trans_rmse_m / vio_trans_rmse_m; }
};

/// Evaluates the outputs of one vims_offline run (global.tum, vio.tum, loops.csv, summary.yaml)
/// against `gt`. Never throws: a missing or unusable global.tum gives a row with ok = false and
/// the reason; missing loops.csv / vio.tum / summary keys give NaN / has_loops = false.
AblationRow evaluateAblationRun(const std::string& mode, const std::string& run_dir, const std::vector<StampedPose>& gt,
                                const EvalOptions& options);

/// Reads sequence duration / wall time from summary.yaml defensively: `real_time_factor`, else
/// `sequence_duration_s / wall_time_s`; NaN when neither is there or the file is unreadable.
double readRealTimeFactor(const std::string& summary_yaml_path);

/// "correct/verifications" ("n/a" without loops.csv).
std::string loopClosingCell(const AblationRow& row);
/// The table in GitHub markdown (header, one line per row; a failed row says "failed: <why>").
std::string ablationMarkdown(const std::vector<AblationRow>& rows);
/// The table as CSV: header row, then one row per variant; numbers with full precision, "nan"
/// for missing values; the error text is quoted.
std::string ablationCsv(const std::vector<AblationRow>& rows);
/// `VIMS_ABLATION mode=... status=ok|failed correct=... verifications=... trans_rmse_m=... ...`
std::string ablationSummaryLine(const AblationRow& row);

/// What the magnetic stage keeps of the places vision alone finds: of the query keyframes that
/// `vision` (w/o Alter.: BoW over the whole map) closed with a correct loop, how many `full`
/// (magnetic candidates first) also closed, at the same keyframe and within `window_s`.
struct MagneticStageRecall {
  std::size_t vision_queries = 0;  ///< queries closed by the vision-only run
  std::size_t same_query = 0;      ///< of them, closed by full at the same keyframe
  std::size_t within_window = 0;   ///< of them, full has a correct loop within window_s
  std::size_t full_only = 0;       ///< queries full closed that the vision-only run did not
  double window_s = 5.0;
};
MagneticStageRecall magneticStageRecall(const AblationRow& full, const AblationRow& vision, double window_s = 5.0);

/// One of the paper's claims about the ablation, checked on the rows.
struct AblationClaim {
  std::string name;       ///< e.g. "full_lowest_trans"
  std::string statement;  ///< the claim in words
  bool holds = false;
  std::string detail;  ///< the figures it was judged on
};
/// The paper's ablation order, for the rows present (a claim whose modes are missing or failed is
/// left out): the full system's global trajectory is not worse than its VIO (global / VIO <= 1);
/// it has the lowest translation RMSE of all modes; w/o Geom. has a larger rotation RMSE; VI-SLAM,
/// w/o Alter. and w/o ORB each close fewer revisit events than full, or as many with more
/// verifications.
std::vector<AblationClaim> ablationClaims(const std::vector<AblationRow>& rows);
/// The claims as a markdown list, and as `VIMS_ABLATION_ORDER holds=k/n name=0|1 ...`.
std::string ablationClaimsMarkdown(const std::vector<AblationClaim>& claims);
std::string ablationClaimsLine(const std::vector<AblationClaim>& claims);

/// What `vims_eval ablation` does.
struct AblationOptions {
  std::string sequence_dir;
  std::string out_dir;
  std::vector<std::string> modes = ablationModes();
  int jobs = 2;                ///< vims_offline processes at a time
  std::string offline_binary;  ///< path of vims_offline
  std::string offline_config;  ///< passed as --config when not empty
  bool run = true;             ///< false: evaluate existing OUT/<mode>/ runs only
  bool figures = true;         ///< trajectory and map figures (and place recognition when possible)
  std::string package_root;    ///< for vocabulary paths (place recognition)
  EvalOptions eval;
};

/// Result of running one child process.
struct ProcessResult {
  int exit_code = -1;  ///< exit status, or -1 when it could not start / was killed
  std::string error;   ///< start failure or signal, empty on a normal exit
};

/// Runs `commands` (argv vectors), at most `jobs` at a time, each with stdout and stderr to
/// its log file. Returns one result per command, in order. Never throws for a failing command.
std::vector<ProcessResult> runProcesses(const std::vector<std::vector<std::string>>& commands,
                                        const std::vector<std::string>& log_files, int jobs, std::ostream& progress);

/// The directory of the running executable (/proc/self/exe), empty when unknown.
std::string executableDir();

/// Runs the variants, evaluates them, writes OUT/ablation.md, OUT/ablation.csv and the figures,
/// prints the table. Returns the rows. Throws std::runtime_error for a missing sequence or
/// ground truth (nothing can be evaluated); a failing variant only makes a failed row.
std::vector<AblationRow> runAblation(const AblationOptions& options, std::ostream& out, std::ostream& err);

/// `vims_eval ablation ...` and `vims_eval place-recognition ...` (args include the command
/// word). Same exit codes as runEvalCli.
int runAblationCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int runPlaceRecognitionCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace eval
}  // namespace vims
