/// The committed configuration files under config/ are what users copy and what the launch files
/// load, so they must state exactly the defaults the code uses: a file that drifts from the code
/// would document one value and run with another (or, when a node loads it, silently change the
/// behaviour of the offline runner, which uses the built-in defaults). Each file is read with the
/// module's own validating reader and its effective options are compared with the defaults.
#include <gtest/gtest.h>

#include <string>

#include "vims_common/config_reader.h"
#include "vims_estimator/estimator_options.h"
#include "vims_magnetometer/magnetometer_options.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_sonar/sonar_filter_options.h"
#include "vims_tracking/tracker_options.h"

namespace {

vims::ConfigReader committedConfig(const std::string& name) {
  return vims::ConfigReader::fromFile(std::string(VIMS_SOURCE_DIR) + "/config/" + name);
}

/// Reads `section` of `file` with the module's reader and compares the effective
/// options, as YAML, with the defaults. The YAML text names the differing key in the failure.
template <typename Options>
void expectFileStatesTheDefaults(const std::string& file, const std::string& section) {
  SCOPED_TRACE("config/" + file);
  const vims::ConfigReader root = committedConfig(file);
  Options from_file;
  root.rejectUnknownKeys({section});  // one module's file: its section alone
  ASSERT_NO_THROW(from_file = Options::fromReader(root.child(section)));
  EXPECT_EQ(from_file.toYaml(), Options().toYaml())
      << "config/" << file << " differs from the defaults in the code: update one of them";
}

TEST(CommittedConfigs, SonarFileStatesTheDefaults) {
  expectFileStatesTheDefaults<vims::SonarFilterOptions>("sonar.yaml", "sonar");
}

TEST(CommittedConfigs, MagnetometerFileStatesTheDefaults) {
  expectFileStatesTheDefaults<vims::MagnetometerOptions>("magnetometer.yaml", "magnetometer");
}

TEST(CommittedConfigs, TrackerFileStatesTheDefaults) {
  expectFileStatesTheDefaults<vims::TrackerOptions>("tracker.yaml", "tracker");
}

TEST(CommittedConfigs, EstimatorFileStatesTheDefaults) {
  expectFileStatesTheDefaults<vims::EstimatorOptions>("estimator.yaml", "estimator");
}

TEST(CommittedConfigs, PoseGraphFileStatesTheDefaults) {
  expectFileStatesTheDefaults<vims::PoseGraphManagerOptions>("pose_graph.yaml", "pose_graph");
}

/// The check above must be able to fail: a changed value is visible in the compared YAML.
TEST(CommittedConfigs, AChangedValueIsDetected) {
  const vims::SonarFilterOptions changed =
      vims::SonarFilterOptions::fromReader(vims::ConfigReader::fromString("window_size: 9\n"));
  EXPECT_NE(changed.toYaml(), vims::SonarFilterOptions().toYaml());
}

}  // namespace

/// config/long_mission.yaml: what the profile is for (a map that stops growing, bench/soak.py).
TEST(CommittedConfigs, LongMissionProfileCullsRedundantViews) {
  vims::PoseGraphManagerOptions profile;
  ASSERT_NO_THROW(
      profile = vims::PoseGraphManagerOptions::fromReader(committedConfig("long_mission.yaml").child("pose_graph")));
  EXPECT_FALSE(profile.loop.keep_culled_bow_vectors);
  EXPECT_GT(profile.loop.redundant_submap_radius_m, vims::PoseGraphManagerOptions().loop.redundant_submap_radius_m);
}

/// config/embedded.yaml: the embedded budget (issue 19) caps features, keyframes and places, and
/// every key in it is one the modules accept.
TEST(CommittedConfigs, EmbeddedProfileCapsFeaturesKeyframesAndPlaces) {
  const vims::ConfigReader root = committedConfig("embedded.yaml");
  ASSERT_NO_THROW(root.rejectUnknownKeys({"tracker", "estimator", "pose_graph"}));
  vims::TrackerOptions tracker;
  vims::EstimatorOptions estimator;
  vims::PoseGraphManagerOptions pose_graph;
  ASSERT_NO_THROW(tracker = vims::TrackerOptions::fromReader(root.child("tracker")));
  ASSERT_NO_THROW(estimator = vims::EstimatorOptions::fromReader(root.child("estimator")));
  ASSERT_NO_THROW(pose_graph = vims::PoseGraphManagerOptions::fromReader(root.child("pose_graph")));
  EXPECT_LT(tracker.max_features, vims::TrackerOptions().max_features);
  EXPECT_GT(estimator.keyframe_parallax_px, vims::EstimatorOptions().keyframe_parallax_px);
  EXPECT_GT(pose_graph.place_min_interval_s, vims::PoseGraphManagerOptions().place_min_interval_s);
}
