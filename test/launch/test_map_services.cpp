// rostest node for test/launch/map_services.test: the pose-graph node's teach-and-repeat
// interface before any keyframe. The latched status says what the node does with a map; the
// services refuse what they cannot do with a message that says why (a mode that needs a map, an
// unknown mode, a save without a path, a file that is not a map, a second load) and do what
// they can (save, load, switch the mode), which the status then shows.
#include <gtest/gtest.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <unistd.h>
#include <vims/LoadMap.h>
#include <vims/MapStatus.h>
#include <vims/SaveMap.h>
#include <vims/SetMapMode.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>

namespace {

constexpr double kTimeoutS = 30.0;

/// Spins until `done` or the timeout; false on timeout.
bool spinUntil(const std::function<bool()>& done) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(kTimeoutS);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    if (done()) return true;
    ros::WallDuration(0.02).sleep();
  }
  return false;
}

template <typename Service>
Service call(const std::string& name, const std::function<void(Service&)>& fill) {
  Service srv;
  fill(srv);
  EXPECT_TRUE(ros::service::waitForService(name, ros::Duration(kTimeoutS))) << name;
  EXPECT_TRUE(ros::service::call(name, srv)) << name;
  return srv;
}

vims::SetMapMode setMode(const std::string& mode) {
  return call<vims::SetMapMode>("/pose_graph/set_map_mode", [&](vims::SetMapMode& s) { s.request.mode = mode; });
}
vims::SaveMap save(const std::string& path) {
  return call<vims::SaveMap>("/pose_graph/save_map", [&](vims::SaveMap& s) { s.request.path = path; });
}
vims::LoadMap load(const std::string& path) {
  return call<vims::LoadMap>("/pose_graph/load_map", [&](vims::LoadMap& s) { s.request.path = path; });
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(MapServices, StatusAndServicesSayWhatTheyDidAndWhy) {
  ros::NodeHandle nh;
  std::optional<vims::MapStatus> status;
  auto sub =
      nh.subscribe<vims::MapStatus>("global/map_status", 10, [&](const vims::MapStatus::ConstPtr& m) { status = *m; });
  ASSERT_TRUE(spinUntil([&] { return status.has_value(); })) << "no global/map_status";
  std::optional<nav_msgs::Path> loaded_path;
  auto loaded_path_sub =
      nh.subscribe<nav_msgs::Path>("global/map_path", 10, [&](const nav_msgs::Path::ConstPtr& m) { loaded_path = *m; });
  EXPECT_EQ(status->map_mode, "mapping");
  EXPECT_FALSE(status->map_loaded);
  EXPECT_FALSE(status->relocalised);
  EXPECT_EQ(status->run_keyframes, 0u);
  EXPECT_DOUBLE_EQ(status->time_since_last_loop_into_map_s, -1.0);
  EXPECT_DOUBLE_EQ(status->map_to_odom.rotation.w, 1.0);

  const vims::SetMapMode no_map = setMode("localisation");
  EXPECT_FALSE(no_map.response.success);
  EXPECT_TRUE(contains(no_map.response.message, "needs a loaded map")) << no_map.response.message;
  const vims::SetMapMode unknown = setMode("localization");
  EXPECT_FALSE(unknown.response.success);
  EXPECT_TRUE(contains(unknown.response.message, "unknown map mode")) << unknown.response.message;
  const vims::SaveMap no_path = save("");
  EXPECT_FALSE(no_path.response.success);
  EXPECT_TRUE(contains(no_path.response.message, "no path")) << no_path.response.message;

  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("vims_map_services_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string map_path = (dir / "empty.vimsmap").string();
  const std::string garbage_path = (dir / "garbage.vimsmap").string();
  std::ofstream(garbage_path) << "not a map";

  const vims::SaveMap saved = save(map_path);
  EXPECT_TRUE(saved.response.success) << saved.response.message;
  EXPECT_TRUE(std::filesystem::exists(map_path));
  const vims::LoadMap garbage = load(garbage_path);
  EXPECT_FALSE(garbage.response.success);
  EXPECT_TRUE(contains(garbage.response.message, "map file")) << garbage.response.message;
  const vims::LoadMap loaded = load(map_path);
  EXPECT_TRUE(loaded.response.success) << loaded.response.message;
  // The loaded map's keyframes (none in this one) are drawn once it is loaded, not before.
  EXPECT_FALSE(loaded_path.has_value()) << "global/map_path before a map was loaded";
  ASSERT_TRUE(spinUntil([&] { return loaded_path.has_value(); })) << "no global/map_path after the load";
  EXPECT_TRUE(loaded_path->poses.empty());
  EXPECT_EQ(loaded_path->header.frame_id, "map");
  const vims::LoadMap again = load(map_path);
  EXPECT_FALSE(again.response.success);
  EXPECT_TRUE(contains(again.response.message, "only once")) << again.response.message;

  const vims::SetMapMode localising = setMode("localisation");
  EXPECT_TRUE(localising.response.success) << localising.response.message;
  status.reset();
  ASSERT_TRUE(spinUntil([&] { return status && status->map_mode == "localisation"; })) << "status not updated";
  EXPECT_TRUE(status->map_loaded);
  EXPECT_EQ(status->map_path, map_path);
  std::filesystem::remove_all(dir);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_vims_map_services");
  return RUN_ALL_TESTS();
}
