#include "vims_eval/ablation.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "vims_common/sequence_paths.h"
#include "vims_eval/cli.h"
#include "vims_eval/loops.h"
#include "vims_eval/map_figures.h"
#include "vims_eval/metrics.h"
#include "vims_eval/place_recognition.h"
#include "vims_eval/report.h"
#include "vims_eval/revisit.h"

extern char** environ;

namespace fs = std::filesystem;

namespace vims {
namespace eval {
namespace {

std::string fixed(double v, int decimals) { return formatFixed(v, decimals); }

/// Full precision for the CSV (what a spreadsheet or a script re-reads).
std::string precise(double v) {
  if (!std::isfinite(v)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return buf;
}

/// Markdown cells must not contain '|' or line breaks.
std::string markdownCell(std::string text) {
  for (char& c : text)
    if (c == '|' || c == '\n' || c == '\r') c = ' ';
  return text;
}

std::string csvQuoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += (c == '\n' || c == '\r') ? ' ' : c;
  }
  return out + "\"";
}

/// SE3 only: the paper's trajectories are "aligned using evo tools" (evo_ape -a).
TrajectoryEvalOptions se3Options(const EvalOptions& options) {
  TrajectoryEvalOptions o = options.trajectory;
  o.alignments = {AlignmentMode::kSe3};
  return o;
}

std::string lastLines(const std::string& path, std::size_t count) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) lines.push_back(line);
  std::string out;
  for (std::size_t i = lines.size() > count ? lines.size() - count : 0; i < lines.size(); ++i)
    out += (out.empty() ? "" : " / ") + lines[i];
  return out;
}

/// The row of `mode` when that variant ran and was evaluated, else nullptr.
const AblationRow* okRowOf(const std::vector<AblationRow>& rows, const std::string& mode) {
  for (const AblationRow& r : rows)
    if (r.mode == mode && r.ok) return &r;
  return nullptr;
}

}  // namespace

const std::vector<std::string>& ablationModes() {
  static const std::vector<std::string> kModes = {"vi_slam", "no_sonar", "no_alter", "no_orb", "no_geom", "full"};
  return kModes;
}

std::string ablationMethodName(const std::string& mode) {
  static const std::map<std::string, std::string> kNames = {{"vi_slam", "VI-SLAM"},     {"no_sonar", "w/o Sonar"},
                                                            {"no_alter", "w/o Alter."}, {"no_orb", "w/o ORB"},
                                                            {"no_geom", "w/o Geom."},   {"full", "Full VIMS"}};
  const auto it = kNames.find(mode);
  return it == kNames.end() ? mode : it->second;
}

double readRealTimeFactor(const std::string& summary_yaml_path) {
  const double nan = std::nan("");
  try {
    const YAML::Node root = YAML::LoadFile(summary_yaml_path);
    if (!root.IsMap()) return nan;
    auto number = [&](const char* key) {
      const YAML::Node n = root[key];
      if (!n || !n.IsScalar()) return nan;
      try {
        return n.as<double>();
      } catch (const YAML::Exception&) {
        return nan;
      }
    };
    const double rtf = number("real_time_factor");
    if (std::isfinite(rtf)) return rtf;
    const double duration = number("sequence_duration_s");
    const double wall = number("wall_time_s");
    if (std::isfinite(duration) && std::isfinite(wall) && wall > 0.0) return duration / wall;
  } catch (const std::exception&) {
    // Missing or malformed file: the factor is simply unknown.
  }
  return nan;
}

AblationRow evaluateAblationRun(const std::string& mode, const std::string& run_dir, const std::vector<StampedPose>& gt,
                                const EvalOptions& options) {
  AblationRow row;
  row.mode = mode;
  row.vio_trans_rmse_m = std::nan("");
  row.real_time_factor = readRealTimeFactor((fs::path(run_dir) / "summary.yaml").string());
  const std::string global_path = (fs::path(run_dir) / "global.tum").string();
  try {
    if (!fs::exists(global_path)) throw std::runtime_error("no global.tum in '" + run_dir + "'");
    const auto est = readTumFile(global_path);
    if (est.empty()) throw std::runtime_error("global.tum in '" + run_dir + "' holds no pose");
    const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, se3Options(options), mode);
    row.trans_rmse_m = ev.primary().ate.rmse;
    row.trans_pct = ev.primary().ate_rmse_pct;
    row.rot_rmse_deg = ev.primary().rot.rmse;
    row.ok = true;
  } catch (const std::exception& e) {
    row.error = e.what();
    return row;
  }
  const std::string vio_path = (fs::path(run_dir) / "vio.tum").string();
  if (fs::exists(vio_path)) {
    try {
      const auto est = readTumFile(vio_path);
      row.vio_trans_rmse_m = evaluateTrajectory(gt, est, se3Options(options), "vio").primary().ate.rmse;
    } catch (const std::exception&) {
      // A VIO that cannot be evaluated (e.g. no pose) leaves the column NaN; the row stands.
    }
  }
  const std::string loops_path = (fs::path(run_dir) / "loops.csv").string();
  if (fs::exists(loops_path)) {
    try {
      const LoopEvaluation ev = evaluateLoops(readLoopCsv(loops_path), gt, options.loops, options.revisit);
      row.has_loops = true;
      row.verifications = ev.score.verifications;
      row.accepted = ev.score.accepted;
      row.correct = ev.score.correct;
      row.wrong = ev.score.wrong;
      row.revisit_events = ev.revisits.events;
      row.revisit_closed = ev.revisits.closed;
      for (const ScoredLoop& l : ev.score.loops)
        if (l.record.accepted && l.has_gt && l.within_tolerance)
          row.correct_loop_query_times.push_back(l.record.t_query);
    } catch (const std::exception& e) {
      row.ok = false;
      row.error = std::string("loops.csv: ") + e.what();
    }
  }
  return row;
}

std::string loopClosingCell(const AblationRow& row) {
  if (!row.has_loops) return "n/a";
  return std::to_string(row.correct) + "/" + std::to_string(row.verifications);
}

std::string ablationMarkdown(const std::vector<AblationRow>& rows) {
  std::ostringstream os;
  os << "| Method | mode | Loop closing (correct / verifications) | wrong loops | revisits closed | "
        "Trans. RMSE [m] | % of distance | Rot. RMSE [deg] | VIO trans. RMSE [m] | global / VIO | real-time factor |\n"
     << "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (const AblationRow& r : rows) {
    os << "| " << ablationMethodName(r.mode) << " | " << r.mode << " | ";
    if (!r.ok) {
      os << "failed: " << markdownCell(r.error) << " | - | - | - | - | - | - | - | " << fixed(r.real_time_factor, 1)
         << " |\n";
      continue;
    }
    os << loopClosingCell(r) << " | " << (r.has_loops ? std::to_string(r.wrong) : "n/a") << " | "
       << (r.has_loops ? std::to_string(r.revisit_closed) + "/" + std::to_string(r.revisit_events) : "n/a") << " | "
       << fixed(r.trans_rmse_m, 3) << " | " << fixed(r.trans_pct, 3) << " | " << fixed(r.rot_rmse_deg, 2) << " | "
       << fixed(r.vio_trans_rmse_m, 3) << " | " << fixed(r.globalOverVio(), 2) << " | " << fixed(r.real_time_factor, 1)
       << " |\n";
  }
  return os.str();
}

std::string ablationCsv(const std::vector<AblationRow>& rows) {
  std::ostringstream os;
  os << "mode,method,status,verifications,accepted,correct,wrong,revisit_events,revisit_closed,trans_rmse_m,"
        "trans_pct,rot_rmse_deg,vio_trans_rmse_m,global_over_vio,real_time_factor,error\n";
  for (const AblationRow& r : rows) {
    const double nan = std::nan("");
    const bool loops = r.ok && r.has_loops;
    auto count = [&](std::size_t v) { return loops ? std::to_string(v) : std::string(); };
    os << r.mode << "," << csvQuoted(ablationMethodName(r.mode)) << "," << (r.ok ? "ok" : "failed") << ","
       << count(r.verifications) << "," << count(r.accepted) << "," << count(r.correct) << "," << count(r.wrong) << ","
       << count(r.revisit_events) << "," << count(r.revisit_closed) << "," << precise(r.ok ? r.trans_rmse_m : nan)
       << "," << precise(r.ok ? r.trans_pct : nan) << "," << precise(r.ok ? r.rot_rmse_deg : nan) << ","
       << precise(r.ok ? r.vio_trans_rmse_m : nan) << "," << precise(r.ok ? r.globalOverVio() : nan) << ","
       << precise(r.real_time_factor) << "," << csvQuoted(r.error) << "\n";
  }
  return os.str();
}

MagneticStageRecall magneticStageRecall(const AblationRow& full, const AblationRow& vision, double window_s) {
  MagneticStageRecall r;
  r.window_s = window_s;
  // Stamps are the same keyframes' in both runs (same sequence, same front end): 1 ms tells them apart.
  constexpr double kSameKeyframe = 1e-3;
  auto nearest = [](const std::vector<double>& times, double t) {
    double best = std::numeric_limits<double>::infinity();
    for (const double u : times) best = std::min(best, std::abs(u - t));
    return best;
  };
  r.vision_queries = vision.correct_loop_query_times.size();
  for (const double t : vision.correct_loop_query_times) {
    const double d = nearest(full.correct_loop_query_times, t);
    r.same_query += d <= kSameKeyframe ? 1 : 0;
    r.within_window += d <= window_s ? 1 : 0;
  }
  for (const double t : full.correct_loop_query_times)
    r.full_only += nearest(vision.correct_loop_query_times, t) > kSameKeyframe ? 1 : 0;
  return r;
}

std::vector<AblationClaim> ablationClaims(const std::vector<AblationRow>& rows) {
  auto find = [&](const std::string& mode) { return okRowOf(rows, mode); };
  std::vector<AblationClaim> claims;
  const AblationRow* full = find("full");
  if (!full) return claims;
  if (std::isfinite(full->globalOverVio())) {
    claims.push_back({"full_not_worse_than_vio",
                      "full: the global trajectory is not worse than its VIO (global / VIO <= 1)",
                      full->globalOverVio() <= 1.0, "global / VIO " + fixed(full->globalOverVio(), 2)});
  }
  {
    bool lowest = true;
    std::string detail = "full " + fixed(full->trans_rmse_m, 4) + " m";
    int others = 0;
    for (const AblationRow& r : rows) {
      if (!r.ok || r.mode == "full") continue;
      ++others;
      detail += ", " + r.mode + " " + fixed(r.trans_rmse_m, 4);
      if (r.trans_rmse_m < full->trans_rmse_m) lowest = false;
    }
    if (others > 0)
      claims.push_back({"full_lowest_trans", "full has the lowest translation RMSE of all modes", lowest, detail});
  }
  if (const AblationRow* g = find("no_geom")) {
    claims.push_back({"no_geom_larger_rot", "w/o Geom. has a larger rotation RMSE than full",
                      g->rot_rmse_deg > full->rot_rmse_deg,
                      "no_geom " + fixed(g->rot_rmse_deg, 3) + " deg, full " + fixed(full->rot_rmse_deg, 3)});
  }
  for (const char* mode : {"vi_slam", "no_alter", "no_orb"}) {
    const AblationRow* r = find(mode);
    if (!r || !r->has_loops || !full->has_loops) continue;
    const bool fewer = r->revisit_closed < full->revisit_closed ||
                       (r->revisit_closed == full->revisit_closed && r->verifications > full->verifications);
    claims.push_back({std::string(mode) + "_closes_fewer",
                      std::string(mode) + " closes fewer revisit events than full (or as many with more verifications)",
                      fewer,
                      std::string(mode) + " " + std::to_string(r->revisit_closed) + " events / " +
                          std::to_string(r->verifications) + " verifications, full " +
                          std::to_string(full->revisit_closed) + " / " + std::to_string(full->verifications)});
  }
  return claims;
}

std::string ablationClaimsMarkdown(const std::vector<AblationClaim>& claims) {
  std::ostringstream os;
  for (const AblationClaim& c : claims)
    os << "- " << (c.holds ? "holds" : "**fails**") << ": " << c.statement << " (" << c.detail << ")\n";
  return os.str();
}

std::string ablationClaimsLine(const std::vector<AblationClaim>& claims) {
  std::size_t holding = 0;
  std::ostringstream names;
  for (const AblationClaim& c : claims) {
    holding += c.holds ? 1 : 0;
    names << " " << c.name << "=" << (c.holds ? 1 : 0);
  }
  return "VIMS_ABLATION_ORDER holds=" + std::to_string(holding) + "/" + std::to_string(claims.size()) + names.str();
}

std::string ablationSummaryLine(const AblationRow& r) {
  std::ostringstream os;
  os << "VIMS_ABLATION mode=" << r.mode << " status=" << (r.ok ? "ok" : "failed");
  if (r.ok) {
    if (r.has_loops)
      os << " correct=" << r.correct << " verifications=" << r.verifications << " accepted=" << r.accepted
         << " wrong=" << r.wrong << " revisit_events=" << r.revisit_events << " revisit_closed=" << r.revisit_closed;
    os << " trans_rmse_m=" << fixed(r.trans_rmse_m, 4) << " trans_pct=" << fixed(r.trans_pct, 4)
       << " rot_rmse_deg=" << fixed(r.rot_rmse_deg, 4) << " vio_trans_rmse_m=" << fixed(r.vio_trans_rmse_m, 4)
       << " global_over_vio=" << fixed(r.globalOverVio(), 4);
  }
  os << " rtf=" << fixed(r.real_time_factor, 2);
  return os.str();
}

// ------------------------------------------------------------------------------------------
// Processes
// ------------------------------------------------------------------------------------------

std::string executableDir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : exe.parent_path().string();
}

std::vector<ProcessResult> runProcesses(const std::vector<std::vector<std::string>>& commands,
                                        const std::vector<std::string>& log_files, int jobs, std::ostream& progress) {
  if (log_files.size() != commands.size()) throw std::invalid_argument("runProcesses: one log file per command");
  std::vector<ProcessResult> results(commands.size());
  std::map<pid_t, std::size_t> running;
  std::size_t next = 0;
  const std::size_t max_jobs = static_cast<std::size_t>(std::max(1, jobs));

  auto start = [&](std::size_t i) {
    const auto& argv_strings = commands[i];
    if (argv_strings.empty()) {
      results[i].error = "empty command";
      return;
    }
    std::vector<char*> argv;
    for (const auto& a : argv_strings) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_files[i].c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) {
      results[i].error = "cannot start '" + argv_strings[0] + "': " + std::strerror(rc);
      return;
    }
    progress << "   started " << argv_strings[0] << " (pid " << pid << ") -> " << log_files[i] << std::endl;
    running[pid] = i;
  };

  while (next < commands.size() || !running.empty()) {
    while (next < commands.size() && running.size() < max_jobs) start(next++);
    if (running.empty()) continue;
    int status = 0;
    const pid_t pid = waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      // No child left to wait for (should not happen): mark the rest as lost.
      for (const auto& [p, i] : running) results[i].error = "lost track of the process";
      running.clear();
      continue;
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;  // a child this function did not start
    ProcessResult& r = results[it->second];
    if (WIFEXITED(status)) {
      r.exit_code = WEXITSTATUS(status);
    } else if (WIFSIGNALED(status)) {
      r.error = "killed by signal " + std::to_string(WTERMSIG(status));
    }
    progress << "   finished pid " << pid << ": "
             << (r.error.empty() ? "exit status " + std::to_string(r.exit_code) : r.error) << std::endl;
    running.erase(it);
  }
  return results;
}

// ------------------------------------------------------------------------------------------
// The command
// ------------------------------------------------------------------------------------------

namespace {

std::string runDirOf(const AblationOptions& options, const std::string& mode) {
  return (fs::path(options.out_dir) / mode).string();
}

std::string mapFileOf(const AblationOptions& options, const std::string& mode) {
  return (fs::path(runDirOf(options, mode)) / "map.vimsmap").string();
}

/// Runs vims_offline once per mode, `options.jobs` at a time. Returns why a mode's run failed,
/// for the modes whose run failed.
std::map<std::string, std::string> runVariants(const AblationOptions& options, const SequencePaths& seq,
                                               std::ostream& out) {
  if (!fs::exists(options.offline_binary))
    throw std::runtime_error("vims_offline not found at '" + options.offline_binary + "' (use --offline PATH)");
  std::error_code ec;
  std::vector<std::vector<std::string>> commands;
  std::vector<std::string> logs;
  for (const auto& mode : options.modes) {
    fs::create_directories(runDirOf(options, mode), ec);
    std::vector<std::string> cmd = {options.offline_binary,   "--sequence", seq.dir, "--out",
                                    runDirOf(options, mode),  "--mode",     mode,    "--map-save",
                                    mapFileOf(options, mode), "--quiet"};
    if (!options.offline_config.empty()) {
      cmd.push_back("--config");
      cmd.push_back(options.offline_config);
    }
    commands.push_back(cmd);
    logs.push_back((fs::path(runDirOf(options, mode)) / "offline.log").string());
  }
  out << "== ablation: " << options.modes.size() << " variants of vims_offline on " << seq.dir << ", " << options.jobs
      << " at a time" << std::endl;
  const auto results = runProcesses(commands, logs, options.jobs, out);
  std::map<std::string, std::string> run_failure;
  for (std::size_t i = 0; i < options.modes.size(); ++i) {
    const ProcessResult& r = results[i];
    if (!r.error.empty()) {
      run_failure[options.modes[i]] = "vims_offline: " + r.error;
    } else if (r.exit_code != 0) {
      const std::string tail = lastLines(logs[i], 1);
      run_failure[options.modes[i]] =
          "vims_offline exit status " + std::to_string(r.exit_code) + (tail.empty() ? "" : " (" + tail + ")");
    }
  }
  return run_failure;
}

/// One row per mode, in the order of options.modes: a failed row for a failed run, else the
/// evaluation of the run's outputs. Every failed row is also reported on `err`.
std::vector<AblationRow> evaluateVariants(const AblationOptions& options, const std::vector<StampedPose>& gt,
                                          const std::map<std::string, std::string>& run_failure, std::ostream& err) {
  std::vector<AblationRow> rows;
  for (const auto& mode : options.modes) {
    const auto failure = run_failure.find(mode);
    if (failure != run_failure.end()) {
      AblationRow row;
      row.mode = mode;
      row.error = failure->second;
      row.real_time_factor = std::nan("");
      rows.push_back(row);
      err << "vims_eval ablation: " << mode << ": " << failure->second << "\n";
      continue;
    }
    rows.push_back(evaluateAblationRun(mode, runDirOf(options, mode), gt, options.eval));
    if (!rows.back().ok) err << "vims_eval ablation: " << mode << ": " << rows.back().error << "\n";
  }
  return rows;
}

/// The magnetic stage against vision alone, in words; empty unless both full and no_alter were
/// evaluated with their loops.
std::string magneticRecallText(const std::vector<AblationRow>& rows) {
  const AblationRow* full = okRowOf(rows, "full");
  const AblationRow* vision = okRowOf(rows, "no_alter");
  if (!(full && vision && full->has_loops && vision->has_loops)) return std::string();
  const MagneticStageRecall m = magneticStageRecall(*full, *vision);
  std::ostringstream os;
  os << "The magnetic stage against vision alone (w/o Alter.): of the " << m.vision_queries
     << " query keyframes w/o Alter. closed with a correct loop, full closed " << m.same_query
     << " at the same keyframe and " << m.within_window << " within " << fixed(m.window_s, 0) << " s; full closed "
     << m.full_only << " queries w/o Alter. did not.\n";
  return os.str();
}

void writeAblationMarkdown(const std::string& md_path, const std::string& sequence_name, const std::string& table,
                           const EvalOptions& eval, const std::vector<AblationClaim>& claims,
                           const std::string& recall_text) {
  std::ofstream md(md_path);
  md << "# Ablation study: " << sequence_name << "\n\n"
     << table << "\n"
     << "Loop closing: correct loops / loop verification attempts (loops.csv rows); a loop is correct within "
     << fixed(eval.loops.trans_tol_m, 2) << " m and " << fixed(eval.loops.rot_tol_deg, 1)
     << " deg of the ground truth. Trans./Rot. RMSE: global.tum against the ground truth after SE3 alignment. "
        "Revisits: ground-truth revisit events (radius "
     << fixed(eval.revisit.radius_m, 2) << " m, gap " << fixed(eval.revisit.min_gap_s, 0)
     << " s) closed by a correct loop. docs/evaluation.md, \"Ablation\".\n\n"
     << "The paper's ablation order:\n\n"
     << ablationClaimsMarkdown(claims) << "\n"
     << recall_text;
  if (!md) throw std::runtime_error("cannot write '" + md_path + "'");
}

void writeAblationCsv(const std::string& csv_path, const std::vector<AblationRow>& rows) {
  std::ofstream csv(csv_path);
  csv << ablationCsv(rows);
  if (!csv) throw std::runtime_error("cannot write '" + csv_path + "'");
}

/// The trajectory and map figures, and place recognition, for the modes that were evaluated.
/// Returns the files written. Figures are extras: a failure is reported and does not lose the table.
std::vector<std::string> writeFigures(const AblationOptions& options, const SequencePaths& seq,
                                      const std::vector<StampedPose>& gt, const std::vector<AblationRow>& rows,
                                      std::ostream& out, std::ostream& err) {
  std::vector<std::string> figures;
  auto attempt = [&](const std::string& what, const std::function<std::vector<std::string>()>& make) {
    try {
      for (const auto& p : make()) figures.push_back(p);
    } catch (const std::exception& e) {
      err << "vims_eval ablation: figure " << what << ": " << e.what() << "\n";
    }
  };
  auto have = [&](const std::string& mode) { return okRowOf(rows, mode) != nullptr; };
  std::vector<std::pair<std::string, std::string>> trajectories;
  if (have("vi_slam"))
    trajectories.emplace_back("VI-SLAM", (fs::path(runDirOf(options, "vi_slam")) / "global.tum").string());
  if (have("full")) trajectories.emplace_back("VIMS", (fs::path(runDirOf(options, "full")) / "global.tum").string());
  if (!trajectories.empty())
    attempt("trajectories", [&] {
      return std::vector<std::string>{
          writeTrajectoryComparison(gt, trajectories, (fs::path(options.out_dir) / "trajectories_top.png").string())};
    });
  if (have("full") && fs::exists(mapFileOf(options, "full")))
    attempt("multi-scale map", [&] {
      return std::vector<std::string>{
          writeMultiScaleMapFigure(mapFileOf(options, "full"), "orb", options.package_root,
                                   (fs::path(options.out_dir) / "multiscale_map.png").string())};
    });
  if (have("full") && have("vi_slam") && fs::exists(mapFileOf(options, "full")) &&
      fs::exists(mapFileOf(options, "vi_slam")))
    attempt("place recognition", [&] {
      PlaceRecognitionInputs in;
      in.sequence_dir = seq.dir;
      in.orb_map = mapFileOf(options, "full");
      in.brief_map = mapFileOf(options, "vi_slam");
      in.signatures_csv = (fs::path(runDirOf(options, "full")) / "mag_signatures.csv").string();
      in.package_root = options.package_root;
      const PlaceRecognitionOptions pr_options = options.offline_config.empty()
                                                     ? PlaceRecognitionOptions()
                                                     : placeRecognitionOptionsFromConfig(options.offline_config);
      const PlaceRecognitionResult pr =
          runPlaceRecognition(in, pr_options, (fs::path(options.out_dir) / "place_recognition").string(), out);
      return pr.figures;
    });
  return figures;
}

}  // namespace

std::vector<AblationRow> runAblation(const AblationOptions& options, std::ostream& out, std::ostream& err) {
  const SequencePaths seq = SequencePaths::resolve(options.sequence_dir);
  if (seq.gt.empty())
    throw std::runtime_error("sequence '" + options.sequence_dir + "' has no ground truth '" + seq.name + "_gt.tum'");
  const auto gt = readTumFile(seq.gt);
  if (gt.empty()) throw std::runtime_error("ground truth '" + seq.gt + "' holds no pose");
  std::error_code ec;
  fs::create_directories(options.out_dir, ec);
  if (!fs::is_directory(options.out_dir))
    throw std::runtime_error("cannot create output directory '" + options.out_dir + "'");

  std::map<std::string, std::string> run_failure;
  if (options.run) run_failure = runVariants(options, seq, out);
  std::vector<AblationRow> rows = evaluateVariants(options, gt, run_failure, err);

  const std::string md_path = (fs::path(options.out_dir) / "ablation.md").string();
  const std::string csv_path = (fs::path(options.out_dir) / "ablation.csv").string();
  const std::string table = ablationMarkdown(rows);
  const std::vector<AblationClaim> claims = ablationClaims(rows);
  const std::string recall_text = magneticRecallText(rows);
  writeAblationMarkdown(md_path, seq.name, table, options.eval, claims, recall_text);
  writeAblationCsv(csv_path, rows);
  std::vector<std::string> figures;
  if (options.figures) figures = writeFigures(options, seq, gt, rows, out, err);

  out << "\n== ablation (" << seq.name << "): global trajectory vs ground truth, loops from loops.csv\n" << table;
  for (const auto& f : figures) out << "   figure: " << f << "\n";
  out << "   wrote " << md_path << " and " << csv_path << "\n";
  out << "   the paper's ablation order:\n" << ablationClaimsMarkdown(claims);
  if (!recall_text.empty()) out << "   " << recall_text;
  for (const auto& r : rows) out << ablationSummaryLine(r) << "\n";
  out << ablationClaimsLine(claims) << "\n";
  out.flush();
  return rows;
}

int runAblationCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const CliArgs a(args, 1,
                  mergeOptions({evalOptionTable(),
                                {{"sequence", true},
                                 {"out", true},
                                 {"jobs", true},
                                 {"modes", true},
                                 {"offline", true},
                                 {"offline-config", true},
                                 {"package-root", true},
                                 {"no-run", false},
                                 {"no-figures", false}}}),
                  "ablation");
  AblationOptions o;
  o.sequence_dir = a.required("sequence", "ablation");
  o.out_dir = a.required("out", "ablation");
  a.integer("jobs", 1, 64, &o.jobs);
  if (a.has("modes")) {
    o.modes.clear();
    std::stringstream ss(a.get("modes", ""));
    std::string m;
    while (std::getline(ss, m, ',')) {
      if (m.empty()) continue;
      bool known = false;
      for (const auto& k : ablationModes()) known = known || k == m;
      if (!known)
        throw UsageError("ablation: unknown mode '" + m +
                         "' in --modes (expected a comma-separated subset of "
                         "vi_slam,no_sonar,no_alter,no_orb,no_geom,full)");
      o.modes.push_back(m);
    }
    if (o.modes.empty()) throw UsageError("ablation: --modes names no mode");
  }
  o.offline_binary = a.get("offline", (fs::path(executableDir()) / "vims_offline").string());
  o.offline_config = a.get("offline-config", "");
  o.package_root = a.get("package-root", defaultPackageRoot());
  o.run = !a.has("no-run");
  o.figures = !a.has("no-figures");
  o.eval = evalOptionsFromArgs(a);
  // A failed variant is a result (the paper's "w/o Sonar" row is a failure): the command fails
  // only when no variant could be evaluated at all.
  const auto rows = runAblation(o, out, err);
  for (const auto& r : rows)
    if (r.ok) return kExitOk;
  return kExitFailure;
}

}  // namespace eval
}  // namespace vims
