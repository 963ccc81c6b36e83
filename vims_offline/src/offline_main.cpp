/// vims_offline: runs the VIMS pipeline on a recorded or simulated sequence straight from its
/// bag, deterministically and as fast as the CPU allows. See docs/offline_outputs.md.

#include <ros/time.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>

#include "offline_pipeline.h"
#include "vims_common/config_reader.h"
#include "vims_common/option_table.h"
#include "vims_system/system_config.h"

namespace {

const char* kUsage =
    "usage: vims_offline --sequence DIR --out OUT [--config FILE]... [--mode MODE] [--map-load FILE]\n"
    "                    [--map-mode MODE] [--map-save FILE] [--package-root DIR] [--threads 1|2]\n"
    "                    [--vio-only] [--quiet]\n"
    "       vims_offline --list-options\n"
    "  --sequence DIR      sequence directory (<seq>.bag + <seq>.yaml, see docs/sensor-contract.md)\n"
    "  --out OUT           output directory (created); summary.yaml and the module outputs go here\n"
    "  --config FILE       system configuration: optional sections sonar, magnetometer, tracker, estimator,\n"
    "                      pose_graph; keys and defaults in config/<section>.yaml. Repeatable: each\n"
    "                      file gives some sections, no section twice. Default: built-in defaults\n"
    "  --mode MODE         full (default), vi_slam, no_sonar, no_alter, no_orb or no_geom: the paper's\n"
    "                      ablation variants (docs/offline_outputs.md)\n"
    "  --map-load FILE     relocalise into a map saved by an earlier run (teach and repeat)\n"
    "  --map-mode MODE     what the run does with the loaded map: mapping (default: optimised with\n"
    "                      the run, which adds its places), extend (held fixed, the run adds its\n"
    "                      places) or localisation (held fixed, the run adds nothing; --map-save\n"
    "                      then writes the loaded map); sets pose_graph.map_mode\n"
    "  --map-save FILE     save the map at the end\n"
    "  --package-root DIR  root for relative vocabulary paths (default: the source tree it was built from)\n"
    "  --threads 1|2       2 (default): the feature tracker and the pose graph run on their own\n"
    "                      threads, overlapping the estimator; 1: one thread. The output files are\n"
    "                      the same for both\n"
    "  --vio-only          the odometry alone (no pose graph: no global.tum, loops.csv or map), to\n"
    "                      measure the VIO's own speed\n"
    "  --quiet             no progress output\n"
    "  --list-options      print every key of the system configuration with the values it accepts\n"
    "                      (tab-separated; defaults and meanings: docs/parameters.md) and exit\n";

int usageError(const std::string& message) {
  std::cerr << "vims_offline: " << message << "\n" << kUsage;
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  vims::OfflineOptions options;
  options.package_root = VIMS_PACKAGE_ROOT;
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
    } else if (arg == "--list-options") {
      for (const vims::OptionRow& row : vims::SystemConfig::optionRows())
        std::cout << row.key << "\t" << row.allowed << "\n";
      return 0;
    } else if (arg == "--sequence") {
      if (!value(&options.sequence_dir)) return usageError("--sequence needs a directory");
    } else if (arg == "--out") {
      if (!value(&options.out_dir)) return usageError("--out needs a directory");
    } else if (arg == "--config") {
      std::string path;
      if (!value(&path)) return usageError("--config needs a file");
      options.config_paths.push_back(path);
    } else if (arg == "--mode") {
      if (!value(&options.mode)) return usageError("--mode needs a mode name");
      const auto& modes = vims::SystemConfig::modes();
      if (std::find(modes.begin(), modes.end(), options.mode) == modes.end()) {
        return usageError("unknown mode '" + options.mode + "'");
      }
    } else if (arg == "--map-load") {
      if (!value(&options.map_load)) return usageError("--map-load needs a file");
    } else if (arg == "--map-mode") {
      if (!value(&options.map_mode)) return usageError("--map-mode needs mapping, extend or localisation");
      if (options.map_mode != "mapping" && options.map_mode != "extend" && options.map_mode != "localisation")
        return usageError("unknown map mode '" + options.map_mode + "' (mapping, extend or localisation)");
    } else if (arg == "--map-save") {
      if (!value(&options.map_save)) return usageError("--map-save needs a file");
    } else if (arg == "--package-root") {
      if (!value(&options.package_root)) return usageError("--package-root needs a directory");
    } else if (arg == "--threads") {
      std::string threads;
      if (!value(&threads)) return usageError("--threads needs 1 or 2");
      if (threads != "1" && threads != "2") return usageError("--threads must be 1 or 2, got '" + threads + "'");
      options.threads = std::stoi(threads);
    } else if (arg == "--vio-only") {
      options.vio_only = true;
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
    std::printf("VIMS_OFFLINE sequence=%s duration_s=%.2f wall_s=%.2f rtf=%.1f vio_rtf=%.1f\n",
                summary.sequence_name.c_str(), summary.sequence_duration_s, summary.wall_time_s,
                summary.real_time_factor, summary.vio_real_time_factor);
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
