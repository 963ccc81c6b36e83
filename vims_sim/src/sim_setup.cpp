#include "vims_sim/sim_setup.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include "vims_sim/random.h"

namespace vims {
namespace sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Sub-stream identifiers of the seeds.
enum : uint64_t {
  kStreamSite = 0x5173,
  kStreamRig = 0x0219,
  kStreamImuBias = 0x1b1a,
  kStreamCoilPhase = 0xc01f,
  kStreamTerrain = 0x7e55,
  kStreamTerrainShape = 0x7e56,
  kStreamWater = 0x3a7e,
  kStreamPressureRig = 0x9b0e,
  kStreamExtrinsicError = 0xe4c0,
  kStreamThrusters = 0x7412,
  kStreamOtherCoilSites = 0xc02a,    // world seed: which point at the spacing holds each further coil
  kStreamOtherCoilPhases = 0xc02f,   // trajectory seed: the further coils' free-running phases
  kStreamMagnetometerIron = 0x1e0f,  // the vehicle's iron belongs to the rig: rig seed
  kStreamSeabedChange = 0x5ed0,      // trajectory seed: the patches re-laid before this dive
};

constexpr double kMinAltitude = 1.0;              // [m] the designed trajectory never comes closer to the seabed
constexpr double kStandardAtmosphere = 101325.0;  // [Pa]

Eigen::Matrix3d smallRotation(Rng& rng, double max_angle) {
  const Eigen::Vector3d v(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
  const Eigen::Vector3d rotation_vector = v * max_angle;
  const double angle = rotation_vector.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
}

Eigen::Isometry3d makeTransform(const Eigen::Matrix3d& R, const Eigen::Vector3d& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = p;
  return T;
}

Eigen::Vector3d jitter(Rng& rng, const Eigen::Vector3d& nominal, const Eigen::Vector3d& half_range) {
  return nominal + Eigen::Vector3d(rng.uniform(-1, 1) * half_range.x(), rng.uniform(-1, 1) * half_range.y(),
                                   rng.uniform(-1, 1) * half_range.z());
}

/// A coil's position moved inside the area, at least 1 m from its edges.
Eigen::Vector2d keptOneMetreInside(const ScenarioArea& area, const Eigen::Vector2d& p) {
  return {std::max(-area.half_size_x + 1.0, std::min(area.half_size_x - 1.0, p.x())),
          std::max(-area.half_size_y + 1.0, std::min(area.half_size_y - 1.0, p.y()))};
}

}  // namespace

SiteModel makeSite(Scenario scenario, uint64_t world_seed) {
  Rng rng(deriveSeed(world_seed, kStreamSite));
  SiteModel site;
  site.geomagnetic.total = 49.0e-6 * (1.0 + rng.uniform(-0.02, 0.02));
  site.geomagnetic.inclination_deg = 46.0 + rng.uniform(-1.0, 1.0);
  site.geomagnetic.declination_deg = rng.sign() * rng.uniform(2.0, 6.0);

  // Coil: a point on a leg of the base pattern (chosen proportionally to leg length), offset
  // sideways by up to 2.5 m, kept inside the area.
  const auto waypoints = scenarioLapWaypoints(scenario);
  std::vector<double> cumulative;
  double total = 0.0;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    total += (waypoints[(i + 1) % waypoints.size()] - waypoints[i]).norm();
    cumulative.push_back(total);
  }
  const double pick = rng.uniform(0.0, total);
  size_t leg = 0;
  while (leg + 1 < cumulative.size() && cumulative[leg] < pick) ++leg;
  const Eigen::Vector2d a = waypoints[leg], b = waypoints[(leg + 1) % waypoints.size()];
  const Eigen::Vector2d direction = (b - a).normalized();
  const Eigen::Vector2d normal(-direction.y(), direction.x());
  Eigen::Vector2d position = a + rng.uniform(0.15, 0.85) * (b - a) + rng.uniform(-2.5, 2.5) * normal;
  const ScenarioArea area = scenarioArea(scenario);
  position = keptOneMetreInside(area, position);
  site.coil.position_w = Eigen::Vector3d(position.x(), position.y(), 0.0);
  site.coil.turns = 330;
  site.coil.current = 2.9;
  site.coil.diameter = 0.6;
  site.coil.frequency = 11.0;
  site.coil.phase = 0.0;
  return site;
}

std::vector<Eigen::Vector2d> placeOtherCoils(Scenario scenario, const Eigen::Vector2d& first, int count,
                                             double spacing_m, uint64_t world_seed) {
  std::vector<Eigen::Vector2d> placed;
  if (count <= 0) return placed;
  // Candidates on the closed base lap: a point every 0.1 m of each leg, the legs' exact crossings
  // of the circle of radius spacing_m round the first coil, and the legs' nearest points to it.
  const auto lap = scenarioLapWaypoints(scenario);
  const ScenarioArea area = scenarioArea(scenario);
  std::vector<Eigen::Vector2d> candidates;
  for (size_t i = 0; i < lap.size(); ++i) {
    const Eigen::Vector2d a = lap[i], d = lap[(i + 1) % lap.size()] - lap[i];
    const double length = d.norm();
    if (length < 1e-9) continue;
    const int steps = static_cast<int>(std::ceil(length / 0.1));
    for (int k = 0; k < steps; ++k) candidates.push_back(a + (static_cast<double>(k) / steps) * d);
    // |a + s d - first|^2 = spacing^2 for s in [0, 1].
    const Eigen::Vector2d r = a - first;
    const double qa = d.squaredNorm(), qb = 2.0 * d.dot(r), qc = r.squaredNorm() - spacing_m * spacing_m;
    const double discriminant = qb * qb - 4.0 * qa * qc;
    if (discriminant >= 0.0) {
      for (const double sign : {-1.0, 1.0}) {
        const double s = (-qb + sign * std::sqrt(discriminant)) / (2.0 * qa);
        if (s >= 0.0 && s <= 1.0) candidates.push_back(a + s * d);
      }
    }
    candidates.push_back(a + std::max(0.0, std::min(1.0, -d.dot(r) / qa)) * d);
  }
  for (Eigen::Vector2d& c : candidates) c = keptOneMetreInside(area, c);  // as the first coil

  Rng rng(deriveSeed(world_seed, kStreamOtherCoilSites));
  constexpr double kTie = 1e-6;  // [m] candidates this close to the best are equally good
  for (int n = 0; n < count; ++n) {
    // Distance to the nearest coil placed so far, the first one included.
    const auto clearance = [&](const Eigen::Vector2d& p) {
      double nearest = (p - first).norm();
      for (const Eigen::Vector2d& q : placed) nearest = std::min(nearest, (p - q).norm());
      return nearest;
    };
    bool any_clear = false;
    for (const Eigen::Vector2d& c : candidates) any_clear = any_clear || clearance(c) >= spacing_m - kTie;
    // With room: the distance from the first coil closest to the spacing, among the points at
    // least the spacing from every earlier coil. Without: the farthest from the earlier coils.
    const auto cost = [&](const Eigen::Vector2d& c) {
      if (any_clear) {
        return clearance(c) >= spacing_m - kTie ? std::abs((c - first).norm() - spacing_m)
                                                : std::numeric_limits<double>::infinity();
      }
      return -clearance(c);
    };
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector2d& c : candidates) best = std::min(best, cost(c));
    std::vector<Eigen::Vector2d> ties;
    for (const Eigen::Vector2d& c : candidates)
      if (cost(c) <= best + kTie) ties.push_back(c);
    const auto pick = std::min(ties.size() - 1, static_cast<size_t>(rng.uniform() * static_cast<double>(ties.size())));
    placed.push_back(ties[pick]);
  }
  return placed;
}

namespace {

/// The designed trajectory must keep the body 1 m above the seabed (rocks and roughness
/// included) and, with a pressure sensor, the port under water. Checked every 0.1 s.
void checkClearances(const SimSetup& setup) {
  const SimOptions& options = setup.options;
  const SeabedTerrain& terrain = *setup.terrain;
  const char* flag = options.depth_hold_z ? "--depth-hold" : "--terrain";
  const auto steps = static_cast<int64_t>(std::ceil(options.duration * 10.0));
  for (int64_t k = 0; k <= steps; ++k) {
    const double t = std::min(options.duration, 0.1 * static_cast<double>(k));
    const Eigen::Isometry3d T_w_b = setup.trajectory.pose(t);
    const Eigen::Vector3d p = T_w_b.translation();
    const double altitude = p.z() - terrain.height(p.x(), p.y());
    if (altitude < kMinAltitude) {
      char buf[200];
      std::snprintf(buf, sizeof(buf),
                    "the designed altitude falls to %.2f m above the seabed at t = %.1f s (minimum %.1f m)", altitude,
                    t, kMinAltitude);
      throw std::invalid_argument(std::string(flag) + ": " + buf);
    }
    if (setup.config.pressure && setup.truth.pressure &&
        (T_w_b * setup.config.pressure->T_b_p.translation()).z() > setup.truth.pressure->water.surface_z - 0.5) {
      char buf[200];
      std::snprintf(buf, sizeof(buf), "the pressure port reaches the water surface (z = %.2f m) at t = %.1f s",
                    setup.truth.pressure->water.surface_z, t);
      throw std::invalid_argument(std::string(options.depth_hold_z ? "--depth-hold" : "--pressure") + ": " + buf);
    }
  }
}

}  // namespace

TerrainParams resolveTerrain(const TerrainOptions& options, uint64_t world_seed) {
  TerrainParams p = terrainFromOptions(options);
  Rng rng(deriveSeed(world_seed, kStreamTerrain));
  const double seeded_azimuth = rng.uniform(0.0, 360.0);
  if (!options.slope_azimuth_deg) p.slope_azimuth_deg = seeded_azimuth;
  p.seed = deriveSeed(world_seed, kStreamTerrainShape);
  return p;
}

SimSetup buildSimSetup(const SimOptions& options) {
  options.validate();
  SimSetup setup;
  setup.options = options;

  TrajectoryParams trajectory_params;
  trajectory_params.scenario = options.scenario;
  trajectory_params.duration = options.duration;
  trajectory_params.seed = options.seed;
  trajectory_params.static_start = options.static_start;
  // The model must cover every true sample time, including images shifted by the delay.
  trajectory_params.margin = 5.0 + std::abs(options.camera_delay);
  trajectory_params.terrain = resolveTerrain(options.terrain, options.worldSeed());
  trajectory_params.depth_hold_z = options.depth_hold_z;
  trajectory_params.hold_plane_only = options.hold_plane_only;
  trajectory_params.start_along_lap_m = options.mission.start_along_lap_m;
  trajectory_params.reverse_lap = options.mission.reverse_lap;
  trajectory_params.altitude_offset_m = options.mission.altitude_offset_m;
  setup.trajectory = Trajectory::design(trajectory_params);
  setup.terrain = std::make_shared<const SeabedTerrain>(trajectory_params.terrain);

  // The water and the lamp of this dive. Murkier water attenuates K times more and its haze builds
  // up K times closer (the same particles scatter back), at the same saturated level; the camera's
  // exposure stays set for the clear water's reference range (a fixed survey exposure).
  const UnderwaterOptics clear_water;
  const double turbidity = options.mission.turbidity;
  setup.optics.attenuation = clear_water.attenuation * turbidity;
  setup.optics.backscatter_range = clear_water.backscatter_range / turbidity;
  setup.optics.lamp_power = options.mission.lamp_power;
  setup.texture.change_fraction = options.mission.seabed_change;
  setup.texture.change_seed = deriveSeed(options.seed, kStreamSeabedChange);

  setup.imu = ImuNoiseParams::mti630();
  setup.imu.rate_hz = options.rates.imu;
  setup.sonar = SonarParams();
  setup.sonar.rate_hz = options.rates.sonar;
  if (options.sonar_max_range) setup.sonar.max_range = *options.sonar_max_range;
  setup.magnetometer = MagnetometerParams();
  setup.magnetometer.rate_hz = options.rates.magnetometer;

  // --- The rig: calibrated once per vehicle set-up (the rig seed, by default the trajectory's).
  Rng rig(deriveSeed(options.rigSeed(), kStreamRig));
  SequenceConfig& cfg = setup.config;
  cfg.camera.model = "pinhole";
  // The focal length and the principal point's offset scale with the width: the field of view
  // across the width is the lens's at any image size.
  const double pixel_scale = options.image_width / 640.0;
  cfg.camera.width = options.image_width;
  cfg.camera.height = options.image_height;
  cfg.camera.fx = 420.0 * pixel_scale * (1.0 + rig.uniform(-0.01, 0.01));
  cfg.camera.fy = cfg.camera.fx * (1.0 + rig.uniform(-0.003, 0.003));
  cfg.camera.cx = 0.5 * (options.image_width - 1) + pixel_scale * rig.uniform(-4.0, 4.0);
  cfg.camera.cy = 0.5 * (options.image_height - 1) + pixel_scale * rig.uniform(-4.0, 4.0);
  cfg.camera.distortion = {rig.uniform(-0.08, -0.04), rig.uniform(0.0, 0.015), rig.uniform(-5e-4, 5e-4),
                           rig.uniform(-5e-4, 5e-4)};
  if (options.distortion_model == "equidistant") {
    // A fisheye behind a dome port: r = f theta_d, so 320 px at f = 290 px is 63 deg off axis
    // (after the k1..k4 series, typical magnitudes of calibrated fisheyes).
    cfg.camera.distortion_model = DistortionModel::kEquidistant;
    cfg.camera.fx = 290.0 * pixel_scale * (1.0 + rig.uniform(-0.01, 0.01));
    cfg.camera.fy = cfg.camera.fx * (1.0 + rig.uniform(-0.003, 0.003));
    cfg.camera.distortion = {rig.uniform(-0.03, -0.01), rig.uniform(0.0, 0.01), rig.uniform(-0.003, 0.0),
                             rig.uniform(0.0, 0.001)};
  }
  cfg.camera.rate_hz = options.rates.camera;
  if (options.image_format != "raw") cfg.topics.image += "/compressed";  // image_transport's name
  // Camera looking down, image "up" towards the bow: x_c = -y_b (starboard), y_c = -x_b, z_c = -z_b.
  Eigen::Matrix3d R_b_c_nominal;
  R_b_c_nominal << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  // The mounting: turned about its optical axis (in the camera frame), then tilted about the
  // body's y axis (port), the optical axis from -z_b towards +x_b (the bow) for a positive tilt.
  if (options.camera_roll_deg != 0.0) {
    R_b_c_nominal = R_b_c_nominal * Eigen::AngleAxisd(options.camera_roll_deg * kDeg, Eigen::Vector3d::UnitZ());
  }
  if (options.camera_tilt_deg != 0.0) {
    R_b_c_nominal = Eigen::AngleAxisd(-options.camera_tilt_deg * kDeg, Eigen::Vector3d::UnitY()) * R_b_c_nominal;
  }
  cfg.camera.T_b_c = makeTransform(R_b_c_nominal * smallRotation(rig, 2.0 * kDeg),
                                   jitter(rig, Eigen::Vector3d(0.25, 0.0, -0.08), Eigen::Vector3d(0.03, 0.03, 0.02)));

  if (options.camera_extrinsic_error_deg > 0.0 || options.camera_extrinsic_error_m > 0.0) {
    // Its own stream, so the error changes nothing else of the sequence.
    Rng error_rng(deriveSeed(options.seed, kStreamExtrinsicError));
    const auto unitVector = [&]() {
      Eigen::Vector3d v;
      do {
        v = Eigen::Vector3d(error_rng.gaussian(), error_rng.gaussian(), error_rng.gaussian());
      } while (v.norm() < 1e-6);
      return Eigen::Vector3d(v.normalized());
    };
    CameraExtrinsicError error;
    error.rotation_deg = options.camera_extrinsic_error_deg;
    error.translation_m = options.camera_extrinsic_error_m;
    error.true_T_b_c = cfg.camera.T_b_c;
    const Eigen::Vector3d axis = unitVector();
    const Eigen::Vector3d direction = unitVector();
    cfg.camera.T_b_c =
        makeTransform(error.true_T_b_c.linear() * Eigen::AngleAxisd(error.rotation_deg * kDeg, axis).toRotationMatrix(),
                      error.true_T_b_c.translation() + error.translation_m * direction);
    setup.truth.camera_extrinsic_error = error;
  }

  cfg.imu.rate_hz = setup.imu.rate_hz;
  cfg.imu.gyro_noise_density = setup.imu.gyro_noise_density;
  cfg.imu.gyro_random_walk = setup.imu.gyro_random_walk;
  cfg.imu.accel_noise_density = setup.imu.accel_noise_density;
  cfg.imu.accel_random_walk = setup.imu.accel_random_walk;
  cfg.imu.gravity = setup.imu.gravity;

  // Sonar beam (+z_s) pointing down: R = Rx(pi) with a small tilt.
  const Eigen::Matrix3d R_b_s_nominal = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  cfg.sonar.T_b_s = makeTransform(R_b_s_nominal * smallRotation(rig, 2.0 * kDeg),
                                  jitter(rig, Eigen::Vector3d(0.10, 0.08, -0.12), Eigen::Vector3d(0.03, 0.03, 0.02)));
  cfg.sonar.rate_hz = setup.sonar.rate_hz;
  cfg.sonar.range_noise_std = setup.sonar.range_noise_std;
  cfg.sonar.min_range = setup.sonar.min_range;
  cfg.sonar.max_range = setup.sonar.max_range;

  cfg.magnetometer.T_b_m = makeTransform(smallRotation(rig, 1.0 * kDeg), jitter(rig, Eigen::Vector3d(-0.35, 0.0, 0.05),
                                                                                Eigen::Vector3d(0.05, 0.05, 0.03)));
  cfg.magnetometer.rate_hz = setup.magnetometer.rate_hz;
  cfg.magnetometer.noise_std = setup.magnetometer.noise_std;

  // Pressure port: its own stream, so adding the sensor changes no other calibration.
  if (options.pressure.enabled) {
    Rng port_rng(deriveSeed(options.rigSeed(), kStreamPressureRig));
    setup.pressure.rate_hz = options.pressure.rate_hz;
    setup.pressure.spike_fraction = options.pressure.spike_fraction;
    PressureCalibration pressure;
    pressure.T_b_p = makeTransform(Eigen::Matrix3d::Identity(), jitter(port_rng, Eigen::Vector3d(-0.30, 0.0, 0.10),
                                                                       Eigen::Vector3d(0.03, 0.03, 0.02)));
    pressure.rate_hz = setup.pressure.rate_hz;
    pressure.noise_std_pa = setup.pressure.noise_std_pa;
    pressure.atmospheric_pa = kStandardAtmosphere + options.pressure.atmospheric_error_pa;
    pressure.water_density = options.scenario == Scenario::kTank ? 1000.0 : 1025.0;  // fresh / sea water
    cfg.pressure = pressure;
  }

  // --- The site.
  SiteModel site = makeSite(options.scenario, options.worldSeed());
  if (!setup.terrain->isFlat()) {
    site.coil.position_w.z() = setup.terrain->height(site.coil.position_w.x(), site.coil.position_w.y());
  }
  site.coil.frequency = options.coil_frequency_hz;
  // The truth file keeps the frequency; the sequence YAML may leave it for VIMS to find (null).
  cfg.magnetometer.coil_frequency_hz = options.coil_frequency_unknown ? 0.0 : site.coil.frequency;
  cfg.magnetometer.other_coil_frequencies_hz = options.other_coil_frequencies_hz;
  cfg.magnetometer.declination_deg = site.geomagnetic.declination_deg;

  // --- The truth.
  SimTruth& truth = setup.truth;
  truth.scenario = scenarioName(options.scenario);
  truth.name = options.sequenceName();
  truth.trajectory_seed = options.seed;
  truth.world_seed = options.worldSeed();
  truth.rig_seed = options.rigSeed();
  truth.start_time = options.start_time;
  truth.duration = options.duration;
  truth.static_start = options.static_start;
  truth.travel = setup.trajectory.designedTravel();
  truth.camera_time_delay = options.camera_delay;
  truth.coil = site.coil;
  Rng phase_rng(deriveSeed(options.seed, kStreamCoilPhase));
  truth.coil.phase = phase_rng.uniform(0.0, 2.0 * M_PI);  // the coil runs freely: its phase differs per dive
  truth.coil.frequency_rate = options.coil_frequency_drift_hz / options.duration;
  if (!options.other_coil_frequencies_hz.empty()) {
    // Further coils: the first one's hardware on the base lap at the spacing from it (world
    // seed), each its own free-running phase (their own stream: the first coil's is unchanged),
    // all drifting by the same number of hertz.
    const auto positions = placeOtherCoils(options.scenario, site.coil.position_w.head<2>(),
                                           static_cast<int>(options.other_coil_frequencies_hz.size()),
                                           options.coil_spacing_m, options.worldSeed());
    Rng other_phase_rng(deriveSeed(options.seed, kStreamOtherCoilPhases));
    for (size_t i = 0; i < positions.size(); ++i) {
      CoilDipole other = truth.coil;
      other.position_w = Eigen::Vector3d(positions[i].x(), positions[i].y(), 0.0);
      if (!setup.terrain->isFlat()) other.position_w.z() = setup.terrain->height(positions[i].x(), positions[i].y());
      other.frequency = options.other_coil_frequencies_hz[i];
      other.phase = other_phase_rng.uniform(0.0, 2.0 * M_PI);
      truth.other_coils.push_back(other);
    }
  }
  truth.geomagnetic = site.geomagnetic;
  if (options.thrusters.enabled) {
    ThrusterInterference th;
    th.line_frequency_hz = options.thrusters.line_hz;
    th.line_amplitude_tesla = options.thrusters.line_nt * 1e-9;
    th.hard_iron_tesla = options.thrusters.hard_iron_ut * 1e-6;
    th.broadband_std_tesla = options.thrusters.broadband_nt * 1e-9;
    // The motors' placement relative to the magnetometer belongs to the vehicle: the rig's seed.
    truth.thrusters = seededThrusterInterference(th, deriveSeed(options.rigSeed(), kStreamThrusters));
  }
  if (options.mag_hard_iron_ut > 0.0 || options.mag_soft_iron_pct > 0.0) {
    truth.magnetometer_iron = seededMagnetometerIron(options.mag_hard_iron_ut, options.mag_soft_iron_pct,
                                                     deriveSeed(options.rigSeed(), kStreamMagnetometerIron));
  }
  if (options.magnetic_anomaly_ut > 0.0) {
    // Under the vehicle's mid-mission position, so the mission crosses it; buried half its width
    // below the vehicle, so the field falls to a third of its peak about that far to the side.
    const double t_mid = options.static_start + 0.5 * (options.duration - options.static_start);
    truth.magnetic_anomaly =
        MagneticAnomaly::induced(setup.trajectory.pose(t_mid).translation(), 0.5 * options.magnetic_anomaly_width_m,
                                 options.magnetic_anomaly_ut * 1e-6, site.geomagnetic.fieldEnu());
  }
  Rng bias_rng(deriveSeed(options.seed, kStreamImuBias));
  for (int i = 0; i < 3; ++i) truth.gyro_bias[i] = bias_rng.gaussian(setup.imu.gyro_initial_bias_std);
  for (int i = 0; i < 3; ++i) truth.accel_bias[i] = bias_rng.gaussian(setup.imu.accel_initial_bias_std);
  truth.dropouts = options.spans;
  truth.terrain = setup.terrain->params();
  truth.depth_hold_z = options.depth_hold_z;
  truth.hold_plane_only = options.hold_plane_only;
  truth.mission = options.mission;
  if (cfg.pressure) {
    PressureTruth pressure;
    // Water depth above the mean seabed: about 10 m in the tank, 30 m at the field site.
    Rng water_rng(deriveSeed(options.worldSeed(), kStreamWater));
    pressure.water.surface_z =
        options.scenario == Scenario::kTank ? water_rng.uniform(9.0, 11.0) : water_rng.uniform(27.0, 33.0);
    pressure.water.atmospheric_pa = kStandardAtmosphere;
    pressure.water.density = cfg.pressure->water_density;
    pressure.water.gravity = cfg.imu.gravity;
    pressure.atmospheric_error_pa = options.pressure.atmospheric_error_pa;
    pressure.spike_fraction = setup.pressure.spike_fraction;
    pressure.spike_min_pa = setup.pressure.spike_min_pa;
    pressure.spike_max_pa = setup.pressure.spike_max_pa;
    truth.pressure = pressure;
  }
  if (!setup.terrain->isFlat() || options.depth_hold_z || cfg.pressure) checkClearances(setup);
  return setup;
}

}  // namespace sim
}  // namespace vims
