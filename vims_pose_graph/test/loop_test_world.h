#pragma once
/// @file loop_test_world.h
/// @brief Test fixture: keyframes rendered by the simulator's seabed renderer (vims_sim) at
/// chosen body poses over a flat textured seabed z = 0, with the VIO's tracked points made from
/// Shi-Tomasi corners of the image and their ground-truth 3D points (ray-plane intersection).

#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "vims_common/camera_model.h"
#include "vims_common/keyframe_data.h"
#include "vims_common/magnetic_signature.h"
#include "vims_common/sequence_config.h"
#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/vocabulary.h"
#include "vims_sim/magnetic_field.h"
#include "vims_sim/seabed_renderer.h"
#include "vims_sim/seabed_texture.h"

namespace vims {
namespace test {

constexpr double kDeg = M_PI / 180.0;

/// A downward camera as the simulator's rig (x_c = -y_b, y_c = -x_b, z_c = -z_b), 640 x 480.
inline CameraCalibration testCamera() {
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = 420.0;
  c.fy = 421.0;
  c.cx = 321.0;
  c.cy = 238.0;
  c.distortion = {-0.06, 0.008, 2e-4, -1e-4};
  Eigen::Matrix3d R_b_c;
  R_b_c << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  c.T_b_c = Eigen::Isometry3d::Identity();
  c.T_b_c.linear() = R_b_c;
  c.T_b_c.translation() = Eigen::Vector3d(0.25, 0.0, -0.08);
  return c;
}

inline SequenceConfig testSequence() {
  SequenceConfig s;
  s.camera = testCamera();
  s.magnetometer.declination_deg = 0.0;
  return s;
}

/// Body pose in the world: position, yaw (ENU), small pitch/roll.
inline Eigen::Isometry3d bodyPose(double x, double y, double z, double yaw_deg, double pitch_deg = 0.0,
                                  double roll_deg = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rotationFromYawPitchRoll(yaw_deg * kDeg, pitch_deg * kDeg, roll_deg * kDeg);
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

/// A 4-DoF transform (yaw + translation), e.g. a VIO frame relative to the world.
inline Eigen::Isometry3d yawTransform(double yaw_deg, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rotationZ(yaw_deg * kDeg);
  T.translation() = t;
  return T;
}

class TestWorld {
 public:
  explicit TestWorld(uint64_t world_seed)
      : camera_(testCamera()),
        model_(camera_),
        texture_(std::make_shared<sim::SeabedTexture>(world_seed)),
        renderer_(camera_, texture_) {}

  const CameraCalibration& camera() const { return camera_; }

  /// The image seen from body pose T_w_b (deterministic per pose and seed).
  cv::Mat render(const Eigen::Isometry3d& T_w_b, uint64_t noise_seed = 1) const {
    return renderer_.render(T_w_b * camera_.T_b_c, noise_seed, true, workspace_);
  }

  /// A keyframe at true pose T_w_b, reported by a VIO whose estimate is T_odom_b: tracked points
  /// are Shi-Tomasi corners of the image; their 3D points are exact in the world and expressed
  /// relative to the VIO's estimate (p_odom = T_odom_b T_w_b^-1 p_w), as a locally consistent VIO does.
  KeyframeData keyframe(double t, uint32_t session, const Eigen::Isometry3d& T_w_b, const Eigen::Isometry3d& T_odom_b,
                        int max_corners = 150, uint64_t noise_seed = 1) const {
    KeyframeData kf;
    kf.t = t;
    kf.session = session;
    kf.T_odom_b = T_odom_b;
    kf.image = render(T_w_b, noise_seed);
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(kf.image, corners, max_corners, 0.01, 12.0);
    addLandmarks(corners, T_w_b, &kf);
    return kf;
  }

  /// A keyframe whose tracked points are chosen like the VIO's tracker chooses them: at most
  /// `max_corners` Shi-Tomasi corners at least 30 px apart, taken in an order set by the track
  /// history rather than by strength (emulated by shuffling the image's corners with
  /// `selection_seed`). Two visits of one place then track mostly different corners, as on real
  /// VIO keyframes (the strongest-first selection of keyframe() re-finds the same ones).
  KeyframeData trackerKeyframe(double t, uint32_t session, const Eigen::Isometry3d& T_w_b,
                               const Eigen::Isometry3d& T_odom_b, uint32_t selection_seed,
                               int max_corners = 150) const {
    KeyframeData kf;
    kf.t = t;
    kf.session = session;
    kf.T_odom_b = T_odom_b;
    kf.image = render(T_w_b, 1);
    std::vector<cv::Point2f> all;
    cv::goodFeaturesToTrack(kf.image, all, 3000, 0.001, 3.0);
    std::mt19937 rng(selection_seed);
    std::shuffle(all.begin(), all.end(), rng);
    std::vector<cv::Point2f> corners;
    for (const cv::Point2f& c : all) {
      if (static_cast<int>(corners.size()) >= max_corners) break;
      bool free = true;
      for (const cv::Point2f& o : corners) free = free && cv::norm(c - o) >= 30.0;
      if (free) corners.push_back(c);
    }
    addLandmarks(corners, T_w_b, &kf);
    return kf;
  }

 private:
  /// Tracked points at `corners` with their exact 3D points (ray-seabed intersection) in the
  /// keyframe's VIO frame.
  void addLandmarks(const std::vector<cv::Point2f>& corners, const Eigen::Isometry3d& T_w_b, KeyframeData* out) const {
    KeyframeData& kf = *out;
    const double t = kf.t;
    const Eigen::Isometry3d& T_odom_b = kf.T_odom_b;
    const Eigen::Isometry3d T_w_c = T_w_b * camera_.T_b_c;
    const Eigen::Isometry3d T_odom_w = T_odom_b * T_w_b.inverse();
    uint64_t id = static_cast<uint64_t>(t * 1000.0) * 1000;
    for (const cv::Point2f& c : corners) {
      const Eigen::Vector2d pixel(c.x, c.y);
      const Eigen::Vector3d ray_c = *model_.unprojectPixel(pixel);
      const Eigen::Vector3d ray_w = T_w_c.linear() * ray_c;
      if (ray_w.z() >= -1e-6) continue;
      const double s = -T_w_c.translation().z() / ray_w.z();
      const Eigen::Vector3d p_w = T_w_c.translation() + s * ray_w;
      KeyframeLandmark f;
      f.id = id++;
      f.p_odom = T_odom_w * p_w;
      f.pixel = pixel;
      f.normalized = ray_c.head<2>();
      kf.features.push_back(f);
    }
  }

  CameraCalibration camera_;
  CameraModel model_;
  std::shared_ptr<sim::SeabedTexture> texture_;
  sim::SeabedRenderer renderer_;
  mutable sim::SeabedRenderer::Workspace workspace_;
};

/// The committed vocabularies (loaded once per test binary).
inline std::shared_ptr<const BinaryVocabulary> vocabulary(const std::string& name) {
  static std::map<std::string, std::shared_ptr<const BinaryVocabulary>> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    const std::string path = std::string(VIMS_SOURCE_DIR) + "/config/vocabulary/" + name;
    it = cache.emplace(name, std::make_shared<const BinaryVocabulary>(BinaryVocabulary::load(path))).first;
  }
  return it->second;
}

/// The coil's signature at a body position, as the extractor reports it (canonical sign).
inline SignatureWindow signatureAt(double t, const sim::CoilDipole& coil, const Eigen::Vector3d& p_w,
                                   bool valid = true) {
  SignatureWindow w;
  w.t = t;
  w.t_start = t - 1.0;
  w.t_end = t + 1.0;
  w.frequency_hz = coil.frequency;
  w.amplitude_enu = canonicalSignature(coil.peakField(p_w));
  w.snr = valid ? 1000.0 : 1.0;
  w.valid = valid;
  return w;
}

/// A recording logger for asserting on warnings.
struct LogRecorder {
  std::shared_ptr<std::vector<std::string>> lines = std::make_shared<std::vector<std::string>>();
  LoggerPtr logger() const {
    auto sink_lines = lines;
    return std::make_shared<Logger>(
        [sink_lines](LogLevel level, const std::string& component, const std::string& message) {
          sink_lines->push_back(std::string(logLevelName(level)) + " [" + component + "] " + message);
        },
        LogLevel::kInfo);
  }
  bool contains(const std::string& text) const {
    for (const std::string& l : *lines)
      if (l.find(text) != std::string::npos) return true;
    return false;
  }
};

}  // namespace test
}  // namespace vims
