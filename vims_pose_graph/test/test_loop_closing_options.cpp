/// Options and modes, loops.csv and the input recording (the map file: test_map_file.cpp).

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <sstream>

#include "test_files.h"
#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/input_recording.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_pose_graph/loop_csv.h"

namespace vims {
namespace {

std::string tempPath(const std::string& name) { return test::tempPath("lc", name); }

using test::errorOf;

// ---------------------------------------------------------------------------------------------
// Modes and options
// ---------------------------------------------------------------------------------------------

TEST(LoopClosingModes, EachModeSelectsItsStages) {
  const ModeSettings full = ModeSettings::forMode(LoopClosingMode::kFull);
  EXPECT_EQ(full.descriptor, DescriptorType::kOrb);
  EXPECT_TRUE(full.magnetic_stage);
  EXPECT_FALSE(full.verify_all_bow_candidates);
  EXPECT_TRUE(full.geomagnetic_yaw);

  const ModeSettings vi = ModeSettings::forMode(LoopClosingMode::kViSlam);
  EXPECT_EQ(vi.descriptor, DescriptorType::kBrief);
  EXPECT_FALSE(vi.magnetic_stage);
  EXPECT_TRUE(vi.verify_all_bow_candidates);
  EXPECT_FALSE(vi.geomagnetic_yaw);

  const ModeSettings no_alter = ModeSettings::forMode(LoopClosingMode::kNoAlter);
  EXPECT_EQ(no_alter.descriptor, DescriptorType::kOrb);
  EXPECT_FALSE(no_alter.magnetic_stage);
  EXPECT_TRUE(no_alter.geomagnetic_yaw);

  const ModeSettings no_orb = ModeSettings::forMode(LoopClosingMode::kNoOrb);
  EXPECT_EQ(no_orb.descriptor, DescriptorType::kBrief);
  EXPECT_TRUE(no_orb.magnetic_stage);
  EXPECT_TRUE(no_orb.geomagnetic_yaw);

  const ModeSettings no_geom = ModeSettings::forMode(LoopClosingMode::kNoGeom);
  EXPECT_EQ(no_geom.descriptor, DescriptorType::kOrb);
  EXPECT_TRUE(no_geom.magnetic_stage);
  EXPECT_FALSE(no_geom.geomagnetic_yaw);

  for (LoopClosingMode m : {LoopClosingMode::kFull, LoopClosingMode::kViSlam, LoopClosingMode::kNoAlter,
                            LoopClosingMode::kNoOrb, LoopClosingMode::kNoGeom})
    EXPECT_EQ(loopClosingModeFromString(toString(m)), m);
  EXPECT_THROW(loopClosingModeFromString("no_sonar"), std::invalid_argument);

  PoseGraphManagerOptions o;
  o.mode = LoopClosingMode::kNoOrb;
  EXPECT_EQ(o.vocabularyPath(), o.vocabulary_brief);
  EXPECT_EQ(o.featureOptions().descriptor, DescriptorType::kBrief);
  o.mode = LoopClosingMode::kNoGeom;
  EXPECT_EQ(o.vocabularyPath(), o.vocabulary_orb);
  EXPECT_EQ(resolveVocabularyPath("config/v.vocab", "/pkg"), "/pkg/config/v.vocab");
  EXPECT_EQ(resolveVocabularyPath("/abs/v.vocab", "/pkg"), "/abs/v.vocab");
}

TEST(LoopClosingOptions, FromReaderReadsNestedBlocksAndRoundTrips) {
  const ConfigReader r = ConfigReader::fromString(R"(
mode: no_alter
synchronous: true
optimise_every_n_keyframes: 4
session_link_yaw_sigma_deg: 30
features: {max_features: 400, fast_threshold: 12}
magnetic_submaps: {max_relative_variation: 0.2, min_members: 4}
loop_closing: {match_ratio: 0.7, pnp_min_inliers: 30, record_prefilter_rejections: false}
pose_graph: {loop_loss: huber}
)");
  const PoseGraphManagerOptions o = PoseGraphManagerOptions::fromReader(r);
  EXPECT_EQ(o.mode, LoopClosingMode::kNoAlter);
  EXPECT_TRUE(o.synchronous);
  EXPECT_EQ(o.optimise_every_n_keyframes, 4);
  EXPECT_NEAR(o.session_link_yaw_sigma_rad, 30.0 * M_PI / 180.0, 1e-12);
  EXPECT_EQ(o.features.max_features, 400);
  EXPECT_EQ(o.features.fast_threshold, 12);
  EXPECT_DOUBLE_EQ(o.magnetic.max_relative_variation, 0.2);
  EXPECT_EQ(o.magnetic.min_members, 4);
  EXPECT_DOUBLE_EQ(o.loop.match_ratio, 0.7);
  EXPECT_EQ(o.loop.pnp_min_inliers, 30);
  EXPECT_FALSE(o.loop.record_prefilter_rejections);
  EXPECT_EQ(o.graph.loop_loss, RobustLoss::kHuber);

  const PoseGraphManagerOptions back = PoseGraphManagerOptions::fromReader(ConfigReader::fromString(o.toYaml()));
  EXPECT_EQ(back.toYaml(), o.toYaml());
  // Defaults round-trip too.
  const PoseGraphManagerOptions d;
  EXPECT_EQ(PoseGraphManagerOptions::fromReader(ConfigReader::fromString(d.toYaml())).toYaml(), d.toYaml());
}

TEST(LoopClosingOptions, UnknownKeysAndBadValuesNameTheKey) {
  auto error = [](const std::string& yaml) {
    return errorOf([&] { PoseGraphManagerOptions::fromReader(ConfigReader::fromString(yaml)); });
  };
  EXPECT_NE(error("mod: full").find("mod"), std::string::npos);
  EXPECT_NE(error("mode: fast").find("mode"), std::string::npos);
  EXPECT_NE(error("loop_closing: {match_ratio: 1.5}").find("loop_closing.match_ratio"), std::string::npos);
  EXPECT_NE(error("loop_closing: {pnp_min_inliers: 3}").find("loop_closing.pnp_min_inliers"), std::string::npos);
  EXPECT_NE(error("loop_closing: {ratio: 0.8}").find("loop_closing.ratio"), std::string::npos);
  EXPECT_NE(error("loop_closing: {redundant_submap_radius_m: -0.5}").find("loop_closing.redundant_submap_radius_m"),
            std::string::npos);
  EXPECT_NE(error("loop_closing: {redundant_submap_max_height_difference_m: -1}")
                .find("loop_closing.redundant_submap_max_height_difference_m"),
            std::string::npos);
  EXPECT_NE(error("magnetic_submaps: {max_radius_m: -1}").find("magnetic_submaps.max_radius_m"), std::string::npos);
  EXPECT_NE(error("geomagnetic_gate: {inclination_deg: 0}").find("geomagnetic_gate.inclination_deg"),
            std::string::npos);
  EXPECT_NE(error("geomagnetic_gate: {min_samples: 2}").find("geomagnetic_gate.min_samples"), std::string::npos);
  EXPECT_NE(error("features: {descriptor: brief}").find("features.descriptor"), std::string::npos);
  EXPECT_NE(error("pose_graph: {loop_loss: l2}").find("pose_graph.loop_loss"), std::string::npos);
  EXPECT_NE(error("vocabulary_orb: ''").find("vocabulary_orb"), std::string::npos);
  EXPECT_NE(error("magnetic_wait_s: nope").find("magnetic_wait_s"), std::string::npos);
  PoseGraphManagerOptions o;
  o.loop.match_ratio = 0.0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// loops.csv
// ---------------------------------------------------------------------------------------------

TEST(LoopCsv, HeaderAndRowsInTheEvaluatorsFormat) {
  EXPECT_STREQ(LoopCsv::header(),
               "t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,bow_score,stage,sigma_x,sigma_y,sigma_"
               "z,sigma_yaw_deg,match_in_map");
  LoopAttempt a;
  a.t_query = 1700000123.25;
  a.t_match = 1700000001.5;
  a.accepted = true;
  a.T_match_query.translation() = Eigen::Vector3d(0.5, -1.25, 0.125);
  a.T_match_query.linear() = rotationZ(M_PI / 2);
  a.inliers = 41;
  a.mag_distance = 2.5e-8;
  a.bow_score = 0.125;
  a.stage = LoopStage::kAccepted;
  a.sigma = Eigen::Vector4d(0.02, 0.03, 0.01, 0.5 * M_PI / 180.0);
  const std::string row = LoopCsv::row(a);
  EXPECT_EQ(row.substr(0, 52), "1700000123.250000,1700000001.500000,1,0.500000,-1.25");
  EXPECT_NE(row.find(",41,2.500000e-08,0.125000,accepted"), std::string::npos) << row;
  EXPECT_NE(row.find("0.707106781"), std::string::npos) << row;
  EXPECT_NE(row.find("accepted,0.020000,0.030000,0.010000,0.500000,0"), std::string::npos) << row;
  LoopAttempt into_map = a;  // a loop into a loaded map says so in the last column
  into_map.match_in_map = true;
  const std::string row_map = LoopCsv::row(into_map);
  EXPECT_EQ(row_map.substr(row_map.size() - 2), ",1");

  LoopAttempt b;  // rejected at BoW: no magnetic distance
  b.bow_score = 0.01;
  b.stage = LoopStage::kBow;
  const std::string row_b = LoopCsv::row(b);
  EXPECT_NE(row_b.find(",0,,0.010000,bow,,,,"), std::string::npos) << row_b;  // no PnP: no sigmas
  EXPECT_EQ(std::count(row_b.begin(), row_b.end(), ','), 18);

  const std::string path = tempPath("loops.csv");
  {
    LoopCsvWriter w(path);
    w.write(a);
    w.write(b);
  }
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, LoopCsv::header());
  std::getline(in, line);
  EXPECT_EQ(line, row);
  std::remove(path.c_str());
  for (LoopStage s : {LoopStage::kMagnetic, LoopStage::kBow, LoopStage::kMatching, LoopStage::kPnp,
                      LoopStage::kCovisibility, LoopStage::kAccepted})
    EXPECT_EQ(loopStageFromString(toString(s)), s);
}

TEST(InputRecording, SignatureWindowsKeepTheirCoilAndVersionOneStillReads) {
  const std::string path = tempPath("inputs.bin");
  SignatureWindow w;
  w.t = 12.0;
  w.t_start = 11.0;
  w.t_end = 13.0;
  w.coil = 2;
  w.frequency_hz = 17.0;
  w.amplitude_enu = Eigen::Vector3d(1e-7, -2e-7, 3e-7);
  w.snr = 400.0;
  w.valid = true;
  {
    InputRecorder recorder(path);
    recorder.write(w);
  }
  {
    InputReader reader(path);
    RecordedInput input;
    ASSERT_TRUE(reader.next(&input));
    const auto* read = std::get_if<SignatureWindow>(&input);
    ASSERT_NE(read, nullptr);
    EXPECT_EQ(read->coil, 2);
    EXPECT_EQ(read->amplitude_enu, w.amplitude_enu);
    EXPECT_TRUE(read->valid);
    EXPECT_FALSE(reader.next(&input));
  }
  // Version 1: the same bytes without the trailing coil index.
  std::ifstream in(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  bytes.resize(bytes.size() - 4);
  bytes[8] = 1;
  std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  InputReader old(path);
  RecordedInput input;
  ASSERT_TRUE(old.next(&input));
  ASSERT_NE(std::get_if<SignatureWindow>(&input), nullptr);
  EXPECT_EQ(std::get<SignatureWindow>(input).coil, 0);
  EXPECT_EQ(std::get<SignatureWindow>(input).amplitude_enu, w.amplitude_enu);
  EXPECT_FALSE(old.next(&input));
  std::remove(path.c_str());
}

TEST(InputRecording, KeyframesKeepTheirPortDepthAndCameraExtrinsicAndVersionTwoStillReads) {
  const std::string path = tempPath("keyframes.bin");
  KeyframeData with;
  with.t = 5.0;
  with.session = 1;
  with.T_odom_b.translation() = Eigen::Vector3d(1.0, 2.0, -3.0);
  with.port_depth = 8.25;
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  T_b_c.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.6, -0.8, 0.0)).toRotationMatrix();
  T_b_c.translation() = Eigen::Vector3d(0.25, 0.01, -0.08);
  with.T_b_c = T_b_c;
  KeyframeData without = with;
  without.t = 6.0;
  without.port_depth.reset();
  without.T_b_c.reset();
  {
    InputRecorder recorder(path);
    recorder.write(with);
    recorder.write(without);
  }
  {
    InputReader reader(path);
    RecordedInput input;
    ASSERT_TRUE(reader.next(&input));
    const KeyframeData& a = std::get<KeyframeData>(input);
    ASSERT_TRUE(a.port_depth.has_value());
    EXPECT_EQ(*a.port_depth, 8.25);
    ASSERT_TRUE(a.T_b_c.has_value());
    EXPECT_TRUE(a.T_b_c->isApprox(T_b_c, 0.0));
    EXPECT_TRUE(a.T_odom_b.isApprox(with.T_odom_b, 0.0));
    ASSERT_TRUE(reader.next(&input));
    EXPECT_FALSE(std::get<KeyframeData>(input).port_depth.has_value());
    EXPECT_FALSE(std::get<KeyframeData>(input).T_b_c.has_value());
    EXPECT_FALSE(reader.next(&input));
  }
  // Version 2: a keyframe event without the trailing parts byte.
  {
    InputRecorder recorder(path);
    recorder.write(without);
  }
  std::ifstream in(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  bytes.resize(bytes.size() - 1);
  bytes[8] = 2;
  std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  InputReader old(path);
  RecordedInput input;
  ASSERT_TRUE(old.next(&input));
  EXPECT_EQ(std::get<KeyframeData>(input).t, 6.0);
  EXPECT_FALSE(old.next(&input));
  std::remove(path.c_str());
}

}  // namespace
}  // namespace vims
