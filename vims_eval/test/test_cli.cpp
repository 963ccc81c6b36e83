#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "vims_common/trajectory_io.h"
#include "vims_eval/cli.h"

namespace fs = std::filesystem;
using vims::StampedPose;
using vims::eval::runEvalCli;

namespace {

struct CliResult {
  int code;
  std::string out;
  std::string err;
};

CliResult run(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = runEvalCli(args, out, err);
  return {code, out.str(), err.str()};
}

/// A clean temporary directory per test.
fs::path tempDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("vims_eval_cli_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

/// Two laps of a 20 m x 10 m rectangle-ish loop at 1 m/s, 20 Hz ground truth.
std::vector<StampedPose> groundTruth() {
  std::vector<StampedPose> gt;
  for (int i = 0; i <= 20 * 160; ++i) {
    StampedPose p;
    p.t = 1000.0 + 0.05 * i;
    const double a = 2 * M_PI * (p.t - 1000.0) / 80.0;
    p.p = Eigen::Vector3d(10.0 * std::cos(a), 5.0 * std::sin(a), -8.0);
    p.q = Eigen::Quaterniond(Eigen::AngleAxisd(a + M_PI / 2, Eigen::Vector3d::UnitZ()));
    gt.push_back(p);
  }
  return gt;
}

/// Every 5th ground-truth pose, shifted in time by 2 ms, with a small drift in x.
/// Every fifth pose of `gt`, 2 ms late, drifting along x by `drift` m per second.
std::vector<StampedPose> estimate(const std::vector<StampedPose>& gt, double drift = 0.002) {
  std::vector<StampedPose> est;
  for (std::size_t i = 0; i < gt.size(); i += 5) {
    StampedPose p = gt[i];
    p.t += 0.002;
    p.p.x() += drift * (p.t - 1000.0);
    est.push_back(p);
  }
  return est;
}

void writeLoops(const fs::path& path, const std::vector<StampedPose>& gt) {
  std::ofstream out(path);
  out << "t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,bow_score,stage\n";
  // A correct loop on the second lap (t = 1090 revisits t = 1010), written from the truth.
  const StampedPose& q = gt[1800];  // t = 1090
  const StampedPose& m = gt[200];   // t = 1010
  const Eigen::Quaterniond q_m_q = m.q.conjugate() * q.q;
  const Eigen::Vector3d p_m_q = m.q.conjugate() * (q.p - m.p);
  out.precision(12);
  out << q.t << "," << m.t << ",1," << p_m_q.x() << "," << p_m_q.y() << "," << p_m_q.z() << "," << q_m_q.x() << ","
      << q_m_q.y() << "," << q_m_q.z() << "," << q_m_q.w() << ",50,1e-7,0.2,accepted\n";
  out << q.t << "," << m.t << ",0,3,0,0,0,0,0,1,4,,0.01,ransac\n";
}

}  // namespace

TEST(Cli, HelpAndUsageErrors) {
  EXPECT_EQ(run({"--help"}).code, 0);
  EXPECT_NE(run({"--help"}).out.find("vims_eval traj"), std::string::npos);
  EXPECT_EQ(run({}).code, 2);
  EXPECT_EQ(run({"bogus"}).code, 2);
  const CliResult missing = run({"traj", "--gt", "a.tum"});
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.err.find("--est is required"), std::string::npos) << missing.err;
  EXPECT_EQ(run({"traj", "--gt", "a", "--est", "b", "--frobnicate"}).code, 2);
  EXPECT_EQ(run({"traj", "--gt", "a", "--est", "b", "--max-dt", "abc"}).code, 2);
  EXPECT_EQ(run({"traj", "--gt", "a", "--est", "b", "--align", "se2"}).code, 2);
}

TEST(Cli, TrajAndLoopsCommands) {
  const fs::path dir = tempDir("traj");
  const auto gt = groundTruth();
  vims::writeTumFile((dir / "gt.tum").string(), gt);
  vims::writeTumFile((dir / "vio.tum").string(), estimate(gt));

  const CliResult missing = run({"traj", "--gt", (dir / "nope.tum").string(), "--est", (dir / "vio.tum").string()});
  EXPECT_EQ(missing.code, 1);
  EXPECT_NE(missing.err.find("nope.tum"), std::string::npos) << missing.err;

  const CliResult traj = run({"traj", "--gt", (dir / "gt.tum").string(), "--est", (dir / "vio.tum").string(), "--plots",
                              (dir / "plots").string()});
  ASSERT_EQ(traj.code, 0) << traj.err;
  const std::string last_line = traj.out.substr(traj.out.rfind("VIMS_EVAL "));
  EXPECT_EQ(last_line.find("VIMS_EVAL label=vio align=se3 poses=641 "), 0u) << last_line;
  EXPECT_TRUE(fs::exists(dir / "plots" / "vio_top.png"));
  EXPECT_TRUE(fs::exists(dir / "plots" / "vio_ate.png"));

  // A 20 ms clock offset breaks nearest-stamp association at 10 ms but not at 30 ms.
  auto shifted = estimate(gt);
  for (auto& p : shifted) p.t += 0.02;
  vims::writeTumFile((dir / "late.tum").string(), shifted);
  const CliResult late = run({"traj", "--gt", (dir / "gt.tum").string(), "--est", (dir / "late.tum").string(),
                              "--max-dt", "0.005", "--align", "se3"});
  EXPECT_EQ(late.code, 1);
  EXPECT_NE(late.err.find("no estimate stamp matches"), std::string::npos) << late.err;
  EXPECT_EQ(
      run({"traj", "--gt", (dir / "gt.tum").string(), "--est", (dir / "late.tum").string(), "--interpolate"}).code, 0);

  writeLoops(dir / "loops.csv", gt);
  const CliResult loops = run({"loops", "--gt", (dir / "gt.tum").string(), "--loops", (dir / "loops.csv").string()});
  ASSERT_EQ(loops.code, 0) << loops.err;
  EXPECT_NE(loops.out.find("VIMS_EVAL_LOOPS verifications=2 accepted=1 correct=1 wrong=0 "), std::string::npos)
      << loops.out;

  std::ofstream(dir / "bad.csv") << "t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,bow_score,stage\n"
                                 << "1,2,1,0,0,0,0,0,0,1,5,0.1,0.2,s\n1,2,1\n";
  const CliResult bad = run({"loops", "--gt", (dir / "gt.tum").string(), "--loops", (dir / "bad.csv").string()});
  EXPECT_EQ(bad.code, 1);
  EXPECT_NE(bad.err.find("bad.csv:3:"), std::string::npos) << bad.err;
}

TEST(Cli, RunWritesEvalYamlAndPlots) {
  const fs::path root = tempDir("run");
  const fs::path seq = root / "lap";
  const fs::path out = root / "out";
  fs::create_directories(seq);
  fs::create_directories(out);
  const auto gt = groundTruth();
  std::ofstream(seq / "lap.bag").put('\n');  // only its presence is checked
  std::ofstream(seq / "lap.yaml") << "{}\n";

  // No ground truth yet: a clear error.
  const CliResult no_gt = run({"run", "--sequence", seq.string(), "--out", out.string()});
  EXPECT_EQ(no_gt.code, 1);
  EXPECT_NE(no_gt.err.find("lap_gt.tum"), std::string::npos) << no_gt.err;

  vims::writeTumFile((seq / "lap_gt.tum").string(), gt);
  const CliResult nothing = run({"run", "--sequence", seq.string(), "--out", out.string()});
  EXPECT_EQ(nothing.code, 1);
  EXPECT_NE(nothing.err.find("nothing to evaluate"), std::string::npos) << nothing.err;

  vims::writeTumFile((out / "vio.tum").string(), estimate(gt));
  vims::writeTumFile((out / "global.tum").string(), estimate(gt, 0.004));  // twice the VIO's drift
  writeLoops(out / "loops.csv", gt);
  const CliResult result = run({"run", "--sequence", seq.string(), "--out", out.string()});
  ASSERT_EQ(result.code, 0) << result.err;
  EXPECT_NE(result.out.find("VIMS_EVAL label=vio "), std::string::npos);
  EXPECT_NE(result.out.find("VIMS_EVAL label=global "), std::string::npos);
  EXPECT_NE(result.out.find("VIMS_EVAL_LOOPS "), std::string::npos);
  // A global trajectory drifting twice as fast as the VIO: twice its error, and said so.
  EXPECT_NE(result.out.find("VIMS_EVAL_GLOBAL_VS_VIO trans_ratio=2.0000 "), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("global_better=no"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("worse than the odometry"), std::string::npos) << result.out;

  const YAML::Node yaml = YAML::LoadFile((out / "eval.yaml").string());
  EXPECT_EQ(yaml["sequence"].as<std::string>(), "lap");
  EXPECT_EQ(yaml["trajectories"]["vio"]["associated_poses"].as<int>(), 641);
  EXPECT_GT(yaml["trajectories"]["global"]["alignments"]["se3"]["ate_m"]["rmse"].as<double>(), 0.0);
  EXPECT_NEAR(yaml["global_vs_vio"]["trans_ratio"].as<double>(), 2.0, 1e-6);
  EXPECT_EQ(yaml["loops"]["correct"].as<int>(), 1);
  EXPECT_EQ(yaml["loops"]["revisit"]["events"].as<int>(), 1);
  EXPECT_EQ(yaml["loops"]["revisit"]["closed"].as<int>(), 1);
  EXPECT_EQ(yaml["plots"].size(), 5u);
  for (const auto& p : yaml["plots"]) EXPECT_TRUE(fs::exists(p.as<std::string>())) << p.as<std::string>();
}

TEST(Cli, RunCountsTheRevisitsNearEachCoilOfTheTruthFile) {
  const fs::path root = tempDir("run_coils");
  const fs::path seq = root / "lap";
  const fs::path out = root / "out";
  fs::create_directories(seq);
  fs::create_directories(out);
  const auto gt = groundTruth();
  std::ofstream(seq / "lap.bag").put('\n');
  std::ofstream(seq / "lap.yaml") << "{}\n";
  vims::writeTumFile((seq / "lap_gt.tum").string(), gt);
  writeLoops(out / "loops.csv", gt);

  // A truth file of another generator, without coil positions: no per-coil lines.
  std::ofstream(seq / "lap_truth.yaml") << "generator: other\nseed: 3\n";
  const CliResult plain = run({"run", "--sequence", seq.string(), "--out", out.string()});
  ASSERT_EQ(plain.code, 0) << plain.err;
  EXPECT_EQ(plain.out.find("VIMS_EVAL_COILS"), std::string::npos) << plain.out;

  // The second lap's revisit event starts at (10, 0), on coil 0; coil 1 is 20 m away.
  {
    std::ofstream truth(seq / "lap_truth.yaml");
    truth << "coil: {position_enu: [10, 0, -10], frequency_hz: 11}\n"
          << "other_coils:\n  - {position_enu: [-10, 0, -10], frequency_hz: 17}\n";
  }
  const CliResult result = run({"run", "--sequence", seq.string(), "--out", out.string()});
  ASSERT_EQ(result.code, 0) << result.err;
  // The accepted loop's query (t = 1090) is at (7.1, 3.5), 4.6 m from coil 0.
  EXPECT_NE(
      result.out.find("VIMS_EVAL_COILS coils=2 coil0_events=1 coil0_closed=1 coil0_loops_correct=1 "
                      "coil0_loops_wrong=0 coil1_events=0 coil1_closed=0 coil1_loops_correct=0 coil1_loops_wrong=0"),
      std::string::npos)
      << result.out;
  const YAML::Node yaml = YAML::LoadFile((out / "eval.yaml").string());
  ASSERT_EQ(yaml["loops"]["near_coils"].size(), 2u);
  EXPECT_EQ(yaml["loops"]["near_coils"][1]["coil"].as<int>(), 1);
  EXPECT_DOUBLE_EQ(yaml["loops"]["near_coils"][1]["position_enu"][0].as<double>(), -10.0);
  EXPECT_EQ(yaml["loops"]["near_coils"][0]["loops_correct"].as<int>(), 1);

  // A radius of 25 m takes coil 1 in, but the event counts once, for the nearest coil.
  const CliResult wide = run({"run", "--sequence", seq.string(), "--out", out.string(), "--revisit-coil-radius", "25"});
  EXPECT_NE(wide.out.find("coil0_events=1 coil0_closed=1 coil0_loops_correct=1 coil0_loops_wrong=0 coil1_events=0"),
            std::string::npos)
      << wide.out;

  // A malformed position is an error naming the key.
  std::ofstream(seq / "lap_truth.yaml") << "coil: {position_enu: [10, 0]}\n";
  const CliResult bad = run({"run", "--sequence", seq.string(), "--out", out.string()});
  EXPECT_EQ(bad.code, 1);
  EXPECT_NE(bad.err.find("coil.position_enu"), std::string::npos) << bad.err;
}

TEST(Cli, RelocalisationScoresARepeatRunAgainstTheTeachRunsMap) {
  const fs::path root = tempDir("relocalisation");
  const auto gt = groundTruth();  // the teach run: an ellipse, 160 s
  // The repeat run: the same place 500 s later, its global poses in the teach map's frame
  // (here the world itself) 0.05 m off in y, relocalised 2 s in by a loop into the map.
  std::vector<StampedPose> repeat_gt = gt;
  for (auto& p : repeat_gt) p.t += 500.0;
  std::vector<StampedPose> repeat_est = estimate(repeat_gt, 0.0);
  for (auto& p : repeat_est) p.p.y() += 0.05;
  for (const char* name : {"teach", "repeat"}) {
    fs::create_directories(root / name);
    fs::create_directories(root / (std::string(name) + "_out"));
    std::ofstream(root / name / (std::string(name) + ".bag")).put('\n');
    std::ofstream(root / name / (std::string(name) + ".yaml")) << "{}\n";
  }
  vims::writeTumFile((root / "teach" / "teach_gt.tum").string(), gt);
  vims::writeTumFile((root / "teach_out" / "global.tum").string(), estimate(gt, 0.0));
  vims::writeTumFile((root / "repeat" / "repeat_gt.tum").string(), repeat_gt);
  vims::writeTumFile((root / "repeat_out" / "global.tum").string(), repeat_est);
  std::ofstream(root / "repeat_out" / "summary.yaml")
      << "pose_graph: {keyframes: 3, relocalised: true, relocalised_t: 1502.000}\n";
  {
    // One loop into the map (the teach run's t = 1010 seen again at the repeat's t = 1510), right.
    std::ofstream loops(root / "repeat_out" / "loops.csv");
    const StampedPose& q = repeat_gt[200];
    const StampedPose& m = gt[200];
    const Eigen::Quaterniond q_m_q = m.q.conjugate() * q.q;
    const Eigen::Vector3d p_m_q = m.q.conjugate() * (q.p - m.p);
    loops.precision(12);
    loops << "t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,bow_score,stage,match_in_map\n"
          << q.t << "," << m.t << ",1," << p_m_q.x() << "," << p_m_q.y() << "," << p_m_q.z() << "," << q_m_q.x() << ","
          << q_m_q.y() << "," << q_m_q.z() << "," << q_m_q.w() << ",50,,0.2,accepted,1\n";
  }
  const std::vector<std::string> args = {"relocalisation",
                                         "--teach-sequence",
                                         (root / "teach").string(),
                                         "--teach-out",
                                         (root / "teach_out").string(),
                                         "--sequence",
                                         (root / "repeat").string(),
                                         "--out",
                                         (root / "repeat_out").string()};
  const CliResult result = run(args);
  ASSERT_EQ(result.code, 0) << result.err;
  EXPECT_NE(result.out.find("VIMS_EVAL_RELOC relocalised=1 correct=1 entered=1 t_entered=1500.000 "
                            "t_relocalised=1502.000 delay_s=2.00 error_at_relocalisation_m=0.050"),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("map_loops_correct=1 map_loops_wrong=0"), std::string::npos) << result.out;
  const YAML::Node yaml = YAML::LoadFile((root / "repeat_out" / "relocalisation.yaml").string());
  EXPECT_NEAR(yaml["ate_map_rmse_m"].as<double>(), 0.05, 1e-6);

  // A summary without the relocalisation figures (an older run): an error naming the key.
  std::ofstream(root / "repeat_out" / "summary.yaml") << "pose_graph: {keyframes: 3}\n";
  const CliResult old = run(args);
  EXPECT_EQ(old.code, 1);
  EXPECT_NE(old.err.find("pose_graph.relocalised"), std::string::npos) << old.err;
  EXPECT_EQ(run({"relocalisation", "--sequence", (root / "repeat").string()}).code, 2);
}
