// vims_mag_calib: fits the magnetometer's hard- and soft-iron correction from a recording of
// turns (iron_calibration.h) and writes it as a configuration file for the magnetometer front end.
//
//   vims_mag_calib --sequence DIR [--out FILE] [options]
//   vims_mag_calib --bag BAG --rig RIG.yaml [--out FILE] [options]
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <string>

#include "vims_common/sequence_paths.h"
#include "vims_magnetometer/iron_calibration.h"
#include "vims_ros/sequence_bag_reader.h"

namespace {

const char* kUsage =
    "usage: vims_mag_calib (--sequence DIR | --bag BAG --rig RIG.yaml) [--out FILE] [--site-field-ut F]\n"
    "                      [--start S] [--end S] [--block-s 0.5]\n"
    "  Fits the hard and soft iron of the magnetometer (topics.mag of the rig file) from turns through\n"
    "  the constant geomagnetic field: a full 3D fit when the recording tumbles the vehicle (pitch and\n"
    "  roll as well as heading), a horizontal fit from level turns (at least 270 deg of heading). The\n"
    "  accelerometer (topics.imu) levels the horizontal fit.\n"
    "  --out FILE          write the correction as a configuration file (magnetometer.iron_correction):\n"
    "                      pass it as one more vims_offline --config or the nodes' config_file\n"
    "  --site-field-ut F   the site's total field [uT] (World Magnetic Model): sets the scale of a full fit\n"
    "  --start S, --end S  use only this span [s from the bag's start] (the calibration manoeuvre)\n"
    "  --block-s S         averaging block [s]: the coil's and thrusters' lines average out (default 0.5)\n"
    "  The last line is 'VIMS_MAG_CALIB ...'. Exit 0: fitted; 1: the data do not allow a fit (the\n"
    "  message says which manoeuvre is missing) or an input error; 2: bad command line.\n";

int usageError(const std::string& message) {
  std::cerr << "vims_mag_calib: " << message << "\n" << kUsage;
  return 2;
}

bool parseNumber(const std::string& text, double* out) {
  char* end = nullptr;
  *out = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && std::isfinite(*out);
}

}  // namespace

int main(int argc, char** argv) {
  std::string sequence, bag, rig, out;
  double start_s = 0.0, end_s = std::numeric_limits<double>::infinity(), block_s = 0.5, site_ut = 0.0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      return 0;
    }
    if (i + 1 >= argc) return usageError("option " + arg + " needs a value (or is unknown)");
    const std::string value = argv[++i];
    double number = 0.0;
    if (arg == "--sequence") {
      sequence = value;
    } else if (arg == "--bag") {
      bag = value;
    } else if (arg == "--rig") {
      rig = value;
    } else if (arg == "--out") {
      out = value;
    } else if (arg == "--start" || arg == "--end" || arg == "--block-s" || arg == "--site-field-ut") {
      if (!parseNumber(value, &number)) return usageError(arg + " needs a number, got '" + value + "'");
      if (arg == "--start") start_s = number;
      if (arg == "--end") end_s = number;
      if (arg == "--block-s") block_s = number;
      if (arg == "--site-field-ut") site_ut = number;
    } else {
      return usageError("unknown option " + arg);
    }
  }
  if (sequence.empty() == (bag.empty() && rig.empty())) return usageError("give either --sequence or --bag and --rig");
  if (sequence.empty() && (bag.empty() || rig.empty())) return usageError("--bag needs --rig (and --rig needs --bag)");
  if (!(block_s > 0.0 && block_s <= 10.0)) return usageError("--block-s must be in (0, 10] s");
  if (site_ut < 0.0 || site_ut > 100.0) return usageError("--site-field-ut must be in [0, 100] uT");
  if (!(end_s > start_s)) return usageError("--end must be after --start");

  try {
    if (!sequence.empty()) {
      const vims::SequencePaths paths = vims::SequencePaths::resolve(sequence);
      bag = paths.bag;
      rig = paths.yaml;
    }
    const vims::SequenceConfig config = vims::SequenceConfig::load(rig);
    vims::SequenceBagReader reader(bag, config);
    reader.requireTopic(config.topics.mag);
    const bool have_imu = reader.hasTopic(config.topics.imu);
    if (!have_imu)
      std::cerr << "vims_mag_calib: no " << config.topics.imu
                << " in the bag: the horizontal fit takes the body's z as up\n";
    // The accelerometer gate: a slow AUV's specific force stays within 0.3 m/s^2 of g; beyond it the
    // block's tilt is not trusted.
    vims::IronFitSampler sampler(block_s, config.imu.gravity, 0.3, config.magnetometer.T_b_m.linear());
    const double t0 = reader.startTime();
    const auto inSpan = [&](double t) { return t - t0 >= start_s && t - t0 < end_s; };
    vims::SequenceBagReader::Handlers handlers;
    handlers.mag = [&](const vims::MagSample& m) {
      if (inSpan(m.t)) sampler.feedMag(m);
    };
    if (have_imu)
      handlers.imu = [&](const vims::ImuSample& s) {
        if (inSpan(s.t)) sampler.feedImu(s);
      };
    reader.run(handlers);

    vims::IronFitOptions options;
    options.site_field_t = site_ut * 1e-6;
    const vims::IronFitResult fit = vims::fitIronCorrection(sampler.finish(), options);
    if (!fit.ok) {
      std::cerr << "vims_mag_calib: no calibration: " << fit.why << "\n";
      std::cout << vims::ironFitSummaryLine(fit) << "\n";
      return 1;
    }
    const std::string yaml = vims::ironCorrectionConfigYaml(fit);
    std::cout << yaml;
    if (!out.empty()) {
      std::ofstream file(out);
      file << yaml;
      if (!file) throw std::runtime_error("cannot write '" + out + "'");
      std::cout << "wrote " << out << "\n";
    }
    std::cout << vims::ironFitSummaryLine(fit) << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "vims_mag_calib: " << e.what() << "\n";
    return 1;
  }
}
