/// vims_sim: writes a simulated underwater sequence (see `vims_sim --help` and
/// vims_sim/docs/simulator.md). ROS glue only: options, the rosbag sink and console output;
/// everything else is vims_sim_core.

#include <ros/time.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "bag_sink.h"
#include "vims_common/sequence_paths.h"
#include "vims_sim/sequence_generator.h"
#include "vims_sim/sim_options.h"
#include "vims_sim/sim_setup.h"

int main(int argc, char** argv) {
  using namespace vims::sim;
  std::optional<SimOptions> options;
  try {
    options = parseSimCommandLine(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const std::exception& e) {
    std::cerr << "vims_sim: error: " << e.what() << "\n(run 'vims_sim --help' for usage)\n";
    return 2;
  }
  if (!options) {
    std::cout << simUsage();
    return 0;
  }

  try {
    ros::Time::init();  // rosbag needs the time type initialised; no master is involved
    const SimSetup setup = buildSimSetup(*options);
    const auto paths = vims::SequencePaths::forWriting(options->out_dir, options->sequenceName());
    std::filesystem::create_directories(options->out_dir);
    std::printf("vims_sim: scenario %s, %.1f s, seed %llu, world seed %llu -> %s\n",
                scenarioName(options->scenario).c_str(), options->duration,
                static_cast<unsigned long long>(options->seed), static_cast<unsigned long long>(options->worldSeed()),
                paths.bag.c_str());
    if (!setup.terrain->isFlat()) {
      const vims::sim::TerrainParams& t = setup.terrain->params();
      std::printf(
          "vims_sim: seabed %s: slope %.1f deg downhill towards %.0f deg, relief %.2f m over %.0f m, roughness "
          "%.3f m rms, rocks up to %.2f m at %.3f per m^2\n",
          options->terrain.preset.c_str(), t.slope_deg, t.slope_azimuth_deg, t.relief_m, t.relief_wavelength_m,
          t.roughness_m, t.rock_height_m, t.rock_density);
    }
    if (options->depth_hold_z) std::printf("vims_sim: depth hold at z = %.2f m\n", *options->depth_hold_z);
    if (setup.config.pressure) {
      std::printf("vims_sim: pressure sensor at %.0f Hz on %s\n", setup.config.pressure->rate_hz,
                  setup.config.topics.pressure.c_str());
    }
    if (!setup.truth.other_coils.empty()) {
      const vims::sim::CoilDipole& first = setup.truth.coil;
      std::printf("vims_sim: %d coils: %.3f Hz at (%.1f, %.1f)", setup.truth.coilCount(), first.frequency,
                  first.position_w.x(), first.position_w.y());
      for (const vims::sim::CoilDipole& other : setup.truth.other_coils) {
        std::printf(", %.3f Hz at (%.1f, %.1f) %.1f m from the first", other.frequency, other.position_w.x(),
                    other.position_w.y(), (other.position_w - first.position_w).head<2>().norm());
      }
      std::printf(" (spacing %.1f m)\n", options->coil_spacing_m);
    }
    std::fflush(stdout);

    BagSink sink(paths.bag, options->lz4, setup.config, setup.sonar, setup.imu, options->image_format);
    int last_percent = -1;
    const GenerationStats stats = generateSequence(setup, sink, [&](double sim_time, double duration, double wall) {
      const int percent = static_cast<int>(100.0 * sim_time / duration + 0.5);
      if (percent / 10 == last_percent / 10) return;  // print every 10 %
      last_percent = percent;
      std::printf("vims_sim: %5.1f / %.1f s (%3d %%), %.1f s wall, real-time factor %.1f\n", sim_time, duration,
                  percent, wall, sim_time / std::max(wall, 1e-9));
      std::fflush(stdout);
    });
    sink.close();

    std::printf("vims_sim: messages: %lld images (%lld black), %lld imu, %lld sonar, %lld mag, %lld ground-truth poses",
                static_cast<long long>(stats.image_messages), static_cast<long long>(stats.blackout_frames),
                static_cast<long long>(stats.imu_messages), static_cast<long long>(stats.sonar_messages),
                static_cast<long long>(stats.mag_messages), static_cast<long long>(stats.pose_messages));
    if (setup.config.pressure) std::printf(", %lld pressure", static_cast<long long>(stats.pressure_messages));
    std::printf("; %zu seabed tiles generated\n", stats.tiles_generated);
    std::printf(
        "vims_sim: done: %.1f s of data in %.1f s wall (real-time factor %.1f), typical Shi-Tomasi corners per "
        "frame %.0f (median of %d frames, min %d)\n",
        options->duration, stats.wall_seconds, stats.realtime_factor, stats.median_corners, stats.corner_frames,
        stats.min_corners);
  } catch (const std::exception& e) {
    std::cerr << "vims_sim: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
