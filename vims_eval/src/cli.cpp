#include "vims_eval/cli.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "vims_common/config_reader.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/trajectory_io.h"
#include "vims_eval/cli_args.h"
#include "vims_eval/eval_options.h"
#include "vims_eval/loops.h"
#include "vims_eval/metrics.h"
#include "vims_eval/relocalisation.h"
#include "vims_eval/report.h"
#include "vims_eval/revisit.h"
#include "vims_eval/truth_coils.h"

namespace fs = std::filesystem;

namespace vims {
namespace eval {
namespace {

// Options shared by the subcommands; `true` = takes a value.
const std::map<std::string, bool> kTrajectoryOptions = {
    {"align", true}, {"max-dt", true}, {"interpolate", false}, {"max-gt-gap", true}, {"rpe-delta", true}};
const std::map<std::string, bool> kLoopOptions = {
    {"trans-tol", true},      {"rot-tol-deg", true},         {"revisit-radius", true}, {"revisit-gap", true},
    {"revisit-margin", true}, {"revisit-coil-radius", true}, {"max-gt-gap", true}};

}  // namespace

std::map<std::string, bool> evalOptionTable() {
  return mergeOptions({kTrajectoryOptions, kLoopOptions, {{"config", true}}});
}

EvalOptions evalOptionsFromArgs(const CliArgs& args) {
  EvalOptions o;
  if (args.has("config")) o = EvalOptions::fromReader(ConfigReader::fromFile(args.get("config", "")).child("eval"));
  auto& assoc = o.trajectory.association;
  args.number("max-dt", &assoc.max_dt_s);
  if (args.has("interpolate")) assoc.interpolate = true;
  args.number("max-gt-gap", &assoc.max_gt_gap_s);
  o.loops.max_gt_gap_s = assoc.max_gt_gap_s;
  if (args.has("align")) {
    try {
      o.trajectory.alignments = parseAlignmentList(args.get("align", ""));
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("option --align: ") + e.what());
    }
  }
  args.number("rpe-delta", &o.trajectory.rpe_delta_m);
  args.number("trans-tol", &o.loops.trans_tol_m);
  args.number("rot-tol-deg", &o.loops.rot_tol_deg);
  args.number("revisit-radius", &o.revisit.radius_m);
  args.number("revisit-gap", &o.revisit.min_gap_s);
  args.number("revisit-margin", &o.revisit.margin_s);
  args.number("revisit-coil-radius", &o.revisit.coil_radius_m);
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  return o;
}

namespace {

std::vector<StampedPose> readTrajectory(const std::string& path, const char* what) {
  if (!fs::exists(path)) throw std::runtime_error(std::string(what) + " file '" + path + "' does not exist");
  std::vector<StampedPose> poses = readTumFile(path);
  if (poses.empty()) throw std::runtime_error(std::string(what) + " file '" + path + "' holds no pose");
  return poses;
}

int commandTraj(const std::vector<std::string>& argv, std::ostream& out) {
  const CliArgs args(argv, 1,
                     mergeOptions({kTrajectoryOptions,
                                   {{"gt", true}, {"est", true}, {"plots", true}, {"label", true}, {"config", true}}}),
                     "traj");
  const std::string gt_path = args.required("gt", "traj");
  const std::string est_path = args.required("est", "traj");
  const EvalOptions options = evalOptionsFromArgs(args);
  const std::string label = args.get("label", fs::path(est_path).stem().string());
  const auto gt = readTrajectory(gt_path, "ground-truth");
  const auto est = readTrajectory(est_path, "estimate");
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options.trajectory, label);
  printTrajectoryReport(out, ev);
  if (args.has("plots"))
    for (const auto& path : writeTrajectoryPlots(ev, args.get("plots", ""))) out << "   plot: " << path << "\n";
  out << trajectorySummaryLine(ev) << std::endl;
  return kExitOk;
}

int commandLoops(const std::vector<std::string>& argv, std::ostream& out) {
  const CliArgs args(argv, 1,
                     mergeOptions({kLoopOptions, {{"gt", true}, {"loops", true}, {"plots", true}, {"config", true}}}),
                     "loops");
  const std::string gt_path = args.required("gt", "loops");
  const std::string loops_path = args.required("loops", "loops");
  const EvalOptions options = evalOptionsFromArgs(args);
  const auto gt = readTrajectory(gt_path, "ground-truth");
  const auto records = readLoopCsv(loops_path);
  const LoopEvaluation ev = evaluateLoops(records, gt, options.loops, options.revisit);
  printLoopReport(out, ev, options.loops, options.revisit);
  if (args.has("plots"))
    for (const auto& path : writeLoopPlots(gt, ev, args.get("plots", ""))) out << "   plot: " << path << "\n";
  out << loopSummaryLine(ev) << std::endl;
  return kExitOk;
}

int commandRun(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const CliArgs args(
      argv, 1, mergeOptions({kTrajectoryOptions, kLoopOptions, {{"sequence", true}, {"out", true}, {"config", true}}}),
      "run");
  const std::string seq_dir = args.required("sequence", "run");
  const std::string out_dir = args.required("out", "run");
  const EvalOptions options = evalOptionsFromArgs(args);
  const SequencePaths seq = SequencePaths::resolve(seq_dir);
  if (seq.gt.empty())
    throw std::runtime_error("sequence '" + seq_dir + "' has no ground truth '" + seq.name + "_gt.tum'");
  if (!fs::is_directory(out_dir)) throw std::runtime_error("output directory '" + out_dir + "' does not exist");

  // The estimator's outputs that are evaluated when present (see docs/evaluation.md).
  const std::vector<std::string> estimate_names = {"vio", "global"};
  const std::string loops_path = (fs::path(out_dir) / "loops.csv").string();
  std::vector<std::string> present;
  for (const auto& name : estimate_names)
    if (fs::exists(fs::path(out_dir) / (name + ".tum"))) present.push_back(name);
  const bool have_loops = fs::exists(loops_path);
  if (present.empty() && !have_loops)
    throw std::runtime_error("nothing to evaluate in '" + out_dir + "' (expected vio.tum, global.tum or loops.csv)");

  const auto gt = readTrajectory(seq.gt, "ground-truth");
  const std::string plot_dir = (fs::path(out_dir) / "plots").string();
  YAML::Node root;
  root["sequence"] = seq.name;
  root["sequence_dir"] = seq.dir;
  root["ground_truth"] = seq.gt;
  root["output_dir"] = out_dir;
  root["options"] = YAML::Load(options.toYaml());
  YAML::Node plots(YAML::NodeType::Sequence);
  std::vector<std::string> summaries;
  bool failed = false;

  YAML::Node trajectories;
  std::map<std::string, TrajectoryEvaluation> evaluated;
  for (const auto& name : present) {
    const std::string path = (fs::path(out_dir) / (name + ".tum")).string();
    try {
      const auto est = readTrajectory(path, "estimate");
      const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options.trajectory, name);
      printTrajectoryReport(out, ev);
      YAML::Node node = trajectoryToYaml(ev);
      node["file"] = path;
      trajectories[name] = node;
      for (const auto& p : writeTrajectoryPlots(ev, plot_dir)) plots.push_back(p);
      summaries.push_back(trajectorySummaryLine(ev));
      evaluated.emplace(name, ev);
    } catch (const std::exception& e) {
      // One broken estimate must not hide the figures of the others; the exit code says it.
      err << "vims_eval run: " << name << ": " << e.what() << "\n";
      YAML::Node node;
      node["file"] = path;
      node["error"] = e.what();
      trajectories[name] = node;
      failed = true;
    }
  }
  if (!present.empty()) root["trajectories"] = trajectories;
  if (evaluated.count("global") && evaluated.count("vio")) {
    const GlobalVsVio ratio = compareGlobalWithVio(evaluated.at("global"), evaluated.at("vio"));
    out << "global against VIO: translation " << formatFixed(ratio.trans_ratio, 3) << "x, rotation "
        << formatFixed(ratio.rot_ratio, 3) << "x"
        << (ratio.globalBetter() ? "" : " (the pose graph made the trajectory worse than the odometry)") << "\n";
    root["global_vs_vio"]["trans_ratio"] = ratio.trans_ratio;
    root["global_vs_vio"]["rot_ratio"] = ratio.rot_ratio;
    summaries.push_back(globalVsVioSummaryLine(ratio));
  }

  if (have_loops) {
    try {
      const LoopEvaluation ev = evaluateLoops(readLoopCsv(loops_path), gt, options.loops, options.revisit);
      printLoopReport(out, ev, options.loops, options.revisit);
      YAML::Node node = loopsToYaml(ev, options.loops, options.revisit);
      node["file"] = loops_path;
      root["loops"] = node;
      for (const auto& p : writeLoopPlots(gt, ev, plot_dir)) plots.push_back(p);
      summaries.push_back(loopSummaryLine(ev));
      // Several coils: the revisits and loops near each, so a coil whose loops never close shows.
      const auto coil_positions = readTruthCoilPositions(seq.truth, nullptr);
      if (!coil_positions.empty()) {
        const auto coils = revisitsNearCoils(ev.events, ev.score, coil_positions, options.revisit.coil_radius_m);
        printCoilRevisits(out, coils, options.revisit.coil_radius_m);
        root["loops"]["near_coils"] = coilRevisitsToYaml(coils);
        summaries.push_back(coilRevisitsSummaryLine(coils));
      }
    } catch (const std::exception& e) {
      err << "vims_eval run: loops: " << e.what() << "\n";
      YAML::Node node;
      node["file"] = loops_path;
      node["error"] = e.what();
      root["loops"] = node;
      failed = true;
    }
  }
  root["plots"] = plots;
  const std::string yaml_path = (fs::path(out_dir) / "eval.yaml").string();
  writeYamlFile(yaml_path, root);
  out << "   wrote " << yaml_path << " and " << plots.size() << " plots in " << plot_dir << "\n";
  for (const auto& line : summaries) out << line << "\n";
  out.flush();
  return failed ? kExitFailure : kExitOk;
}

/// The global trajectory of a vims_offline output directory.
std::vector<StampedPose> readGlobal(const std::string& out_dir, const char* what) {
  return readTrajectory((fs::path(out_dir) / "global.tum").string(), what);
}

int commandRelocalisation(const std::vector<std::string>& argv, std::ostream& out) {
  const CliArgs args(argv, 1,
                     {{"teach-sequence", true},
                      {"teach-out", true},
                      {"sequence", true},
                      {"out", true},
                      {"map-radius", true},
                      {"correct-tol", true}},
                     "relocalisation");
  const SequencePaths teach_seq = SequencePaths::resolve(args.required("teach-sequence", "relocalisation"));
  const std::string teach_out = args.required("teach-out", "relocalisation");
  const SequencePaths repeat_seq = SequencePaths::resolve(args.required("sequence", "relocalisation"));
  const std::string repeat_out = args.required("out", "relocalisation");
  RelocalisationOptions options;
  args.number("map-radius", &options.map_radius_m);
  args.number("correct-tol", &options.correct_tol_m);
  if (!(options.map_radius_m > 0.0) || !(options.correct_tol_m > 0.0))
    throw UsageError("--map-radius and --correct-tol must be > 0");
  for (const SequencePaths* seq : {&teach_seq, &repeat_seq})
    if (seq->gt.empty()) throw std::runtime_error("sequence '" + seq->dir + "' has no ground truth");

  const auto teach_gt = readTrajectory(teach_seq.gt, "ground-truth");
  const auto repeat_gt = readTrajectory(repeat_seq.gt, "ground-truth");
  // Loops into the map are scored against the teach run's truth (a log without the
  // match_in_map column has none).
  const std::string loops_path = (fs::path(repeat_out) / "loops.csv").string();
  std::optional<LoopScore> loops;
  if (fs::exists(loops_path)) loops = scoreLoops(readLoopCsv(loops_path), repeat_gt, LoopScoringOptions{}, &teach_gt);
  const RelocalisationEvaluation ev = evaluateRelocalisation(
      teach_gt, readGlobal(teach_out, "teach run's global"), repeat_gt, readGlobal(repeat_out, "repeat run's global"),
      readRelocalisationReport((fs::path(repeat_out) / "summary.yaml").string()), options, loops ? &*loops : nullptr);
  printRelocalisationReport(out, ev, options);
  const std::string yaml_path = (fs::path(repeat_out) / "relocalisation.yaml").string();
  writeYamlFile(yaml_path, relocalisationToYaml(ev));
  out << "   wrote " << yaml_path << "\n" << ev.summaryLine() << std::endl;
  return kExitOk;
}

bool wantsHelp(const std::vector<std::string>& args) {
  for (const auto& a : args)
    if (a == "--help" || a == "-h") return true;
  return false;
}

}  // namespace

std::string evalUsage() {
  return R"(vims_eval: trajectory and loop-closure evaluation against ground truth (docs/evaluation.md)

usage:
  vims_eval traj --gt GT.tum --est EST.tum [--align se3|sim3|posyaw|none|all] [--max-dt 0.01]
                 [--interpolate] [--max-gt-gap 0.5] [--rpe-delta 10] [--plots DIR] [--label NAME]
                 [--config FILE]
  vims_eval loops --gt GT.tum --loops loops.csv [--trans-tol 0.5] [--rot-tol-deg 5]
                  [--revisit-radius 1.5] [--revisit-gap 60] [--revisit-margin 0] [--plots DIR]
                  [--config FILE]
  vims_eval run --sequence DIR --out OUT [any option of traj and loops except --gt/--est/--loops/--plots/--label]
  vims_eval relocalisation --teach-sequence DIR --teach-out OUT --sequence DIR --out OUT
                           [--map-radius 1] [--correct-tol 0.5]
  vims_eval ablation --sequence DIR --out OUT [--jobs 2] [--modes vi_slam,no_sonar,no_alter,no_orb,no_geom,full]
                     [--offline PATH] [--offline-config FILE] [--package-root DIR] [--no-run] [--no-figures]
                     [evaluation options as run]
  vims_eval place-recognition --sequence DIR --orb-run RUN --brief-run RUN --out OUT [--radius 1.5]
                              [--config FILE] [--package-root DIR]
  vims_eval map-size --map FILE [--descriptor orb|brief] [--csv OUT] [--package-root DIR]

  traj   associate, align and report ATE (m and % of distance), rotation RMSE, RPE per 10 m, Sim3
         scale; the last line is 'VIMS_EVAL key=value ...'. --align defaults to all (se3 first).
  loops  score loops.csv (correct: within --trans-tol m and --rot-tol-deg deg of the ground truth's
         T_match_query), find revisit events in the ground truth; last line 'VIMS_EVAL_LOOPS ...'.
  run    evaluate OUT/vio.tum, OUT/global.tum and OUT/loops.csv (those present) against the
         sequence's <seq>_gt.tum; writes OUT/eval.yaml and OUT/plots/*.png. With a
         <seq>_truth.yaml that gives the coils' positions, also the revisit events near each
         coil (--revisit-coil-radius 15); last line 'VIMS_EVAL_COILS ...'.
  relocalisation  teach and repeat: the repeat run (vims_offline --map-load the teach run's map,
         output OUT) against the teach run (output --teach-out): when it entered the mapped area
         (within --map-radius m of the teach track), when and how right it relocalised
         (pose_graph.relocalised_t of OUT/summary.yaml; wrong beyond --correct-tol m), and its
         ATE in the map's frame from then on beside the teach run's own; writes
         OUT/relocalisation.yaml; last line 'VIMS_EVAL_RELOC ...'.
  ablation  runs vims_offline (next to this executable, or --offline) once per variant into
         OUT/<mode>/ (--jobs at a time, --map-save OUT/<mode>/map.vimsmap), evaluates global.tum (SE3),
         vio.tum and loops.csv, prints the paper's table, writes OUT/ablation.md, OUT/ablation.csv,
         OUT/trajectories_top.png, OUT/multiscale_map.png and OUT/place_recognition/.
  place-recognition  precision-recall curves and recognition matrices of Mag-ORB, Mag, ORB and
         BRIEF from an ORB run's map.vimsmap + mag_signatures.csv and a BRIEF run's map.vimsmap.
  map-size  a saved map's submap memory per keyframe (CSV: t, visual_submap, keypoints, bytes,
         cumulative_mb) and a 'VIMS_MAP_SIZE ...' line: what bench/soak.py sets beside the RSS.
  --config FILE reads the 'eval:' section of a YAML file first; flags override it.

exit status: 0 ok, 1 evaluation failed (missing or malformed input, no association), 2 bad usage.
)";
}

int runEvalCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
               const std::map<std::string, EvalCommand>& extra_commands) {
  if (args.empty()) {
    err << evalUsage();
    return kExitUsage;
  }
  if (wantsHelp(args)) {
    out << evalUsage();
    return kExitOk;
  }
  const std::string& command = args.front();
  try {
    if (command == "traj") return commandTraj(args, out);
    if (command == "loops") return commandLoops(args, out);
    if (command == "run") return commandRun(args, out, err);
    if (command == "relocalisation") return commandRelocalisation(args, out);
    const auto extra = extra_commands.find(command);
    if (extra != extra_commands.end()) return extra->second(args, out, err);
    throw UsageError("unknown command '" + command +
                     "' (expected traj, loops, run, relocalisation, ablation, place-recognition or map-size)");
  } catch (const UsageError& e) {
    err << "vims_eval: " << e.what() << "\n(see vims_eval --help)\n";
    return kExitUsage;
  } catch (const ConfigError& e) {
    err << "vims_eval: configuration error: " << e.what() << "\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    err << "vims_eval " << command << ": error: " << e.what() << "\n";
    return kExitFailure;
  }
}

}  // namespace eval
}  // namespace vims
