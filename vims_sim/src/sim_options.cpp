#include "vims_sim/sim_options.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "vims_sim/rig_file.h"

namespace vims {
namespace sim {
namespace {

/// At most this many coils (--coil-frequencies).
constexpr int kMaxCoils = 8;
/// [Hz] Two coils' lines separate in the signature's 2 s Hann window (bins of 0.5 Hz) this far apart.
constexpr double kMinCoilSeparationHz = 1.0;

std::invalid_argument argError(const std::string& flag, const std::string& message) {
  return std::invalid_argument(flag + ": " + message);
}

double parseDouble(const std::string& flag, const std::string& text) {
  if (text.empty()) throw argError(flag, "expected a number, got an empty value");
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text.c_str(), &end);
  if (errno != 0 || end != text.c_str() + text.size() || !std::isfinite(value)) {
    throw argError(flag, "expected a number, got '" + text + "'");
  }
  return value;
}

uint64_t parseSeed(const std::string& flag, const std::string& text) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) {
    throw argError(flag, "expected a non-negative integer, got '" + text + "'");
  }
  errno = 0;
  char* end = nullptr;
  const unsigned long long value = std::strtoull(text.c_str(), &end, 10);
  if (errno != 0) throw argError(flag, "value '" + text + "' is too large");
  return static_cast<uint64_t>(value);
}

TimeSpan parseSpan(const std::string& flag, const std::string& text) {
  const auto colon = text.find(':');
  if (colon == std::string::npos) {
    throw argError(flag, "expected A:B (seconds from the sequence start), got '" + text + "'");
  }
  TimeSpan span;
  span.begin = parseDouble(flag, text.substr(0, colon));
  span.end = parseDouble(flag, text.substr(colon + 1));
  if (span.begin < 0.0) throw argError(flag, "span start must be >= 0, got '" + text + "'");
  if (!(span.end > span.begin)) throw argError(flag, "span end must be greater than its start, got '" + text + "'");
  return span;
}

void requireInRange(const std::string& flag, const std::optional<double>& value, double lo, double hi,
                    const std::string& unit) {
  if (value && !(*value >= lo && *value <= hi)) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "must be in [%g, %g]%s%s, got %g", lo, hi, unit.empty() ? "" : " ", unit.c_str(),
                  *value);
    throw argError(flag, buf);
  }
}

}  // namespace

const std::vector<std::string>& terrainPresetNames() {
  static const std::vector<std::string> names = {"flat", "slope4", "rough", "hills"};
  return names;
}

TerrainParams terrainPreset(const std::string& name) {
  TerrainParams p;
  if (name == "flat") return p;
  if (name == "slope4") {
    // A gently sloping sandy seabed: 4 deg, long swells, a little roughness.
    p.slope_deg = 4.0;
    p.relief_m = 0.25;
    p.relief_wavelength_m = 30.0;
    p.roughness_m = 0.02;
  } else if (name == "rough") {
    // Rugged ground: a 2 deg slope, swells, 10 cm of roughness and rocks of 0.15-0.3 m.
    p.slope_deg = 2.0;
    p.relief_m = 0.25;
    p.relief_wavelength_m = 30.0;
    p.roughness_m = 0.1;
    p.rock_height_m = 0.3;
    p.rock_density = 0.05;
  } else if (name == "hills") {
    // Rolling hills of +-1 m over 40 m with a few rocks.
    p.slope_deg = 1.0;
    p.relief_m = 1.0;
    p.relief_wavelength_m = 40.0;
    p.roughness_m = 0.03;
    p.rock_height_m = 0.2;
    p.rock_density = 0.01;
  } else {
    throw std::invalid_argument("unknown terrain preset '" + name + "'");
  }
  return p;
}

TerrainParams terrainFromOptions(const TerrainOptions& options) {
  TerrainParams p = terrainPreset(options.preset);
  p.slope_deg = options.slope_deg.value_or(p.slope_deg);
  p.slope_azimuth_deg = options.slope_azimuth_deg.value_or(p.slope_azimuth_deg);
  p.relief_m = options.relief_m.value_or(p.relief_m);
  p.relief_wavelength_m = options.relief_wavelength_m.value_or(p.relief_wavelength_m);
  p.roughness_m = options.roughness_m.value_or(p.roughness_m);
  p.rock_height_m = options.rock_height_m.value_or(p.rock_height_m);
  p.rock_density = options.rock_density.value_or(p.rock_density);
  return p;
}

std::string SimOptions::sequenceName() const {
  if (!name.empty()) return name;
  // "runs/dive_07/", "runs/dive_07" and "." (inside dive_07) all name the sequence dive_07.
  std::filesystem::path dir = std::filesystem::absolute(std::filesystem::path(out_dir)).lexically_normal();
  if (!dir.has_filename()) dir = dir.parent_path();
  return dir.filename().string();
}

namespace {

/// The checks of what a rig file may set (rig_file.h), also run on the file alone.
void validateRig(const SimOptions& options) {
  if (options.image_width < 160 || options.image_width > 2048)
    throw argError("--image-width", "must be in [160, 2048] px, got " + std::to_string(options.image_width));
  if (options.image_height < 120 || options.image_height > 2048)
    throw argError("--image-height", "must be in [120, 2048] px, got " + std::to_string(options.image_height));
  requireInRange("--camera-tilt-deg", options.camera_tilt_deg, -45.0, 45.0, "deg");
  requireInRange("--camera-roll-deg", options.camera_roll_deg, -180.0, 180.0, "deg");
  requireInRange("--camera-rate-hz", options.rates.camera, 5.0, 30.0, "Hz");
  requireInRange("--imu-rate-hz", options.rates.imu, 100.0, 1000.0, "Hz");
  requireInRange("--sonar-rate-hz", options.rates.sonar, 1.0, 20.0, "Hz");
  requireInRange("--mag-rate-hz", options.rates.magnetometer, 200.0, 2000.0, "Hz");
}

int parseInteger(const std::string& flag, const std::string& text) {
  const double value = parseDouble(flag, text);
  if (value != std::floor(value) || std::abs(value) > 1.0e6)
    throw argError(flag, "expected an integer, got '" + text + "'");
  return static_cast<int>(value);
}

}  // namespace

void SimOptions::validate() const {
  if (!(duration > 0.0)) throw argError("--duration", "must be > 0 seconds");
  if (duration > 1.0e5) throw argError("--duration", "must be at most 100000 seconds");
  if (out_dir.empty()) throw argError("--out", "an output directory is required");
  const std::string seq = sequenceName();
  if (seq.empty() || seq == "." || seq == ".." || seq.find('/') != std::string::npos) {
    throw argError(name.empty() ? "--out" : "--name", "cannot derive a valid sequence name ('" + seq + "')");
  }
  if (static_start < 0.0 || static_start >= duration) throw argError("--static-start", "must be in [0, duration)");
  if (std::abs(camera_delay) > 0.5) throw argError("--camera-delay", "must be within [-0.5, 0.5] seconds");
  if (!(camera_extrinsic_error_deg >= 0.0 && camera_extrinsic_error_deg <= 10.0))
    throw argError("--camera-extrinsic-error-deg", "must be within [0, 10] degrees");
  if (!(camera_extrinsic_error_m >= 0.0 && camera_extrinsic_error_m <= 0.2))
    throw argError("--camera-extrinsic-error-m", "must be within [0, 0.2] m");
  if (start_time < 1.0 || start_time + duration + 10.0 > 4.0e9) {
    throw argError("--start-time", "must be a positive bag-clock time that keeps all stamps below 4e9 s");
  }
  if (render_threads < 0 || render_threads > 64) throw argError("--threads", "must be in [0, 64] (0 = automatic)");

  const auto& presets = terrainPresetNames();
  if (std::find(presets.begin(), presets.end(), terrain.preset) == presets.end()) {
    throw argError("--terrain", "expected flat, slope4, rough or hills, got '" + terrain.preset + "'");
  }
  requireInRange("--terrain-slope-deg", terrain.slope_deg, 0.0, 15.0, "deg");
  requireInRange("--terrain-slope-azimuth-deg", terrain.slope_azimuth_deg, 0.0, 360.0, "deg");
  requireInRange("--terrain-relief-m", terrain.relief_m, 0.0, 2.0, "m");
  requireInRange("--terrain-relief-wavelength-m", terrain.relief_wavelength_m, 5.0, 200.0, "m");
  requireInRange("--terrain-roughness-m", terrain.roughness_m, 0.0, 0.2, "m");
  requireInRange("--terrain-rock-height-m", terrain.rock_height_m, 0.0, 0.4, "m");
  requireInRange("--terrain-rock-density", terrain.rock_density, 0.0, 0.1, "per m^2");
  requireInRange("--depth-hold", depth_hold_z, 1.0, 100.0, "m");
  if (!std::isfinite(mission.start_along_lap_m) || mission.start_along_lap_m < 0.0)
    throw argError("--start-along-lap-m", "must be >= 0 m");
  requireInRange("--altitude-offset-m", mission.altitude_offset_m, -1.0, 3.0, "m");
  if (depth_hold_z && mission.altitude_offset_m != 0.0)
    throw argError("--altitude-offset-m", "conflicts with --depth-hold (it offsets the altitude hold)");
  requireInRange("--turbidity", mission.turbidity, 1.0, 8.0, "(x the clear water's)");
  requireInRange("--lamp-power", mission.lamp_power, 0.1, 3.0, "(x the default lamp's)");
  requireInRange("--seabed-change", mission.seabed_change, 0.0, 0.6, "(fraction of the area)");
  requireInRange("--sonar-max-range", sonar_max_range, 1.0, 100.0, "m");
  validateRig(*this);
  if (!other_coil_frequencies_hz.empty()) {
    // Several coils: every frequency as --coil-frequency's, pairwise 1 Hz apart (two bins of the
    // signature's 2 s window, so the lines separate), the same drift for all (it keeps them apart).
    const char* flag = "--coil-frequencies";
    if (coil_frequency_unknown) {
      throw argError(flag,
                     "conflicts with --coil-frequency-unknown (a sequence of several coils states their "
                     "frequencies)");
    }
    if (1 + other_coil_frequencies_hz.size() > static_cast<size_t>(kMaxCoils)) {
      throw argError(flag, "at most " + std::to_string(kMaxCoils) + " coils");
    }
    std::vector<double> all{coil_frequency_hz};
    all.insert(all.end(), other_coil_frequencies_hz.begin(), other_coil_frequencies_hz.end());
    char buf[200];
    for (size_t i = 0; i < all.size(); ++i) {
      requireInRange(flag, all[i], 2.0, 200.0, "Hz");
      if (all[i] >= 0.45 * rates.magnetometer) {
        std::snprintf(buf, sizeof(buf), "%g Hz must be below 0.45 x the magnetometer's rate (--mag-rate-hz)", all[i]);
        throw argError(flag, buf);
      }
      if (all[i] + coil_frequency_drift_hz < 2.0 || all[i] + coil_frequency_drift_hz >= 0.45 * rates.magnetometer) {
        std::snprintf(buf, sizeof(buf),
                      "takes the %g Hz coil's frequency out of [2 Hz, 0.45 x the magnetometer's rate)", all[i]);
        throw argError("--coil-frequency-drift-hz", buf);
      }
      for (size_t j = 0; j < i; ++j) {
        if (std::abs(all[i] - all[j]) < kMinCoilSeparationHz) {
          std::snprintf(buf, sizeof(buf),
                        "%g Hz and %g Hz are closer than %g Hz (their lines would not separate in a 2 s window)",
                        all[j], all[i], kMinCoilSeparationHz);
          throw argError(flag, buf);
        }
      }
    }
  } else if (coil_spacing_m != SimOptions().coil_spacing_m) {
    throw argError("--coil-spacing", "needs --coil-frequencies (one coil)");
  }
  requireInRange("--coil-spacing", coil_spacing_m, 1.0, 100.0, "m");
  requireInRange("--coil-frequency", coil_frequency_hz, 2.0, 200.0, "Hz");
  if (coil_frequency_hz >= 0.45 * rates.magnetometer) {
    throw argError("--coil-frequency", "must be below 0.45 x the magnetometer's rate (--mag-rate-hz)");
  }
  requireInRange("--coil-frequency-drift-hz", coil_frequency_drift_hz, -2.0, 2.0, "Hz");
  if (coil_frequency_hz + coil_frequency_drift_hz < 2.0 ||
      coil_frequency_hz + coil_frequency_drift_hz >= 0.45 * rates.magnetometer)
    throw argError("--coil-frequency-drift-hz",
                   "takes the coil's frequency out of [2 Hz, 0.45 x the magnetometer's rate)");
  requireInRange("--thruster-line-hz", thrusters.line_hz, 1.0, 500.0, "Hz");
  requireInRange("--thruster-line-nt", thrusters.line_nt, 0.0, 10000.0, "nT");
  requireInRange("--thruster-hard-iron-ut", thrusters.hard_iron_ut, 0.0, 50.0, "uT");
  requireInRange("--thruster-broadband-nt", thrusters.broadband_nt, 0.0, 1000.0, "nT");
  if (!thrusters.enabled) {
    const Thrusters defaults;
    const char* flag = thrusters.line_hz != defaults.line_hz             ? "--thruster-line-hz"
                       : thrusters.line_nt != defaults.line_nt           ? "--thruster-line-nt"
                       : thrusters.hard_iron_ut != defaults.hard_iron_ut ? "--thruster-hard-iron-ut"
                       : thrusters.broadband_nt != defaults.broadband_nt ? "--thruster-broadband-nt"
                                                                         : nullptr;
    if (flag) throw argError(flag, "needs --thrusters");
  }
  requireInRange("--magnetic-anomaly-ut", magnetic_anomaly_ut, 0.0, 50.0, "uT");
  requireInRange("--magnetic-anomaly-width-m", magnetic_anomaly_width_m, 2.0, 50.0, "m");
  requireInRange("--mag-hard-iron-ut", mag_hard_iron_ut, 0.0, 50.0, "uT");
  requireInRange("--mag-soft-iron-pct", mag_soft_iron_pct, 0.0, 20.0, "%");

  requireInRange("--pressure-rate-hz", pressure.rate_hz, 1.0, 50.0, "Hz");
  requireInRange("--pressure-atmospheric-error-pa", pressure.atmospheric_error_pa, -2.0e4, 2.0e4, "Pa");
  requireInRange("--pressure-spikes", pressure.spike_fraction, 0.0, 0.5, "");
  if (!pressure.enabled) {
    const char* flag = pressure.rate_hz != 10.0               ? "--pressure-rate-hz"
                       : pressure.atmospheric_error_pa != 0.0 ? "--pressure-atmospheric-error-pa"
                       : pressure.spike_fraction != 0.0       ? "--pressure-spikes"
                       : !spans.pressure_off.empty()          ? "--pressure-off"
                                                              : nullptr;
    if (flag) throw argError(flag, "needs --pressure (the pressure sensor is off)");
  }
}

namespace {

/// "F1,F2,...": two or more numbers.
std::vector<double> parseFrequencyList(const std::string& flag, const std::string& text) {
  std::vector<double> list;
  size_t begin = 0;
  while (true) {
    const size_t comma = text.find(',', begin);
    list.push_back(
        parseDouble(flag, text.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin)));
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  if (list.size() < 2) {
    throw argError(flag, "expected two or more comma-separated frequencies (F1,F2,...), got '" + text +
                             "' (one coil: --coil-frequency)");
  }
  return list;
}

}  // namespace

namespace {

/// What the flags said beyond the options' values: which required ones came, and the choices
/// that exclude others.
struct FlagsSeen {
  bool scenario = false, duration = false, seed = false, out = false;
  bool altitude_hold = false, coil_frequency = false, coil_frequencies = false;
};

/// Applies the flags of `args` to `options`; false for --help.
bool applyFlags(const std::vector<std::string>& args, SimOptions& options, FlagsSeen& seen) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& flag = args[i];
    if (flag == "--help" || flag == "-h") return false;
    if (flag == "--lz4") {
      options.lz4 = true;
      continue;
    }
    if (flag == "--pressure") {
      options.pressure.enabled = true;
      continue;
    }
    if (flag == "--thrusters") {
      options.thrusters.enabled = true;
      continue;
    }
    if (flag == "--coil-frequency-unknown") {
      options.coil_frequency_unknown = true;
      continue;
    }
    if (flag == "--altitude-hold") {
      if (options.depth_hold_z) throw argError(flag, "conflicts with --depth-hold");
      seen.altitude_hold = true;
      continue;
    }
    if (flag == "--reverse-lap") {
      options.mission.reverse_lap = true;
      continue;
    }
    if (flag == "--hold-plane-only") {
      if (options.depth_hold_z) throw argError(flag, "conflicts with --depth-hold");
      options.hold_plane_only = true;
      continue;
    }
    if (flag.rfind("--", 0) != 0) throw argError(flag, "unexpected argument (options start with --; see --help)");
    if (i + 1 >= args.size()) throw argError(flag, "missing value");
    const std::string& value = args[++i];
    if (flag == "--scenario") {
      if (value != "tank" && value != "field") throw argError(flag, "expected 'tank' or 'field', got '" + value + "'");
      options.scenario = parseScenario(value);
      seen.scenario = true;
    } else if (flag == "--duration") {
      options.duration = parseDouble(flag, value);
      seen.duration = true;
    } else if (flag == "--seed") {
      options.seed = parseSeed(flag, value);
      seen.seed = true;
    } else if (flag == "--out") {
      if (value.empty()) throw argError(flag, "empty directory");
      options.out_dir = value;
      seen.out = true;
    } else if (flag == "--name") {
      if (value.empty() || value.find('/') != std::string::npos)
        throw argError(flag, "expected a file-name stem, got '" + value + "'");
      options.name = value;
    } else if (flag == "--world-seed") {
      options.world_seed = parseSeed(flag, value);
    } else if (flag == "--rig-seed") {
      options.rig_seed = parseSeed(flag, value);
    } else if (flag == "--static-start") {
      options.static_start = parseDouble(flag, value);
    } else if (flag == "--camera-delay") {
      options.camera_delay = parseDouble(flag, value);
    } else if (flag == "--camera-extrinsic-error-deg") {
      options.camera_extrinsic_error_deg = parseDouble(flag, value);
    } else if (flag == "--camera-extrinsic-error-m") {
      options.camera_extrinsic_error_m = parseDouble(flag, value);
    } else if (flag == "--camera-blackout") {
      options.spans.camera_blackout.push_back(parseSpan(flag, value));
    } else if (flag == "--camera-off") {
      options.spans.camera_off.push_back(parseSpan(flag, value));
    } else if (flag == "--sonar-off") {
      options.spans.sonar_off.push_back(parseSpan(flag, value));
    } else if (flag == "--mag-off") {
      options.spans.mag_off.push_back(parseSpan(flag, value));
    } else if (flag == "--imu-gap") {
      options.spans.imu_gap.push_back(parseSpan(flag, value));
    } else if (flag == "--pressure-off") {
      options.spans.pressure_off.push_back(parseSpan(flag, value));
    } else if (flag == "--terrain") {
      options.terrain.preset = value;
    } else if (flag == "--terrain-slope-deg") {
      options.terrain.slope_deg = parseDouble(flag, value);
    } else if (flag == "--terrain-slope-azimuth-deg") {
      options.terrain.slope_azimuth_deg = parseDouble(flag, value);
    } else if (flag == "--terrain-relief-m") {
      options.terrain.relief_m = parseDouble(flag, value);
    } else if (flag == "--terrain-relief-wavelength-m") {
      options.terrain.relief_wavelength_m = parseDouble(flag, value);
    } else if (flag == "--terrain-roughness-m") {
      options.terrain.roughness_m = parseDouble(flag, value);
    } else if (flag == "--terrain-rock-height-m") {
      options.terrain.rock_height_m = parseDouble(flag, value);
    } else if (flag == "--terrain-rock-density") {
      options.terrain.rock_density = parseDouble(flag, value);
    } else if (flag == "--depth-hold") {
      if (seen.altitude_hold) throw argError(flag, "conflicts with --altitude-hold");
      if (options.hold_plane_only) throw argError(flag, "conflicts with --hold-plane-only");
      options.depth_hold_z = parseDouble(flag, value);
    } else if (flag == "--sonar-max-range") {
      options.sonar_max_range = parseDouble(flag, value);
    } else if (flag == "--pressure-rate-hz") {
      options.pressure.rate_hz = parseDouble(flag, value);
    } else if (flag == "--pressure-atmospheric-error-pa") {
      options.pressure.atmospheric_error_pa = parseDouble(flag, value);
    } else if (flag == "--pressure-spikes") {
      options.pressure.spike_fraction = parseDouble(flag, value);
    } else if (flag == "--coil-frequency") {
      if (seen.coil_frequencies) throw argError(flag, "conflicts with --coil-frequencies");
      options.coil_frequency_hz = parseDouble(flag, value);
      seen.coil_frequency = true;
    } else if (flag == "--coil-frequencies") {
      if (seen.coil_frequency) throw argError(flag, "conflicts with --coil-frequency (list every coil's frequency)");
      const std::vector<double> list = parseFrequencyList(flag, value);
      options.coil_frequency_hz = list.front();
      options.other_coil_frequencies_hz.assign(list.begin() + 1, list.end());
      seen.coil_frequencies = true;
    } else if (flag == "--coil-spacing") {
      options.coil_spacing_m = parseDouble(flag, value);
    } else if (flag == "--coil-frequency-drift-hz") {
      options.coil_frequency_drift_hz = parseDouble(flag, value);
    } else if (flag == "--thruster-line-hz") {
      options.thrusters.line_hz = parseDouble(flag, value);
    } else if (flag == "--thruster-line-nt") {
      options.thrusters.line_nt = parseDouble(flag, value);
    } else if (flag == "--thruster-hard-iron-ut") {
      options.thrusters.hard_iron_ut = parseDouble(flag, value);
    } else if (flag == "--thruster-broadband-nt") {
      options.thrusters.broadband_nt = parseDouble(flag, value);
    } else if (flag == "--magnetic-anomaly-ut") {
      options.magnetic_anomaly_ut = parseDouble(flag, value);
    } else if (flag == "--magnetic-anomaly-width-m") {
      options.magnetic_anomaly_width_m = parseDouble(flag, value);
    } else if (flag == "--mag-hard-iron-ut") {
      options.mag_hard_iron_ut = parseDouble(flag, value);
    } else if (flag == "--mag-soft-iron-pct") {
      options.mag_soft_iron_pct = parseDouble(flag, value);
    } else if (flag == "--start-along-lap-m") {
      options.mission.start_along_lap_m = parseDouble(flag, value);
    } else if (flag == "--altitude-offset-m") {
      options.mission.altitude_offset_m = parseDouble(flag, value);
    } else if (flag == "--turbidity") {
      options.mission.turbidity = parseDouble(flag, value);
    } else if (flag == "--lamp-power") {
      options.mission.lamp_power = parseDouble(flag, value);
    } else if (flag == "--seabed-change") {
      options.mission.seabed_change = parseDouble(flag, value);
    } else if (flag == "--camera-rate-hz") {
      options.rates.camera = parseDouble(flag, value);
    } else if (flag == "--imu-rate-hz") {
      options.rates.imu = parseDouble(flag, value);
    } else if (flag == "--sonar-rate-hz") {
      options.rates.sonar = parseDouble(flag, value);
    } else if (flag == "--mag-rate-hz") {
      options.rates.magnetometer = parseDouble(flag, value);
    } else if (flag == "--start-time") {
      options.start_time = parseDouble(flag, value);
    } else if (flag == "--distortion-model") {
      if (value != "radtan" && value != "equidistant") {
        throw argError(flag, "expected radtan or equidistant, got '" + value + "'");
      }
      options.distortion_model = value;
    } else if (flag == "--image-format") {
      if (value != "raw" && value != "png" && value != "jpeg")
        throw argError(flag, "expected raw, png or jpeg, got '" + value + "'");
      options.image_format = value;
    } else if (flag == "--threads") {
      const double threads = parseDouble(flag, value);
      if (threads != std::floor(threads)) throw argError(flag, "expected an integer, got '" + value + "'");
      options.render_threads = static_cast<int>(std::max(-1.0, std::min(threads, 1000.0)));
    } else if (flag == "--image-width") {
      options.image_width = parseInteger(flag, value);
    } else if (flag == "--image-height") {
      options.image_height = parseInteger(flag, value);
    } else if (flag == "--camera-tilt-deg") {
      options.camera_tilt_deg = parseDouble(flag, value);
    } else if (flag == "--camera-roll-deg") {
      options.camera_roll_deg = parseDouble(flag, value);
    } else {
      throw argError(flag, "unknown option (see --help)");
    }
  }
  return true;
}

}  // namespace

std::optional<SimOptions> parseSimCommandLine(const std::vector<std::string>& command_line) {
  // --rig FILE: the file's flags are applied first, so a flag on the command line overrides them.
  std::string rig_path;
  std::vector<std::string> args;
  for (size_t i = 0; i < command_line.size(); ++i) {
    if (command_line[i] != "--rig") {
      args.push_back(command_line[i]);
      continue;
    }
    if (i + 1 >= command_line.size()) throw argError("--rig", "missing value");
    if (!rig_path.empty()) throw argError("--rig", "given twice");
    rig_path = command_line[++i];
  }
  SimOptions options;
  FlagsSeen seen;
  if (!rig_path.empty()) {
    try {
      applyFlags(rigFileArguments(rig_path), options, seen);
      validateRig(options);
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      if (what.rfind("--rig ", 0) == 0) throw;
      throw std::invalid_argument("--rig " + rig_path + ": " + what);
    }
  }
  if (!applyFlags(args, options, seen)) return std::nullopt;
  if (!seen.scenario) throw argError("--scenario", "is required (tank or field)");
  if (!seen.duration) throw argError("--duration", "is required (seconds)");
  if (!seen.seed) throw argError("--seed", "is required (a non-negative integer)");
  if (!seen.out) throw argError("--out", "is required (output directory)");
  options.validate();
  return options;
}

std::string simUsage() {
  return R"(vims_sim: simulated underwater sequences (camera, IMU, sonar altimeter, magnetometer, pressure,
ground truth) over a flat or shaped seabed

Usage:
  vims_sim --scenario tank|field --duration SECONDS --seed N --out DIR [options]

Required:
  --scenario tank|field    tank: ~20 m x 20 m, ~130 m per 750 s lap; field: ~80 m x 60 m, long transits
  --duration SECONDS       sequence length
  --seed N                 trajectory seed: path variation, all sensor noise (and the rig, unless --rig-seed)
  --out DIR                output directory (created if missing)

Options:
  --name NAME              sequence name (default: basename of DIR)
  --world-seed M           seabed texture, coil position, site geomagnetic field (default: N)
  --rig-seed R             the vehicle's rig calibration and magnetic make-up (default: N); a repeat
                           mission of the same vehicle: the teach run's seed
  --static-start SECONDS   initial rest phase (default 3)
  --camera-delay SECONDS   image header.stamp = true exposure time + delay (default 0, |d| <= 0.5)
  --camera-extrinsic-error-deg DEG  the YAML's T_b_c is turned by DEG (0-10) about a seeded axis
                           from the true one (an imperfect calibration; the truth file keeps both)
  --camera-extrinsic-error-m M      ... and moved by M (0-0.2 m) in a seeded direction
  --camera-blackout A:B    frames in [A, B) are black: lamp failure, only sensor noise (repeatable)
  --camera-off A:B         no image messages in [A, B) (repeatable)
  --sonar-off A:B          no sonar messages in [A, B) (repeatable)
  --mag-off A:B            no magnetometer messages in [A, B) (repeatable)
  --sonar-max-range M      the sonar's range limit, 1-100 m (default 50): a seabed farther away
                           gives no echo (+inf), as over a drop-off
  --imu-gap A:B            no IMU messages in [A, B) (repeatable)
  --pressure-off A:B       no pressure messages in [A, B) (repeatable; needs --pressure)
  --coil-frequency HZ      the seabed coil's frequency, 2-200 Hz (default 11, the paper's)
  --coil-frequency-unknown the sequence YAML says coil_frequency_hz: null (contract v2: VIMS finds
                           it from the data); the truth file keeps it
  --coil-frequencies F1,F2,...  two or more coils (at most 8; instead of --coil-frequency and not
                           with --coil-frequency-unknown), each 2-200 Hz, below 0.45 x the
                           magnetometer's rate and at least 1 Hz from the others; the same hardware,
                           each its own free-running phase. The YAML lists them all
  --coil-spacing M         with --coil-frequencies: the further coils lie on the base lap M m
                           (1-100, default 30) from the first (horizontally), at least M from each
                           other where the lap allows (else as far as it allows; world seed)
  --coil-frequency-drift-hz D  the coil's frequency drifts linearly by D Hz (|D| <= 2) over the
                           sequence (every coil's by the same D); the YAML states the frequency at
                           the start
  --thrusters              the vehicle's two thrusters disturb the magnetometer: lines at the
                           motors' electrical frequency (~ sqrt(thrust)), a static offset and
                           broadband noise (~ thrust); thrust from drag (v|v|) and inertia (m a)
  --thruster-line-hz F     line frequency at the 0.5 m/s reference thrust (default 45; the second
                           motor 4 % faster); --thruster-line-nt A its peak amplitude (default 200)
  --thruster-hard-iron-ut H  static offset at the reference thrust (default 3)
  --thruster-broadband-nt B  extra white noise per axis at the reference thrust (default 15)
  --magnetic-anomaly-ut UT a static geomagnetic anomaly (buried steel, magnetised along the site's
                           field) under the vehicle's mid-mission position, UT (0-50) at the vehicle
                           (default 0: none); the truth file keeps it
  --magnetic-anomaly-width-m M  its width (2-50 m, default 10): the dipole lies M/2 below the vehicle
  --mag-hard-iron-ut H     the magnetometer is not calibrated: H uT (0-50) of hard iron in a seeded
                           direction (default 0); the YAML does not say so, the truth file does
  --mag-soft-iron-pct P    and soft iron scaling and skewing the outside field by up to P % (0-20,
                           default 0) along seeded axes (vims_mag_calib fits both)
  --camera-rate-hz HZ      image rate, 5-30 (default 10)
  --imu-rate-hz HZ         IMU rate, 100-1000 (default 200; the noise densities stay the same)
  --sonar-rate-hz HZ       sonar rate, 1-20 (default 10)
  --mag-rate-hz HZ         magnetometer rate, 200-2000 (default 1000)
  --start-time T           bag-clock time of the sequence start (default 1700000000.0)
  --lz4                    write lz4-compressed bag chunks
  --distortion-model M     radtan (default: pinhole, 60 deg across) or equidistant (fisheye behind
                           a dome port, about 110 deg across)
  --image-width W, --image-height H  the image size, 160-2048 x 120-2048 px (default 640 x 480);
                           the focal length scales with the width (the field of view stays)
  --camera-tilt-deg D      the camera's optical axis turned from straight down towards the bow by D
                           deg (-45 to 45, negative: towards the stern; default 0)
  --camera-roll-deg R      the camera turned about its optical axis by R deg (-180 to 180; default 0:
                           the image's up towards the bow)
  --rig FILE               a rig file (config/rigs/*.yaml): the camera, mounting and rate flags above
                           as `flag: value` (without the dashes); flags on the command line override it
  --image-format F         raw (default: sensor_msgs/Image mono8), png (lossless) or jpeg (quality 95):
                           sensor_msgs/CompressedImage on /cam0/image_raw/compressed
  --threads N              render threads (default 0: one per hardware thread)
  --help                   this text

Seabed (default: flat, z = 0; a preset, then any term overridden):
  --terrain flat|slope4|rough|hills
                           slope4: 4 deg + 0.25 m relief (30 m) + 2 cm roughness (sloping sand);
                           rough: 2 deg + 0.25 m relief + 10 cm roughness + rocks 0.15-0.3 m (0.05 / m^2);
                           hills: 1 deg + 1 m relief (40 m) + 3 cm roughness + rocks 0.1-0.2 m (0.01 / m^2)
  --terrain-slope-deg DEG            plane slope, 0-15
  --terrain-slope-azimuth-deg DEG    downhill direction, clockwise from north, 0-360 (default: seeded)
  --terrain-relief-m M               rolling relief peak amplitude, 0-2
  --terrain-relief-wavelength-m M    longest relief wavelength, 5-200
  --terrain-roughness-m M            rms height of the 1-5 m roughness, 0-0.2
  --terrain-rock-height-m M          tallest rock, 0-0.4 (rocks are 0.5-1 x this)
  --terrain-rock-density N           rocks per m^2, 0-0.1
  --altitude-hold          fly the altitude profile above the large-scale seabed (default)
  --hold-plane-only        altitude hold above the seabed's plane only: the rolling relief passes
                           under the vehicle unfollowed (its altitude then varies by the relief)
  --depth-hold Z           hold the body at world height Z [m] instead (the seabed's mean is z = 0;
                           an error if the altitude falls below 1 m anywhere)

Repeat mission (a saved map's world seed flown again; default: as the teach run):
  --start-along-lap-m S    start S m along the scenario's lap (any S >= 0, modulo the lap's length:
                           the tank's is 136.5 m, the field's 412 m), heading along it
  --reverse-lap            fly the lap the other way round (every leg in the opposite direction)
  --altitude-offset-m D    fly D m higher (or lower), -1 to 3 (the default profile: 2.1-4.9 m)
  --turbidity K            murkier water, 1-8: attenuation and the backscatter haze's build-up K
                           times the clear water's (the exposure stays set for 2 m of clear water)
  --lamp-power P           the lamp's light x P, 0.1-3 (a dimmer or brighter lamp, same exposure)
  --seabed-change F        a fraction F (0-0.6) of the seabed re-laid since the survey: in patches
                           about 2 m across the sand, shells, pebbles, weed and rocks are another
                           seabed's (the patches are the dive's: trajectory seed)

Pressure sensor (default: none):
  --pressure               a depth sensor on /pressure (sensor_msgs/FluidPressure)
  --pressure-rate-hz HZ    1-50 (default 10)
  --pressure-atmospheric-error-pa X  the YAML's atmospheric_pa is off by X from the truth (|X| <= 20000)
  --pressure-spikes P      a fraction P (0-0.5) of the samples carries a spike of 1.5-2.5e4 Pa

Spans are seconds from the sequence start. Output: DIR/NAME.bag, NAME.yaml, NAME_gt.tum,
NAME_truth.yaml (see docs/sensor-contract.md and vims_sim/docs/simulator.md).
)";
}

}  // namespace sim
}  // namespace vims
