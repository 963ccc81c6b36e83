// Front-end benchmark: runs the feature tracker over every image of a sequence, held in memory
// so that the bag reader is not measured, and reports the tracker's CPU time per frame (thread
// CPU clock, the measure of vims_offline's summary vio_cpu_s), its per-stage wall times, and
// what it tracked (feature and rejection counts, a checksum of every output) so that a speed
// change can be shown not to change the tracks.
//   bench_vims_tracker --sequence DIR [--repeat N] [--config FILE]
#include <time.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "vims_common/config_reader.h"
#include "vims_common/fnv1a.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/timing.h"
#include "vims_ros/sequence_bag_reader.h"
#include "vims_tracking/feature_tracker.h"
#include "vims_tracking/tracker_options.h"

using vims::percentile;
using vims::threadCpuSeconds;

namespace {

/// FNV-1a over the bytes of a value: a checksum of the tracker's outputs.
template <typename T>
void mix(std::uint64_t* hash, const T& value) {
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  *hash = vims::fnv1a64(bytes, sizeof(T), *hash);
}

int usage() {
  std::cerr << "usage: bench_vims_tracker --sequence DIR [--repeat N] [--config FILE]\n"
               "  --repeat N     passes over the sequence (default 3); the CPU time reported is the\n"
               "                 fastest pass (the machine's other load only ever adds)\n"
               "  --config FILE  YAML with a `tracker:` section (default: built-in defaults)\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string sequence, config_file;
  int repeat = 3;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--sequence" && i + 1 < argc)
      sequence = argv[++i];
    else if (arg == "--repeat" && i + 1 < argc)
      repeat = std::atoi(argv[++i]);
    else if (arg == "--config" && i + 1 < argc)
      config_file = argv[++i];
    else
      return usage();
  }
  if (sequence.empty() || repeat < 1) return usage();
  try {
    const vims::SequencePaths paths = vims::SequencePaths::resolve(sequence);
    const vims::SequenceConfig config = vims::SequenceConfig::load(paths.yaml);
    const vims::TrackerOptions options =
        config_file.empty()
            ? vims::TrackerOptions()
            : vims::TrackerOptions::fromReader(vims::ConfigReader::fromFile(config_file).childOrEmpty("tracker"));
    std::vector<vims::CameraFrame> frames;
    vims::SequenceBagReader reader(paths.bag, config);
    vims::SequenceBagReader::Handlers handlers;
    handlers.image = [&](const vims::CameraFrame& frame) { frames.push_back(frame); };
    reader.run(handlers);
    if (frames.empty()) {
      std::cerr << "bench_vims_tracker: no images in " << paths.bag << "\n";
      return 1;
    }

    double best_cpu_s = 0.0;
    for (int pass = 0; pass < repeat; ++pass) {
      vims::FeatureTracker tracker(config.camera, options);
      std::vector<double> total_ms, preprocess_ms, klt_ms, ransac_ms, detect_ms, cpu_ms;
      long features = 0, detected = 0, lost_klt = 0, rejected_fb = 0, rejected_ransac = 0;
      std::uint64_t checksum = vims::kFnv1a64OffsetBasis;
      for (const vims::CameraFrame& frame : frames) {
        const double cpu_start = threadCpuSeconds();
        const vims::TrackedFrame out = tracker.process(frame);
        cpu_ms.push_back(1e3 * (threadCpuSeconds() - cpu_start));
        total_ms.push_back(out.stats.total_ms);
        preprocess_ms.push_back(out.stats.preprocess_ms);
        klt_ms.push_back(out.stats.klt_ms);
        ransac_ms.push_back(out.stats.ransac_ms);
        detect_ms.push_back(out.stats.detect_ms);
        features += static_cast<long>(out.features.size());
        detected += out.stats.detected;
        lost_klt += out.stats.lost_klt;
        rejected_fb += out.stats.rejected_fb;
        rejected_ransac += out.stats.rejected_ransac;
        mix(&checksum, static_cast<int>(out.status));
        for (const vims::TrackedFeature& f : out.features) {
          mix(&checksum, f.id);
          mix(&checksum, f.pixel.x());
          mix(&checksum, f.pixel.y());
        }
      }
      double cpu_s = 0.0;
      for (double ms : cpu_ms) cpu_s += 1e-3 * ms;
      if (pass == 0 || cpu_s < best_cpu_s) best_cpu_s = cpu_s;
      const double n = static_cast<double>(frames.size());
      std::cout << std::fixed << std::setprecision(3) << "pass " << pass + 1 << ": cpu ms/frame " << 1e3 * cpu_s / n
                << " (p50 " << percentile(cpu_ms, 0.5) << ", p99 " << percentile(cpu_ms, 0.99) << ")"
                << "; wall ms p50: preprocess " << percentile(preprocess_ms, 0.5) << ", klt " << percentile(klt_ms, 0.5)
                << ", ransac " << percentile(ransac_ms, 0.5) << ", detect " << percentile(detect_ms, 0.5) << ", total "
                << percentile(total_ms, 0.5) << "\n";
      if (pass == 0) {
        std::cout << "tracks: frames " << frames.size() << ", features/frame " << std::setprecision(2) << features / n
                  << ", detected " << detected << ", lost_klt " << lost_klt << ", rejected_fb " << rejected_fb
                  << ", rejected_ransac " << rejected_ransac << ", checksum " << std::hex << checksum << std::dec
                  << "\n";
      }
    }
    std::cout << std::fixed << std::setprecision(3) << "BENCH_TRACKER frames=" << frames.size()
              << " cpu_ms_per_frame=" << 1e3 * best_cpu_s / static_cast<double>(frames.size()) << "\n";
  } catch (const std::exception& e) {
    std::cerr << "bench_vims_tracker: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
