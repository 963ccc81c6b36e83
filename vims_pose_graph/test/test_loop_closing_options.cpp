/// Options and modes, loops.csv, and the map file format (round trip and corrupt files) on a
/// map built without imagery.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>

#include "vims_common/fnv1a.h"
#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/input_recording.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_pose_graph/loop_csv.h"
#include "vims_pose_graph/multiscale_map.h"

namespace vims {
namespace {

namespace fs = std::filesystem;

std::shared_ptr<const BinaryVocabulary> loadVocabulary(const std::string& name) {
  return std::make_shared<const BinaryVocabulary>(
      BinaryVocabulary::load(std::string(VIMS_SOURCE_DIR) + "/config/vocabulary/" + name));
}

std::string tempPath(const std::string& name) {
  return (fs::temp_directory_path() / ("vims_lc_" + std::to_string(::getpid()) + "_" + name)).string();
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

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
  EXPECT_STREQ(loopCsvHeader(),
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
  const std::string row = formatLoopCsvRow(a);
  EXPECT_EQ(row.substr(0, 52), "1700000123.250000,1700000001.500000,1,0.500000,-1.25");
  EXPECT_NE(row.find(",41,2.500000e-08,0.125000,accepted"), std::string::npos) << row;
  EXPECT_NE(row.find("0.707106781"), std::string::npos) << row;
  EXPECT_NE(row.find("accepted,0.020000,0.030000,0.010000,0.500000,0"), std::string::npos) << row;
  LoopAttempt into_map = a;  // a loop into a loaded map says so in the last column
  into_map.match_in_map = true;
  const std::string row_map = formatLoopCsvRow(into_map);
  EXPECT_EQ(row_map.substr(row_map.size() - 2), ",1");

  LoopAttempt b;  // rejected at BoW: no magnetic distance
  b.bow_score = 0.01;
  b.stage = LoopStage::kBow;
  const std::string row_b = formatLoopCsvRow(b);
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
  EXPECT_EQ(line, loopCsvHeader());
  std::getline(in, line);
  EXPECT_EQ(line, row);
  std::remove(path.c_str());
  for (LoopStage s : {LoopStage::kMagnetic, LoopStage::kBow, LoopStage::kMatching, LoopStage::kPnp,
                      LoopStage::kCovisibility, LoopStage::kAccepted})
    EXPECT_EQ(loopStageFromString(toString(s)), s);
}

// ---------------------------------------------------------------------------------------------
// Map file
// ---------------------------------------------------------------------------------------------

/// A small map with every kind of content: two sessions, submaps with random ORB-like
/// descriptors, sequential / link / loop edges, yaw factors and magnetic submaps.
/// A camera 0.25 m ahead of the body looking down, a little rotated: what a map records per session.
Eigen::Isometry3d testCameraExtrinsic() {
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  T_b_c.linear() = rotationFromYawPitchRoll(-M_PI / 2, 0.01, M_PI - 0.02);
  T_b_c.translation() = Eigen::Vector3d(0.25, 0.01, -0.07);
  return T_b_c;
}

/// The bytes of an older file version: `bytes` with `erase` bytes removed at `offset` (after
/// each of `offsets`, back to front), the version set and the payload size and checksum redone.
std::vector<uint8_t> olderVersion(std::vector<uint8_t> bytes, std::vector<size_t> offsets, size_t erase,
                                  uint8_t version) {
  std::sort(offsets.rbegin(), offsets.rend());
  for (const size_t offset : offsets)
    bytes.erase(bytes.begin() + static_cast<std::ptrdiff_t>(offset),
                bytes.begin() + static_cast<std::ptrdiff_t>(offset + erase));
  bytes[8] = version;
  uint64_t payload = 0;
  for (int i = 0; i < 8; ++i) payload |= static_cast<uint64_t>(bytes[12 + i]) << (8 * i);
  payload -= erase * offsets.size();
  for (int i = 0; i < 8; ++i) bytes[12 + static_cast<size_t>(i)] = static_cast<uint8_t>(payload >> (8 * i));
  const uint64_t checksum = fnv1a64(bytes.data(), bytes.size() - 8);
  for (int i = 0; i < 8; ++i)
    bytes[bytes.size() - 8 + static_cast<size_t>(i)] = static_cast<uint8_t>(checksum >> (8 * i));
  return bytes;
}

MultiScaleMap makeMap(const std::shared_ptr<const BinaryVocabulary>& vocabulary, int keypoints_per_keyframe = 40) {
  MultiScaleMap map(vocabulary, PoseGraphOptions(), 0.1);
  map.setRunCameraExtrinsic(testCameraExtrinsic());
  std::mt19937_64 rng(7);
  const uint32_t s0 = map.addSession(0, false);
  const uint32_t s1 = map.addSession(1, false);
  for (int i = 0; i < 12; ++i) {
    const uint32_t s = i < 8 ? s0 : s1;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = rotationFromYawPitchRoll(0.1 * i, 0.02, -0.01);
    T.translation() = Eigen::Vector3d(0.5 * i, 0.1 * i, 2.0);
    VisualSubmap v;
    if (i != 5) {  // one keyframe without a visual submap
      for (int k = 0; k < keypoints_per_keyframe; ++k) {
        BinaryDescriptor d;
        for (uint64_t& w : d.words) w = rng();
        v.descriptors.push_back(d);
        v.keypoints.emplace_back(cv::Point2f(10.0f * k, 5.0f * k), 31.0f * (1 + k % 3), 12.5f * k, 1e-4f, k % 3);
        v.normalized.emplace_back(0.01 * k, -0.02 * k);
      }
      v.bow = vocabulary->transform(v.descriptors);
    }
    const PoseGraphNodeId id =
        map.addNode(100.0 + i, s, T, T.translation() + Eigen::Vector3d(0.01, 0, 0), 0.1 * i + 0.01, v, i % 2 == 0);
    if (i > 0 && i != 8) map.addSequentialEdge(id - 1, id);
  }
  map.addSessionLink(7, 8, 1.5, 0.4);
  Eigen::Isometry3d T_mq = Eigen::Isometry3d::Identity();
  T_mq.translation() = Eigen::Vector3d(0.2, -0.1, 0.05);
  map.addLoopEdge(1, 10, T_mq);
  EXPECT_TRUE(map.addYawMeasurement(3, Eigen::Vector3d(2e-5, 1e-5, -4e-5)));
  EXPECT_TRUE(map.addYawMeasurement(9, Eigen::Vector3d(1e-5, 2e-5, -4e-5)));
  MagneticSubmapDraft d;
  d.tied_node = 4;
  d.t = 104.2;
  d.coil = 3;
  d.signature_enu = Eigen::Vector3d(1e-7, -2e-7, 3e-7);
  d.radius_m = 0.8;
  d.num_members = 9;
  map.addMagneticSubmap(d);
  return map;
}

// save() streams through a 1 MiB buffer with an incremental checksum; a map of several buffers
// must give exactly the bytes of serialize() and load back.
TEST(MapFile, StreamedSaveOfALargeMapEqualsSerialize) {
  const auto vocabulary = loadVocabulary("orb_k8l4.vocab");
  const MultiScaleMap map = makeMap(vocabulary, 3000);
  const std::vector<uint8_t> bytes = map.serialize("orb.vocab");
  ASSERT_GT(bytes.size(), size_t{2} << 20);
  const std::string path = tempPath("large.vmap");
  map.save(path, "orb.vocab");
  std::ifstream in(path, std::ios::binary);
  const std::vector<uint8_t> saved((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(saved == bytes);
  MultiScaleMap loaded(vocabulary, PoseGraphOptions(), 0.1);
  EXPECT_NO_THROW(loaded.load(path));
  EXPECT_EQ(loaded.numNodes(), map.numNodes());
  std::remove(path.c_str());
}

// Loop edge weights: the constant sigmas, or with loop_sigma_from_inliers each loop's own
// sigmas with the floors added in quadrature; a loop without sigmas keeps the constants.
TEST(MultiScaleMapLoops, EdgeWeightsFromTheLoopsOwnSigmas) {
  const auto vocabulary = loadVocabulary("orb_k8l4.vocab");
  PoseGraphOptions graph;
  graph.loop_sigma_from_inliers = true;
  graph.loop_position_sigma_floor_m = 0.004;
  graph.loop_yaw_sigma_floor_rad = 0.001;
  MultiScaleMap map(vocabulary, graph, 0.1);
  const uint32_t s = map.addSession(0, false);
  for (int i = 0; i < 3; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0.5 * i, 0.0, 2.0);
    map.addNode(100.0 + i, s, T, T.translation(), 0.0, VisualSubmap(), false);
  }
  Eigen::Isometry3d T_mq = Eigen::Isometry3d::Identity();
  T_mq.translation() = Eigen::Vector3d(0.2, -0.1, 0.05);
  map.addLoopEdge(0, 2, T_mq, Eigen::Vector4d(0.003, 0.003, 0.0, 0.0));
  map.addLoopEdge(0, 1, T_mq);  // no sigmas (e.g. a degenerate refinement)
  ASSERT_EQ(map.loopEdges().size(), 2u);
  EXPECT_TRUE(
      map.loopEdges()[0].sqrt_information.isApprox(Eigen::Vector4d(1 / 0.005, 1 / 0.005, 1 / 0.004, 1 / 0.001), 1e-12));
  const double ip = 1.0 / graph.loop_position_sigma_m;
  EXPECT_TRUE(
      map.loopEdges()[1].sqrt_information.isApprox(Eigen::Vector4d(ip, ip, ip, 1.0 / graph.loop_yaw_sigma_rad), 1e-12));

  graph.loop_sigma_from_inliers = false;  // the default: constants for every loop
  MultiScaleMap constant(vocabulary, graph, 0.1);
  const uint32_t s2 = constant.addSession(0, false);
  for (int i = 0; i < 2; ++i)
    constant.addNode(100.0 + i, s2, Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), 0.0, VisualSubmap(), false);
  constant.addLoopEdge(0, 1, T_mq, Eigen::Vector4d(0.003, 0.003, 0.0, 0.0));
  EXPECT_TRUE(constant.loopEdges()[0].sqrt_information.isApprox(
      Eigen::Vector4d(ip, ip, ip, 1.0 / graph.loop_yaw_sigma_rad), 1e-12));
}

TEST(MapFile, RoundTripIsByteIdentical) {
  const auto vocabulary = loadVocabulary("orb_k8l4.vocab");
  const MultiScaleMap map = makeMap(vocabulary);
  const std::string path = tempPath("roundtrip.vmap");
  map.save(path, "config/vocabulary/orb_k8l4.vocab");
  MultiScaleMap loaded(vocabulary, PoseGraphOptions(), 0.1);
  loaded.load(path);
  EXPECT_EQ(loaded.serialize("config/vocabulary/orb_k8l4.vocab"), map.serialize("config/vocabulary/orb_k8l4.vocab"));
  ASSERT_EQ(loaded.numNodes(), map.numNodes());
  for (PoseGraphNodeId i = 0; i < map.numNodes(); ++i) {
    EXPECT_TRUE(loaded.worldPose(i).isApprox(map.worldPose(i), 1e-12));
    EXPECT_EQ(loaded.node(i).visual.descriptors, map.node(i).visual.descriptors);
    EXPECT_EQ(loaded.node(i).bow_image >= 0, map.node(i).bow_image >= 0);
    EXPECT_TRUE(loaded.sessions()[loaded.node(i).session].loaded);
  }
  // Each session keeps the camera extrinsic of the run that made it, not the loading run's.
  for (const MapSession& session : loaded.sessions()) EXPECT_TRUE(session.T_b_c.isApprox(testCameraExtrinsic(), 1e-15));
  EXPECT_EQ(loaded.loopEdges().size(), 1u);
  EXPECT_EQ(loaded.sequentialEdges().size(), map.sequentialEdges().size());
  EXPECT_EQ(loaded.yawMeasurements().size(), 2u);
  ASSERT_EQ(loaded.magneticSubmaps().size(), 1u);
  EXPECT_EQ(loaded.magneticSubmaps()[0].signature_enu, map.magneticSubmaps()[0].signature_enu);
  EXPECT_EQ(loaded.magneticSubmaps()[0].coil, 3);
  // Components survive: the link and the loop join both sessions.
  EXPECT_TRUE(loaded.sameComponent(0, 11));
  // The BoW database answers the same.
  const BowVector& q = map.node(10).visual.bow;
  const auto a = map.bowDatabase()->query(q, 3);
  const auto b = loaded.bowDatabase()->query(q, 3);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(map.nodeOfImage(a[i].image), loaded.nodeOfImage(b[i].image));
    EXPECT_DOUBLE_EQ(a[i].score, b[i].score);
  }
  // Loading twice into one map is a programming error, not a file error.
  EXPECT_THROW(loaded.load(path), std::logic_error);
  std::remove(path.c_str());
}

TEST(MapFile, CorruptFilesGiveClearErrors) {
  const auto vocabulary = loadVocabulary("orb_k8l4.vocab");
  const std::vector<uint8_t> good = makeMap(vocabulary).serialize("orb.vocab");
  auto loadBytes = [&](const std::vector<uint8_t>& bytes) {
    return errorOf([&] {
      MultiScaleMap m(vocabulary, PoseGraphOptions(), 0.0);
      m.deserialize(bytes, "test.vmap");
    });
  };
  EXPECT_EQ(loadBytes(good), "");

  std::vector<uint8_t> truncated(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(good.size() / 2));
  EXPECT_NE(loadBytes(truncated).find("truncated"), std::string::npos);
  EXPECT_NE(loadBytes(std::vector<uint8_t>(good.begin(), good.begin() + 10)).find("truncated"), std::string::npos);
  std::vector<uint8_t> longer = good;
  longer.push_back(0);
  EXPECT_NE(loadBytes(longer).find("oversized"), std::string::npos);
  std::vector<uint8_t> flipped = good;
  flipped[good.size() / 3] ^= 0x40;
  EXPECT_NE(loadBytes(flipped).find("checksum mismatch"), std::string::npos);
  std::vector<uint8_t> magic = good;
  magic[0] = 'X';
  EXPECT_NE(loadBytes(magic).find("bad magic"), std::string::npos);
  std::vector<uint8_t> version = good;
  version[8] = 99;
  EXPECT_NE(loadBytes(version).find("unsupported version 99"), std::string::npos);
  EXPECT_NE(loadBytes({}).find("test.vmap"), std::string::npos);

  // A version-2 file (before the sessions' camera extrinsics) loads with the loading run's
  // extrinsic. The two sessions' records (vio session, parent, then the extrinsic's 96 bytes)
  // follow the header, the descriptor type and vocabulary path strings, two u64 and the count.
  const size_t sessions_at = 20 + 4 + 3 + 4 + 9 + 8 + 8 + 4;
  ASSERT_EQ(std::string(good.begin() + 24, good.begin() + 27), "orb");
  const std::vector<uint8_t> v2 = olderVersion(good, {sessions_at + 8, sessions_at + 8 + 104}, 96, 2);
  MultiScaleMap v2_map(vocabulary, PoseGraphOptions(), 0.0);
  Eigen::Isometry3d loading_rig = Eigen::Isometry3d::Identity();
  loading_rig.translation() = Eigen::Vector3d(0.3, 0.0, 0.0);
  v2_map.setRunCameraExtrinsic(loading_rig);
  EXPECT_EQ(errorOf([&] { v2_map.deserialize(v2, "v2.vmap"); }), "");
  ASSERT_EQ(v2_map.sessions().size(), 2u);
  EXPECT_TRUE(v2_map.sessions()[1].T_b_c.isApprox(loading_rig));
  EXPECT_EQ(v2_map.numNodes(), 12u);

  // A version-1 file (before several coils: no coil index) still loads; its submaps are coil 0's.
  // The map's one submap is last: tied node, t, coil, signature, radius, members, then the checksum.
  const size_t coil_offset = v2.size() - 8 - 4 - 8 - 24 - 4;
  ASSERT_EQ(v2[coil_offset], 3);
  const std::vector<uint8_t> v1 = olderVersion(v2, {coil_offset}, 4, 1);
  MultiScaleMap old(vocabulary, PoseGraphOptions(), 0.0);
  EXPECT_EQ(errorOf([&] { old.deserialize(v1, "v1.vmap"); }), "");
  ASSERT_EQ(old.magneticSubmaps().size(), 1u);
  EXPECT_EQ(old.magneticSubmaps()[0].coil, 0);
  EXPECT_EQ(old.magneticSubmaps()[0].signature_enu, Eigen::Vector3d(1e-7, -2e-7, 3e-7));

  // A map built with BRIEF descriptors cannot be used by an ORB run (and vice versa).
  const auto brief = loadVocabulary("brief_k8l4.vocab");
  MultiScaleMap brief_map(brief, PoseGraphOptions(), 0.0);
  brief_map.addSession(0, false);
  const std::vector<uint8_t> brief_bytes = brief_map.serialize("brief.vocab");
  EXPECT_NE(loadBytes(brief_bytes).find("'brief' descriptors"), std::string::npos);

  // Missing file.
  MultiScaleMap m(vocabulary, PoseGraphOptions(), 0.0);
  const std::string missing = errorOf([&] { m.load("/nonexistent/dir/map.vmap"); });
  EXPECT_NE(missing.find("cannot be opened"), std::string::npos);
  EXPECT_THROW(m.load("/nonexistent/dir/map.vmap"), MapFileError);
  // A failed load leaves the map empty and usable.
  EXPECT_EQ(m.numNodes(), 0u);
  const uint32_t s = m.addSession(0, false);
  m.addNode(0.0, s, Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), 0.0, VisualSubmap(), false);
  EXPECT_EQ(m.numNodes(), 1u);
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

}  // namespace
}  // namespace vims
