#include "vims_sim/camera_model.h"

#include <Eigen/Dense>

namespace vims {
namespace sim {

Eigen::Vector2d PinholeRadtanCamera::distort(const Eigen::Vector2d& p) const {
  const double k1 = calib_.distortion[0], k2 = calib_.distortion[1];
  const double p1 = calib_.distortion[2], p2 = calib_.distortion[3];
  const double x = p.x(), y = p.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
  return Eigen::Vector2d(x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                         y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y);
}

Eigen::Vector2d PinholeRadtanCamera::undistort(const Eigen::Vector2d& distorted) const {
  const double k1 = calib_.distortion[0], k2 = calib_.distortion[1];
  const double p1 = calib_.distortion[2], p2 = calib_.distortion[3];
  Eigen::Vector2d p = distorted;
  for (int iteration = 0; iteration < 20; ++iteration) {
    const Eigen::Vector2d residual = distort(p) - distorted;
    if (residual.squaredNorm() < 1e-26) break;
    const double x = p.x(), y = p.y();
    const double r2 = x * x + y * y;
    const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
    const double dradial = k1 + 2.0 * k2 * r2;  // d radial / d r2
    Eigen::Matrix2d J;
    J(0, 0) = radial + x * dradial * 2.0 * x + 2.0 * p1 * y + p2 * 6.0 * x;
    J(0, 1) = x * dradial * 2.0 * y + 2.0 * p1 * x + p2 * 2.0 * y;
    J(1, 0) = y * dradial * 2.0 * x + p1 * 2.0 * x + 2.0 * p2 * y;
    J(1, 1) = radial + y * dradial * 2.0 * y + p1 * 6.0 * y + 2.0 * p2 * x;
    p -= J.inverse() * residual;
  }
  return p;
}

bool PinholeRadtanCamera::project(const Eigen::Vector3d& p_c, Eigen::Vector2d* pixel) const {
  if (p_c.z() <= 0.0) return false;
  const Eigen::Vector2d d = distort(Eigen::Vector2d(p_c.x() / p_c.z(), p_c.y() / p_c.z()));
  *pixel = Eigen::Vector2d(calib_.fx * d.x() + calib_.cx, calib_.fy * d.y() + calib_.cy);
  return true;
}

Eigen::Vector3d PinholeRadtanCamera::unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d d((pixel.x() - calib_.cx) / calib_.fx, (pixel.y() - calib_.cy) / calib_.fy);
  const Eigen::Vector2d u = undistort(d);
  return Eigen::Vector3d(u.x(), u.y(), 1.0);
}

}  // namespace sim
}  // namespace vims
