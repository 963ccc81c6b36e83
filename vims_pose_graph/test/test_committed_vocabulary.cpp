// The committed vocabulary (config/vocabulary/orb_k8l4.vocab, trained as docs/vocabulary.md
// says on world seed 9001) must recognise places of a seabed it has never seen (world seed
// 9002), revisited with other headings -- the situation VIMS's loop closing faces.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>

#include "vims_pose_graph/bow_database.h"
#include "vims_pose_graph/feature_extraction.h"
#include "vims_pose_graph/vocabulary.h"
#include "vims_sim/seabed_renderer.h"
#include "vims_sim/seabed_texture.h"

namespace fs = std::filesystem;

namespace vims {
namespace {

const std::string kVocabularyPath = std::string(VIMS_SOURCE_DIR) + "/config/vocabulary/orb_k8l4.vocab";

CameraCalibration downwardCamera() {
  CameraCalibration calib;
  calib.width = 640;
  calib.height = 480;
  calib.fx = calib.fy = 420.0;
  calib.cx = 320.0;
  calib.cy = 240.0;
  calib.distortion = {-0.05, 0.01, 0.0, 0.0};
  return calib;
}

/// Camera looking straight down from `altitude` above (x, y), image x axis along `heading`.
Eigen::Isometry3d downwardPose(double x, double y, double altitude, double heading) {
  Eigen::Matrix3d R_down;  // columns: camera x, y, z axes in the world; z points down
  R_down << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
  T_w_c.linear() = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R_down;
  T_w_c.translation() = Eigen::Vector3d(x, y, altitude);
  return T_w_c;
}

TEST(CommittedVocabulary, FileMatchesItsDocumentation) {
  ASSERT_TRUE(fs::exists(kVocabularyPath)) << kVocabularyPath;
  EXPECT_LE(fs::file_size(kVocabularyPath), 5u * 1024u * 1024u);
  const BinaryVocabulary voc = BinaryVocabulary::load(kVocabularyPath);
  EXPECT_EQ(voc.branching(), 8);
  EXPECT_EQ(voc.levels(), 4);
  EXPECT_EQ(voc.descriptorType(), "orb");
  EXPECT_GE(voc.numWords(), 4000u);
  EXPECT_EQ(voc.numTrainingImages(), 600u);
}

TEST(CommittedVocabulary, RecognisesUnseenSeabedRevisitedWithOtherHeadings) {
  auto voc = std::make_shared<const BinaryVocabulary>(BinaryVocabulary::load(kVocabularyPath));
  BowDatabase database(voc, 2);
  const sim::SeabedRenderer renderer(downwardCamera(), std::make_shared<const sim::SeabedTexture>(9002));
  FeatureExtractor extractor{FeatureExtractionOptions()};

  // 12 places 4 m apart (footprints do not overlap at 3 m altitude), first seen heading east.
  constexpr int kPlaces = 12;
  for (int i = 0; i < kPlaces; ++i) {
    const cv::Mat image = renderer.render(downwardPose(4.0 * i, 0.0, 3.0, 0.0), 100 + i);
    database.add(extractor.extract(image).descriptors);
  }
  // Revisits: turned by 90, 180 and 270 deg, 0.3 m off and 0.3 m higher, with other noise.
  int correct = 0;
  int queries = 0;
  for (int i = 0; i < kPlaces; ++i) {
    for (const double turn_deg : {90.0, 180.0, 270.0}) {
      const double heading = turn_deg * M_PI / 180.0;
      const cv::Mat image = renderer.render(downwardPose(4.0 * i + 0.3, 0.2, 3.3, heading), 1000 + queries);
      const auto results = database.query(voc->transform(extractor.extract(image).descriptors), 1);
      ASSERT_FALSE(results.empty());
      correct += results.front().image == static_cast<ImageId>(i) ? 1 : 0;
      ++queries;
    }
  }
  std::cout << "[ INFO     ] unseen seabed, rotated revisits: top-1 " << correct << " of " << queries << std::endl;
  EXPECT_GE(correct, static_cast<int>(0.9 * queries));
}

}  // namespace
}  // namespace vims
