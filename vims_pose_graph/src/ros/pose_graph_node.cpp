// vims_pose_graph_node: a thin ROS wrapper around vims::PoseGraphManager (asynchronous mode: the
// feed calls only enqueue, the manager's worker threads describe, detect and optimise).
//
// Subscribes  vio/keyframe     (vims/Keyframe) keyframes of the VIO
//             mag/signature    (vims/MagneticSignature) magnetic place signatures
//             mag/geomagnetic  (sensor_msgs/MagneticField) low-passed geomagnetic field, body frame
//             vio/odometry     (nav_msgs/Odometry) VIO odometry, republished corrected
// Publishes   global/path         (nav_msgs/Path, latched) optimised keyframe poses in map
//             global/map_path     (nav_msgs/Path, latched) the loaded map's keyframes in map (teach
//                                 and repeat), again whenever a solve may have moved them
//             global/odometry     (nav_msgs/Odometry) vio/odometry moved into map by T_map_odom
//             global/loop_edges   (visualization_msgs/Marker, latched) LINE_LIST between loop keyframes
//             global/map_markers  (visualization_msgs/MarkerArray, latched) magnetic submaps (discs of
//                                 their radius + ENU signature arrows), visual submaps (spheres:
//                                 this run's blue, a loaded map's purple)
//             global/map_status   (vims/MapStatus, latched) teach and repeat: map mode, relocalised or
//                                 not, loops into the loaded map, map -> odom
//             tf map -> odom      (REP 105), with every odometry message and after new keyframes
// Services    ~save_map        (vims/SaveMap) save the map now (path, '' = ~map_save)
//             ~load_map        (vims/LoadMap) load a map to relocalise into, before the first keyframe
//             ~set_map_mode    (vims/SetMapMode) mapping | extend | localisation
// Params      ~sequence_config (string, required): the sequence YAML (camera, T_b_c, declination)
//             ~config_file     (string or list of strings, optional): system configuration files
//                              (vims::SystemConfig); the node uses the section pose_graph (e.g.
//                              config/pose_graph.yaml); empty = the defaults. `synchronous` is
//                              forced to false.
//             ~mode            (string, optional): an ablation mode as vims_offline --mode
//                              (SystemConfig::applyMode), overriding pose_graph.mode; no_sonar
//                              (the estimator's ablation) means full here
//             ~package_root    (string): where relative vocabulary paths start; default: the path
//                              of the `vims` package (roslib), required without roslib
//             ~map_load        (string, optional): a saved map to relocalise against (teach and repeat)
//             ~map_save        (string, optional): where to save the map on shutdown (and ~save_map's default)
//             ~map_mode        (string, optional): mapping | extend | localisation, overriding
//                              pose_graph.map_mode
//             ~output_dir      (string, optional): writes loops.csv there as the attempts come
//                              and, on shutdown after processing what is queued, global.tum: the
//                              same files vims_offline writes (docs/offline_outputs.md)
//             ~map_frame_id, ~odom_frame_id (string, default "map", "odom")
//             ~publish_period_s           (double, default 1.0): path, loop edges and map markers
//             ~signature_arrow_length_m   (double, default 1.0): length of the signature arrows
//                                         (direction only: amplitudes span nT to uT)
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>
#include <tf2_ros/transform_broadcaster.h>
#include <vims/LoadMap.h>
#include <vims/MagneticSignature.h>
#include <vims/MapStatus.h>
#include <vims/SaveMap.h>
#include <vims/SetMapMode.h>
#include <visualization_msgs/Marker.h>
#include <visualization_msgs/MarkerArray.h>

#ifdef VIMS_HAVE_ROSLIB
#include <ros/package.h>
#endif

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "vims_common/config_reader.h"
#include "vims_common/heap.h"
#include "vims_common/sequence_config.h"
#include "vims_common/trajectory_io.h"
#include "vims_pose_graph/loop_csv.h"
#include "vims_pose_graph/pose_graph_manager.h"
#include "vims_ros/conversions.h"
#include "vims_ros/keyframe_conversions.h"
#include "vims_ros/node_config.h"
#include "vims_ros/ros_logger.h"
#include "vims_system/system_config.h"

namespace {

constexpr double kWarnThrottlePeriodS = 5.0;

struct NodeSettings {
  std::string map_frame_id = "map";
  std::string odom_frame_id = "odom";
  double publish_period_s = 1.0;
  double signature_arrow_length_m = 1.0;
  std::string map_save_path;
  std::string output_dir;
};

geometry_msgs::Point toPointMsg(const Eigen::Vector3d& p) {
  geometry_msgs::Point out;
  out.x = p.x();
  out.y = p.y();
  out.z = p.z();
  return out;
}

bool finite(const geometry_msgs::Vector3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

bool allFinite(const boost::array<double, 36>& values) {
  return std::all_of(values.begin(), values.end(), [](double x) { return std::isfinite(x); });
}

std_msgs::ColorRGBA colour(float r, float g, float b, float a) {
  std_msgs::ColorRGBA out;
  out.r = r;
  out.g = g;
  out.b = b;
  out.a = a;
  return out;
}

/// A 6x6 pose covariance (x, y, z, rot x, rot y, rot z; row-major) expressed in a frame rotated by R.
boost::array<double, 36> rotateCovariance(const boost::array<double, 36>& covariance, const Eigen::Matrix3d& R) {
  Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov(covariance.data());
  Eigen::Matrix<double, 6, 6> R6 = Eigen::Matrix<double, 6, 6>::Zero();
  R6.topLeftCorner<3, 3>() = R;
  R6.bottomRightCorner<3, 3>() = R;
  const Eigen::Matrix<double, 6, 6, Eigen::RowMajor> rotated = R6 * cov * R6.transpose();
  boost::array<double, 36> out;
  std::copy(rotated.data(), rotated.data() + 36, out.begin());
  return out;
}

class PoseGraphNode {
 public:
  PoseGraphNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, std::unique_ptr<vims::PoseGraphManager> manager,
                NodeSettings settings)
      : manager_(std::move(manager)), settings_(std::move(settings)) {
    path_pub_ = nh.advertise<nav_msgs::Path>("global/path", 2, true);
    map_path_pub_ = nh.advertise<nav_msgs::Path>("global/map_path", 1, true);
    odometry_pub_ = nh.advertise<nav_msgs::Odometry>("global/odometry", 50);
    loop_edges_pub_ = nh.advertise<visualization_msgs::Marker>("global/loop_edges", 2, true);
    map_markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("global/map_markers", 2, true);
    map_status_pub_ = nh.advertise<vims::MapStatus>("global/map_status", 1, true);
    save_map_srv_ = pnh.advertiseService("save_map", &PoseGraphNode::onSaveMap, this);
    load_map_srv_ = pnh.advertiseService("load_map", &PoseGraphNode::onLoadMap, this);
    set_map_mode_srv_ = pnh.advertiseService("set_map_mode", &PoseGraphNode::onSetMapMode, this);
    // Keyframes carry images: a short queue; the manager's own queue absorbs bursts.
    keyframe_sub_ = nh.subscribe("vio/keyframe", 20, &PoseGraphNode::onKeyframe, this);
    signature_sub_ = nh.subscribe("mag/signature", 50, &PoseGraphNode::onSignature, this);
    geomagnetic_sub_ = nh.subscribe("mag/geomagnetic", 200, &PoseGraphNode::onGeomagnetic, this);
    odometry_sub_ =
        nh.subscribe("vio/odometry", 200, &PoseGraphNode::onOdometry, this, ros::TransportHints().tcpNoDelay());
    publish_timer_ =
        nh.createWallTimer(ros::WallDuration(settings_.publish_period_s), &PoseGraphNode::onPublishTimer, this);
    if (!settings_.output_dir.empty()) {
      // loops.csv is streamed (the manager forgets the attempts it hands over): a mission's
      // attempts need not stay in memory until shutdown.
      try {
        std::error_code ec;
        std::filesystem::create_directories(settings_.output_dir, ec);
        loops_csv_ =
            std::make_unique<vims::LoopCsvWriter>((std::filesystem::path(settings_.output_dir) / "loops.csv").string());
      } catch (const std::exception& e) {
        ROS_ERROR_STREAM("cannot write loops.csv to " << settings_.output_dir << ": " << e.what());
      }
    }
    ROS_INFO_STREAM("pose graph (mode " << vims::toString(manager_->options().mode) << "): " << keyframe_sub_.getTopic()
                                        << ", " << signature_sub_.getTopic() << ", " << geomagnetic_sub_.getTopic()
                                        << ", " << odometry_sub_.getTopic() << " -> " << path_pub_.getTopic() << ", "
                                        << map_path_pub_.getTopic() << ", " << odometry_pub_.getTopic() << ", "
                                        << loop_edges_pub_.getTopic() << ", " << map_markers_pub_.getTopic() << ", "
                                        << map_status_pub_.getTopic() << ", tf " << settings_.map_frame_id << " -> "
                                        << settings_.odom_frame_id << "; services " << save_map_srv_.getService()
                                        << ", " << load_map_srv_.getService() << ", "
                                        << set_map_mode_srv_.getService());
    publishMapStatus();
  }

  /// End of the run (after ros::spin returned): processes what is still queued and saves the
  /// map when asked to. Returns false when saving failed. Reports on stderr: after SIGINT
  /// rosconsole no longer prints.
  bool shutdown() {
    publish_timer_.stop();
    if (settings_.map_save_path.empty() && settings_.output_dir.empty()) return true;
    manager_->finish();
    if (!settings_.output_dir.empty() && !writeOutputs()) return false;
    if (settings_.map_save_path.empty()) return true;
    try {
      manager_->saveMap(settings_.map_save_path);
    } catch (const std::exception& e) {
      std::cerr << "vims_pose_graph: could not save the map to " << settings_.map_save_path << ": " << e.what()
                << std::endl;
      return false;
    }
    std::cerr << "vims_pose_graph: map saved to " << settings_.map_save_path << std::endl;
    return true;
  }

 private:
  /// global.tum (the final optimised body pose of every keyframe of this run, world frame) and
  /// the last rows of loops.csv (streamed since the start), as vims_offline writes them.
  bool writeOutputs() {
    const std::filesystem::path dir(settings_.output_dir);
    try {
      std::error_code ec;
      std::filesystem::create_directories(dir, ec);
      const std::vector<vims::KeyframePose> poses = manager_->keyframePoses();
      vims::TumWriter global_tum((dir / "global.tum").string());
      for (const vims::KeyframePose& pose : poses) {
        global_tum.write(pose.t, pose.T_w_b.translation(), Eigen::Quaterniond(pose.T_w_b.linear()));
      }
      global_tum.flush();
      writeLoopAttempts(manager_->takeNewLoopAttempts());
      if (loops_csv_) loops_csv_->flush();
      std::cerr << "vims_pose_graph: " << poses.size() << " keyframe poses written to " << (dir / "global.tum").string()
                << std::endl;
    } catch (const std::exception& e) {
      std::cerr << "vims_pose_graph: could not write the outputs to " << settings_.output_dir << ": " << e.what()
                << std::endl;
      return false;
    }
    return true;
  }

  bool onSaveMap(vims::SaveMap::Request& request, vims::SaveMap::Response& response) {
    const std::string path = request.path.empty() ? settings_.map_save_path : request.path;
    if (path.empty()) {
      response.message = "no path given and no ~map_save set";
    } else {
      try {
        manager_->saveMap(path);
        response.success = true;
        response.message = "map saved to " + path;
      } catch (const std::exception& e) {
        response.message = "could not save the map to " + path + ": " + e.what();
      }
    }
    logServiceResult("save_map", response.success, response.message);
    return true;
  }

  bool onLoadMap(vims::LoadMap::Request& request, vims::LoadMap::Response& response) {
    try {
      manager_->loadMap(request.path);
      response.success = true;
      response.message = "map loaded from " + request.path;
    } catch (const vims::MapFileError& e) {
      response.message = e.what();
    } catch (const std::logic_error&) {
      response.message = "a map is loaded before the run's first keyframe and only once (restart with ~map_load)";
    }
    logServiceResult("load_map", response.success, response.message);
    publishMapStatus();
    return true;
  }

  bool onSetMapMode(vims::SetMapMode::Request& request, vims::SetMapMode::Response& response) {
    try {
      manager_->setMapMode(vims::mapModeFromString(request.mode));
      response.success = true;
      response.message = "map mode " + request.mode;
    } catch (const std::invalid_argument& e) {
      response.message = e.what();
    }
    logServiceResult("set_map_mode", response.success, response.message);
    publishMapStatus();
    return true;
  }

  static void logServiceResult(const char* service, bool success, const std::string& message) {
    if (success)
      ROS_INFO_STREAM(service << ": " << message);
    else
      ROS_WARN_STREAM(service << " failed: " << message);
  }

  void publishMapStatus() {
    const vims::RelocalisationStatus status = manager_->relocalisationStatus();
    vims::MapStatus msg;
    msg.header.stamp = ros::Time(status.latest_keyframe_t);
    msg.header.frame_id = settings_.map_frame_id;
    msg.map_mode = vims::toString(status.map_mode);
    msg.map_loaded = status.map_loaded;
    msg.map_path = status.map_path;
    msg.loaded_keyframes = static_cast<uint32_t>(status.loaded_keyframes);
    msg.run_keyframes = static_cast<uint32_t>(status.run_keyframes);
    msg.relocalised = status.relocalised;
    if (status.relocalised) msg.relocalised_stamp = ros::Time(status.relocalised_t);
    msg.loops_into_map = static_cast<uint32_t>(status.loops_into_map);
    msg.time_since_last_loop_into_map_s = -1.0;
    if (status.loops_into_map > 0) {
      msg.last_loop_into_map_stamp = ros::Time(status.last_loop_into_map_t);
      msg.time_since_last_loop_into_map_s = std::max(0.0, status.latest_keyframe_t - status.last_loop_into_map_t);
    }
    const geometry_msgs::Pose pose = vims::toPoseMsg(status.T_map_odom);
    msg.map_to_odom.translation.x = pose.position.x;
    msg.map_to_odom.translation.y = pose.position.y;
    msg.map_to_odom.translation.z = pose.position.z;
    msg.map_to_odom.rotation = pose.orientation;
    map_status_pub_.publish(msg);
  }

  void onKeyframe(const vims::Keyframe::ConstPtr& msg) {
    vims::KeyframeData keyframe;
    std::string why;
    if (!vims::toKeyframeData(*msg, &keyframe, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "keyframe dropped: " << why);
      return;
    }
    manager_->feedKeyframe(keyframe);
  }

  void onSignature(const vims::MagneticSignature::ConstPtr& msg) {
    vims::SignatureWindow window;
    std::string why;
    if (!vims::toSignatureWindow(*msg, &window, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "magnetic signature dropped: " << why);
      return;
    }
    manager_->feedSignature(window);
  }

  void onGeomagnetic(const sensor_msgs::MagneticField::ConstPtr& msg) {
    vims::MagSample sample;
    std::string why;
    if (!vims::toMagSample(*msg, &sample, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "geomagnetic sample dropped: " << why);
      return;
    }
    manager_->feedGeomagnetic(sample.t, sample.field);
  }

  void onOdometry(const nav_msgs::Odometry::ConstPtr& msg) {
    Eigen::Isometry3d T_odom_b;
    std::string why;
    if (!vims::toIsometry(msg->pose.pose, &T_odom_b, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "odometry dropped: " << why);
      return;
    }
    // The twist and the covariances are passed on: nothing non-finite may go out with them.
    if (!allFinite(msg->pose.covariance) || !allFinite(msg->twist.covariance) || !finite(msg->twist.twist.linear) ||
        !finite(msg->twist.twist.angular)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "odometry dropped: non-finite twist or covariance");
      return;
    }
    const Eigen::Isometry3d T_map_odom = manager_->T_map_odom();
    publishMapToOdom(T_map_odom, msg->header.stamp);

    nav_msgs::Odometry corrected;
    corrected.header.stamp = msg->header.stamp;
    corrected.header.frame_id = settings_.map_frame_id;
    corrected.child_frame_id = msg->child_frame_id;
    corrected.pose.pose = vims::toPoseMsg(T_map_odom * T_odom_b);
    corrected.pose.covariance = rotateCovariance(msg->pose.covariance, T_map_odom.rotation());
    corrected.twist = msg->twist;  // in the child (body) frame: unchanged by map -> odom
    odometry_pub_.publish(corrected);
  }

  void onPublishTimer(const ros::WallTimerEvent& /*event*/) {
    const std::vector<vims::KeyframePose> poses = manager_->keyframePoses();
    if (!poses.empty()) {
      // Keeps map -> odom current when no odometry arrives (e.g. only keyframes are recorded).
      publishMapToOdom(manager_->T_map_odom(), ros::Time(poses.back().t));
    }
    if (!poses.empty()) publishPath(path_pub_, poses);
    publishLoadedMapPath();
    publishLoopEdges(manager_->loopEdges());
    publishMapMarkers(manager_->mapContents());
    publishMapStatus();
    const std::vector<vims::LoopAttempt> attempts = manager_->takeNewLoopAttempts();
    for (const vims::LoopAttempt& attempt : attempts) {
      if (attempt.accepted) {
        ROS_INFO_STREAM("loop accepted: keyframe " << attempt.query_node << " (t " << attempt.t_query
                                                   << ") -> keyframe " << attempt.match_node << " (t "
                                                   << attempt.t_match << "), " << attempt.inliers << " inliers");
      }
    }
    writeLoopAttempts(attempts);
    // Freed pages back to the OS once a minute (vims_common/heap.h): the resident set then
    // follows the map on a long mission.
    heap_release_.tick(ros::WallTime::now().toSec());
  }

  void writeLoopAttempts(const std::vector<vims::LoopAttempt>& attempts) {
    if (!loops_csv_) return;
    try {
      for (const vims::LoopAttempt& attempt : attempts) loops_csv_->write(attempt);
    } catch (const std::exception& e) {
      ROS_ERROR_STREAM("loops.csv: " << e.what() << "; no more rows are written");
      loops_csv_.reset();
    }
  }

  /// tf2 drops (and warns about) a transform repeated at the same stamp: only newer stamps.
  void publishMapToOdom(const Eigen::Isometry3d& T_map_odom, const ros::Time& stamp) {
    if (last_tf_stamp_ && stamp <= *last_tf_stamp_) return;
    last_tf_stamp_ = stamp;
    geometry_msgs::TransformStamped transform;
    transform.header.stamp = stamp;
    transform.header.frame_id = settings_.map_frame_id;
    transform.child_frame_id = settings_.odom_frame_id;
    const geometry_msgs::Pose pose = vims::toPoseMsg(T_map_odom);
    transform.transform.translation.x = pose.position.x;
    transform.transform.translation.y = pose.position.y;
    transform.transform.translation.z = pose.position.z;
    transform.transform.rotation = pose.orientation;
    tf_broadcaster_.sendTransform(transform);
  }

  /// The loaded map's keyframes, after the load and again after each solve (mapping mode moves
  /// them; a held map's come out the same). The run's own are global/path.
  void publishLoadedMapPath() {
    const vims::RelocalisationStatus status = manager_->relocalisationStatus();
    if (!status.map_loaded) return;
    const size_t optimisations = manager_->stats().optimisations;
    if (map_path_published_ && optimisations == map_path_optimisations_) return;
    std::vector<vims::KeyframePose> loaded;
    for (const vims::KeyframePose& pose : manager_->keyframePoses(true))
      if (pose.loaded) loaded.push_back(pose);
    publishPath(map_path_pub_, loaded);
    map_path_published_ = true;
    map_path_optimisations_ = optimisations;
  }

  void publishPath(ros::Publisher& publisher, const std::vector<vims::KeyframePose>& poses) {
    nav_msgs::Path path;
    path.header.frame_id = settings_.map_frame_id;
    path.header.stamp = poses.empty() ? ros::Time() : ros::Time(poses.back().t);
    path.poses.reserve(poses.size());
    for (const vims::KeyframePose& pose : poses) {
      geometry_msgs::PoseStamped stamped;
      stamped.header.frame_id = settings_.map_frame_id;
      stamped.header.stamp = ros::Time(pose.t);
      stamped.pose = vims::toPoseMsg(pose.T_w_b);
      path.poses.push_back(stamped);
    }
    publisher.publish(path);
  }

  void publishLoopEdges(const std::vector<vims::LoopEdgeInfo>& edges) {
    visualization_msgs::Marker marker;
    marker.header.frame_id = settings_.map_frame_id;
    marker.header.stamp = ros::Time();
    marker.ns = "loop_edges";
    marker.id = 0;
    marker.type = visualization_msgs::Marker::LINE_LIST;
    marker.pose.orientation.w = 1.0;
    marker.scale.x = 0.05;  // line width [m]
    marker.color = colour(0.1f, 0.9f, 0.1f, 1.0f);
    if (edges.empty()) {
      marker.action = visualization_msgs::Marker::DELETE;
      loop_edges_pub_.publish(marker);
      return;
    }
    marker.action = visualization_msgs::Marker::ADD;
    const std_msgs::ColorRGBA enabled = colour(0.1f, 0.9f, 0.1f, 1.0f);
    const std_msgs::ColorRGBA disabled = colour(0.6f, 0.6f, 0.6f, 0.5f);
    for (const vims::LoopEdgeInfo& edge : edges) {
      marker.points.push_back(toPointMsg(edge.p_w_match));
      marker.points.push_back(toPointMsg(edge.p_w_query));
      marker.colors.push_back(edge.enabled ? enabled : disabled);
      marker.colors.push_back(edge.enabled ? enabled : disabled);
    }
    loop_edges_pub_.publish(marker);
  }

  void publishMapMarkers(const vims::MapContents& contents) {
    visualization_msgs::MarkerArray markers;
    visualization_msgs::Marker clear;
    clear.header.frame_id = settings_.map_frame_id;
    clear.action = visualization_msgs::Marker::DELETEALL;
    markers.markers.push_back(clear);

    for (const vims::MagneticSubmapMarker& submap : contents.magnetic) {
      visualization_msgs::Marker disc;
      disc.header.frame_id = settings_.map_frame_id;
      disc.ns = "magnetic_submaps";
      disc.id = static_cast<int>(submap.id);
      disc.type = visualization_msgs::Marker::CYLINDER;
      disc.action = visualization_msgs::Marker::ADD;
      disc.pose.position = toPointMsg(submap.p_w);
      disc.pose.orientation.w = 1.0;
      disc.scale.x = 2.0 * submap.radius_m;
      disc.scale.y = 2.0 * submap.radius_m;
      disc.scale.z = 0.02;  // a flat disc
      disc.color = colour(0.9f, 0.5f, 0.1f, 0.25f);
      markers.markers.push_back(disc);

      const double amplitude = submap.signature_enu.norm();
      if (amplitude > 0.0 && std::isfinite(amplitude)) {
        visualization_msgs::Marker arrow;
        arrow.header.frame_id = settings_.map_frame_id;
        arrow.ns = "magnetic_signatures";
        arrow.id = static_cast<int>(submap.id);
        arrow.type = visualization_msgs::Marker::ARROW;
        arrow.action = visualization_msgs::Marker::ADD;
        arrow.pose.orientation.w = 1.0;
        arrow.points.push_back(toPointMsg(submap.p_w));
        arrow.points.push_back(
            toPointMsg(submap.p_w + settings_.signature_arrow_length_m / amplitude * submap.signature_enu));
        arrow.scale.x = 0.04;  // shaft diameter [m]
        arrow.scale.y = 0.1;   // head diameter [m]
        arrow.scale.z = 0.15;  // head length [m]
        arrow.color = colour(0.9f, 0.2f, 0.1f, 0.9f);
        markers.markers.push_back(arrow);
      }
    }

    if (!contents.visual.empty()) {
      visualization_msgs::Marker spheres;
      spheres.header.frame_id = settings_.map_frame_id;
      spheres.ns = "visual_submaps";
      spheres.id = 0;
      spheres.type = visualization_msgs::Marker::SPHERE_LIST;
      spheres.action = visualization_msgs::Marker::ADD;
      spheres.pose.orientation.w = 1.0;
      spheres.scale.x = spheres.scale.y = spheres.scale.z = 0.1;
      const std_msgs::ColorRGBA this_run = colour(0.2f, 0.5f, 1.0f, 0.9f);
      const std_msgs::ColorRGBA loaded = colour(0.7f, 0.3f, 0.9f, 0.9f);
      for (const vims::VisualSubmapMarker& submap : contents.visual) {
        spheres.points.push_back(toPointMsg(submap.p_w));
        spheres.colors.push_back(submap.loaded ? loaded : this_run);
      }
      markers.markers.push_back(spheres);
    }
    map_markers_pub_.publish(markers);
  }

  std::unique_ptr<vims::PoseGraphManager> manager_;
  NodeSettings settings_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::optional<ros::Time> last_tf_stamp_;
  vims::PeriodicHeapRelease heap_release_;          ///< on the wall clock
  std::unique_ptr<vims::LoopCsvWriter> loops_csv_;  ///< OUT/loops.csv when ~output_dir is set
  ros::Publisher path_pub_;
  ros::Publisher map_path_pub_;
  bool map_path_published_ = false;
  size_t map_path_optimisations_ = 0;  ///< the solve count when global/map_path was last published
  ros::Publisher odometry_pub_;
  ros::Publisher loop_edges_pub_;
  ros::Publisher map_markers_pub_;
  ros::Publisher map_status_pub_;
  ros::ServiceServer save_map_srv_;
  ros::ServiceServer load_map_srv_;
  ros::ServiceServer set_map_mode_srv_;
  ros::Subscriber keyframe_sub_;
  ros::Subscriber signature_sub_;
  ros::Subscriber geomagnetic_sub_;
  ros::Subscriber odometry_sub_;
  ros::WallTimer publish_timer_;
};

/// ~package_root, else the `vims` package's path (roslib), else "" (the caller reports it).
std::string packageRoot(const ros::NodeHandle& pnh) {
  std::string root;
  if (pnh.getParam("package_root", root) && !root.empty()) return root;
#ifdef VIMS_HAVE_ROSLIB
  root = ros::package::getPath("vims");
#endif
  return root;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "vims_pose_graph");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string sequence_path, mode_name, map_load_path, map_mode_name;
  if (!pnh.getParam("sequence_config", sequence_path)) {
    ROS_FATAL("parameter ~sequence_config (path of the sequence YAML) is required");
    return 1;
  }
  pnh.param<std::string>("mode", mode_name, "");
  pnh.param<std::string>("map_load", map_load_path, "");
  pnh.param<std::string>("map_mode", map_mode_name, "");
  NodeSettings settings;
  pnh.param<std::string>("map_save", settings.map_save_path, "");
  pnh.param<std::string>("output_dir", settings.output_dir, "");
  pnh.param<std::string>("map_frame_id", settings.map_frame_id, settings.map_frame_id);
  pnh.param<std::string>("odom_frame_id", settings.odom_frame_id, settings.odom_frame_id);
  pnh.param("publish_period_s", settings.publish_period_s, settings.publish_period_s);
  pnh.param("signature_arrow_length_m", settings.signature_arrow_length_m, settings.signature_arrow_length_m);
  if (!(settings.publish_period_s > 0.0) || !std::isfinite(settings.publish_period_s)) {
    ROS_FATAL_STREAM("parameter ~publish_period_s must be > 0 (is " << settings.publish_period_s << ")");
    return 1;
  }
  if (!(settings.signature_arrow_length_m > 0.0) || !std::isfinite(settings.signature_arrow_length_m)) {
    ROS_FATAL_STREAM("parameter ~signature_arrow_length_m must be > 0 (is " << settings.signature_arrow_length_m
                                                                            << ")");
    return 1;
  }
  const std::string package_root = packageRoot(pnh);
  if (package_root.empty()) {
    ROS_FATAL(
        "parameter ~package_root (where the relative vocabulary paths start) is required: the vims "
        "package was not found");
    return 1;
  }

  std::unique_ptr<PoseGraphNode> node;
  try {
    std::vector<std::string> unknown;
    const vims::SequenceConfig sequence = vims::SequenceConfig::load(sequence_path, &unknown);
    for (const auto& key : unknown) ROS_WARN_STREAM(sequence_path << ": key '" << key << "' is not in the contract");
    vims::SystemConfig config = vims::SystemConfig::load(vims::configFilesParam(pnh), sequence);
    if (!mode_name.empty()) config.applyMode(mode_name);
    vims::PoseGraphManagerOptions& options = config.pose_graph;
    if (!map_mode_name.empty()) options.map_mode = vims::mapModeFromString(map_mode_name);
    if (options.map_mode != vims::MapMode::kMapping && map_load_path.empty())
      ROS_WARN_STREAM("map mode " << vims::toString(options.map_mode)
                                  << " without ~map_load: load a map with ~load_map before the first keyframe, "
                                     "or the run maps");
    if (options.synchronous) {
      ROS_INFO("pose graph options: synchronous ignored, the node uses the worker threads");
      options.synchronous = false;
    }
    ROS_INFO_STREAM("pose graph options:\n" << options.toYaml());
    auto manager = std::make_unique<vims::PoseGraphManager>(
        options, sequence, vims::PoseGraphManager::loadVocabulary(options, package_root), vims::rosLogger());
    if (!map_load_path.empty()) {
      manager->loadMap(map_load_path);
      ROS_INFO_STREAM("map loaded from " << map_load_path);
    }
    node = std::make_unique<PoseGraphNode>(nh, pnh, std::move(manager), settings);
  } catch (const vims::ConfigError& e) {
    ROS_FATAL_STREAM("configuration error: " << e.what());
    return 1;
  } catch (const vims::VocabularyFileError& e) {
    ROS_FATAL_STREAM("vocabulary: " << e.what() << " (package_root " << package_root << ")");
    return 1;
  } catch (const vims::MapFileError& e) {
    ROS_FATAL_STREAM("parameter ~map_load: " << e.what());
    return 1;
  } catch (const std::invalid_argument& e) {
    ROS_FATAL_STREAM("pose graph options (or ~map_mode): " << e.what());
    return 1;
  }
  ros::spin();
  return node->shutdown() ? 0 : 1;
}
