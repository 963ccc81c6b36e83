/// The map file format on a map built without imagery: round trip, the keypoint blocks read
/// when asked for, older versions, and corrupt files.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>

#include "test_files.h"
#include "vims_common/fnv1a.h"
#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/multiscale_map.h"

namespace vims {
namespace {

std::shared_ptr<const BinaryVocabulary> loadVocabulary(const std::string& name) {
  return std::make_shared<const BinaryVocabulary>(
      BinaryVocabulary::load(std::string(VIMS_SOURCE_DIR) + "/config/vocabulary/" + name));
}

std::string tempPath(const std::string& name) { return test::tempPath("map_file", name); }

using test::errorOf;

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
    EXPECT_EQ(loaded.visualSubmap(i)->descriptors, map.visualSubmap(i)->descriptors);
    EXPECT_EQ(loaded.node(i).num_keypoints, map.node(i).num_keypoints);
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
  const BowVector& q = map.node(10).bow;
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
  std::vector<uint8_t> flipped = good;  // a byte of the index (the vocabulary path)
  flipped[28 + 4 + 3 + 4 + 2] ^= 0x40;
  EXPECT_NE(loadBytes(flipped).find("checksum mismatch"), std::string::npos);
  std::vector<uint8_t> blocks_size = good;  // the index says less keypoint bytes than the keyframes have
  blocks_size[20] ^= 0x01;
  EXPECT_NE(loadBytes(blocks_size).find("truncated"), std::string::npos);
  std::vector<uint8_t> magic = good;
  magic[0] = 'X';
  EXPECT_NE(loadBytes(magic).find("bad magic"), std::string::npos);
  std::vector<uint8_t> version = good;
  version[8] = 99;
  EXPECT_NE(loadBytes(version).find("unsupported version 99"), std::string::npos);
  EXPECT_NE(loadBytes({}).find("test.vmap"), std::string::npos);

  // A version-3 file (keypoints inline, one checksum) loads, and writes back as this version.
  const MultiScaleMap source = makeMap(vocabulary);
  const std::vector<uint8_t> v3 = source.serialize("orb.vocab", MapSaveScope::kAll, 3);
  MultiScaleMap v3_map(vocabulary, PoseGraphOptions(), 0.0);
  EXPECT_EQ(errorOf([&] { v3_map.deserialize(v3, "v3.vmap"); }), "");
  EXPECT_TRUE(v3_map.serialize("orb.vocab") == good);
  EXPECT_TRUE(v3_map.serialize("orb.vocab", MapSaveScope::kAll, 3) == v3);
  std::vector<uint8_t> v3_flipped = v3;  // version 3 checks every byte at once
  v3_flipped[v3.size() / 2] ^= 0x40;
  EXPECT_NE(loadBytes(v3_flipped).find("checksum mismatch"), std::string::npos);
  EXPECT_NE(
      errorOf([&] { source.serialize("orb.vocab", MapSaveScope::kAll, 2); }).find("cannot write map file version 2"),
      std::string::npos);

  // A version-2 file (before the sessions' camera extrinsics) loads with the loading run's
  // extrinsic. The two sessions' records (vio session, parent, then the extrinsic's 96 bytes)
  // follow the header, the descriptor type and vocabulary path strings, two u64 and the count.
  const size_t sessions_at = 20 + 4 + 3 + 4 + 9 + 8 + 8 + 4;
  ASSERT_EQ(std::string(v3.begin() + 24, v3.begin() + 27), "orb");
  const std::vector<uint8_t> v2 = olderVersion(v3, {sessions_at + 8, sessions_at + 8 + 104}, 96, 2);
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

// Version 4 leaves each keyframe's keypoints in the (mapped) file until a loop asks for them:
// they decode to what was saved, the file can be replaced by a save while mapped, a corrupt
// block is logged once and reads as no submap while the other keyframes work.
TEST(MapFile, KeypointBlocksAreReadWhenAskedForAndACorruptOneIsLeftOut) {
  const auto vocabulary = loadVocabulary("orb_k8l4.vocab");
  const MultiScaleMap map = makeMap(vocabulary);
  const std::string path = tempPath("paged.vmap");
  map.save(path, "orb.vocab");
  MultiScaleMap loaded(vocabulary, PoseGraphOptions(), 0.1);
  loaded.load(path);
  // Saving over the loaded file (a rename) keeps the loaded map's bytes.
  loaded.save(path, "orb.vocab");
  for (PoseGraphNodeId i = 0; i < map.numNodes(); ++i) {
    EXPECT_EQ(loaded.node(i).num_keypoints, map.node(i).num_keypoints);
    const std::shared_ptr<const VisualSubmap> a = map.visualSubmap(i), b = loaded.visualSubmap(i);
    EXPECT_EQ(b->descriptors, a->descriptors) << "node " << i;
    EXPECT_EQ(b->normalized, a->normalized) << "node " << i;
    ASSERT_EQ(b->keypoints.size(), a->keypoints.size());
    for (size_t k = 0; k < a->keypoints.size(); ++k) {
      EXPECT_EQ(b->keypoints[k].pt, a->keypoints[k].pt);
      EXPECT_EQ(b->keypoints[k].octave, a->keypoints[k].octave);
      EXPECT_EQ(b->keypoints[k].angle, a->keypoints[k].angle);
    }
  }
  EXPECT_FALSE(loaded.node(5).hasVisualSubmap());
  EXPECT_TRUE(loaded.visualSubmap(5)->empty());

  // A byte of the last keyframe's block (the file's last bytes) flipped after saving.
  std::vector<uint8_t> bytes = map.serialize("orb.vocab");
  bytes[bytes.size() - 3] ^= 0x10;
  std::vector<std::string> errors;
  auto logger = std::make_shared<Logger>(
      [&](LogLevel level, const std::string&, const std::string& message) {
        if (level == LogLevel::kError) errors.push_back(message);
      },
      LogLevel::kInfo);
  MultiScaleMap corrupt(vocabulary, PoseGraphOptions(), 0.1, logger);
  ASSERT_EQ(errorOf([&] { corrupt.deserialize(bytes, "flipped.vmap"); }), "");
  const PoseGraphNodeId last = static_cast<PoseGraphNodeId>(map.numNodes() - 1);
  EXPECT_TRUE(corrupt.visualSubmap(last)->empty());
  EXPECT_TRUE(corrupt.visualSubmap(last)->empty());
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("flipped.vmap': the visual submap of keyframe 11 is corrupt (checksum mismatch)"),
            std::string::npos)
      << errors[0];
  EXPECT_EQ(corrupt.visualSubmap(last - 1)->descriptors, map.visualSubmap(last - 1)->descriptors);
  // Written again, the corrupt block keeps its recorded checksum: still detected on the next load.
  MultiScaleMap again(vocabulary, PoseGraphOptions(), 0.1);
  again.deserialize(corrupt.serialize("orb.vocab"), "again.vmap");
  EXPECT_TRUE(again.visualSubmap(last)->empty());
  std::remove(path.c_str());
}

}  // namespace
}  // namespace vims
