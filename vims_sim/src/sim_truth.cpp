#include "vims_sim/sim_truth.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "vims_common/config_reader.h"

namespace vims {
namespace sim {
namespace {

/// Shortest decimal that reads back as exactly the same double.
std::string num(double v) {
  char buf[64];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof(buf), "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

std::string vec(const Eigen::Vector3d& v) { return "[" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + "]"; }

/// The 16 numbers of the 4 x 4 matrix, row-major (as the sequence YAML's transforms).
std::string transform16(const Eigen::Isometry3d& T) {
  std::string out = "[";
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out += num(T.matrix()(r, c)) + (r == 3 && c == 3 ? "]" : ", ");
  return out;
}

std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char ch : text) {
    if (ch == '"' || ch == '\\') out += '\\';
    out += ch;
  }
  return out + "\"";
}

std::string spans(const std::vector<TimeSpan>& s) {
  std::string out = "[";
  for (size_t i = 0; i < s.size(); ++i) out += (i ? ", [" : "[") + num(s[i].begin) + ", " + num(s[i].end) + "]";
  return out + "]";
}

Eigen::Vector3d readVec3(const ConfigReader& reader, const std::string& key) {
  const auto v = reader.getVector(key, 3);
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

std::vector<TimeSpan> readSpans(const ConfigReader& reader, const std::string& key) {
  std::vector<TimeSpan> out;
  if (!reader.has(key)) return out;
  const YAML::Node node = reader.node()[key];
  if (!node.IsSequence()) throw reader.error(key, "expected a list of [begin, end] pairs");
  for (const auto& item : node) {
    if (!item.IsSequence() || item.size() != 2) throw reader.error(key, "expected a list of [begin, end] pairs");
    TimeSpan span;
    try {
      span.begin = item[0].as<double>();
      span.end = item[1].as<double>();
    } catch (const YAML::Exception&) {
      throw reader.error(key, "span bounds must be numbers");
    }
    if (!(span.end > span.begin)) throw reader.error(key, "span end must be greater than its begin");
    out.push_back(span);
  }
  return out;
}

std::string terrainYaml(const TerrainParams& p) {
  const SeabedTerrain terrain(p);
  std::ostringstream os;
  auto waves = [&](const char* key, const std::vector<TerrainWave>& list) {
    os << "  " << key << ":" << (list.empty() ? " []" : "") << "\n";
    for (const TerrainWave& w : list) {
      os << "    - [" << num(w.amplitude) << ", " << num(w.wavelength) << ", " << num(w.direction_deg) << ", "
         << num(w.phase) << "]\n";
    }
  };
  os << "terrain:  # seabed height h(x, y) [m] in world ENU = plane + relief + roughness + rocks (terrainFromTruth)\n"
     << "  seed: " << p.seed << "\n"
     << "  slope_deg: " << num(p.slope_deg) << "\n"
     << "  slope_azimuth_deg: " << num(p.slope_azimuth_deg) << "  # downhill direction, clockwise from north\n"
     << "  relief_m: " << num(p.relief_m) << "  # peak amplitude of the rolling relief\n"
     << "  relief_wavelength_m: " << num(p.relief_wavelength_m) << "\n"
     << "  roughness_m: " << num(p.roughness_m) << "  # rms height\n"
     << "  rock_height_m: " << num(p.rock_height_m) << "  # tallest rock; rocks are 0.5-1 x this\n"
     << "  rock_density_per_m2: " << num(p.rock_density) << "\n"
     << "  rock_cell_m: " << num(SeabedTerrain::kRockCell)
     << "  # at most one rock per cell, placed by a hash of the seed\n"
     << "  # waves derived from the seed: [amplitude_m, wavelength_m, direction_deg, phase_rad],\n"
     << "  # amplitude * sin(2 pi (sin(dir) x + cos(dir) y) / wavelength + phase), dir clockwise from north\n";
  waves("relief_waves", terrain.reliefWaves());
  waves("roughness_waves", terrain.roughnessWaves());
  return os.str();
}

/// The keys of one coil, each line indented by `indent` (the first by `first`: a list item's "- ").
std::string coilYaml(const CoilDipole& coil, const std::string& first, const std::string& indent) {
  std::ostringstream os;
  os << first << "position_enu: " << vec(coil.position_w) << "  # [m] world ENU, coil centre\n"
     << indent << "moment_enu: " << vec(coil.peakMoment()) << "  # [A m^2] peak, = turns * current_a * pi d^2 / 4\n"
     << indent << "turns: " << coil.turns << "\n"
     << indent << "current_a: " << num(coil.current) << "  # peak\n"
     << indent << "diameter_m: " << num(coil.diameter) << "\n"
     << indent << "frequency_hz: " << num(coil.frequency) << "\n"
     << indent << "phase_rad: " << num(coil.phase) << "\n";
  if (coil.frequency_rate != 0.0)
    os << indent << "frequency_rate_hz_per_s: " << num(coil.frequency_rate)
       << "  # a drifting coil: frequency_hz + rate (t - start_time), phase its integral\n";
  return os.str();
}

CoilDipole readCoil(const ConfigReader& coil) {
  coil.rejectUnknownKeys({"position_enu", "moment_enu", "turns", "current_a", "diameter_m", "frequency_hz", "phase_rad",
                          "frequency_rate_hz_per_s"});
  CoilDipole c;
  c.position_w = readVec3(coil, "position_enu");
  c.turns = coil.get<int>("turns");
  if (c.turns <= 0) throw coil.error("turns", "must be > 0");
  c.current = coil.get<double>("current_a");
  c.diameter = coil.get<double>("diameter_m");
  requirePositive(coil, "diameter_m", c.diameter);
  c.frequency = coil.get<double>("frequency_hz");
  requirePositive(coil, "frequency_hz", c.frequency);
  c.phase = coil.get<double>("phase_rad");
  if (coil.has("frequency_rate_hz_per_s")) c.frequency_rate = coil.get<double>("frequency_rate_hz_per_s");
  if ((readVec3(coil, "moment_enu") - c.peakMoment()).norm() > 1e-9 * (1.0 + c.peakMoment().norm())) {
    throw coil.error("moment_enu", "inconsistent with turns, current_a and diameter_m");
  }
  return c;
}

/// The optional list `other_coils`: each item a mapping with the keys of `coil`.
std::vector<CoilDipole> readOtherCoils(const ConfigReader& root) {
  std::vector<CoilDipole> coils;
  if (!root.has("other_coils")) return coils;
  const YAML::Node list = root.node()["other_coils"];
  if (!list.IsSequence()) throw root.error("other_coils", "expected a list of coils (mappings with the keys of coil)");
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string path = root.keyPath("other_coils") + "[" + std::to_string(i) + "]";
    if (!list[i].IsMap()) throw ConfigError(root.source() + ": " + path + ": expected a mapping with the keys of coil");
    coils.push_back(readCoil(ConfigReader(list[i], path, root.source())));
  }
  return coils;
}

TerrainParams readTerrain(const ConfigReader& root) {
  const ConfigReader t = root.child("terrain");
  t.rejectUnknownKeys({"seed", "slope_deg", "slope_azimuth_deg", "relief_m", "relief_wavelength_m", "roughness_m",
                       "rock_height_m", "rock_density_per_m2", "rock_cell_m", "relief_waves", "roughness_waves"});
  TerrainParams p;
  p.seed = t.get<uint64_t>("seed");
  p.slope_deg = t.get<double>("slope_deg");
  p.slope_azimuth_deg = t.get<double>("slope_azimuth_deg");
  p.relief_m = t.get<double>("relief_m");
  p.relief_wavelength_m = t.get<double>("relief_wavelength_m");
  p.roughness_m = t.get<double>("roughness_m");
  p.rock_height_m = t.get<double>("rock_height_m");
  p.rock_density = t.get<double>("rock_density_per_m2");
  if (t.get<double>("rock_cell_m") != SeabedTerrain::kRockCell) {
    throw t.error("rock_cell_m", "this build places rocks on a " + num(SeabedTerrain::kRockCell) + " m grid");
  }
  std::optional<SeabedTerrain> terrain;
  try {
    terrain.emplace(p);
  } catch (const std::invalid_argument& e) {
    throw t.error("seed", e.what());
  }
  // The listed waves must be the ones this build derives from the seed and the parameters.
  auto checkWaves = [&](const std::string& key, const std::vector<TerrainWave>& expected) {
    const YAML::Node node = t.node()[key];
    if (!node || !node.IsSequence()) throw t.error(key, "expected a list of [amplitude, wavelength, direction, phase]");
    bool same = node.size() == expected.size();
    for (size_t i = 0; same && i < expected.size(); ++i) {
      std::vector<double> v;
      try {
        v = node[i].as<std::vector<double>>();
      } catch (const YAML::Exception&) {
        throw t.error(key, "expected lists of 4 numbers");
      }
      const TerrainWave& w = expected[i];
      const double want[4] = {w.amplitude, w.wavelength, w.direction_deg, w.phase};
      same = v.size() == 4;
      for (int k = 0; same && k < 4; ++k) same = std::abs(v[k] - want[k]) <= 1e-12 * (1.0 + std::abs(want[k]));
    }
    if (!same) throw t.error(key, "inconsistent with the seed and the terrain parameters");
  };
  checkWaves("relief_waves", terrain->reliefWaves());
  checkWaves("roughness_waves", terrain->roughnessWaves());
  return p;
}

PressureTruth readPressure(const ConfigReader& root) {
  const ConfigReader p = root.child("pressure");
  p.rejectUnknownKeys({"surface_z", "atmospheric_pa", "water_density", "gravity", "atmospheric_error_pa",
                       "spike_fraction", "spike_min_pa", "spike_max_pa"});
  PressureTruth truth;
  truth.water.surface_z = p.get<double>("surface_z");
  truth.water.atmospheric_pa = p.get<double>("atmospheric_pa");
  requirePositive(p, "atmospheric_pa", truth.water.atmospheric_pa);
  truth.water.density = p.get<double>("water_density");
  requirePositive(p, "water_density", truth.water.density);
  truth.water.gravity = p.get<double>("gravity");
  requirePositive(p, "gravity", truth.water.gravity);
  truth.atmospheric_error_pa = p.get<double>("atmospheric_error_pa");
  truth.spike_fraction = p.get<double>("spike_fraction");
  requireInRange(p, "spike_fraction", truth.spike_fraction, 0.0, 1.0);
  truth.spike_min_pa = p.get<double>("spike_min_pa");
  truth.spike_max_pa = p.get<double>("spike_max_pa");
  return truth;
}

}  // namespace

SeabedTerrain terrainFromTruth(const SimTruth& truth) { return SeabedTerrain(truth.terrain); }

bool anySpanContains(const std::vector<TimeSpan>& spans, double t) {
  for (const auto& s : spans)
    if (s.contains(t)) return true;
  return false;
}

bool MissionConditions::isDefault() const {
  const MissionConditions none;
  return start_along_lap_m == none.start_along_lap_m && reverse_lap == none.reverse_lap &&
         altitude_offset_m == none.altitude_offset_m && turbidity == none.turbidity && lamp_power == none.lamp_power &&
         seabed_change == none.seabed_change;
}

std::string SimTruth::toYaml() const {
  std::ostringstream os;
  os << "# Simulation truth (evaluation only: the estimator never reads it).\n"
     << "# Times are seconds; 'dropouts' spans are [begin, end) from start_time.\n"
     << "generator: " << generator << "\n"
     << "scenario: " << scenario << "\n"
     << "name: " << quoted(name) << "\n"
     << "trajectory_seed: " << trajectory_seed << "\n"
     << "world_seed: " << world_seed << "\n"
     << "rig_seed: " << rig_seed << "\n"
     << "start_time: " << num(start_time) << "\n"
     << "duration: " << num(duration) << "\n"
     << "static_start: " << num(static_start) << "\n"
     << "travel_m: " << num(travel) << "\n"
     << "camera_time_delay: " << num(camera_time_delay) << "  # image stamp = exposure time + delay\n"
     << "coil:  # current I(t) = current_a * sin(2 pi frequency_hz (t - start_time) + phase_rad)\n"
     << coilYaml(coil, "  ", "  ");
  if (!other_coils.empty()) {
    os << "other_coils:  # the further coils, entries 1, 2, ... of NAME.yaml's coil_frequency_hz list (keys as coil)\n";
    for (const CoilDipole& other : other_coils) os << coilYaml(other, "  - ", "    ");
  }
  os << "geomagnetic:\n"
     << "  field_enu: " << vec(geomagnetic.fieldEnu()) << "  # [T]\n"
     << "  total_t: " << num(geomagnetic.total) << "\n"
     << "  inclination_deg: " << num(geomagnetic.inclination_deg) << "  # positive: pointing down\n"
     << "  declination_deg: " << num(geomagnetic.declination_deg) << "  # east positive\n"
     << "imu_initial_bias:\n"
     << "  gyro: " << vec(gyro_bias) << "  # [rad/s]\n"
     << "  accel: " << vec(accel_bias) << "  # [m/s^2]\n"
     << "dropouts:\n"
     << "  camera_blackout: " << spans(dropouts.camera_blackout) << "\n"
     << "  camera_off: " << spans(dropouts.camera_off) << "\n"
     << "  sonar_off: " << spans(dropouts.sonar_off) << "\n"
     << "  mag_off: " << spans(dropouts.mag_off) << "\n"
     << "  imu_gap: " << spans(dropouts.imu_gap) << "\n";
  if (pressure || !dropouts.pressure_off.empty()) os << "  pressure_off: " << spans(dropouts.pressure_off) << "\n";
  if (!terrain.isFlat()) os << terrainYaml(terrain);
  if (pressure) {
    os << "pressure:  # absolute pressure at the port = atmospheric_pa + water_density * gravity * (surface_z - z)\n"
       << "  surface_z: " << num(pressure->water.surface_z) << "  # [m] water surface height in world ENU\n"
       << "  atmospheric_pa: " << num(pressure->water.atmospheric_pa) << "  # true air pressure on the surface\n"
       << "  water_density: " << num(pressure->water.density) << "  # [kg/m^3]\n"
       << "  gravity: " << num(pressure->water.gravity) << "\n"
       << "  atmospheric_error_pa: " << num(pressure->atmospheric_error_pa)
       << "  # NAME.yaml's atmospheric_pa minus the true one\n"
       << "  spike_fraction: " << num(pressure->spike_fraction) << "  # samples carrying a spike\n"
       << "  spike_min_pa: " << num(pressure->spike_min_pa) << "  # spike magnitude U(min, max), random sign\n"
       << "  spike_max_pa: " << num(pressure->spike_max_pa) << "\n";
  }
  if (depth_hold_z) os << "depth_hold_z: " << num(*depth_hold_z) << "  # [m] the body held this world z (depth hold)\n";
  if (hold_plane_only) os << "hold_plane_only: true  # the altitude hold followed the seabed's plane, not its relief\n";
  if (!mission.isDefault()) {
    os << "mission:  # a repeat mission's conditions (vims_sim --start-along-lap-m ... --seabed-change)\n"
       << "  start_along_lap_m: " << num(mission.start_along_lap_m) << "\n"
       << "  reverse_lap: " << (mission.reverse_lap ? "true" : "false") << "\n"
       << "  altitude_offset_m: " << num(mission.altitude_offset_m) << "\n"
       << "  turbidity: " << num(mission.turbidity) << "\n"
       << "  lamp_power: " << num(mission.lamp_power) << "\n"
       << "  seabed_change: " << num(mission.seabed_change) << "\n";
  }
  if (camera_extrinsic_error) {
    os << "camera_extrinsic_error:  # NAME.yaml's T_b_c is the true one turned by rotation_deg and moved by "
          "translation_m\n"
       << "  rotation_deg: " << num(camera_extrinsic_error->rotation_deg) << "\n"
       << "  translation_m: " << num(camera_extrinsic_error->translation_m) << "\n"
       << "  true_T_b_c: " << transform16(camera_extrinsic_error->true_T_b_c) << "\n";
  }
  if (thrusters) {
    os << "thrusters:  # the vehicle's thrusters at the magnetometer (vims_sim --thrusters; thruster_interference.h)\n"
       << "  reference_speed_mps: " << num(thrusters->reference_speed_mps) << "\n"
       << "  inertia_length_m: " << num(thrusters->inertia_length_m) << "\n"
       << "  line_frequency_hz: " << num(thrusters->line_frequency_hz) << "  # thruster 0 at the reference thrust\n"
       << "  second_motor_ratio: " << num(thrusters->second_motor_ratio) << "\n"
       << "  line_amplitude_t: " << num(thrusters->line_amplitude_tesla) << "\n"
       << "  hard_iron_t: " << num(thrusters->hard_iron_tesla) << "\n"
       << "  broadband_std_t: " << num(thrusters->broadband_std_tesla) << "\n"
       << "  line_direction_0_m: " << vec(thrusters->line_direction_m[0]) << "  # unit, mag frame\n"
       << "  line_direction_1_m: " << vec(thrusters->line_direction_m[1]) << "\n"
       << "  hard_iron_direction_m: " << vec(thrusters->hard_iron_direction_m) << "\n";
  }
  if (magnetometer_iron) {
    const Eigen::Matrix3d& W = magnetometer_iron->soft_iron;
    os << "magnetometer_iron:  # the magnetometer is not calibrated: m = soft_iron h + hard_iron_t (vims_sim "
          "--mag-hard-iron-ut, --mag-soft-iron-pct)\n"
       << "  hard_iron_t: " << vec(magnetometer_iron->hard_iron_t) << "  # [T] mag frame\n"
       << "  soft_iron: [";
    for (int i = 0; i < 9; ++i) os << (i ? ", " : "") << num(W(i / 3, i % 3));
    os << "]  # 3x3 row-major\n";
  }
  if (magnetic_anomaly) {
    os << "magnetic_anomaly:  # a point dipole buried in the seabed; its static field adds to the geomagnetic one\n"
       << "  position_enu: " << vec(magnetic_anomaly->position_w) << "  # [m] world ENU\n"
       << "  moment_enu: " << vec(magnetic_anomaly->moment_enu) << "  # [A m^2]\n";
  }
  return os.str();
}

void SimTruth::save(const std::string& path) const {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write simulation truth '" + path + "'");
  out << toYaml();
  if (!out) throw std::runtime_error("failed while writing '" + path + "'");
}

SimTruth SimTruth::load(const std::string& path) {
  const ConfigReader root = ConfigReader::fromFile(path);
  root.rejectUnknownKeys({"generator",        "scenario",          "name",
                          "trajectory_seed",  "world_seed",        "rig_seed",
                          "start_time",       "duration",          "static_start",
                          "travel_m",         "camera_time_delay", "coil",
                          "other_coils",      "geomagnetic",       "imu_initial_bias",
                          "dropouts",         "terrain",           "pressure",
                          "depth_hold_z",     "hold_plane_only",   "camera_extrinsic_error",
                          "magnetic_anomaly", "thrusters",         "magnetometer_iron",
                          "mission"});
  SimTruth t;
  t.generator = root.get<std::string>("generator");
  t.scenario = root.get<std::string>("scenario");
  if (t.scenario != "tank" && t.scenario != "field") throw root.error("scenario", "expected 'tank' or 'field'");
  t.name = root.get<std::string>("name");
  t.trajectory_seed = root.get<uint64_t>("trajectory_seed");
  t.world_seed = root.get<uint64_t>("world_seed");
  t.rig_seed = root.has("rig_seed") ? root.get<uint64_t>("rig_seed") : t.trajectory_seed;
  t.start_time = root.get<double>("start_time");
  t.duration = root.get<double>("duration");
  requirePositive(root, "duration", t.duration);
  t.static_start = root.get<double>("static_start");
  requireNonNegative(root, "static_start", t.static_start);
  t.travel = root.get<double>("travel_m");
  t.camera_time_delay = root.get<double>("camera_time_delay");

  t.coil = readCoil(root.child("coil"));
  t.other_coils = readOtherCoils(root);  // absent: one coil (older files)

  const ConfigReader geo = root.child("geomagnetic");
  geo.rejectUnknownKeys({"field_enu", "total_t", "inclination_deg", "declination_deg"});
  t.geomagnetic.total = geo.get<double>("total_t");
  requirePositive(geo, "total_t", t.geomagnetic.total);
  t.geomagnetic.inclination_deg = geo.get<double>("inclination_deg");
  requireInRange(geo, "inclination_deg", t.geomagnetic.inclination_deg, -90.0, 90.0);
  t.geomagnetic.declination_deg = geo.get<double>("declination_deg");
  requireInRange(geo, "declination_deg", t.geomagnetic.declination_deg, -180.0, 180.0);
  if ((readVec3(geo, "field_enu") - t.geomagnetic.fieldEnu()).norm() > 1e-12) {
    throw geo.error("field_enu", "inconsistent with total_t, inclination_deg and declination_deg");
  }

  const ConfigReader bias = root.child("imu_initial_bias");
  bias.rejectUnknownKeys({"gyro", "accel"});
  t.gyro_bias = readVec3(bias, "gyro");
  t.accel_bias = readVec3(bias, "accel");

  const ConfigReader drops = root.child("dropouts");
  drops.rejectUnknownKeys({"camera_blackout", "camera_off", "sonar_off", "mag_off", "imu_gap", "pressure_off"});
  t.dropouts.camera_blackout = readSpans(drops, "camera_blackout");
  t.dropouts.camera_off = readSpans(drops, "camera_off");
  t.dropouts.sonar_off = readSpans(drops, "sonar_off");
  t.dropouts.mag_off = readSpans(drops, "mag_off");
  t.dropouts.imu_gap = readSpans(drops, "imu_gap");
  t.dropouts.pressure_off = readSpans(drops, "pressure_off");

  if (root.has("terrain")) t.terrain = readTerrain(root);  // absent: the flat seabed of older files
  if (root.has("pressure")) t.pressure = readPressure(root);
  if (root.has("depth_hold_z")) t.depth_hold_z = root.get<double>("depth_hold_z");
  if (root.has("hold_plane_only")) t.hold_plane_only = root.get<bool>("hold_plane_only");
  if (root.has("mission")) {
    const ConfigReader m = root.child("mission");
    m.rejectUnknownKeys(
        {"start_along_lap_m", "reverse_lap", "altitude_offset_m", "turbidity", "lamp_power", "seabed_change"});
    t.mission.start_along_lap_m = m.get<double>("start_along_lap_m");
    t.mission.reverse_lap = m.get<bool>("reverse_lap");
    t.mission.altitude_offset_m = m.get<double>("altitude_offset_m");
    t.mission.turbidity = m.get<double>("turbidity");
    t.mission.lamp_power = m.get<double>("lamp_power");
    t.mission.seabed_change = m.get<double>("seabed_change");
  }
  if (root.has("camera_extrinsic_error")) {
    const ConfigReader e = root.child("camera_extrinsic_error");
    e.rejectUnknownKeys({"rotation_deg", "translation_m", "true_T_b_c"});
    CameraExtrinsicError error;
    error.rotation_deg = e.get<double>("rotation_deg");
    error.translation_m = e.get<double>("translation_m");
    error.true_T_b_c = e.getTransform("true_T_b_c");
    t.camera_extrinsic_error = error;
  }
  if (root.has("thrusters")) {
    const ConfigReader r = root.child("thrusters");
    r.rejectUnknownKeys({"reference_speed_mps", "inertia_length_m", "line_frequency_hz", "second_motor_ratio",
                         "line_amplitude_t", "hard_iron_t", "broadband_std_t", "line_direction_0_m",
                         "line_direction_1_m", "hard_iron_direction_m"});
    ThrusterInterference th;
    th.reference_speed_mps = r.get<double>("reference_speed_mps");
    requirePositive(r, "reference_speed_mps", th.reference_speed_mps);
    th.inertia_length_m = r.get<double>("inertia_length_m");
    th.line_frequency_hz = r.get<double>("line_frequency_hz");
    th.second_motor_ratio = r.get<double>("second_motor_ratio");
    th.line_amplitude_tesla = r.get<double>("line_amplitude_t");
    th.hard_iron_tesla = r.get<double>("hard_iron_t");
    th.broadband_std_tesla = r.get<double>("broadband_std_t");
    th.line_direction_m[0] = readVec3(r, "line_direction_0_m");
    th.line_direction_m[1] = readVec3(r, "line_direction_1_m");
    th.hard_iron_direction_m = readVec3(r, "hard_iron_direction_m");
    t.thrusters = th;
  }
  if (root.has("magnetometer_iron")) {
    const ConfigReader r = root.child("magnetometer_iron");
    r.rejectUnknownKeys({"hard_iron_t", "soft_iron"});
    MagnetometerIron iron;
    iron.hard_iron_t = readVec3(r, "hard_iron_t");
    const std::vector<double> w = r.getVector("soft_iron", 9);
    for (int i = 0; i < 9; ++i) iron.soft_iron(i / 3, i % 3) = w[static_cast<size_t>(i)];
    t.magnetometer_iron = iron;
  }
  if (root.has("magnetic_anomaly")) {
    const ConfigReader a = root.child("magnetic_anomaly");
    a.rejectUnknownKeys({"position_enu", "moment_enu"});
    t.magnetic_anomaly = MagneticAnomaly{readVec3(a, "position_enu"), readVec3(a, "moment_enu")};
  }
  return t;
}

}  // namespace sim
}  // namespace vims
