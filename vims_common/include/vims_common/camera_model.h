#pragma once
/// @file camera_model.h
/// @brief The one camera model of VIMS (tracker, loop verification, simulator): a pinhole camera
/// with the contract's distortion models, radial-tangential (k1, k2, p1, p2; OpenCV's 4-parameter
/// model) or equidistant (fisheye, Kannala-Brandt k1..k4; OpenCV's fisheye module). Built from the
/// sequence's vims::CameraCalibration, never hard-coded.
///
/// Distortion of undistorted normalised coordinates m = (x, y), r = |m|:
///   radtan       md = m (1 + k1 r^2 + k2 r^4) + (2 p1 x y + p2 (r^2 + 2 x^2), p1 (r^2 + 2 y^2) + 2 p2 x y)
///   equidistant  theta = atan(r), theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8),
///                md = (theta_d / r) m   (md = m at r = 0)
///
/// Coordinates used throughout VIMS:
///   - camera frame point p_c = (X, Y, Z), optical frame (z forward, x right, y down);
///   - normalised (undistorted) coordinates m = (X/Z, Y/Z), i.e. the ray (m, 1);
///   - distorted normalised coordinates md = distort(m);
///   - pixel u = (fx * md.x + cx, fy * md.y + cy).

#include <Eigen/Core>
#include <array>
#include <optional>

#include "vims_common/sequence_config.h"

namespace vims {

class CameraModel {
 public:
  /// Throws std::invalid_argument when the calibration is not a usable pinhole model
  /// (model name, non-positive size or focal length, non-finite numbers).
  explicit CameraModel(const CameraCalibration& calibration);

  int width() const { return width_; }
  int height() const { return height_; }
  double fx() const { return fx_; }
  double fy() const { return fy_; }
  double cx() const { return cx_; }
  double cy() const { return cy_; }
  /// Mean focal length [px]; converts normalised-plane distances to (approximate) pixels.
  double meanFocal() const { return 0.5 * (fx_ + fy_); }

  DistortionModel distortionModel() const { return distortion_model_; }

  /// Undistorted -> distorted normalised coordinates. `jacobian` (optional) receives d md / d m.
  Eigen::Vector2d distortNormalized(const Eigen::Vector2d& normalized, Eigen::Matrix2d* jacobian = nullptr) const;

  /// Distorted -> undistorted normalised coordinates by Gauss-Newton on distortNormalized().
  /// Converges to well below 1e-6 px inside the image; returns nullopt when the iteration does not
  /// converge or lands where the distortion folds over (non-invertible Jacobian), so callers
  /// never receive a wrong branch of the polynomial.
  std::optional<Eigen::Vector2d> undistortNormalized(const Eigen::Vector2d& distorted_normalized) const;

  /// Pixel (distorted) -> undistorted normalised coordinates (see undistortNormalized()).
  std::optional<Eigen::Vector2d> normalizedFromPixel(const Eigen::Vector2d& pixel) const;
  /// Pixel -> ray (m.x, m.y, 1) in the camera frame (see undistortNormalized()).
  std::optional<Eigen::Vector3d> unprojectPixel(const Eigen::Vector2d& pixel) const;

  /// Undistorted normalised coordinates -> pixel (applies distortion and intrinsics).
  Eigen::Vector2d pixelFromNormalized(const Eigen::Vector2d& normalized) const;

  /// Projects a point in the camera frame to a pixel. Returns nullopt for points with
  /// Z <= kMinDepth (behind or on the camera plane). `jacobian` (optional) receives
  /// d pixel / d p_c (2x3), including the distortion, e.g. to map a pixel sigma onto the
  /// estimator's residual.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& point_camera,
                                         Eigen::Matrix<double, 2, 3>* jacobian = nullptr) const;

  /// True when the pixel lies at least `border` pixels inside the image.
  bool isInImage(const Eigen::Vector2d& pixel, double border = 0.0) const;

  /// Points closer to the camera plane than this [m] are not projected.
  static constexpr double kMinDepth = 1e-6;

 private:
  int width_;
  int height_;
  double fx_, fy_, cx_, cy_;
  DistortionModel distortion_model_;
  std::array<double, 4> coefficients_;  ///< radtan: k1, k2, p1, p2; equidistant: k1..k4

  Eigen::Vector2d distortRadtan(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian) const;
  Eigen::Vector2d distortEquidistant(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian) const;
};

}  // namespace vims
