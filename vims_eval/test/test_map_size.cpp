// vims_eval map-size: per-keyframe submap memory of a saved map (bench/soak.py's map column).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "vims_eval/map_figures.h"
#include "vims_pose_graph/pose_graph_manager.h"

namespace fs = std::filesystem;
using namespace vims;
using namespace vims::eval;

namespace {

/// A visual submap of `n` keypoints with made-up descriptors and the BoW vector the committed
/// ORB vocabulary gives them.
VisualSubmap submapOf(size_t n, const BinaryVocabulary& vocabulary) {
  VisualSubmap v;
  for (size_t i = 0; i < n; ++i) {
    v.keypoints.emplace_back(cv::Point2f(40.0f + i, 50.0f), 31.0f, 0.0f, 1.0f, 0);
    BinaryDescriptor d;
    for (size_t w = 0; w < d.words.size(); ++w) d.words[w] = 0x9E3779B97F4A7C15ull * (i + 1) * (w + 3);
    v.descriptors.push_back(d);
    v.normalized.emplace_back(0.01 * i, 0.02);
  }
  v.bow = vocabulary.transform(v.descriptors);
  return v;
}

}  // namespace

TEST(MapSize, RowsPerKeyframeAndCsvOfACulledAndAStoredSubmap) {
  PoseGraphManagerOptions options;
  const auto vocabulary = PoseGraphManager::loadVocabulary(options, defaultPackageRoot());
  MultiScaleMap map(vocabulary, options.graph, 0.0);
  const uint32_t s = map.addSession(0, false);
  const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  map.addNode(10.0, s, T, Eigen::Vector3d::Zero(), 0.0, submapOf(20, *vocabulary), false);
  VisualSubmap bow_only;  // a culled keyframe: its BoW vector only
  bow_only.bow = submapOf(20, *vocabulary).bow;
  map.addNode(11.0, s, T, Eigen::Vector3d(0.1, 0.0, 0.0), 0.0, std::move(bow_only), false);
  map.addNode(12.0, s, T, Eigen::Vector3d(0.2, 0.0, 0.0), 0.0, VisualSubmap(), false);  // no image corners

  const std::vector<MapGrowthRow> rows = mapGrowth(map);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_TRUE(rows[0].visual_submap);
  EXPECT_EQ(rows[0].keypoints, 20u);
  EXPECT_GE(rows[0].bytes, 20 * (sizeof(cv::KeyPoint) + sizeof(BinaryDescriptor) + sizeof(Eigen::Vector2d)));
  EXPECT_FALSE(rows[1].visual_submap);
  EXPECT_EQ(rows[1].keypoints, 0u);
  EXPECT_GT(rows[1].bytes, 0u);  // the BoW vector
  EXPECT_LT(rows[1].bytes, rows[0].bytes);
  EXPECT_EQ(rows[2].bytes, 0u);
  EXPECT_DOUBLE_EQ(rows[2].t, 12.0);

  const fs::path dir = fs::temp_directory_path() / ("vims_map_size_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string map_file = (dir / "map.vimsmap").string();
  map.save(map_file, options.vocabularyPath());
  std::ostringstream out, err;
  const std::string csv = (dir / "growth.csv").string();
  ASSERT_EQ(runMapSizeCli({"map-size", "--map", map_file, "--csv", csv}, out, err), 0) << err.str();
  EXPECT_NE(out.str().find("VIMS_MAP_SIZE keyframes=3 visual_submaps=1 without_submap=2 keypoints=20"),
            std::string::npos)
      << out.str();
  std::ifstream in(csv);
  std::string header, line;
  std::getline(in, header);
  EXPECT_EQ(header, "t,visual_submap,keypoints,bytes,cumulative_mb");
  int n = 0;
  while (std::getline(in, line)) ++n;
  EXPECT_EQ(n, 3);
  // A missing file is an error with the reason, not a crash.
  EXPECT_THROW(runMapSizeCli({"map-size", "--map", (dir / "none.vimsmap").string()}, out, err), std::exception);
  fs::remove_all(dir);
}
