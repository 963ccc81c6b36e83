// The ablation table (formatting, summary.yaml reading), the process runner, and the whole
// `vims_eval ablation` orchestration on the simulated tank30 sequence (fixture sim_tank30).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "vims_eval/ablation.h"
#include "vims_eval/cli.h"
#include "vims_eval/place_recognition.h"

namespace fs = std::filesystem;
using namespace vims::eval;

namespace {

fs::path freshDir(const std::string& name) {
  const fs::path dir = fs::path(VIMS_BINARY_DIR) / "test_ablation" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string readFile(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

AblationRow okRow(const std::string& mode) {
  AblationRow r;
  r.mode = mode;
  r.ok = true;
  r.has_loops = true;
  r.verifications = 1957;
  r.accepted = 26;
  r.correct = 25;
  r.wrong = 1;
  r.revisit_events = 10;
  r.revisit_closed = 8;
  r.trans_rmse_m = 1.11;
  r.trans_pct = 0.5;
  r.rot_rmse_deg = 6.9;
  r.vio_trans_rmse_m = 1.5;
  r.real_time_factor = 3.25;
  return r;
}

std::string testSequence(const std::string& name) {
  const char* root = std::getenv("VIMS_TEST_DATA");
  return root ? (fs::path(root) / name).string() : std::string();
}

}  // namespace

TEST(AblationTable, ModesInThePapersOrderWithItsNames) {
  ASSERT_EQ(ablationModes().size(), 6u);
  EXPECT_EQ(ablationModes().front(), "vi_slam");
  EXPECT_EQ(ablationModes().back(), "full");
  EXPECT_EQ(ablationMethodName("no_alter"), "w/o Alter.");
  EXPECT_EQ(ablationMethodName("full"), "Full VIMS");
  EXPECT_EQ(ablationMethodName("other"), "other");
}

TEST(AblationTable, MarkdownRowsCarryThePapersColumnsAndSayWhenAVariantFailed) {
  AblationRow failed;
  failed.mode = "no_sonar";
  failed.error = "vims_offline exit status 1 (bad | thing)";
  failed.real_time_factor = std::nan("");
  AblationRow no_loops = okRow("no_geom");
  no_loops.has_loops = false;
  const std::string md = ablationMarkdown({okRow("full"), failed, no_loops});
  EXPECT_NE(md.find("| Method | mode | Loop closing (correct / verifications) |"), std::string::npos) << md;
  EXPECT_NE(md.find("| Full VIMS | full | 25/1957 | 1 | 8/10 | 1.110 | 0.500 | 6.90 | 1.500 | 0.74 | 3.2 |"),
            std::string::npos)
      << md;
  // The '|' of the error text must not open a new cell.
  EXPECT_NE(md.find("| w/o Sonar | no_sonar | failed: vims_offline exit status 1 (bad   thing) | - |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| w/o Geom. | no_geom | n/a | n/a | n/a | 1.110 |"), std::string::npos) << md;
  // Header, separator and one line per row.
  EXPECT_EQ(std::count(md.begin(), md.end(), '\n'), 5);
}

TEST(AblationTable, CsvHasOneRowPerVariantAndQuotesTheError) {
  AblationRow failed;
  failed.mode = "no_sonar";
  failed.error = "said \"no\", twice";
  failed.real_time_factor = std::nan("");
  const std::string csv = ablationCsv({okRow("full"), failed});
  std::istringstream in(csv);
  std::string header, full, sonar, extra;
  std::getline(in, header);
  std::getline(in, full);
  std::getline(in, sonar);
  EXPECT_FALSE(std::getline(in, extra));
  EXPECT_EQ(header,
            "mode,method,status,verifications,accepted,correct,wrong,revisit_events,revisit_closed,trans_rmse_m,"
            "trans_pct,rot_rmse_deg,vio_trans_rmse_m,global_over_vio,real_time_factor,error");
  EXPECT_EQ(full, "full,\"Full VIMS\",ok,1957,26,25,1,10,8,1.11,0.5,6.9,1.5,0.74,3.25,\"\"");
  EXPECT_EQ(sonar, "no_sonar,\"w/o Sonar\",failed,,,,,,,nan,nan,nan,nan,nan,nan,\"said \"\"no\"\", twice\"");
}

TEST(AblationTable, SummaryLine) {
  EXPECT_EQ(ablationSummaryLine(okRow("full")),
            "VIMS_ABLATION mode=full status=ok correct=25 verifications=1957 accepted=26 wrong=1 revisit_events=10 "
            "revisit_closed=8 trans_rmse_m=1.1100 trans_pct=0.5000 rot_rmse_deg=6.9000 vio_trans_rmse_m=1.5000 "
            "global_over_vio=0.7400 rtf=3.25");
}

TEST(AblationOrder, ClaimsJudgedOnTheRowsPresent) {
  std::vector<AblationRow> rows;
  for (const char* mode : {"vi_slam", "no_sonar", "no_alter", "no_orb", "no_geom", "full"}) rows.push_back(okRow(mode));
  auto row = [&](const std::string& mode) -> AblationRow& {
    for (AblationRow& r : rows)
      if (r.mode == mode) return r;
    throw std::logic_error(mode);
  };
  row("full").trans_rmse_m = 0.01;  // lowest; global / VIO = 0.01 / 1.5
  row("no_geom").rot_rmse_deg = 7.5;
  row("vi_slam").revisit_closed = 1;
  row("no_orb").revisit_closed = 0;
  row("no_alter").verifications = 4000;  // as many events as full, more verifications
  std::vector<AblationClaim> claims = ablationClaims(rows);
  ASSERT_EQ(claims.size(), 6u);
  for (const AblationClaim& c : claims) EXPECT_TRUE(c.holds) << c.name << ": " << c.detail;
  EXPECT_EQ(ablationClaimsLine(claims),
            "VIMS_ABLATION_ORDER holds=6/6 full_not_worse_than_vio=1 full_lowest_trans=1 no_geom_larger_rot=1 "
            "vi_slam_closes_fewer=1 no_alter_closes_fewer=1 no_orb_closes_fewer=1");

  // What the issue found: w/o Alter. more accurate than full and closing more events; full worse than its VIO.
  row("no_alter").trans_rmse_m = 0.005;
  row("no_alter").revisit_closed = 9;
  row("full").vio_trans_rmse_m = 0.008;
  claims = ablationClaims(rows);
  for (const AblationClaim& c : claims) {
    const bool should_fail =
        c.name == "full_lowest_trans" || c.name == "no_alter_closes_fewer" || c.name == "full_not_worse_than_vio";
    EXPECT_EQ(c.holds, !should_fail) << c.name;
  }
  EXPECT_NE(ablationClaimsMarkdown(claims).find(
                "- **fails**: full has the lowest translation RMSE of all modes (full 0.0100 m"),
            std::string::npos)
      << ablationClaimsMarkdown(claims);

  // Missing or failed modes leave their claims out; without full there is nothing to judge.
  rows.erase(rows.begin());  // vi_slam
  row("no_geom").ok = false;
  claims = ablationClaims(rows);
  for (const AblationClaim& c : claims) EXPECT_TRUE(c.name != "vi_slam_closes_fewer" && c.name != "no_geom_larger_rot");
  EXPECT_EQ(claims.size(), 4u);
  row("full").ok = false;
  EXPECT_TRUE(ablationClaims(rows).empty());
  EXPECT_EQ(ablationClaimsLine({}), "VIMS_ABLATION_ORDER holds=0/0");
}

TEST(AblationOrder, MagneticStageRecallAgainstVisionAlone) {
  AblationRow full = okRow("full");
  AblationRow vision = okRow("no_alter");
  vision.correct_loop_query_times = {10.0, 20.0, 30.0, 40.0};
  full.correct_loop_query_times = {10.0, 20.0, 33.0, 50.0, 60.0};  // 30 found 3 s later, 40 lost
  const MagneticStageRecall r = magneticStageRecall(full, vision, 5.0);
  EXPECT_EQ(r.vision_queries, 4u);
  EXPECT_EQ(r.same_query, 2u);
  EXPECT_EQ(r.within_window, 3u);
  EXPECT_EQ(r.full_only, 3u);  // 33, 50, 60
  const MagneticStageRecall none = magneticStageRecall(AblationRow(), vision, 5.0);
  EXPECT_EQ(none.same_query, 0u);
  EXPECT_EQ(none.within_window, 0u);
}

TEST(AblationTable, RealTimeFactorIsReadDefensively) {
  const fs::path dir = freshDir("rtf");
  std::ofstream(dir / "a.yaml") << "sequence: x\nreal_time_factor: 4.5\nlatency_ms: {new_key_p50: 3}\n";
  std::ofstream(dir / "b.yaml") << "sequence_duration_s: 30\nwall_time_s: 12\n";
  std::ofstream(dir / "c.yaml") << "real_time_factor: fast\n";
  std::ofstream(dir / "d.yaml") << "[not, a, map\n";
  EXPECT_DOUBLE_EQ(readRealTimeFactor((dir / "a.yaml").string()), 4.5);
  EXPECT_DOUBLE_EQ(readRealTimeFactor((dir / "b.yaml").string()), 2.5);
  EXPECT_TRUE(std::isnan(readRealTimeFactor((dir / "c.yaml").string())));
  EXPECT_TRUE(std::isnan(readRealTimeFactor((dir / "d.yaml").string())));
  EXPECT_TRUE(std::isnan(readRealTimeFactor((dir / "missing.yaml").string())));
}

TEST(AblationTable, RunWithoutGlobalTrajectoryIsAFailedRowNotAnException) {
  const fs::path dir = freshDir("no_global");
  std::vector<vims::StampedPose> gt(3);
  for (int i = 0; i < 3; ++i) gt[i].t = i, gt[i].p = Eigen::Vector3d(i, 0, 0);
  const AblationRow row = evaluateAblationRun("full", dir.string(), gt, EvalOptions());
  EXPECT_FALSE(row.ok);
  EXPECT_NE(row.error.find("no global.tum"), std::string::npos) << row.error;
}

TEST(ProcessRunner, ReportsExitCodesLogsOutputAndStartFailures) {
  const fs::path dir = freshDir("processes");
  std::ostringstream progress;
  const std::vector<std::vector<std::string>> commands = {{"/bin/sh", "-c", "echo out; echo err 1>&2; exit 0"},
                                                          {"/bin/sh", "-c", "sleep 0.2; exit 3"},
                                                          {"/nonexistent/vims_tool"},
                                                          {"/bin/sh", "-c", "kill -9 $$"}};
  const std::vector<std::string> logs = {(dir / "0.log").string(), (dir / "1.log").string(), (dir / "2.log").string(),
                                         (dir / "3.log").string()};
  const auto results = runProcesses(commands, logs, 2, progress);
  ASSERT_EQ(results.size(), 4u);
  EXPECT_EQ(results[0].exit_code, 0);
  EXPECT_TRUE(results[0].error.empty());
  EXPECT_EQ(readFile(dir / "0.log"), "out\nerr\n");
  EXPECT_EQ(results[1].exit_code, 3);
  EXPECT_FALSE(results[2].error.empty());
  EXPECT_NE(results[3].error.find("signal 9"), std::string::npos) << results[3].error;
}

TEST(AblationCli, BadUsage) {
  std::ostringstream out, err;
  const std::map<std::string, EvalCommand> extra = {{"ablation", runAblationCli}};
  EXPECT_EQ(runEvalCli({"ablation", "--sequence", "x"}, out, err, extra), kExitUsage);
  EXPECT_NE(err.str().find("--out is required"), std::string::npos) << err.str();
  err.str("");
  EXPECT_EQ(runEvalCli({"ablation", "--sequence", "x", "--out", "y", "--modes", "full,fast"}, out, err, extra),
            kExitUsage);
  EXPECT_NE(err.str().find("unknown mode 'fast'"), std::string::npos) << err.str();
  err.str("");
  EXPECT_EQ(runEvalCli({"ablation", "--sequence", "x", "--out", "y", "--jobs", "0"}, out, err, extra), kExitUsage);
}

// The whole command on tank30: two variants run in parallel, evaluated, tabled, with figures; a
// variant whose vims_offline fails becomes a failed row.
TEST(AblationSystem, RunsTwoVariantsOnTank30AndTablesThem) {
  const std::string seq = testSequence("tank30");
  ASSERT_FALSE(seq.empty()) << "VIMS_TEST_DATA not set (run through ctest)";
  const fs::path out = freshDir("tank30");
  AblationOptions o;
  o.sequence_dir = seq;
  o.out_dir = out.string();
  o.modes = {"vi_slam", "full"};
  o.jobs = 2;
  o.offline_binary = std::string(VIMS_DEVEL_BIN_DIR) + "/vims_offline";
  o.package_root = VIMS_SOURCE_DIR;
  std::ostringstream log, err;
  const auto rows = runAblation(o, log, err);
  ASSERT_EQ(rows.size(), 2u);
  for (const auto& r : rows) {
    ASSERT_TRUE(r.ok) << r.mode << ": " << r.error << "\n" << log.str() << err.str();
    // 30 s of the tank pattern (1.9 m, nearly straight): the global trajectory is good to
    // millimetres (2.7 mm in both variants, commit 3d8bce4; bound about twice). The SE3 rotation about a straight path
    // is not determined by positions, so the rotation RMSE is only checked to be a number here (tank750 gives 0.12
    // deg).
    std::cout << "tank30 " << r.mode << ": global ATE " << r.trans_rmse_m << " m\n";
    EXPECT_GT(r.trans_rmse_m, 0.0);
    EXPECT_LT(r.trans_rmse_m, 0.006) << r.mode;
    EXPECT_TRUE(std::isfinite(r.rot_rmse_deg)) << r.mode;
    EXPECT_GT(r.real_time_factor, 0.0) << r.mode;
    EXPECT_TRUE(r.has_loops) << r.mode;
    EXPECT_TRUE(fs::exists(out / r.mode / "map.vimsmap")) << r.mode;
    EXPECT_TRUE(fs::exists(out / r.mode / "offline.log")) << r.mode;
  }
  EXPECT_EQ(rows[0].mode, "vi_slam");
  const std::string md = readFile(out / "ablation.md");
  EXPECT_NE(md.find("| VI-SLAM | vi_slam |"), std::string::npos) << md;
  EXPECT_NE(md.find("| Full VIMS | full |"), std::string::npos) << md;
  EXPECT_NE(log.str().find("VIMS_ABLATION mode=full status=ok"), std::string::npos) << log.str();
  const std::string csv = readFile(out / "ablation.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3) << csv;
  EXPECT_GT(fs::file_size(out / "trajectories_top.png"), 1000u);
  EXPECT_GT(fs::file_size(out / "multiscale_map.png"), 1000u);

  // Place recognition on the two runs' maps. 30 s are too short for the paper's 50-keyframe
  // exclusion, so queries are compared with keyframes 5 s and 10 keyframes older here.
  PlaceRecognitionInputs in;
  in.sequence_dir = seq;
  in.orb_map = (out / "full" / "map.vimsmap").string();
  in.brief_map = (out / "vi_slam" / "map.vimsmap").string();
  in.signatures_csv = (out / "full" / "mag_signatures.csv").string();
  in.package_root = VIMS_SOURCE_DIR;
  PlaceRecognitionOptions pro;
  pro.loop.exclude_recent_keyframes = 10;
  pro.loop.exclude_recent_s = 5.0;
  std::ostringstream pr_log;
  const PlaceRecognitionResult pr = runPlaceRecognition(in, pro, (out / "pr").string(), pr_log);
  EXPECT_GT(pr.keyframes, 20u) << pr_log.str();
  ASSERT_EQ(pr.curves.size(), 4u);
  EXPECT_EQ(pr.curves[0].method, "Mag-ORB");
  for (const auto& c : pr.curves) {
    EXPECT_EQ(c.pairs, pr.curves[0].pairs);
    EXPECT_GE(c.best_f05, 0.0);
    EXPECT_LE(c.best_f05, 1.0);
  }
  // Mag-ORB recognises a subset of what ORB recognises at any threshold (the magnetic gate only
  // removes candidates), so at ORB's best threshold it has no more false positives.
  EXPECT_LE(pr.curves[0].points.empty() ? 0u : pr.curves[0].points.back().fp,
            pr.curves[2].points.empty() ? 0u : pr.curves[2].points.back().fp);
  EXPECT_EQ(pr.figures.size(), 5u);
  for (const auto& f : pr.figures) EXPECT_GT(fs::file_size(f), 1000u) << f;
  EXPECT_NE(pr_log.str().find("VIMS_PLACE_RECOGNITION method=BRIEF"), std::string::npos) << pr_log.str();

  // Re-evaluating the same runs (--no-run) gives the same table.
  AblationOptions again = o;
  again.run = false;
  again.figures = false;
  std::ostringstream log2, err2;
  const auto rows2 = runAblation(again, log2, err2);
  ASSERT_EQ(rows2.size(), 2u);
  EXPECT_DOUBLE_EQ(rows2[1].trans_rmse_m, rows[1].trans_rmse_m);
  EXPECT_EQ(rows2[1].verifications, rows[1].verifications);

  // A variant whose run fails (a configuration with an unknown key) is a row saying so.
  const fs::path bad_out = freshDir("tank30_bad_config");
  std::ofstream(bad_out / "bad.yaml") << "pose_graph:\n  no_such_key: 1\n";
  AblationOptions bad = o;
  bad.out_dir = (bad_out / "runs").string();
  bad.modes = {"full"};
  bad.offline_config = (bad_out / "bad.yaml").string();
  std::ostringstream log3, err3;
  const auto rows3 = runAblation(bad, log3, err3);
  ASSERT_EQ(rows3.size(), 1u);
  EXPECT_FALSE(rows3[0].ok);
  EXPECT_NE(rows3[0].error.find("exit status"), std::string::npos) << rows3[0].error;
  EXPECT_NE(readFile(bad_out / "runs" / "ablation.md").find("failed:"), std::string::npos);
}
