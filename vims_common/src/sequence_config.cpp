#include "vims_common/sequence_config.h"

#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace vims {

const char* distortionModelName(DistortionModel model) {
  switch (model) {
    case DistortionModel::kRadtan:
      return "radtan";
    case DistortionModel::kEquidistant:
      return "equidistant";
  }
  return "?";
}
namespace {

void collectUnknown(const ConfigReader& reader, const std::set<std::string>& allowed,
                    std::vector<std::string>* unknown_keys) {
  if (!unknown_keys) return;
  for (auto& k : reader.unknownKeys(allowed)) unknown_keys->push_back(k);
}

/// magnetometer.coil_frequency_hz (contract v2): a number, a list (several coils), or null / no
/// key (an empty list: the front end finds the frequency from the data).
std::vector<double> readCoilFrequencies(const ConfigReader& mag, double rate_hz) {
  const std::string key = "coil_frequency_hz";
  if (!mag.has(key)) return {};
  const std::vector<double> list =
      mag.node()[key].IsSequence() ? mag.getVector(key) : std::vector<double>{mag.get<double>(key)};
  if (list.empty()) throw mag.error(key, "an empty list: give the frequencies, or null to find one from the data");
  for (const double f : list) {
    requirePositive(mag, key, f);
    if (f >= 0.5 * rate_hz) throw mag.error(key, "must be below the Nyquist frequency (rate_hz / 2)");
  }
  return list;
}

std::string transformToYaml(const Eigen::Isometry3d& T) {
  std::ostringstream os;
  os << std::setprecision(12) << "[";
  const Eigen::Matrix4d m = T.matrix();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) os << m(r, c) << (r == 3 && c == 3 ? "" : ", ");
  os << "]";
  return os.str();
}

}  // namespace

SequenceConfig SequenceConfig::load(const std::string& path, std::vector<std::string>* unknown_keys) {
  return fromReader(ConfigReader::fromFile(path), unknown_keys);
}

SequenceConfig SequenceConfig::fromReader(const ConfigReader& root, std::vector<std::string>* unknown_keys) {
  SequenceConfig cfg;
  collectUnknown(root, {"topics", "camera", "imu", "sonar", "magnetometer", "pressure"}, unknown_keys);

  const ConfigReader topics = root.childOrEmpty("topics");
  collectUnknown(topics, {"image", "imu", "sonar", "mag", "pressure"}, unknown_keys);
  cfg.topics.image = topics.get<std::string>("image", cfg.topics.image);
  cfg.topics.imu = topics.get<std::string>("imu", cfg.topics.imu);
  cfg.topics.sonar = topics.get<std::string>("sonar", cfg.topics.sonar);
  cfg.topics.mag = topics.get<std::string>("mag", cfg.topics.mag);
  cfg.topics.pressure = topics.get<std::string>("pressure", cfg.topics.pressure);

  const ConfigReader cam = root.child("camera");
  collectUnknown(cam, {"model", "width", "height", "intrinsics", "distortion_model", "distortion", "T_b_c", "rate_hz"},
                 unknown_keys);
  cfg.camera.model = cam.get<std::string>("model");
  if (cfg.camera.model != "pinhole")
    throw cam.error(
        "model", "only 'pinhole' (with radtan or equidistant distortion) is supported, got '" + cfg.camera.model + "'");
  const std::string distortion_model = cam.get<std::string>("distortion_model", "radtan");
  if (distortion_model == "radtan") {
    cfg.camera.distortion_model = DistortionModel::kRadtan;
  } else if (distortion_model == "equidistant") {
    cfg.camera.distortion_model = DistortionModel::kEquidistant;
  } else {
    throw cam.error("distortion_model", "expected radtan or equidistant, got '" + distortion_model + "'");
  }
  cfg.camera.width = cam.get<int>("width");
  cfg.camera.height = cam.get<int>("height");
  if (cfg.camera.width <= 0) throw cam.error("width", "must be a positive number of pixels");
  if (cfg.camera.height <= 0) throw cam.error("height", "must be a positive number of pixels");
  const auto intr = cam.getVector("intrinsics", 4);
  cfg.camera.fx = intr[0];
  cfg.camera.fy = intr[1];
  cfg.camera.cx = intr[2];
  cfg.camera.cy = intr[3];
  if (cfg.camera.fx <= 0 || cfg.camera.fy <= 0) throw cam.error("intrinsics", "focal lengths fx, fy must be > 0");
  const auto dist = cam.getVector("distortion", 4);
  for (int i = 0; i < 4; ++i) cfg.camera.distortion[i] = dist[i];
  cfg.camera.T_b_c = cam.getTransform("T_b_c");
  cfg.camera.rate_hz = cam.get<double>("rate_hz");
  requirePositive(cam, "rate_hz", cfg.camera.rate_hz);

  const ConfigReader imu = root.child("imu");
  collectUnknown(
      imu, {"rate_hz", "gyro_noise_density", "gyro_random_walk", "accel_noise_density", "accel_random_walk", "gravity"},
      unknown_keys);
  cfg.imu.rate_hz = imu.get<double>("rate_hz");
  requirePositive(imu, "rate_hz", cfg.imu.rate_hz);
  cfg.imu.gyro_noise_density = imu.get<double>("gyro_noise_density");
  cfg.imu.gyro_random_walk = imu.get<double>("gyro_random_walk");
  cfg.imu.accel_noise_density = imu.get<double>("accel_noise_density");
  cfg.imu.accel_random_walk = imu.get<double>("accel_random_walk");
  requireNonNegative(imu, "gyro_noise_density", cfg.imu.gyro_noise_density);
  requireNonNegative(imu, "gyro_random_walk", cfg.imu.gyro_random_walk);
  requireNonNegative(imu, "accel_noise_density", cfg.imu.accel_noise_density);
  requireNonNegative(imu, "accel_random_walk", cfg.imu.accel_random_walk);
  cfg.imu.gravity = imu.get<double>("gravity", cfg.imu.gravity);
  requireInRange(imu, "gravity", cfg.imu.gravity, 9.7, 9.9);

  const ConfigReader sonar = root.child("sonar");
  collectUnknown(sonar, {"T_b_s", "rate_hz", "range_noise_std", "min_range", "max_range"}, unknown_keys);
  cfg.sonar.T_b_s = sonar.getTransform("T_b_s");
  cfg.sonar.rate_hz = sonar.get<double>("rate_hz");
  requirePositive(sonar, "rate_hz", cfg.sonar.rate_hz);
  cfg.sonar.range_noise_std = sonar.get<double>("range_noise_std");
  requireNonNegative(sonar, "range_noise_std", cfg.sonar.range_noise_std);
  cfg.sonar.min_range = sonar.get<double>("min_range");
  cfg.sonar.max_range = sonar.get<double>("max_range");
  requireNonNegative(sonar, "min_range", cfg.sonar.min_range);
  if (!(cfg.sonar.max_range > cfg.sonar.min_range)) throw sonar.error("max_range", "must be greater than min_range");

  const ConfigReader mag = root.child("magnetometer");
  collectUnknown(mag, {"T_b_m", "rate_hz", "noise_std", "coil_frequency_hz", "declination_deg"}, unknown_keys);
  cfg.magnetometer.T_b_m = mag.getTransform("T_b_m");
  cfg.magnetometer.rate_hz = mag.get<double>("rate_hz");
  requirePositive(mag, "rate_hz", cfg.magnetometer.rate_hz);
  cfg.magnetometer.noise_std = mag.get<double>("noise_std");
  requireNonNegative(mag, "noise_std", cfg.magnetometer.noise_std);
  const std::vector<double> coils = readCoilFrequencies(mag, cfg.magnetometer.rate_hz);
  cfg.magnetometer.coil_frequency_hz = coils.empty() ? 0.0 : coils.front();
  if (coils.size() > 1) cfg.magnetometer.other_coil_frequencies_hz.assign(coils.begin() + 1, coils.end());
  cfg.magnetometer.declination_deg = mag.get<double>("declination_deg", 0.0);
  requireInRange(mag, "declination_deg", cfg.magnetometer.declination_deg, -180.0, 180.0);

  if (root.has("pressure")) {
    const ConfigReader pressure = root.child("pressure");
    collectUnknown(pressure, {"T_b_p", "rate_hz", "noise_std_pa", "atmospheric_pa", "water_density"}, unknown_keys);
    PressureCalibration p;
    p.T_b_p = pressure.getTransform("T_b_p");
    p.rate_hz = pressure.get<double>("rate_hz");
    requirePositive(pressure, "rate_hz", p.rate_hz);
    p.noise_std_pa = pressure.get<double>("noise_std_pa", p.noise_std_pa);
    requireNonNegative(pressure, "noise_std_pa", p.noise_std_pa);
    // Sea level is 101.3 kPa; a wrong unit (hPa, bar) is far outside this range.
    p.atmospheric_pa = pressure.get<double>("atmospheric_pa", p.atmospheric_pa);
    requireInRange(pressure, "atmospheric_pa", p.atmospheric_pa, 5.0e4, 1.5e5);
    // Fresh water 998, sea water 1020-1030 kg/m^3.
    p.water_density = pressure.get<double>("water_density", p.water_density);
    requireInRange(pressure, "water_density", p.water_density, 990.0, 1050.0);
    cfg.pressure = p;
  }
  return cfg;
}

double PressureCalibration::depthOf(double pressure_pa, double gravity) const {
  return (pressure_pa - atmospheric_pa) / (water_density * gravity);
}

double PressureCalibration::depthStd(double gravity) const { return noise_std_pa / (water_density * gravity); }

std::string SequenceConfig::toYaml() const {
  std::ostringstream os;
  os << std::setprecision(12);
  os << "# Sensor configuration (VIMS sensor data contract).\n";
  os << "topics: {image: " << topics.image << ", imu: " << topics.imu << ", sonar: " << topics.sonar
     << ", mag: " << topics.mag;
  if (pressure) os << ", pressure: " << topics.pressure;
  os << "}\n";
  os << "camera:\n"
     << "  model: " << camera.model << "\n"
     << "  width: " << camera.width << "\n"
     << "  height: " << camera.height << "\n"
     << "  intrinsics: [" << camera.fx << ", " << camera.fy << ", " << camera.cx << ", " << camera.cy << "]\n";
  // Version 1 files have no distortion_model: radtan is written as before.
  if (camera.distortion_model != DistortionModel::kRadtan) {
    os << "  distortion_model: " << distortionModelName(camera.distortion_model) << "\n";
  }
  os << "  distortion: [" << camera.distortion[0] << ", " << camera.distortion[1] << ", " << camera.distortion[2]
     << ", " << camera.distortion[3] << "]\n"
     << "  T_b_c: " << transformToYaml(camera.T_b_c) << "\n"
     << "  rate_hz: " << camera.rate_hz << "\n";
  os << "imu:\n"
     << "  rate_hz: " << imu.rate_hz << "\n"
     << "  gyro_noise_density: " << imu.gyro_noise_density << "\n"
     << "  gyro_random_walk: " << imu.gyro_random_walk << "\n"
     << "  accel_noise_density: " << imu.accel_noise_density << "\n"
     << "  accel_random_walk: " << imu.accel_random_walk << "\n"
     << "  gravity: " << imu.gravity << "\n";
  os << "sonar:\n"
     << "  T_b_s: " << transformToYaml(sonar.T_b_s) << "\n"
     << "  rate_hz: " << sonar.rate_hz << "\n"
     << "  range_noise_std: " << sonar.range_noise_std << "\n"
     << "  min_range: " << sonar.min_range << "\n"
     << "  max_range: " << sonar.max_range << "\n";
  os << "magnetometer:\n"
     << "  T_b_m: " << transformToYaml(magnetometer.T_b_m) << "\n"
     << "  rate_hz: " << magnetometer.rate_hz << "\n"
     << "  noise_std: " << magnetometer.noise_std << "\n"
     << "  coil_frequency_hz: ";
  if (!magnetometer.other_coil_frequencies_hz.empty()) {
    os << "[" << magnetometer.coil_frequency_hz;
    for (const double f : magnetometer.other_coil_frequencies_hz) os << ", " << f;
    os << "]\n";
  } else if (magnetometer.coilFrequencyKnown()) {
    os << magnetometer.coil_frequency_hz << "\n";
  } else {
    os << "null  # found from the data\n";
  }
  os << "  declination_deg: " << magnetometer.declination_deg << "\n";
  if (pressure) {
    os << "pressure:\n"
       << "  T_b_p: " << transformToYaml(pressure->T_b_p) << "\n"
       << "  rate_hz: " << pressure->rate_hz << "\n"
       << "  noise_std_pa: " << pressure->noise_std_pa << "\n"
       << "  atmospheric_pa: " << pressure->atmospheric_pa << "\n"
       << "  water_density: " << pressure->water_density << "\n";
  }
  return os.str();
}

void SequenceConfig::save(const std::string& path) const {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write sequence configuration '" + path + "'");
  out << toYaml();
  if (!out) throw std::runtime_error("failed while writing '" + path + "'");
}

}  // namespace vims
