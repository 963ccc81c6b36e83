#pragma once
/// @file bspline.h
/// @brief Uniform B-spline of any degree over time, with exact analytic derivatives.
///
/// The simulator's trajectory is one such spline for position and one for the Euler angles,
/// so pose, velocity, acceleration and angular rate all come from the same analytic model
/// (integrating the noiseless IMU reproduces the ground truth).
///
/// Evaluation uses the cumulative form p(t) = P_i + sum_j Bcum_j(u) (P_{i+j} - P_{i+j-1}):
/// where neighbouring control points are equal (the static start) the curve and all its
/// derivatives are exactly constant/zero, not just up to rounding.

#include <Eigen/Core>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace vims {
namespace sim {

template <int Dim>
class UniformBSpline {
 public:
  using Vector = Eigen::Matrix<double, Dim, 1>;

  UniformBSpline() = default;

  /// Segment i covers [t0 + i*dt, t0 + (i+1)*dt) and blends control points i..i+degree.
  /// The control point P_j therefore acts around time t0 + (j - degree/2 + 0.5)*dt.
  UniformBSpline(int degree, double t0, double dt, std::vector<Vector> control_points)
      : degree_(degree), t0_(t0), dt_(dt), control_(std::move(control_points)) {
    if (degree < 1 || degree > 7) throw std::invalid_argument("UniformBSpline: degree must be in [1, 7]");
    if (!(dt > 0.0)) throw std::invalid_argument("UniformBSpline: dt must be > 0");
    if (static_cast<int>(control_.size()) < degree + 1) {
      throw std::invalid_argument("UniformBSpline: needs at least degree + 1 control points");
    }
    cumulative_ = cumulativeBlendingMatrix(degree);
  }

  int degree() const { return degree_; }
  double dt() const { return dt_; }
  /// Times in [validBegin(), validEnd()] are evaluated exactly; outside, t is clamped.
  double validBegin() const { return t0_; }
  double validEnd() const { return t0_ + static_cast<double>(control_.size() - degree_) * dt_; }
  const std::vector<Vector>& controlPoints() const { return control_; }

  /// Value and the first `max_derivative` time derivatives (out[0] = value, out[1] = d/dt, ...).
  /// out must hold max_derivative + 1 vectors; max_derivative <= degree.
  void evaluate(double t, int max_derivative, Vector* out) const {
    if (control_.empty()) throw std::logic_error("UniformBSpline: evaluated before it was constructed");
    if (max_derivative < 0 || max_derivative > degree_)
      throw std::invalid_argument("UniformBSpline: bad derivative order");
    const int num_segments = static_cast<int>(control_.size()) - degree_;
    double x = (t - t0_) / dt_;
    int segment = static_cast<int>(std::floor(x));
    if (segment < 0) {
      segment = 0;
      x = 0.0;
    } else if (segment >= num_segments) {
      segment = num_segments - 1;
      x = static_cast<double>(num_segments);
    }
    const double u = x - segment;
    const int k = degree_ + 1;
    double u_power[8] = {1, 0, 0, 0, 0, 0, 0, 0};
    for (int n = 1; n < k; ++n) u_power[n] = u_power[n - 1] * u;
    for (int d = 0; d <= max_derivative; ++d) {
      // Derivative d of the power basis [1, u, u^2, ...], scaled to time (1/dt^d).
      double powers[8] = {0, 0, 0, 0, 0, 0, 0, 0};
      double scale = 1.0;
      for (int i = 0; i < d; ++i) scale /= dt_;
      for (int n = d; n < k; ++n) {
        double coeff = 1.0;
        for (int i = 0; i < d; ++i) coeff *= static_cast<double>(n - i);
        powers[n] = coeff * u_power[n - d] * scale;
      }
      Vector value = d == 0 ? control_[segment] : Vector::Zero().eval();
      for (int j = 1; j < k; ++j) {
        double w = 0.0;
        for (int n = 0; n < k; ++n) w += cumulative_(j, n) * powers[n];
        value += w * (control_[segment + j] - control_[segment + j - 1]);
      }
      out[d] = value;
    }
  }

  Vector value(double t) const {
    Vector v[1];
    evaluate(t, 0, v);
    return v[0];
  }

  /// Blending matrix M (k x k, k = degree + 1): the weight of control point i+s at local
  /// parameter u is sum_n M(s, n) u^n (closed form of the uniform B-spline basis).
  static Eigen::MatrixXd blendingMatrix(int degree) {
    const int k = degree + 1;
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(k, k);
    double factorial = 1.0;
    for (int i = 2; i < k; ++i) factorial *= i;
    for (int s = 0; s < k; ++s) {
      for (int n = 0; n < k; ++n) {
        double sum = 0.0;
        for (int l = s; l < k; ++l) {
          const double sign = ((l - s) % 2 == 0) ? 1.0 : -1.0;
          const int exponent = k - 1 - n;
          const double base = static_cast<double>(k - 1 - l);
          const double power = exponent == 0 ? 1.0 : std::pow(base, exponent);
          sum += sign * binomial(k, l - s) * power;
        }
        m(s, n) = binomial(k - 1, n) / factorial * sum;
      }
    }
    return m;
  }

  /// Cumulative blending matrix: row j = sum of rows j..k-1 of the blending matrix.
  static Eigen::MatrixXd cumulativeBlendingMatrix(int degree) {
    Eigen::MatrixXd m = blendingMatrix(degree);
    Eigen::MatrixXd c = m;
    for (int j = m.rows() - 2; j >= 0; --j) c.row(j) = c.row(j + 1) + m.row(j);
    return c;
  }

 private:
  static double binomial(int n, int r) {
    if (r < 0 || r > n) return 0.0;
    double result = 1.0;
    for (int i = 1; i <= r; ++i) result = result * (n - r + i) / i;
    return result;
  }

  int degree_ = 5;
  double t0_ = 0.0;
  double dt_ = 1.0;
  std::vector<Vector> control_;
  Eigen::MatrixXd cumulative_;
};

}  // namespace sim
}  // namespace vims
