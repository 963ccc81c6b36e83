#include "vims_pose_graph/geomagnetic_gate.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vims_common/option_table.h"
#include "vims_pose_graph/angles.h"

namespace vims {

namespace {

constexpr double kDeg = M_PI / 180.0;
// Fewer samples than this say nothing about the site: held candidates are then accepted.
constexpr size_t kMinSamplesToJudge = 3;
// The heading reference needs this many azimuths of the session in the window (the candidate's
// own included) before its median says more than the candidate itself.
constexpr size_t kMinHeadingReference = 5;
// The VIO's drift rate is measured over this many heading windows (600 s by default).
constexpr double kSlopeHorizonWindows = 5.0;
// A drift of the azimuths below this over a heading window is not modelled. A disturbed site
// tilts the fitted slopes by up to 3.5 deg per 120 s (a 16 m tank over a 10 m, 2 uT anomaly),
// while VIMS's VIO drifts by a few tenths of a degree in minutes; 10 deg per 120 s is a VIO whose
// gyro bias is failing, where a constant reference would reject every sample.
constexpr double kMinModelledDriftRad = 10.0 * M_PI / 180.0;

double medianOfSorted(const std::vector<double>& sorted) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t n = sorted.size();
  return n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
}

void insertSorted(std::vector<double>& sorted, double value) {
  sorted.insert(std::upper_bound(sorted.begin(), sorted.end(), value), value);
}

}  // namespace

const OptionTable<GeomagneticGateOptions>& GeomagneticGateOptions::optionTable() {
  using O = GeomagneticGateOptions;
  static const auto table = OptionTable<O>()
                                .flag("enabled", &O::enabled)
                                .number("magnitude_fraction", &O::magnitude_fraction, Bounds::closed(1e-4, 1.0))
                                .scaledNumber("inclination_deg", &O::inclination_rad, kDeg, Bounds::closed(0.01, 90.0))
                                .scaledNumber("heading_deg", &O::heading_rad, kDeg, Bounds::closed(0.0, 180.0))
                                .number("heading_window_s", &O::heading_window_s, Bounds::closed(1.0, 1e5))
                                .integer("min_samples", &O::min_samples, Bounds::closed(3, 100000));
  return table;
}

GeomagneticGate::GeomagneticGate(const GeomagneticGateOptions& options) : options_(options) {}

GeomagneticCandidate GeomagneticGate::levelled(uint32_t node, uint32_t session, double t,
                                               const Eigen::Vector3d& field_b, const Eigen::Matrix3d& R_odom_b) {
  GeomagneticCandidate c;
  c.node = node;
  c.session = session;
  c.t = t;
  c.field_b = field_b;
  // The odometry frame is levelled (z up, gravity-aligned): a field pointing below the horizon
  // has B.z < 0, and its horizontal part's direction is the azimuth the heading check follows.
  const Eigen::Vector3d B_odom = R_odom_b * field_b;
  c.magnitude_tesla = B_odom.norm();
  c.inclination_rad = std::atan2(-B_odom.z(), B_odom.head<2>().norm());
  c.azimuth_odom_rad = std::atan2(B_odom.y(), B_odom.x());
  return c;
}

std::vector<GeomagneticVerdict> GeomagneticGate::add(const GeomagneticCandidate& candidate) {
  insertSorted(magnitudes_, candidate.magnitude_tesla);
  insertSorted(inclinations_, candidate.inclination_rad);
  held_.push_back(candidate);
  // Disabled: nothing to wait for, every measurement is accepted at once.
  if (options_.enabled && magnitudes_.size() < static_cast<size_t>(options_.min_samples)) return {};
  return flush();
}

std::vector<GeomagneticVerdict> GeomagneticGate::flush() {
  std::vector<GeomagneticVerdict> verdicts;
  verdicts.reserve(held_.size());
  const bool can_judge = magnitudes_.size() >= kMinSamplesToJudge;
  // Two passes: every held candidate that passes the invariants joins the heading reference
  // before any is checked against it, so the first ones of a run have neighbours on both sides.
  std::vector<bool> invariants_ok;
  for (const GeomagneticCandidate& c : held_) {
    GeomagneticVerdict v;
    v.candidate = c;
    const bool ok = can_judge && invariantsAgree(c, &v);
    if (ok) azimuths_.push_back(Azimuth{c.session, c.t, c.azimuth_odom_rad});
    invariants_ok.push_back(ok);
    verdicts.push_back(v);
  }
  for (size_t i = 0; i < verdicts.size(); ++i) {
    GeomagneticVerdict& v = verdicts[i];
    ++judged_;
    if (!can_judge) continue;  // too few samples to know the site: accepted
    bool ok = invariants_ok[i];
    if (ok && options_.heading_rad > 0.0) {
      const std::optional<double> error = headingError(v.candidate);
      if (error) {
        v.heading_error_rad = *error;
        ok = std::abs(*error) <= options_.heading_rad;
      }
    }
    v.accepted = ok || !options_.enabled;
    if (!v.accepted) ++rejected_;
  }
  // Later candidates are newer than every held one: older azimuths can no longer be in a window.
  if (!held_.empty()) {
    const double oldest_needed = held_.back().t - kSlopeHorizonWindows * options_.heading_window_s;
    while (!azimuths_.empty() && azimuths_.front().t < oldest_needed) azimuths_.pop_front();
  }
  held_.clear();
  return verdicts;
}

void GeomagneticGate::restartSite(const std::vector<GeomagneticCandidate>& history) {
  magnitudes_.clear();
  inclinations_.clear();
  for (const GeomagneticCandidate& c : history) {
    magnitudes_.push_back(c.magnitude_tesla);
    inclinations_.push_back(c.inclination_rad);
  }
  std::sort(magnitudes_.begin(), magnitudes_.end());
  std::sort(inclinations_.begin(), inclinations_.end());
  azimuths_.clear();
  if (magnitudes_.size() < kMinSamplesToJudge) return;
  const double oldest_needed = history.back().t - kSlopeHorizonWindows * options_.heading_window_s;
  for (const GeomagneticCandidate& c : history) {
    GeomagneticVerdict unused;
    if (c.t >= oldest_needed && invariantsAgree(c, &unused))
      azimuths_.push_back(Azimuth{c.session, c.t, c.azimuth_odom_rad});
  }
}

bool GeomagneticGate::invariantsAgree(const GeomagneticCandidate& candidate, GeomagneticVerdict* verdict) const {
  const double site_magnitude = siteMagnitude();
  verdict->magnitude_error_fraction = (candidate.magnitude_tesla - site_magnitude) / site_magnitude;
  verdict->inclination_error_rad = candidate.inclination_rad - siteInclination();
  return std::abs(verdict->magnitude_error_fraction) <= options_.magnitude_fraction &&
         std::abs(verdict->inclination_error_rad) <= options_.inclination_rad;
}

std::optional<double> GeomagneticGate::headingError(const GeomagneticCandidate& candidate) const {
  // Azimuths of the session relative to the candidate's (wrapped) against time from it, in time
  // order, over the slope's horizon; the window's ones are the reference.
  const double horizon = kSlopeHorizonWindows * options_.heading_window_s;
  std::vector<double> dt, offset;
  size_t in_window = 0;
  for (const Azimuth& a : azimuths_)
    if (a.session == candidate.session && std::abs(a.t - candidate.t) <= horizon) {
      dt.push_back(a.t - candidate.t);
      offset.push_back(wrapAngle(a.azimuth - candidate.azimuth_odom_rad));
      if (std::abs(dt.back()) <= options_.heading_window_s) ++in_window;
    }
  if (in_window < kMinHeadingReference) return std::nullopt;
  // The VIO's yaw may drift (a gyro bias: linearly in time), so the reference is a robust line:
  // its slope the median of the slopes between samples half the horizon apart (a disturbance,
  // local and bounded, hardly tilts pairs that far apart), its value at the candidate the median
  // of the window's offsets with that slope taken out. A slope below kMinModelledDriftRad over the
  // window is taken as zero: a disturbed site's azimuths tilt the slopes by as much, and VIMS's
  // own VIO drifts far less.
  const size_t n = dt.size();
  std::vector<double> slopes;
  const size_t half = n / 2;
  for (size_t i = 0; i + half < n; ++i)
    if (dt[i + half] > dt[i]) slopes.push_back((offset[i + half] - offset[i]) / (dt[i + half] - dt[i]));
  std::sort(slopes.begin(), slopes.end());
  double slope = slopes.empty() ? 0.0 : medianOfSorted(slopes);
  if (std::abs(slope) * options_.heading_window_s < kMinModelledDriftRad) slope = 0.0;
  std::vector<double> at_candidate;
  for (size_t i = 0; i < n; ++i)
    if (std::abs(dt[i]) <= options_.heading_window_s) at_candidate.push_back(offset[i] - slope * dt[i]);
  std::sort(at_candidate.begin(), at_candidate.end());
  return -medianOfSorted(at_candidate);
}

double GeomagneticGate::siteMagnitude() const { return medianOfSorted(magnitudes_); }

double GeomagneticGate::siteInclination() const { return medianOfSorted(inclinations_); }

}  // namespace vims
