// The front end on a simulated sequence (CTest fixture sim_tank30, see test/CMakeLists.txt):
// feature counts and track lengths are asserted, the per-frame latency is reported.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <vector>

#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_ros/sequence_bag_reader.h"
#include "vims_tracking/feature_tracker.h"

namespace {

template <typename T>
T percentile(std::vector<T> values, double fraction) {
  if (values.empty()) return T();
  std::sort(values.begin(), values.end());
  const std::size_t index = std::min(values.size() - 1, static_cast<std::size_t>(fraction * (values.size() - 1) + 0.5));
  return values[index];
}

/// Directory of a generated sequence, or "" when the test data location is not set.
std::string sequenceDir(const std::string& name) {
  const char* root = std::getenv("VIMS_TEST_DATA");
  if (!root || !*root) return "";
  return (std::filesystem::path(root) / name).string();
}

}  // namespace

TEST(TrackerOnSequence, Tank30KeepsEnoughLongTracks) {
  const std::string dir = sequenceDir("tank30");
  if (dir.empty()) GTEST_SKIP() << "VIMS_TEST_DATA is not set (run through ctest, fixture sim_tank30)";
  const vims::SequencePaths paths = vims::SequencePaths::resolve(dir);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths.yaml);

  vims::FeatureTracker tracker(config.camera, vims::TrackerOptions(),
                               vims::Logger::stderrLogger(vims::LogLevel::kWarn));
  std::vector<int> features_per_frame;
  std::vector<double> latency_ms, preprocess_ms, klt_ms, ransac_ms, detect_ms;
  std::map<std::uint64_t, int> track_length_by_id;
  std::map<vims::FrameStatus, int> status_count;
  long rejected_fb = 0, rejected_ransac = 0, lost_klt = 0, detected = 0;

  vims::SequenceBagReader reader(paths.bag, config);
  vims::SequenceBagReader::Handlers handlers;
  handlers.image = [&](const vims::CameraFrame& frame) {
    const vims::TrackedFrame out = tracker.process(frame);
    ++status_count[out.status];
    if (!out.accepted()) return;
    features_per_frame.push_back(static_cast<int>(out.features.size()));
    latency_ms.push_back(out.stats.total_ms);
    preprocess_ms.push_back(out.stats.preprocess_ms);
    klt_ms.push_back(out.stats.klt_ms);
    ransac_ms.push_back(out.stats.ransac_ms);
    detect_ms.push_back(out.stats.detect_ms);
    for (const vims::TrackedFeature& f : out.features) {
      track_length_by_id[f.id] = std::max(track_length_by_id[f.id], f.track_length);
    }
    rejected_fb += out.stats.rejected_fb;
    rejected_ransac += out.stats.rejected_ransac;
    lost_klt += out.stats.lost_klt;
    detected += out.stats.detected;
  };
  reader.run(handlers);

  ASSERT_GE(features_per_frame.size(), 250u) << "30 s at 10 Hz";
  std::vector<int> track_lengths;
  for (const auto& [id, length] : track_length_by_id) track_lengths.push_back(length);

  const int median_features = percentile(features_per_frame, 0.5);
  const int median_track_length = percentile(track_lengths, 0.5);
  const double latency_p50 = percentile(latency_ms, 0.5);
  const double latency_p99 = percentile(latency_ms, 0.99);
  std::cout << std::fixed << std::setprecision(2) << "[tank30] frames " << features_per_frame.size()
            << ", features/frame p10/p50/p90 " << percentile(features_per_frame, 0.1) << "/" << median_features << "/"
            << percentile(features_per_frame, 0.9) << ", tracks " << track_lengths.size() << ", track length p50/p90 "
            << median_track_length << "/" << percentile(track_lengths, 0.9) << ", detected " << detected
            << ", lost KLT " << lost_klt << ", rejected FB " << rejected_fb << ", rejected RANSAC " << rejected_ransac
            << ", latency ms p50/p99/max " << latency_p50 << "/" << latency_p99 << "/" << percentile(latency_ms, 1.0)
            << std::endl;
  std::cout << "[tank30] stage p50 ms: preprocess " << percentile(preprocess_ms, 0.5) << ", KLT "
            << percentile(klt_ms, 0.5) << ", RANSAC " << percentile(ransac_ms, 0.5) << ", detection "
            << percentile(detect_ms, 0.5) << std::endl;
  for (const auto& [status, count] : status_count) {
    std::cout << "[tank30] status " << vims::frameStatusName(status) << ": " << count << std::endl;
  }
  RecordProperty("median_features_per_frame", median_features);
  RecordProperty("median_track_length", median_track_length);
  RecordProperty("latency_ms_p50", std::to_string(latency_p50));
  RecordProperty("latency_ms_p99", std::to_string(latency_p99));

  EXPECT_GE(median_features, 100);
  EXPECT_GE(median_track_length, 5);
}

TEST(TrackerOnSequence, BlackoutEndsTracksAndRecovers) {
  // Sequence with the lamp failing for t in [4, 6) s (black frames with sensor noise) and no
  // images at all for [7, 7.5) s, see vims_tracking/CMakeLists.txt.
  const std::string dir = sequenceDir("tank_blackout10");
  if (dir.empty()) GTEST_SKIP() << "VIMS_TEST_DATA is not set (run through ctest, fixture sim_tank_blackout10)";
  const vims::SequencePaths paths = vims::SequencePaths::resolve(dir);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths.yaml);
  vims::FeatureTracker tracker(config.camera, vims::TrackerOptions());
  vims::SequenceBagReader reader(paths.bag, config);

  struct FrameSummary {
    double t;
    vims::FrameStatus status;
    int features;
    int tracked;
  };
  std::vector<FrameSummary> frames;
  vims::SequenceBagReader::Handlers handlers;
  handlers.image = [&](const vims::CameraFrame& frame) {
    const vims::TrackedFrame out = tracker.process(frame);
    frames.push_back(
        {frame.t - reader.startTime(), out.status, static_cast<int>(out.features.size()), out.stats.tracked});
  };
  reader.run(handlers);
  ASSERT_GE(frames.size(), 80u);

  int blank = 0;
  for (const FrameSummary& f : frames) {
    const bool in_blackout = f.t >= 4.0 + 1e-6 && f.t < 6.0 - 1e-6;
    if (in_blackout) {
      EXPECT_EQ(f.status, vims::FrameStatus::kBlank) << "t=" << f.t;
      EXPECT_EQ(f.features, 0) << "t=" << f.t;
      ++blank;
    } else if (f.t < 3.95 || f.t > 6.35) {
      // Outside the blackout (and a few frames after it to rebuild), the budget is kept.
      EXPECT_TRUE(f.status == vims::FrameStatus::kTracked || f.status == vims::FrameStatus::kStarted) << "t=" << f.t;
      EXPECT_GE(f.features, 100) << "t=" << f.t;
    }
  }
  EXPECT_GE(blank, 18);
  // The first frame after the blackout starts afresh, the next ones track again.
  const auto after =
      std::find_if(frames.begin(), frames.end(), [](const FrameSummary& f) { return f.t >= 6.0 - 1e-6; });
  ASSERT_NE(after, frames.end());
  EXPECT_EQ(after->status, vims::FrameStatus::kStarted);
  ASSERT_NE(after + 1, frames.end());
  EXPECT_EQ((after + 1)->status, vims::FrameStatus::kTracked);
  EXPECT_GE((after + 1)->tracked, 100);
}
