/// vims_offline: runs the VIMS pipeline on a recorded or simulated sequence straight from its
/// bag, deterministically and as fast as the CPU allows. See docs/offline_outputs.md.

#include <ros/time.h>

#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>

#include "offline_pipeline.h"
#include "vims_common/config_reader.h"

namespace {

const char* kUsage =
    "usage: vims_offline --sequence DIR --out OUT [--config FILE] [--mode full|no_sonar] [--quiet]\n"
    "  --sequence DIR   sequence directory (<seq>.bag + <seq>.yaml, see docs/sensor-contract.md)\n"
    "  --out OUT        output directory (created); summary.yaml and the module outputs go here\n"
    "  --config FILE    system configuration (default: built-in defaults, see config/vims.yaml)\n"
    "  --mode MODE      full (default) or no_sonar (visual-inertial odometry without the sonar factors)\n"
    "  --quiet          no progress output\n";

int usageError(const std::string& message) {
  std::cerr << "vims_offline: " << message << "\n" << kUsage;
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  vims::OfflineOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](std::string* target) {
      if (i + 1 >= argc) return false;
      *target = argv[++i];
      return true;
    };
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      return 0;
    } else if (arg == "--sequence") {
      if (!value(&options.sequence_dir)) return usageError("--sequence needs a directory");
    } else if (arg == "--out") {
      if (!value(&options.out_dir)) return usageError("--out needs a directory");
    } else if (arg == "--config") {
      if (!value(&options.config_path)) return usageError("--config needs a file");
    } else if (arg == "--mode") {
      if (!value(&options.mode)) return usageError("--mode needs full or no_sonar");
      if (options.mode != "full" && options.mode != "no_sonar") {
        return usageError("unknown mode '" + options.mode + "' (expected full or no_sonar)");
      }
    } else if (arg == "--quiet") {
      options.show_progress = false;
    } else {
      return usageError("unknown argument '" + arg + "'");
    }
  }
  if (options.sequence_dir.empty()) return usageError("--sequence is required");
  if (options.out_dir.empty()) return usageError("--out is required");

  ros::Time::init();  // rosbag needs the time module; no master is contacted
  try {
    vims::OfflinePipeline pipeline(options, vims::Logger::stderrLogger(vims::LogLevel::kInfo));
    const vims::OfflineSummary summary = pipeline.run();
    std::printf("VIMS_OFFLINE sequence=%s duration_s=%.2f wall_s=%.2f rtf=%.1f\n", summary.sequence_name.c_str(),
                summary.sequence_duration_s, summary.wall_time_s, summary.real_time_factor);
    for (const auto& [topic, stats] : summary.topics) {
      std::printf("  %-22s %-28s %8ld messages, %ld rejected\n", topic.c_str(), stats.type.c_str(), stats.messages,
                  stats.rejected);
    }
  } catch (const vims::ConfigError& e) {
    std::cerr << "vims_offline: configuration error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "vims_offline: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
