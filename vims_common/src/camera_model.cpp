#include "vims_common/camera_model.h"

#include <Eigen/LU>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vims {

namespace {

// Gauss-Newton settings of the inverse distortion. The tolerance is in normalised units;
// times a focal length of ~500 px it is ~1e-9 px, far below the 0.01 px the estimator needs.
constexpr int kUndistortMaxIterations = 20;
constexpr double kUndistortStepTolerance = 1e-12;
// Accept a solution only if re-distorting it reproduces the input to this (normalised) error.
constexpr double kUndistortResidualTolerance = 1e-9;
// Below this normalised radius the equidistant model is the identity to double precision.
constexpr double kTinyRadius = 1e-12;

}  // namespace

CameraModel::CameraModel(const CameraCalibration& calibration)
    : width_(calibration.width),
      height_(calibration.height),
      fx_(calibration.fx),
      fy_(calibration.fy),
      cx_(calibration.cx),
      cy_(calibration.cy),
      distortion_model_(calibration.distortion_model),
      coefficients_(calibration.distortion) {
  if (calibration.model != "pinhole") {
    throw std::invalid_argument(
        "CameraModel: only the pinhole model (radtan or equidistant distortion) is supported, got '" +
        calibration.model + "'");
  }
  if (width_ <= 0 || height_ <= 0) throw std::invalid_argument("CameraModel: image size must be positive");
  const double numbers[] = {fx_, fy_, cx_, cy_, coefficients_[0], coefficients_[1], coefficients_[2], coefficients_[3]};
  for (double v : numbers) {
    if (!std::isfinite(v)) throw std::invalid_argument("CameraModel: intrinsics and distortion must be finite");
  }
  if (fx_ <= 0.0 || fy_ <= 0.0) throw std::invalid_argument("CameraModel: focal lengths must be > 0");
}

Eigen::Vector2d CameraModel::distortNormalized(const Eigen::Vector2d& normalized, Eigen::Matrix2d* jacobian) const {
  return distortion_model_ == DistortionModel::kEquidistant ? distortEquidistant(normalized, jacobian)
                                                            : distortRadtan(normalized, jacobian);
}

Eigen::Vector2d CameraModel::distortEquidistant(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian) const {
  const auto& [k1, k2, k3, k4] = coefficients_;
  const double r2 = m.squaredNorm();
  if (r2 < kTinyRadius * kTinyRadius) {
    // theta_d / r -> 1 and its derivative -> 0 at the centre: the identity (to O(r^2)).
    if (jacobian) jacobian->setIdentity();
    return m;
  }
  const double r = std::sqrt(r2);
  const double theta = std::atan(r);
  const double t2 = theta * theta;
  const double series = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)));
  const double theta_d = theta * series;
  const double scale = theta_d / r;
  if (jacobian) {
    // md = s(r) m with s = theta_d / r: d md / d m = s I + (ds/dr) m m^T / r, where
    // ds/dr = (theta_d'(theta) theta'(r) - s) / r, theta'(r) = 1 / (1 + r^2) and
    // theta_d'(theta) = 1 + 3 k1 theta^2 + 5 k2 theta^4 + 7 k3 theta^6 + 9 k4 theta^8.
    const double dtheta_d = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
    const double ds_dr = (dtheta_d / (1.0 + r2) - scale) / r;
    *jacobian = scale * Eigen::Matrix2d::Identity() + (ds_dr / r) * (m * m.transpose());
  }
  return scale * m;
}

Eigen::Vector2d CameraModel::distortRadtan(const Eigen::Vector2d& normalized, Eigen::Matrix2d* jacobian) const {
  const auto& [k1, k2, p1, p2] = coefficients_;
  const double x = normalized.x();
  const double y = normalized.y();
  const double xx = x * x, yy = y * y, xy = x * y;
  const double r2 = xx + yy;
  const double radial = 1.0 + r2 * (k1 + k2 * r2);
  const Eigen::Vector2d distorted(x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * xx),
                                  y * radial + p1 * (r2 + 2.0 * yy) + 2.0 * p2 * xy);
  if (jacobian) {
    // d radial / d r2 = k1 + 2 k2 r2, and d r2 / d(x, y) = 2 (x, y).
    const double dradial_dr2 = k1 + 2.0 * k2 * r2;
    (*jacobian)(0, 0) = radial + 2.0 * xx * dradial_dr2 + 2.0 * p1 * y + 6.0 * p2 * x;
    (*jacobian)(0, 1) = 2.0 * xy * dradial_dr2 + 2.0 * p1 * x + 2.0 * p2 * y;
    (*jacobian)(1, 0) = (*jacobian)(0, 1);
    (*jacobian)(1, 1) = radial + 2.0 * yy * dradial_dr2 + 6.0 * p1 * y + 2.0 * p2 * x;
  }
  return distorted;
}

std::optional<Eigen::Vector2d> CameraModel::undistortNormalized(const Eigen::Vector2d& distorted_normalized) const {
  if (!distorted_normalized.allFinite()) return std::nullopt;
  // Gauss-Newton (a Newton iteration, the system is square) instead of the usual fixed-point
  // iteration: the fixed point converges slowly, or not at all, in the image corners of
  // strongly distorted lenses, while Newton reaches machine precision in a few steps.
  Eigen::Vector2d m = distorted_normalized;
  Eigen::Matrix2d jacobian;
  for (int iteration = 0; iteration < kUndistortMaxIterations; ++iteration) {
    const Eigen::Vector2d residual = distortNormalized(m, &jacobian) - distorted_normalized;
    const double det = jacobian.determinant();
    if (!(det > 0.0)) return std::nullopt;  // folded-over region: no unique inverse
    const Eigen::Vector2d step = jacobian.inverse() * residual;
    m -= step;
    if (!m.allFinite()) return std::nullopt;
    if (step.norm() < kUndistortStepTolerance) break;
  }
  const Eigen::Vector2d residual = distortNormalized(m, &jacobian) - distorted_normalized;
  if (!(residual.norm() < kUndistortResidualTolerance) || !(jacobian.determinant() > 0.0)) return std::nullopt;
  return m;
}

std::optional<Eigen::Vector2d> CameraModel::normalizedFromPixel(const Eigen::Vector2d& pixel) const {
  return undistortNormalized(Eigen::Vector2d((pixel.x() - cx_) / fx_, (pixel.y() - cy_) / fy_));
}

std::optional<Eigen::Vector3d> CameraModel::unprojectPixel(const Eigen::Vector2d& pixel) const {
  const std::optional<Eigen::Vector2d> m = normalizedFromPixel(pixel);
  if (!m) return std::nullopt;
  return Eigen::Vector3d(m->x(), m->y(), 1.0);
}

Eigen::Vector2d CameraModel::pixelFromNormalized(const Eigen::Vector2d& normalized) const {
  const Eigen::Vector2d md = distortNormalized(normalized);
  return Eigen::Vector2d(fx_ * md.x() + cx_, fy_ * md.y() + cy_);
}

std::optional<Eigen::Vector2d> CameraModel::project(const Eigen::Vector3d& point_camera,
                                                    Eigen::Matrix<double, 2, 3>* jacobian) const {
  const double z = point_camera.z();
  if (!point_camera.allFinite() || !(z > kMinDepth)) return std::nullopt;
  const double inv_z = 1.0 / z;
  const Eigen::Vector2d m(point_camera.x() * inv_z, point_camera.y() * inv_z);
  Eigen::Matrix2d distortion_jacobian;
  const Eigen::Vector2d md = distortNormalized(m, jacobian ? &distortion_jacobian : nullptr);
  if (jacobian) {
    Eigen::Matrix<double, 2, 3> dm_dp;
    dm_dp << inv_z, 0.0, -m.x() * inv_z,  //
        0.0, inv_z, -m.y() * inv_z;
    const Eigen::Matrix2d focal = Eigen::Vector2d(fx_, fy_).asDiagonal();
    *jacobian = focal * distortion_jacobian * dm_dp;
  }
  return Eigen::Vector2d(fx_ * md.x() + cx_, fy_ * md.y() + cy_);
}

bool CameraModel::isInImage(const Eigen::Vector2d& pixel, double border) const {
  // Pixel centres are at integer coordinates, so the image spans [-0.5, size - 0.5].
  return pixel.x() >= border - 0.5 && pixel.y() >= border - 0.5 && pixel.x() <= width_ - 0.5 - border &&
         pixel.y() <= height_ - 0.5 - border;
}

}  // namespace vims
