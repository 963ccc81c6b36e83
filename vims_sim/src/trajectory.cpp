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
  d.lap = scenarioLapWaypoints(scenario);
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

  const ScenarioDesign design = scenarioDesign(params.scenario);
  // Independent streams per design element, so a short sequence is exactly the start of a
  // long one with the same seed (the number of laps drawn does not shift the other draws).
  Rng rng(deriveSeed(params.seed, 0x7241));
  Rng jitter_rng(deriveSeed(params.seed, 0x7242));

  // --- 1. The horizontal path: laps of the pattern with seeded waypoint jitter, long enough
  // that even at the maximum cruise speed the vehicle never reaches its end, and never shorter
  // than what the pace calibration below looks at.
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
  const PlanarPath path = PlanarPath::roundedPolyline(waypoints, design.corner_radius);

  // --- 2. Speed along the path: a wandering cruise speed, limited in turns by the lateral
  // acceleration, then made feasible with bounded longitudinal acceleration (backward pass
  // for braking before turns, forward pass from rest). The mean cruise speed is scaled so the
  // scenario's reference pace is met whatever the seed (a few fixed-point iterations).
  const SmoothNoise1D cruise_noise(rng.next(), design.cruise_wavelength);
  const int n = static_cast<int>(std::ceil(path.length() / kArcStep)) + 1;
  std::vector<double> base_speed(n), turn_limit(n);
  for (int i = 0; i < n; ++i) {
    const double s = std::min(i * kArcStep, path.length());
    base_speed[i] = 1.0 + design.cruise_variation * cruise_noise.at(s);
    const double curvature = std::abs(path.at(s).curvature);
    turn_limit[i] = curvature > 1e-9 ? std::sqrt(design.lateral_accel / curvature) : design.cruise_max;
  }
  // The path motion starts two knots after static_start: with the centred control points of a
  // quintic spline this makes the spline exactly constant up to static_start and moving after.
  const double motion_start = params.static_start + 2.0 * kKnotSpacing;
  const double dv2 = 2.0 * design.longitudinal_accel * kArcStep;
  std::vector<double> speed(n), time_at(n);
  auto buildProfile = [&](double mean_cruise) {
    for (int i = 0; i < n; ++i) {
      speed[i] = std::min({mean_cruise * base_speed[i], design.cruise_max, turn_limit[i]});
    }
    for (int i = n - 2; i >= 0; --i) speed[i] = std::min(speed[i], std::sqrt(speed[i + 1] * speed[i + 1] + dv2));
    speed[0] = 0.0;
    for (int i = 1; i < n; ++i) speed[i] = std::min(speed[i], std::sqrt(speed[i - 1] * speed[i - 1] + dv2));
    time_at[0] = motion_start;
    for (int i = 1; i < n; ++i) time_at[i] = time_at[i - 1] + 2.0 * kArcStep / (speed[i - 1] + speed[i]);
  };
  auto travelAfter = [&](double motion_time) {
    const auto it = std::upper_bound(time_at.begin(), time_at.end(), motion_start + motion_time);
    return static_cast<double>(it - time_at.begin()) * kArcStep;
  };
  double mean_cruise = design.reference_travel / design.reference_time;
  for (int iteration = 0; iteration < 6; ++iteration) {
    buildProfile(mean_cruise);
    const double travel = travelAfter(design.reference_time);
    if (travel >= path.length() - 1.0) break;  // path shorter than the reference: keep the pace
    mean_cruise *= design.reference_travel / std::max(travel, 1.0);
  }
  buildProfile(mean_cruise);

  struct ArcState {
    double s;
    double v;
  };
  auto arcAt = [&](double tau) -> ArcState {
    if (tau <= motion_start) return {0.0, 0.0};
    if (tau >= time_at.back()) return {path.length(), speed.back()};
    const auto it = std::upper_bound(time_at.begin(), time_at.end(), tau);
    const int i = static_cast<int>(it - time_at.begin()) - 1;
    const double f = (tau - time_at[i]) / (time_at[i + 1] - time_at[i]);
    return {(i + f) * kArcStep, speed[i] + f * (speed[i + 1] - speed[i])};
  };

  // --- 3. Altitude above the seabed's large-scale shape (z = 0 when flat): two slow
  // undulations keep it in [2.1, 4.9] m with climb slopes below 0.3 (0.1 m/s at cruise speed).
  const double alt_mean = 3.5;
  const double alt_amp1 = 1.1, alt_amp2 = 0.3;
  const double alt_wave1 = rng.uniform(35.0, 50.0), alt_wave2 = rng.uniform(14.0, 20.0);
  const double alt_phase1 = rng.uniform(0.0, 2.0 * M_PI), alt_phase2 = rng.uniform(0.0, 2.0 * M_PI);
  auto altitude = [&](double s) {
    return alt_mean + alt_amp1 * std::sin(2.0 * M_PI * s / alt_wave1 + alt_phase1) +
           alt_amp2 * std::sin(2.0 * M_PI * s / alt_wave2 + alt_phase2);
  };
  auto altitudeSlope = [&](double s) {
    return alt_amp1 * 2.0 * M_PI / alt_wave1 * std::cos(2.0 * M_PI * s / alt_wave1 + alt_phase1) +
           alt_amp2 * 2.0 * M_PI / alt_wave2 * std::cos(2.0 * M_PI * s / alt_wave2 + alt_phase2);
  };

  // --- 4. Attitude: yaw follows the path heading plus a small wandering crab angle; pitch
  // has a trim, follows the climb a little and sways; roll has a trim, banks slightly in turns
  // and sways. All motion terms fade in after the start so the static phase is truly static.
  const SmoothNoise1D crab_noise(rng.next(), 20.0);
  const double crab_amplitude = 1.5 * kDeg;
  const double pitch_trim = rng.uniform(-1.0, 1.0) * kDeg;
  const double roll_trim = rng.uniform(-1.0, 1.0) * kDeg;
  const double pitch_coupling = 0.2;  // fraction of the climb angle the hull pitches
  const double bank_gain = 0.15;      // [s] roll per yaw rate
  const double pitch_sway = rng.uniform(0.8, 1.5) * kDeg, pitch_period = rng.uniform(9.0, 15.0);
  const double roll_sway = rng.uniform(1.0, 2.0) * kDeg, roll_period = rng.uniform(6.0, 11.0);
  const double pitch_phase = rng.uniform(0.0, 2.0 * M_PI), roll_phase = rng.uniform(0.0, 2.0 * M_PI);
  const double fade_in = 15.0;  // [s]

  // Where the terrain is not flat, the designed height is the large-scale seabed plus the
  // altitude profile (altitude hold) or a constant (depth hold), and the climb the hull pitches
  // with is that height's slope along the path. The flat seabed keeps the plain profile.
  const bool flat_altitude_hold = params.terrain.isFlat() && !params.depth_hold_z;
  const SeabedTerrain terrain(params.terrain);
  auto designedHeight = [&](double s, const PlanarPath::Point& pt, double* climb_slope) {
    if (params.depth_hold_z) {
      *climb_slope = 0.0;
      return *params.depth_hold_z;
    }
    Eigen::Vector2d ground_gradient;
    const double ground = params.hold_plane_only
                              ? terrain.planeHeight(pt.position.x(), pt.position.y(), &ground_gradient)
                              : terrain.largeScale(pt.position.x(), pt.position.y(), &ground_gradient);
    *climb_slope = altitudeSlope(s) + ground_gradient.dot(Eigen::Vector2d(std::cos(pt.heading), std::sin(pt.heading)));
    return ground + altitude(s);
  };

  // --- 5. Control points of the two quintic splines.
  const double t0 =
      params.static_start - kKnotSpacing * std::ceil((params.static_start + params.margin) / kKnotSpacing);
  const int num_control =
      static_cast<int>(std::ceil((params.duration + params.margin - t0) / kKnotSpacing)) + kSplineDegree + 1;
  std::vector<Eigen::Vector3d> position_control(num_control), euler_control(num_control);
  for (int j = 0; j < num_control; ++j) {
    const double tau = t0 + (j - kSplineDegree / 2) * kKnotSpacing;
    const ArcState arc = arcAt(tau);
    const PlanarPath::Point pt = path.at(arc.s);
    double z, climb_slope;
    if (flat_altitude_hold) {
      z = altitude(arc.s);
      climb_slope = altitudeSlope(arc.s);
    } else {
      z = designedHeight(arc.s, pt, &climb_slope);
    }
    position_control[j] = Eigen::Vector3d(pt.position.x(), pt.position.y(), z);
    const double fade = smoothstep01((tau - motion_start) / fade_in);
    const double yaw = pt.heading + fade * crab_amplitude * crab_noise.at(tau);
    const double pitch = pitch_trim + fade * (-pitch_coupling * std::atan(climb_slope) +
                                              pitch_sway * std::sin(2.0 * M_PI * tau / pitch_period + pitch_phase));
    const double roll = roll_trim + fade * (-bank_gain * arc.v * pt.curvature +
                                            roll_sway * std::sin(2.0 * M_PI * tau / roll_period + roll_phase));
    euler_control[j] = Eigen::Vector3d(yaw, pitch, roll);
  }

  Trajectory trajectory;
  trajectory.params_ = params;
  trajectory.position_ = UniformBSpline<3>(kSplineDegree, t0, kKnotSpacing, std::move(position_control));
  trajectory.euler_ = UniformBSpline<3>(kSplineDegree, t0, kKnotSpacing, std::move(euler_control));
  trajectory.designed_travel_ = arcAt(params.duration).s;
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
