#include "vims_sim/sim_options.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

namespace vims {
namespace sim {
namespace {

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

}  // namespace

std::string SimOptions::sequenceName() const {
  if (!name.empty()) return name;
  // "runs/dive_07/", "runs/dive_07" and "." (inside dive_07) all name the sequence dive_07.
  std::filesystem::path dir = std::filesystem::absolute(std::filesystem::path(out_dir)).lexically_normal();
  if (!dir.has_filename()) dir = dir.parent_path();
  return dir.filename().string();
}

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
  if (start_time < 1.0 || start_time + duration + 10.0 > 4.0e9) {
    throw argError("--start-time", "must be a positive bag-clock time that keeps all stamps below 4e9 s");
  }
  if (render_threads < 0 || render_threads > 64) throw argError("--threads", "must be in [0, 64] (0 = automatic)");
}

std::optional<SimOptions> parseSimCommandLine(const std::vector<std::string>& args) {
  SimOptions options;
  bool have_scenario = false, have_duration = false, have_seed = false, have_out = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& flag = args[i];
    if (flag == "--help" || flag == "-h") return std::nullopt;
    if (flag == "--lz4") {
      options.lz4 = true;
      continue;
    }
    if (flag.rfind("--", 0) != 0) throw argError(flag, "unexpected argument (options start with --; see --help)");
    if (i + 1 >= args.size()) throw argError(flag, "missing value");
    const std::string& value = args[++i];
    if (flag == "--scenario") {
      if (value != "tank" && value != "field") throw argError(flag, "expected 'tank' or 'field', got '" + value + "'");
      options.scenario = parseScenario(value);
      have_scenario = true;
    } else if (flag == "--duration") {
      options.duration = parseDouble(flag, value);
      have_duration = true;
    } else if (flag == "--seed") {
      options.seed = parseSeed(flag, value);
      have_seed = true;
    } else if (flag == "--out") {
      if (value.empty()) throw argError(flag, "empty directory");
      options.out_dir = value;
      have_out = true;
    } else if (flag == "--name") {
      if (value.empty() || value.find('/') != std::string::npos) throw argError(flag, "expected a file-name stem, got '" + value + "'");
      options.name = value;
    } else if (flag == "--world-seed") {
      options.world_seed = parseSeed(flag, value);
    } else if (flag == "--static-start") {
      options.static_start = parseDouble(flag, value);
    } else if (flag == "--camera-delay") {
      options.camera_delay = parseDouble(flag, value);
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
    } else if (flag == "--start-time") {
      options.start_time = parseDouble(flag, value);
    } else if (flag == "--threads") {
      const double threads = parseDouble(flag, value);
      if (threads != std::floor(threads)) throw argError(flag, "expected an integer, got '" + value + "'");
      options.render_threads = static_cast<int>(std::max(-1.0, std::min(threads, 1000.0)));
    } else {
      throw argError(flag, "unknown option (see --help)");
    }
  }
  if (!have_scenario) throw argError("--scenario", "is required (tank or field)");
  if (!have_duration) throw argError("--duration", "is required (seconds)");
  if (!have_seed) throw argError("--seed", "is required (a non-negative integer)");
  if (!have_out) throw argError("--out", "is required (output directory)");
  options.validate();
  return options;
}

std::string simUsage() {
  return R"(vims_sim: simulated underwater sequences (camera, IMU, sonar altimeter, magnetometer, ground truth)

Usage:
  vims_sim --scenario tank|field --duration SECONDS --seed N --out DIR [options]

Required:
  --scenario tank|field    tank: ~20 m x 20 m, ~130 m per 750 s lap; field: ~80 m x 60 m, long transits
  --duration SECONDS       sequence length
  --seed N                 trajectory seed: path variation, rig calibration, all sensor noise
  --out DIR                output directory (created if missing)

Options:
  --name NAME              sequence name (default: basename of DIR)
  --world-seed M           seabed texture, coil position, site geomagnetic field (default: N)
  --static-start SECONDS   initial rest phase (default 3)
  --camera-delay SECONDS   image header.stamp = true exposure time + delay (default 0, |d| <= 0.5)
  --camera-blackout A:B    frames in [A, B) are black: lamp failure, only sensor noise (repeatable)
  --camera-off A:B         no image messages in [A, B) (repeatable)
  --sonar-off A:B          no sonar messages in [A, B) (repeatable)
  --mag-off A:B            no magnetometer messages in [A, B) (repeatable)
  --imu-gap A:B            no IMU messages in [A, B) (repeatable)
  --start-time T           bag-clock time of the sequence start (default 1700000000.0)
  --lz4                    write lz4-compressed bag chunks
  --threads N              render threads (default 0: one per hardware thread)
  --help                   this text

Spans are seconds from the sequence start. Output: DIR/NAME.bag, NAME.yaml, NAME_gt.tum,
NAME_truth.yaml (see docs/sensor-contract.md and vims_sim/docs/simulator.md).
)";
}

}  // namespace sim
}  // namespace vims
