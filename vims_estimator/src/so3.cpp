#include "vims_estimator/so3.h"

#include <cmath>

namespace vims {
namespace so3 {

namespace {
// Below this angle [rad] the closed forms lose digits to cancellation (1 - cos t, t - sin t),
// so the Taylor series are used; their truncation error there is below 1e-20.
constexpr double kSmallAngle = 1e-5;
}  // namespace

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Quaterniond exp(const Eigen::Vector3d& theta) {
  const double t2 = theta.squaredNorm();
  const double t = std::sqrt(t2);
  double w, s;  // q = (s * theta, w)
  if (t < kSmallAngle) {
    w = 1.0 - t2 / 8.0;
    s = 0.5 - t2 / 48.0;
  } else {
    w = std::cos(0.5 * t);
    s = std::sin(0.5 * t) / t;
  }
  Eigen::Quaterniond q(w, s * theta.x(), s * theta.y(), s * theta.z());
  q.normalize();
  return q;
}

Eigen::Vector3d log(const Eigen::Quaterniond& q_in) {
  // q and -q are the same rotation; pick w >= 0 so the angle is in [0, pi].
  Eigen::Quaterniond q = q_in.w() < 0.0 ? Eigen::Quaterniond(-q_in.coeffs()) : q_in;
  const double n = q.vec().norm();
  const double w = q.w();
  double factor;  // theta = factor * vec(q)
  if (n < kSmallAngle) {
    // 2 atan(n/w)/n = 2/w (1 - n^2/(3 w^2) + ...); w ~ 1 here.
    factor = 2.0 / w * (1.0 - n * n / (3.0 * w * w));
  } else {
    factor = 2.0 * std::atan2(n, w) / n;
  }
  return factor * q.vec();
}

Eigen::Matrix3d rightJacobian(const Eigen::Vector3d& theta) {
  const double t2 = theta.squaredNorm();
  const Eigen::Matrix3d K = skew(theta);
  if (t2 < kSmallAngle * kSmallAngle) {
    return Eigen::Matrix3d::Identity() - 0.5 * K + (1.0 / 6.0) * K * K;
  }
  const double t = std::sqrt(t2);
  return Eigen::Matrix3d::Identity() - (1.0 - std::cos(t)) / t2 * K + (t - std::sin(t)) / (t2 * t) * K * K;
}

Eigen::Matrix3d rightJacobianInverse(const Eigen::Vector3d& theta) {
  const double t2 = theta.squaredNorm();
  const Eigen::Matrix3d K = skew(theta);
  if (t2 < kSmallAngle * kSmallAngle) {
    return Eigen::Matrix3d::Identity() + 0.5 * K + (1.0 / 12.0) * K * K;
  }
  const double t = std::sqrt(t2);
  const double c = 1.0 / t2 - (1.0 + std::cos(t)) / (2.0 * t * std::sin(t));
  return Eigen::Matrix3d::Identity() + 0.5 * K + c * K * K;
}

Eigen::Matrix<double, 4, 3> quaternionPlusJacobian(const Eigen::Quaterniond& q) {
  // q (x) (theta/2, 1): vec = w theta/2 + v x theta/2 + v, w' = w - v.theta/2.
  Eigen::Matrix<double, 4, 3> J;
  J.topRows<3>() = 0.5 * (q.w() * Eigen::Matrix3d::Identity() + skew(q.vec()));
  J.bottomRows<1>() = -0.5 * q.vec().transpose();
  return J;
}

Eigen::Matrix<double, 3, 4> quaternionLiftJacobian(const Eigen::Quaterniond& q) {
  // Log(q^{-1} (x) q') ~= 2 vec(q^* (x) q') near q' = q, and
  // vec(q^* (x) q') = w v' - w' v - v x v' (linear in q' = (v', w')).
  Eigen::Matrix<double, 3, 4> J;
  J.leftCols<3>() = 2.0 * (q.w() * Eigen::Matrix3d::Identity() - skew(q.vec()));
  J.rightCols<1>() = -2.0 * q.vec();
  return J;
}

}  // namespace so3
}  // namespace vims
