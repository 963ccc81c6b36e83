// vims_frontend_eval: scores the sonar filter or the magnetic signature extractor on a simulated
// sequence against its ground truth (see frontend_eval.h for the definitions) and prints the
// figures plus one parseable summary line (VIMS_SONAR ... / VIMS_MAG ...; with several coils also
// one VIMS_MAG_COIL ... line per coil).
//
//   vims_frontend_eval sonar --sequence DIR [--options config/sonar.yaml] [--csv sonar_filtered.csv]
//   vims_frontend_eval mag   --sequence DIR [--options config/magnetometer.yaml] [--csv mag_signatures.csv]
//
// Exit status: 0 on success, 1 on bad usage or unreadable input.
#include <ros/time.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

#include "frontend_eval.h"
#include "vims_common/config_reader.h"

namespace {

void usage() {
  std::cerr << "usage: vims_frontend_eval sonar|mag --sequence DIR [--options FILE] [--csv FILE] [--verbose]\n"
               "  sonar  injected-outlier rejection and good-sample loss of the sonar filter\n"
               "  mag    signature amplitude error against the coil's analytic dipole field, and the\n"
               "         difference between visits of the same spot with different headings\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    usage();
    return 1;
  }
  const std::string command = argv[1];
  std::string sequence, options_path, csv_path;
  bool verbose = false;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      return argv[++i];
    };
    try {
      if (arg == "--sequence") {
        sequence = value();
      } else if (arg == "--options") {
        options_path = value();
      } else if (arg == "--csv") {
        csv_path = value();
      } else if (arg == "--verbose") {
        verbose = true;
      } else if (arg == "--help" || arg == "-h") {
        usage();
        return 0;
      } else {
        throw std::invalid_argument("unknown argument '" + arg + "'");
      }
    } catch (const std::invalid_argument& e) {
      std::cerr << "vims_frontend_eval: " << e.what() << "\n";
      usage();
      return 1;
    }
  }
  if ((command != "sonar" && command != "mag") || sequence.empty()) {
    usage();
    return 1;
  }
  ros::Time::init();  // rosbag needs the time subsystem, not a master
  const vims::LoggerPtr logger = vims::Logger::stderrLogger(verbose ? vims::LogLevel::kInfo : vims::LogLevel::kError);
  try {
    if (command == "sonar") {
      const auto options =
          options_path.empty()
              ? vims::SonarFilterOptions{}
              : vims::SonarFilterOptions::fromReader(vims::ConfigReader::fromFile(options_path).child("sonar"));
      const auto ev = vims::frontend_eval::evaluateSonar(sequence, options, logger, csv_path);
      std::printf("sonar filter on %s\n", sequence.c_str());
      std::printf("  samples %ld (dropouts %ld, without ground truth %ld)\n", ev.samples, ev.dropouts, ev.no_truth);
      std::printf("  injected outliers (> 5 sigma from the true range): %ld, rejected %ld = %.2f %%\n", ev.outliers,
                  ev.outliers_rejected, ev.rejectedPct());
      std::printf("  good samples: %ld, lost %ld = %.2f %%\n", ev.good, ev.good_lost, ev.lostPct());
      std::printf("  resets %ld, filtered range RMSE %.4f m\n", ev.resets, ev.filtered_rmse_m);
      std::printf("%s\n", ev.summaryLine().c_str());
    } else {
      const auto options =
          options_path.empty()
              ? vims::MagnetometerOptions{}
              : vims::MagnetometerOptions::fromReader(vims::ConfigReader::fromFile(options_path).child("magnetometer"));
      const vims::frontend_eval::MagEvaluationOptions eval_options;
      const auto ev = vims::frontend_eval::evaluateMagnetometer(sequence, options, eval_options, logger, csv_path);
      std::printf("magnetic signatures on %s\n", sequence.c_str());
      std::printf("  windows %ld, valid %ld, scored (true amplitude >= %.0f nT) %ld, median SNR %.1f\n", ev.windows,
                  ev.valid_windows, eval_options.min_amplitude_t * 1e9, ev.scored, ev.median_snr);
      std::printf("  relative amplitude error: median %.2f %%, 90th percentile %.2f %%\n", ev.median_rel_err_pct,
                  ev.p90_rel_err_pct);
      std::printf("  of which: magnitude error median %.2f %%; azimuth error median %.2f deg, mean %+.2f deg\n",
                  ev.median_magnitude_err_pct, ev.median_azimuth_err_deg, ev.mean_azimuth_err_deg);
      if (ev.coils.size() > 1) {
        for (const auto& coil : ev.coils) {
          std::printf(
              "  coil %d (%.3f Hz): scored %ld, relative amplitude error: median %.2f %%, 90th percentile %.2f %%\n",
              coil.coil, coil.frequency_hz, coil.scored, coil.median_rel_err_pct, coil.p90_rel_err_pct);
        }
      }
      if (ev.unknown_coil > 0)
        std::printf("  %ld valid windows of a coil the truth does not have (not scored)\n", ev.unknown_coil);
      std::printf(
          "  same spot (< %.1f m), heading differing by > %.0f deg: %ld pairs, median difference beyond the "
          "field change %.2f %% (raw difference %.2f %%)\n",
          eval_options.pair_radius_m, eval_options.pair_min_heading_deg, ev.heading_pairs,
          ev.heading_median_rel_diff_pct, ev.heading_median_raw_diff_pct);
      std::printf("%s\n", ev.summaryLine().c_str());
      if (ev.coils.size() > 1)
        for (const auto& coil : ev.coils) std::printf("%s\n", coil.summaryLine().c_str());
    }
  } catch (const std::exception& e) {
    std::cerr << "vims_frontend_eval: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
