#pragma once
/// @file camera_model.h
/// @brief Pinhole camera with radial-tangential (k1, k2, p1, p2) distortion, the model of the
/// sensor contract (same equations as OpenCV's 4-parameter distortion).

#include <Eigen/Core>

#include "vims_common/sequence_config.h"

namespace vims {
namespace sim {

class PinholeRadtanCamera {
 public:
  explicit PinholeRadtanCamera(const CameraCalibration& calibration) : calib_(calibration) {}

  const CameraCalibration& calibration() const { return calib_; }
  int width() const { return calib_.width; }
  int height() const { return calib_.height; }

  /// Applies the distortion to normalised image coordinates (x/z, y/z).
  Eigen::Vector2d distort(const Eigen::Vector2d& undistorted) const;
  /// Inverts distort() by Gauss-Newton; converges to < 1e-12 for the mild distortion used here.
  Eigen::Vector2d undistort(const Eigen::Vector2d& distorted) const;

  /// Projects a point in the camera frame to pixels. Returns false behind the camera (z <= 0).
  bool project(const Eigen::Vector3d& p_c, Eigen::Vector2d* pixel) const;
  /// The viewing ray of a pixel in the camera frame, scaled to z = 1.
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const;

 private:
  CameraCalibration calib_;
};

}  // namespace sim
}  // namespace vims
