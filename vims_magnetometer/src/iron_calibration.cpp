#include "vims_magnetometer/iron_calibration.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>

#include "vims_common/option_table.h"
#include "vims_magnetometer/magnetometer_options.h"

namespace vims {
namespace {

// The fit works in microtesla so that offsets, gains and the field have similar magnitudes.
constexpr double kMicro = 1e6;
constexpr int kMinSamples = 20;

/// A model: parameters -> correction (in uT), the field magnitude (full) or the horizontal and
/// vertical components (horizontal model).
struct Model {
  std::function<IronCorrection(const Eigen::VectorXd&)> correction;
  std::function<double(const Eigen::VectorXd&)> field;
  std::function<double(const Eigen::VectorXd&)> vertical;  ///< horizontal model only
  bool horizontal = false;
  int residualsPerSample() const { return horizontal ? 2 : 1; }
};

// The horizontal model's b_z and cross terms show only through tilt that does not follow the
// heading; where the tilt does follow it (pitching over a slope), they trade against each other
// along a flat valley. A weak pull towards zero picks the valley's smallest point and costs
// nothing measurable where the data decide: 1e-3 uT per uT of b_z (and per 2 % of a cross term)
// against residuals of tens of nT at hundreds of samples.
constexpr double kPriorWeight = 1e-2;
constexpr double kCrossTermScale_uT = 50.0;

/// The body's up in the mag frame: the block's specific force, or the mag frame's z without it.
Eigen::Vector3d upOf(const IronFitSample& s) {
  return s.has_specific_force ? s.specific_force.normalized() : Eigen::Vector3d::UnitZ();
}

/// Full: |h| - F. Horizontal: |up x h| - B_h and up.h - B_z (the level frame's components of a
/// constant field stay constant while the heading turns).
void sampleResiduals(const Model& model, const IronCorrection& c, double field, double vertical, const IronFitSample& s,
                     double* r) {
  const Eigen::Vector3d h = c.apply(s.field_t);
  if (!model.horizontal) {
    r[0] = h.norm() - field;
    return;
  }
  const Eigen::Vector3d up = upOf(s);
  r[0] = up.cross(h).norm() - field;
  r[1] = up.dot(h) - vertical;
}

Eigen::VectorXd residuals(const Model& model, const Eigen::VectorXd& p, const std::vector<IronFitSample>& samples) {
  const IronCorrection c = model.correction(p);
  const double f = model.field(p);
  const double v = model.horizontal ? model.vertical(p) : 0.0;
  const int k = model.residualsPerSample();
  const int priors = model.horizontal ? 3 : 0;
  Eigen::VectorXd r(k * samples.size() + priors);
  for (std::size_t i = 0; i < samples.size(); ++i) sampleResiduals(model, c, f, v, samples[i], &r[k * i]);
  if (model.horizontal) {
    const std::size_t n = k * samples.size();
    r[n] = kPriorWeight * c.hard_iron_t.z();
    r[n + 1] = kPriorWeight * kCrossTermScale_uT * c.soft_iron_inverse(0, 2);
    r[n + 2] = kPriorWeight * kCrossTermScale_uT * c.soft_iron_inverse(1, 2);
  }
  return r;
}

/// Levenberg-Marquardt with a central-difference Jacobian (a handful of parameters, a few
/// thousand residuals: no need for more).
Eigen::VectorXd solve(const Model& model, Eigen::VectorXd p, const std::vector<IronFitSample>& samples,
                      int max_iterations) {
  double lambda = 1e-3;
  Eigen::VectorXd r = residuals(model, p, samples);
  double cost = r.squaredNorm();
  for (int it = 0; it < max_iterations; ++it) {
    Eigen::MatrixXd J(r.size(), p.size());
    for (int k = 0; k < p.size(); ++k) {
      const double h = 1e-6 * std::max(1.0, std::abs(p[k]));
      Eigen::VectorXd hi = p, lo = p;
      hi[k] += h;
      lo[k] -= h;
      J.col(k) = (residuals(model, hi, samples) - residuals(model, lo, samples)) / (2.0 * h);
    }
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::MatrixXd damped = A;
      damped.diagonal() += lambda * A.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd dp = damped.ldlt().solve(-g);
      const Eigen::VectorXd candidate = p + dp;
      const Eigen::VectorXd rc = residuals(model, candidate, samples);
      const double c = rc.squaredNorm();
      if (std::isfinite(c) && c < cost) {
        const bool converged = dp.norm() < 1e-12 * (1.0 + p.norm());
        p = candidate;
        r = rc;
        cost = c;
        lambda = std::max(lambda / 10.0, 1e-12);
        improved = true;
        if (converged) return p;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  return p;
}

double rmsAboutMean(const std::vector<double>& v) {
  double mean = 0.0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  double ss = 0.0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / static_cast<double>(v.size()));
}

/// Sphere |m - b| = F through the points by linear least squares (|m|^2 = 2 b.m + c): the start.
void sphereFit(const std::vector<IronFitSample>& s, Eigen::Vector3d* b, double* F) {
  Eigen::MatrixXd A(s.size(), 4);
  Eigen::VectorXd y(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    A.row(i) << 2.0 * s[i].field_t.transpose(), 1.0;
    y[i] = s[i].field_t.squaredNorm();
  }
  const Eigen::Vector4d x = A.colPivHouseholderQr().solve(y);
  *b = x.head<3>();
  *F = std::sqrt(std::max(x[3] + b->squaredNorm(), 1e-12));
}

/// Circle in the x-y plane (the level vehicle's turns), the horizontal fit's start.
void circleFit(const std::vector<IronFitSample>& s, Eigen::Vector2d* b, double* H) {
  Eigen::MatrixXd A(s.size(), 3);
  Eigen::VectorXd y(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    A.row(i) << 2.0 * s[i].field_t.head<2>().transpose(), 1.0;
    y[i] = s[i].field_t.head<2>().squaredNorm();
  }
  const Eigen::Vector3d x = A.colPivHouseholderQr().solve(y);
  *b = x.head<2>();
  *H = std::sqrt(std::max(x[2] + b->squaredNorm(), 1e-12));
}

/// 360 deg minus the largest gap between the directions of (m_xy - centre).
double headingCoverageDeg(const std::vector<IronFitSample>& s, const Eigen::Vector2d& centre) {
  std::vector<double> angles;
  for (const auto& x : s) angles.push_back(std::atan2(x.field_t.y() - centre.y(), x.field_t.x() - centre.x()));
  std::sort(angles.begin(), angles.end());
  double gap = 2.0 * M_PI - (angles.back() - angles.front());
  for (std::size_t i = 1; i < angles.size(); ++i) gap = std::max(gap, angles[i] - angles[i - 1]);
  return (2.0 * M_PI - gap) * 180.0 / M_PI;
}

}  // namespace

IronFitSampler::IronFitSampler(double block_s, double gravity, double accel_gate_mps2, const Eigen::Matrix3d& R_b_m)
    : block_s_(block_s), gravity_(gravity), accel_gate_(accel_gate_mps2), R_m_b_(R_b_m.transpose()) {}

void IronFitSampler::feedImu(const ImuSample& sample) {
  if (!open_ || sample.t < block_start_ || sample.t >= block_start_ + block_s_) return;
  force_sum_ += R_m_b_ * sample.accel;
  ++force_count_;
}

void IronFitSampler::feedMag(const MagSample& sample) {
  if (!sample.field.allFinite()) return;
  if (open_ && sample.t >= block_start_ + block_s_) closeBlock();
  if (!open_) {
    open_ = true;
    block_start_ = sample.t;
  }
  mag_sum_ += sample.field;
  ++mag_count_;
}

void IronFitSampler::closeBlock() {
  if (mag_count_ > 0) {
    IronFitSample s;
    s.field_t = mag_sum_ / static_cast<double>(mag_count_);
    if (force_count_ > 0) {
      s.specific_force = force_sum_ / static_cast<double>(force_count_);
      s.has_specific_force = std::abs(s.specific_force.norm() - gravity_) < accel_gate_;
    }
    samples_.push_back(s);
  }
  open_ = false;
  mag_sum_.setZero();
  force_sum_.setZero();
  mag_count_ = force_count_ = 0;
}

std::vector<IronFitSample> IronFitSampler::finish() {
  if (open_) closeBlock();
  return samples_;
}

const char* ironFitModelName(IronFitModel model) { return model == IronFitModel::kFull ? "full" : "horizontal"; }

IronFitResult fitIronCorrection(const std::vector<IronFitSample>& input, const IronFitOptions& options) {
  IronFitResult result;
  result.samples = static_cast<int>(input.size());
  if (result.samples < kMinSamples) {
    result.why = "only " + std::to_string(result.samples) + " blocks of data; at least " + std::to_string(kMinSamples) +
                 " are needed (record the manoeuvre for longer)";
    return result;
  }
  std::vector<IronFitSample> samples = input;
  for (auto& s : samples) s.field_t *= kMicro;

  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& s : samples) mean += s.field_t;
  mean /= static_cast<double>(samples.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& s : samples) cov += (s.field_t - mean) * (s.field_t - mean).transpose();
  const Eigen::Vector3d eig = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvalues();
  result.spread_ratio = eig[2] > 0.0 ? std::max(eig[0], 0.0) / eig[2] : 0.0;
  Eigen::Vector2d centre_xy;
  double H0 = 0.0;
  circleFit(samples, &centre_xy, &H0);
  result.heading_coverage_deg = headingCoverageDeg(samples, centre_xy);

  Model model;
  Eigen::VectorXd p;
  const double site_uT = options.site_field_t * kMicro;
  if (result.spread_ratio >= options.min_full_spread_ratio) {
    result.model = IronFitModel::kFull;
    Eigen::Vector3d b0;
    double F0 = 0.0;
    sphereFit(samples, &b0, &F0);
    const bool fixed_field = site_uT > 0.0;
    // K = I + E, E symmetric; with F fitted, trace(E) = 0 (E22 = -E00 - E11).
    model.correction = [fixed_field](const Eigen::VectorXd& q) {
      IronCorrection c;
      c.hard_iron_t = q.head<3>();
      Eigen::Matrix3d E;
      const double e22 = fixed_field ? q[5] : -q[3] - q[4];
      const int o = fixed_field ? 6 : 5;
      E << q[3], q[o], q[o + 1], q[o], q[4], q[o + 2], q[o + 1], q[o + 2], e22;
      c.soft_iron_inverse = Eigen::Matrix3d::Identity() + E;
      return c;
    };
    model.field = [fixed_field, site_uT](const Eigen::VectorXd& q) { return fixed_field ? site_uT : q[8]; };
    p = Eigen::VectorXd::Zero(9);
    p.head<3>() = b0;
    if (!fixed_field) p[8] = F0;
  } else {
    result.model = IronFitModel::kHorizontal;
    if (result.heading_coverage_deg < options.min_heading_coverage_deg) {
      char buf[320];
      std::snprintf(buf, sizeof(buf),
                    "the heading turned through %.0f deg and the field's directions span too little for a full fit "
                    "(spread %.3f < %.3f): turn the vehicle through at least %.0f deg (two full circles are best), "
                    "or tumble it for a full calibration",
                    result.heading_coverage_deg, result.spread_ratio, options.min_full_spread_ratio,
                    options.min_heading_coverage_deg);
      result.why = buf;
      return result;
    }
    model.horizontal = true;
    // K = [[1 + a, c, d], [c, 1 - a, e], [d, e, 1]]: the x-y block's trace kept, K_zz = 1 (a
    // vertical gain looks like another vertical field); b = (bx, by, bz), bz seen through the tilt.
    model.correction = [](const Eigen::VectorXd& q) {
      IronCorrection c;
      c.hard_iron_t = q.head<3>();
      c.soft_iron_inverse << 1.0 + q[3], q[4], q[5], q[4], 1.0 - q[3], q[6], q[5], q[6], 1.0;
      return c;
    };
    model.field = [](const Eigen::VectorXd& q) { return q[7]; };
    model.vertical = [](const Eigen::VectorXd& q) { return q[8]; };
    double mean_vertical = 0.0;
    for (const auto& s : samples) mean_vertical += upOf(s).dot(s.field_t) / static_cast<double>(samples.size());
    p = Eigen::VectorXd::Zero(9);
    p.head<2>() = centre_xy;
    p[7] = H0;
    p[8] = mean_vertical;
  }

  // Before: each component's spread about its mean, raw.
  const int k = model.residualsPerSample();
  std::vector<std::vector<double>> raw(k);
  for (const auto& s : samples) {
    double r[2];
    sampleResiduals(model, IronCorrection{}, 0.0, 0.0, s, r);
    for (int j = 0; j < k; ++j) raw[j].push_back(r[j]);
  }
  double ss_before = 0.0;
  for (const auto& component : raw) ss_before += std::pow(rmsAboutMean(component), 2);
  result.rms_before_t = std::sqrt(ss_before / k) / kMicro;
  p = solve(model, p, samples, options.max_iterations);
  const Eigen::VectorXd r = residuals(model, p, samples).head(k * samples.size());           // without the priors
  result.rms_after_t = std::sqrt(r.squaredNorm() / static_cast<double>(r.size())) / kMicro;  // over all components
  result.correction = model.correction(p);
  result.correction.hard_iron_t /= kMicro;
  result.field_t = model.field(p) / kMicro;
  if (model.horizontal) result.vertical_field_t = model.vertical(p) / kMicro;
  // A soft iron of a real vehicle is a few percent; a K far from I (or not positive definite)
  // means the data held something else than turns through a constant field.
  const Eigen::Vector3d k_eig =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(result.correction.soft_iron_inverse).eigenvalues();
  if (!result.correction.soft_iron_inverse.allFinite() || k_eig[0] < 0.5 || k_eig[2] > 2.0 || !(result.field_t > 0.0)) {
    result.why =
        "the fit did not converge to a plausible correction (gains outside 0.5-2): the data do not show "
        "turns through a constant field";
    return result;
  }
  result.ok = true;
  return result;
}

std::string ironCorrectionConfigYaml(const IronFitResult& fit) {
  std::ostringstream os;
  os << "# vims_mag_calib: " << ironFitModelName(fit.model) << " fit of " << fit.samples << " blocks; field magnitude "
     << formatOptionNumber(fit.field_t * 1e6) << " uT"
     << (fit.model == IronFitModel::kHorizontal ? " (horizontal)" : "") << "; residual "
     << formatOptionNumber(std::round(fit.rms_before_t * 1e10) / 10.0) << " nT rms before, "
     << formatOptionNumber(std::round(fit.rms_after_t * 1e10) / 10.0) << " nT after.\n";
  if (fit.model == IronFitModel::kHorizontal)
    os << "# Level turns only: the soft iron's vertical gain is left at 1 (level turns cannot tell it from the "
          "field's\n"
          "# vertical component).\n";
  // The option table writes the keys, so the file reads back exactly as MagnetometerOptions reads it.
  os << "magnetometer:\n  iron_correction:\n" << indentYaml(ironCorrectionYaml(fit.correction), "    ");
  return os.str();
}

std::string ironFitSummaryLine(const IronFitResult& fit) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(3);
  const Eigen::Vector3d gains =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(fit.correction.soft_iron_inverse).eigenvalues();
  os << "VIMS_MAG_CALIB ok=" << (fit.ok ? 1 : 0) << " model=" << ironFitModelName(fit.model)
     << " samples=" << fit.samples << " spread=" << fit.spread_ratio
     << " heading_coverage_deg=" << fit.heading_coverage_deg << " rms_before_nt=" << fit.rms_before_t * 1e9
     << " rms_after_nt=" << fit.rms_after_t * 1e9 << " field_ut=" << fit.field_t * 1e6
     << " hard_iron_ut=" << fit.correction.hard_iron_t.x() * 1e6 << "," << fit.correction.hard_iron_t.y() * 1e6 << ","
     << fit.correction.hard_iron_t.z() * 1e6 << " gains=" << gains[0] << "," << gains[1] << "," << gains[2];
  return os.str();
}

}  // namespace vims
