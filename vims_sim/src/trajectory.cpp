#include "vims_sim/trajectory.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "vims_sim/planar_path.h"
#include "vims_sim/random.h"

namespace vims {
namespace sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int kSplineDegree = 5;      // quintic: acceleration is C^3, the IMU sees no kinks
constexpr double kKnotSpacing = 1.0;  // [s] control point spacing (0.4 m at the fastest)
constexpr double kArcStep = 0.02;     // [m] resolution of the speed profile

/// Per-scenario design numbers. Every value is a property of the survey, not a tuning knob
/// for an algorithm, so it lives here and in docs/simulator.md.
struct ScenarioDesign {
  std::vector<Eigen::Vector2d> lap;
  double corner_radius;       // [m] rounded waypoint corners
  double waypoint_jitter;     // [m] per-lap seeded displacement of each waypoint (uniform +-)
  double cruise_max;          // [m/s] never exceeded
  double cruise_variation;    // relative +- variation of the cruise speed along the path
  double cruise_wavelength;   // [m] along-path scale of the cruise speed variation
  double reference_travel;    // [m] travel reached after reference_time of motion (the pace)
  double reference_time;      // [s]
  double lateral_accel;       // [m/s^2] speed in turns is limited to sqrt(a / curvature)
  double longitudinal_accel;  // [m/s^2] speed changes at most this fast
};

ScenarioDesign scenarioDesign(Scenario scenario) {
  ScenarioDesign d;
  d.lap = scenarioLapWaypoints(scenario);  // missionLap() turns it into the mission's lap
  if (scenario == Scenario::kTank) {
    // About 130 m per lap in about 750 s with a maximum of 0.38 m/s, like the reference tank test.
    d.corner_radius = 2.0;
    d.waypoint_jitter = 0.5;
    d.cruise_max = 0.37;
    d.cruise_variation = 0.8;
    d.cruise_wavelength = 8.0;
    d.reference_travel = 130.0;
    d.reference_time = 747.0;
    d.lateral_accel = 0.03;
    d.longitudinal_accel = 0.008;
  } else {
    // Long transits between revisits, a little faster on average.
    d.corner_radius = 4.0;
    d.waypoint_jitter = 1.5;
    d.cruise_max = 0.37;
    d.cruise_variation = 0.3;
    d.cruise_wavelength = 25.0;
    d.reference_travel = 405.0;  // 0.27 m/s on average: one lap in about 1500 s
    d.reference_time = 1500.0;
    d.lateral_accel = 0.03;
    d.longitudinal_accel = 0.008;
  }
  return d;
}

/// Smooth 1-D value noise in [-1, 1] (quintic interpolation of seeded lattice values).
class SmoothNoise1D {
 public:
  SmoothNoise1D(uint64_t seed, double spacing) : seed_(seed), spacing_(spacing) {}
  double at(double x) const {
    const double f = x / spacing_;
    const double i = std::floor(f);
    const double u = f - i;
    const double w = u * u * u * (u * (u * 6.0 - 15.0) + 10.0);
    const auto li = static_cast<int64_t>(i);
    const double a = 2.0 * hashToUnit(hashCoords(seed_, li)) - 1.0;
    const double b = 2.0 * hashToUnit(hashCoords(seed_, li + 1)) - 1.0;
    return a + (b - a) * w;
  }

 private:
  uint64_t seed_;
  double spacing_;
};

double smoothstep01(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

/// The horizontal path: laps of the pattern with seeded waypoint jitter, long enough
/// that even at the maximum cruise speed the vehicle never reaches its end, and never shorter
/// than what the pace calibration of SpeedProfile looks at.
PlanarPath surveyPath(const TrajectoryParams& params, const ScenarioDesign& design, Rng& jitter_rng) {
  const double time_needed =
      std::max(params.duration, design.reference_time) + 2.0 * params.margin + 10.0 * kKnotSpacing;
  const double length_needed = time_needed * design.cruise_max + 10.0;
  std::vector<Eigen::Vector2d> waypoints;
  double polyline_length = 0.0;
  while (polyline_length < length_needed + 20.0) {
    for (const auto& base : design.lap) {
      Eigen::Vector2d w = base;
      if (!waypoints.empty()) {  // the very first waypoint (the start) stays on the pattern
        w += Eigen::Vector2d(jitter_rng.uniform(-1.0, 1.0), jitter_rng.uniform(-1.0, 1.0)) * design.waypoint_jitter;
        polyline_length += (w - waypoints.back()).norm();
      }
      waypoints.push_back(w);
    }
  }
  return PlanarPath::roundedPolyline(waypoints, design.corner_radius);
}

/// Where the vehicle is on the path at one time.
struct ArcState {
  double s;  // [m] arc length
  double v;  // [m/s] speed
};

/// Speed along the path: a wandering cruise speed, limited in turns by the lateral
/// acceleration, then made feasible with bounded longitudinal acceleration (backward pass
/// for braking before turns, forward pass from rest). The mean cruise speed is scaled so the
/// scenario's reference pace is met whatever the seed (a few fixed-point iterations).
class SpeedProfile {
 public:
  /// The profile along `path`, its cruise variation seeded by `cruise_seed`, starting from rest
  /// at motion_start.
  SpeedProfile(const ScenarioDesign& design, const PlanarPath& path, uint64_t cruise_seed, double motion_start)
      : cruise_max_(design.cruise_max),
        dv2_(2.0 * design.longitudinal_accel * kArcStep),
        motion_start_(motion_start),
        path_length_(path.length()) {
    const SmoothNoise1D cruise_noise(cruise_seed, design.cruise_wavelength);
    const int n = static_cast<int>(std::ceil(path.length() / kArcStep)) + 1;
    base_speed_.resize(n);
    turn_limit_.resize(n);
    for (int i = 0; i < n; ++i) {
      const double s = std::min(i * kArcStep, path.length());
      base_speed_[i] = 1.0 + design.cruise_variation * cruise_noise.at(s);
      const double curvature = std::abs(path.at(s).curvature);
      turn_limit_[i] = curvature > 1e-9 ? std::sqrt(design.lateral_accel / curvature) : design.cruise_max;
    }
    speed_.resize(n);
    time_at_.resize(n);
    double mean_cruise = design.reference_travel / design.reference_time;
    for (int iteration = 0; iteration < 6; ++iteration) {
      build(mean_cruise);
      const double travel = travelAfter(design.reference_time);
      if (travel >= path.length() - 1.0) break;  // path shorter than the reference: keep the pace
      mean_cruise *= design.reference_travel / std::max(travel, 1.0);
    }
    build(mean_cruise);
  }

  /// Arc length and speed at time tau: at rest before the motion starts, at the end of the path
  /// once it is reached.
  ArcState at(double tau) const {
    if (tau <= motion_start_) return {0.0, 0.0};
    if (tau >= time_at_.back()) return {path_length_, speed_.back()};
    const auto it = std::upper_bound(time_at_.begin(), time_at_.end(), tau);
    const int i = static_cast<int>(it - time_at_.begin()) - 1;
    const double f = (tau - time_at_[i]) / (time_at_[i + 1] - time_at_[i]);
    return {(i + f) * kArcStep, speed_[i] + f * (speed_[i + 1] - speed_[i])};
  }

  double motionStart() const { return motion_start_; }

 private:
  /// Speed and time on the arc-length grid for a mean cruise speed.
  void build(double mean_cruise) {
    const int n = static_cast<int>(speed_.size());
    for (int i = 0; i < n; ++i) {
      speed_[i] = std::min({mean_cruise * base_speed_[i], cruise_max_, turn_limit_[i]});
    }
    for (int i = n - 2; i >= 0; --i) speed_[i] = std::min(speed_[i], std::sqrt(speed_[i + 1] * speed_[i + 1] + dv2_));
    speed_[0] = 0.0;
    for (int i = 1; i < n; ++i) speed_[i] = std::min(speed_[i], std::sqrt(speed_[i - 1] * speed_[i - 1] + dv2_));
    time_at_[0] = motion_start_;
    for (int i = 1; i < n; ++i) time_at_[i] = time_at_[i - 1] + 2.0 * kArcStep / (speed_[i - 1] + speed_[i]);
  }

  /// Arc length reached after motion_time of motion (on the grid).
  double travelAfter(double motion_time) const {
    const auto it = std::upper_bound(time_at_.begin(), time_at_.end(), motion_start_ + motion_time);
    return static_cast<double>(it - time_at_.begin()) * kArcStep;
  }

  double cruise_max_;    // [m/s]
  double dv2_;           // [m^2/s^2] largest change of v^2 over one kArcStep
  double motion_start_;  // [s]
  double path_length_;   // [m]
  // On the arc-length grid i * kArcStep:
  std::vector<double> base_speed_;  // cruise speed relative to the mean
  std::vector<double> turn_limit_;  // [m/s]
  std::vector<double> speed_;       // [m/s]
  std::vector<double> time_at_;     // [s] when the vehicle is there
};

/// Altitude above the seabed's large-scale shape (z = 0 when flat): two slow
/// undulations keep it in [2.1, 4.9] m with climb slopes below 0.3 (0.1 m/s at cruise speed).
struct AltitudeProfile {
  static constexpr double kMean = 3.5;
  static constexpr double kAmp1 = 1.1, kAmp2 = 0.3;
  double offset = 0.0;                // [m] TrajectoryParams::altitude_offset_m
  double wave1 = 0.0, wave2 = 0.0;    // [m] along-path wavelengths
  double phase1 = 0.0, phase2 = 0.0;  // [rad]

  /// Altitude at arc length s.
  double at(double s) const {
    return kMean + offset + kAmp1 * std::sin(2.0 * M_PI * s / wave1 + phase1) +
           kAmp2 * std::sin(2.0 * M_PI * s / wave2 + phase2);
  }
  /// d(altitude) / ds.
  double slope(double s) const {
    return kAmp1 * 2.0 * M_PI / wave1 * std::cos(2.0 * M_PI * s / wave1 + phase1) +
           kAmp2 * 2.0 * M_PI / wave2 * std::cos(2.0 * M_PI * s / wave2 + phase2);
  }
};

AltitudeProfile drawAltitudeProfile(Rng& rng) {
  AltitudeProfile altitude;
  altitude.wave1 = rng.uniform(35.0, 50.0);
  altitude.wave2 = rng.uniform(14.0, 20.0);
  altitude.phase1 = rng.uniform(0.0, 2.0 * M_PI);
  altitude.phase2 = rng.uniform(0.0, 2.0 * M_PI);
  return altitude;
}

/// Attitude: yaw follows the path heading plus a small wandering crab angle; pitch
/// has a trim, follows the climb a little and sways; roll has a trim, banks slightly in turns
/// and sways. All motion terms fade in after the start so the static phase is truly static.
class AttitudeMotion {
 public:
  /// Draws the seeded terms from `rng`, in this order.
  explicit AttitudeMotion(Rng& rng) : crab_noise_(rng.next(), 20.0) {
    pitch_trim_ = rng.uniform(-1.0, 1.0) * kDeg;
    roll_trim_ = rng.uniform(-1.0, 1.0) * kDeg;
    pitch_sway_ = rng.uniform(0.8, 1.5) * kDeg;
    pitch_period_ = rng.uniform(9.0, 15.0);
    roll_sway_ = rng.uniform(1.0, 2.0) * kDeg;
    roll_period_ = rng.uniform(6.0, 11.0);
    pitch_phase_ = rng.uniform(0.0, 2.0 * M_PI);
    roll_phase_ = rng.uniform(0.0, 2.0 * M_PI);
  }

  /// (yaw, pitch, roll) at time tau at path point `pt`, with speed v and the slope of the
  /// designed height along the path; the motion starts at motion_start.
  Eigen::Vector3d euler(double tau, double motion_start, const PlanarPath::Point& pt, double v,
                        double climb_slope) const {
    const double fade = smoothstep01((tau - motion_start) / kFadeIn);
    const double yaw = pt.heading + fade * kCrabAmplitude * crab_noise_.at(tau);
    const double pitch = pitch_trim_ + fade * (-kPitchCoupling * std::atan(climb_slope) +
                                               pitch_sway_ * std::sin(2.0 * M_PI * tau / pitch_period_ + pitch_phase_));
    const double roll = roll_trim_ + fade * (-kBankGain * v * pt.curvature +
                                             roll_sway_ * std::sin(2.0 * M_PI * tau / roll_period_ + roll_phase_));
    return Eigen::Vector3d(yaw, pitch, roll);
  }

 private:
  static constexpr double kCrabAmplitude = 1.5 * kDeg;
  static constexpr double kPitchCoupling = 0.2;  // fraction of the climb angle the hull pitches
  static constexpr double kBankGain = 0.15;      // [s] roll per yaw rate
  static constexpr double kFadeIn = 15.0;        // [s]
  SmoothNoise1D crab_noise_;
  double pitch_trim_ = 0.0, roll_trim_ = 0.0;     // [rad]
  double pitch_sway_ = 0.0, pitch_period_ = 0.0;  // [rad], [s]
  double roll_sway_ = 0.0, roll_period_ = 0.0;    // [rad], [s]
  double pitch_phase_ = 0.0, roll_phase_ = 0.0;   // [rad]
};

/// The height of the body where the terrain is not flat, at arc length s (path point `pt`), and
/// the slope of that height along the path (`climb_slope`).
double designedHeight(const TrajectoryParams& params, const SeabedTerrain& terrain, const AltitudeProfile& altitude,
                      double s, const PlanarPath::Point& pt, double* climb_slope) {
  if (params.depth_hold_z) {
    *climb_slope = 0.0;
    return *params.depth_hold_z;
  }
  Eigen::Vector2d ground_gradient;
  const double ground = params.hold_plane_only ? terrain.planeHeight(pt.position.x(), pt.position.y(), &ground_gradient)
                                               : terrain.largeScale(pt.position.x(), pt.position.y(), &ground_gradient);
  *climb_slope = altitude.slope(s) + ground_gradient.dot(Eigen::Vector2d(std::cos(pt.heading), std::sin(pt.heading)));
  return ground + altitude.at(s);
}

/// Control points of the two quintic splines, on knots kKnotSpacing apart from t0.
struct SplineControlPoints {
  double t0 = 0.0;
  std::vector<Eigen::Vector3d> position;  // p_w_b
  std::vector<Eigen::Vector3d> euler;     // (yaw, pitch, roll)
};

SplineControlPoints designControlPoints(const TrajectoryParams& params, const PlanarPath& path,
                                        const SpeedProfile& speed, const AltitudeProfile& altitude,
                                        const AttitudeMotion& attitude) {
  // Where the terrain is not flat, the designed height is the large-scale seabed plus the
  // altitude profile (altitude hold) or a constant (depth hold), and the climb the hull pitches
  // with is that height's slope along the path. The flat seabed keeps the plain profile.
  const bool flat_altitude_hold = params.terrain.isFlat() && !params.depth_hold_z;
  const SeabedTerrain terrain(params.terrain);

  SplineControlPoints control;
  control.t0 = params.static_start - kKnotSpacing * std::ceil((params.static_start + params.margin) / kKnotSpacing);
  const int num_control =
      static_cast<int>(std::ceil((params.duration + params.margin - control.t0) / kKnotSpacing)) + kSplineDegree + 1;
  control.position.resize(num_control);
  control.euler.resize(num_control);
  for (int j = 0; j < num_control; ++j) {
    const double tau = control.t0 + (j - kSplineDegree / 2) * kKnotSpacing;
    const ArcState arc = speed.at(tau);
    const PlanarPath::Point pt = path.at(arc.s);
    double z, climb_slope;
    if (flat_altitude_hold) {
      z = altitude.at(arc.s);
      climb_slope = altitude.slope(arc.s);
    } else {
      z = designedHeight(params, terrain, altitude, arc.s, pt, &climb_slope);
    }
    control.position[j] = Eigen::Vector3d(pt.position.x(), pt.position.y(), z);
    control.euler[j] = attitude.euler(tau, speed.motionStart(), pt, arc.v, climb_slope);
  }
  return control;
}

}  // namespace

std::string scenarioName(Scenario scenario) { return scenario == Scenario::kTank ? "tank" : "field"; }

Scenario parseScenario(const std::string& name) {
  if (name == "tank") return Scenario::kTank;
  if (name == "field") return Scenario::kField;
  throw std::invalid_argument("unknown scenario '" + name + "' (expected 'tank' or 'field')");
}

ScenarioArea scenarioArea(Scenario scenario) {
  if (scenario == Scenario::kTank) return {10.0, 10.0};
  return {40.0, 30.0};
}

std::vector<Eigen::Vector2d> scenarioLapWaypoints(Scenario scenario) {
  if (scenario == Scenario::kTank) {
    // Three east-west lines, then north-south lines crossing them at 90 deg, then a southbound
    // pass over the first northbound leg (x = 7.35) and a westbound line across everything.
    const double k = 1.05;  // scales the lap to about 130 m of travel
    return {k * Eigen::Vector2d(-8.5, -6),  k * Eigen::Vector2d(7, -6),      k * Eigen::Vector2d(7, 0),
            k * Eigen::Vector2d(-7, 0),     k * Eigen::Vector2d(-7, 6),      k * Eigen::Vector2d(3.5, 6),
            k * Eigen::Vector2d(3.5, -8.5), k * Eigen::Vector2d(-3.5, -8.5), k * Eigen::Vector2d(-3.5, 8),
            k * Eigen::Vector2d(7, 8),      k * Eigen::Vector2d(7, -3),      k * Eigen::Vector2d(-8.5, -3)};
  }
  // 80 m x 60 m: a long eastbound transit, a loop round the site, north-south legs crossing the
  // transits at 90 deg, a southbound pass next to the first northbound leg and a long westbound
  // transit back, 4 m beside the first one.
  return {{-34, -24}, {32, -24}, {32, 22},  {-20, 22},  {-20, -27}, {5, -27},
          {5, 10},    {34, 10},  {34, -20}, {-37, -20}, {-37, -24}};
}

std::vector<Eigen::Vector2d> missionLap(const std::vector<Eigen::Vector2d>& lap, double start_along_m, bool reverse) {
  if (lap.size() < 2 || (start_along_m == 0.0 && !reverse)) return lap;
  std::vector<Eigen::Vector2d> pattern = lap;
  if (reverse) std::reverse(pattern.begin(), pattern.end());
  // The lap is a closed pattern: its last waypoint leads back to its first.
  const size_t n = pattern.size();
  double length = 0.0;
  for (size_t i = 0; i < n; ++i) length += (pattern[(i + 1) % n] - pattern[i]).norm();
  double s = std::fmod(start_along_m, length);
  if (s < 0.0) s += length;
  size_t edge = 0;
  for (; edge + 1 < n; ++edge) {
    const double edge_length = (pattern[edge + 1] - pattern[edge]).norm();
    if (s < edge_length) break;
    s -= edge_length;
  }
  const Eigen::Vector2d& a = pattern[edge];
  const Eigen::Vector2d& b = pattern[(edge + 1) % n];
  const double edge_length = (b - a).norm();
  std::vector<Eigen::Vector2d> mission{a + (b - a) * (edge_length > 0.0 ? std::min(s / edge_length, 1.0) : 0.0)};
  for (size_t k = 1; k <= n; ++k) {
    const Eigen::Vector2d& w = pattern[(edge + k) % n];
    if ((w - mission.back()).norm() > 1e-9) mission.push_back(w);
  }
  if (mission.size() > 1 && (mission.back() - mission.front()).norm() < 1e-9) mission.pop_back();
  return mission;
}

Eigen::Quaterniond Trajectory::eulerToQuaternion(double yaw, double pitch, double roll) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
}

Trajectory Trajectory::design(const TrajectoryParams& params) {
  if (!(params.duration > 0.0)) throw std::invalid_argument("trajectory duration must be > 0");
  if (params.static_start < 0.0 || params.static_start >= params.duration) {
    throw std::invalid_argument("static start must be in [0, duration)");
  }
  if (params.margin < 0.0) throw std::invalid_argument("trajectory margin must be >= 0");

  if (params.altitude_offset_m < -1.0 || params.altitude_offset_m > 3.0) {
    throw std::invalid_argument("altitude offset must be in [-1, 3] m");
  }
  if (!std::isfinite(params.start_along_lap_m)) throw std::invalid_argument("start along the lap must be finite");

  ScenarioDesign design = scenarioDesign(params.scenario);
  design.lap = missionLap(design.lap, params.start_along_lap_m, params.reverse_lap);
  // Independent streams per design element, so a short sequence is exactly the start of a
  // long one with the same seed (the number of laps drawn does not shift the other draws).
  // The order of the draws from `rng` below (cruise noise, altitude, attitude) is part of
  // every sequence: keep it.
  Rng rng(deriveSeed(params.seed, 0x7241));
  Rng jitter_rng(deriveSeed(params.seed, 0x7242));

  const PlanarPath path = surveyPath(params, design, jitter_rng);
  // The path motion starts two knots after static_start: with the centred control points of a
  // quintic spline this makes the spline exactly constant up to static_start and moving after.
  const double motion_start = params.static_start + 2.0 * kKnotSpacing;
  const SpeedProfile speed(design, path, rng.next(), motion_start);
  AltitudeProfile altitude = drawAltitudeProfile(rng);
  altitude.offset = params.altitude_offset_m;
  const AttitudeMotion attitude(rng);
  SplineControlPoints control = designControlPoints(params, path, speed, altitude, attitude);

  Trajectory trajectory;
  trajectory.params_ = params;
  trajectory.position_ = UniformBSpline<3>(kSplineDegree, control.t0, kKnotSpacing, std::move(control.position));
  trajectory.euler_ = UniformBSpline<3>(kSplineDegree, control.t0, kKnotSpacing, std::move(control.euler));
  trajectory.designed_travel_ = speed.at(params.duration).s;
  return trajectory;
}

TrajectoryState Trajectory::sample(double t) const {
  Eigen::Vector3d p[3], e[2];
  position_.evaluate(t, 2, p);
  euler_.evaluate(t, 1, e);
  TrajectoryState state;
  state.t = t;
  state.p_w_b = p[0];
  state.v_w_b = p[1];
  state.a_w_b = p[2];
  const double yaw = e[0].x(), pitch = e[0].y(), roll = e[0].z();
  const double yaw_rate = e[1].x(), pitch_rate = e[1].y(), roll_rate = e[1].z();
  state.q_w_b = eulerToQuaternion(yaw, pitch, roll);
  // Body rates of R = Rz(yaw) Ry(pitch) Rx(roll): omega_b = E(roll, pitch) * euler_rates.
  const double sr = std::sin(roll), cr = std::cos(roll), sp = std::sin(pitch), cp = std::cos(pitch);
  state.omega_b = Eigen::Vector3d(roll_rate - yaw_rate * sp, pitch_rate * cr + yaw_rate * sr * cp,
                                  -pitch_rate * sr + yaw_rate * cr * cp);
  return state;
}

Eigen::Isometry3d Trajectory::pose(double t) const {
  const Eigen::Vector3d p = position_.value(t);
  const Eigen::Vector3d e = euler_.value(t);
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.linear() = eulerToQuaternion(e.x(), e.y(), e.z()).toRotationMatrix();
  T_w_b.translation() = p;
  return T_w_b;
}

}  // namespace sim
}  // namespace vims
