#include "offline_pipeline.h"

#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstddef>
#include <cstdio>
#include <deque>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <mutex>
#include <numeric>
#include <optional>
#include <sstream>

#include "vims_common/config_reader.h"
#include "vims_common/timing.h"

namespace fs = std::filesystem;

namespace vims {

/// The format of `seabed.csv` (docs/offline_outputs.md): the VIO's body height, the seabed it
/// estimates under the vehicle and the factors that tie them, 10 significant digits, NaN without
/// a seabed estimate.
struct SeabedCsv {
  using Row = VioFrameResult;
  static const char* header() { return "t,body_z,seabed_z,slope_x,slope_y,sonar_factors,pressure_factors"; }
  static std::string row(const VioFrameResult& r) {
    std::ostringstream row;
    row << std::setprecision(10) << r.t_stamp << ',' << r.T_odom_b.translation().z() << ','
        << (r.seabed_height ? *r.seabed_height : std::numeric_limits<double>::quiet_NaN()) << ',' << r.seabed_slope.x()
        << ',' << r.seabed_slope.y() << ',' << r.sonar_factors << ',' << r.pressure_factors;
    return row.str();
  }
};

namespace {

/// Progress on stderr: a rewriting line on a terminal, a line every 10 % otherwise (CI logs).
class ProgressPrinter {
 public:
  explicit ProgressPrinter(bool enabled) : enabled_(enabled), tty_(isatty(STDERR_FILENO)) {}
  void update(double fraction, double wall_s, double seq_s) {
    if (!enabled_) return;
    const int percent = static_cast<int>(std::floor(100.0 * fraction));
    if (tty_) {
      if (percent == last_percent_) return;
      std::fprintf(stderr, "\r[vims_offline] %3d %%  %.1f s of sequence in %.1f s wall (%.1fx real time)", percent,
                   seq_s, wall_s, wall_s > 0 ? seq_s / wall_s : 0.0);
      if (percent >= 100) std::fprintf(stderr, "\n");
    } else {
      if (percent / 10 == last_percent_ / 10) return;
      std::fprintf(stderr, "[vims_offline] %3d %%  %.1f s of sequence in %.1f s wall\n", percent, seq_s, wall_s);
    }
    last_percent_ = percent;
  }

 private:
  bool enabled_;
  bool tty_;
  int last_percent_ = -1;
};

using Clock = std::chrono::steady_clock;

}  // namespace

/// Runs VioSystem::track on the camera frames one at a time, in submission order, on a
/// SerialWorker: with a thread, submit() returns at once and up to kFramesInFlight frames are
/// tracked while the caller goes on; take() returns the oldest. Without one, submit() tracks
/// inline. The tracker's state depends on its input images only, so both give the same
/// TrackedFrames.
class OfflinePipeline::TrackerWorker {
 public:
  using Result = TrackedResult;
  /// Frames submitted and not yet taken before onImage() hands the oldest to the estimator.
  /// Several rather than one let the tracker run ahead through the estimator's slow frames
  /// (marginalisation at keyframes) instead of waiting for it at every frame.
  static constexpr std::size_t kFramesInFlight = 3;

  TrackerWorker(VioSystem* vio, bool threaded) : vio_(vio), worker_(threaded, kFramesInFlight) {}

  /// Frames submitted and not yet taken.
  std::size_t pending() const { return pending_; }

  /// Queues `frame` for tracking (tracks it at once without a thread).
  void submit(const CameraFrame& frame) {
    ++pending_;
    worker_.submit([this, frame] {
      Result job;
      job.frame = frame;
      try {
        const Clock::time_point start = Clock::now();
        const double cpu_start = threadCpuSeconds();
        job.tracked = vio_->track(job.frame);  // the tracker is used by the worker only
        job.ms = millisecondsSince(start);
        job.cpu_s = threadCpuSeconds() - cpu_start;
      } catch (...) {
        job.error = std::current_exception();
      }
      {
        std::lock_guard<std::mutex> lock(mutex_);
        done_.push_back(std::move(job));
      }
      ready_.notify_all();
    });
  }

  /// Waits for the oldest submitted frame and returns it with its tracking result (rethrows what
  /// the tracker threw on it).
  Result take() {
    --pending_;
    Result result;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      ready_.wait(lock, [this] { return !done_.empty(); });
      result = std::move(done_.front());
      done_.pop_front();
    }
    if (result.error) std::rethrow_exception(result.error);
    return result;
  }

 private:
  VioSystem* vio_;
  std::size_t pending_ = 0;  ///< caller side only
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<Result> done_;  ///< tracked, in submission order, not yet taken
  SerialWorker worker_;      ///< last: its thread stops before the members above go
};

OfflinePipeline::OfflinePipeline(const OfflineOptions& options, LoggerPtr logger)
    : options_(options), logger_(std::move(logger)) {
  paths_ = SequencePaths::resolve(options_.sequence_dir);
  std::vector<std::string> unknown;
  sequence_ = SequenceConfig::load(paths_.yaml, &unknown);
  for (const auto& key : unknown)
    logger_->warn("offline", paths_.yaml + ": ignoring key '" + key + "' (not in the sensor contract)");
  config_ = SystemConfig::load(options_.config_paths, sequence_);
  config_.applyMode(options_.mode);
  if (!options_.map_mode.empty()) config_.pose_graph.map_mode = mapModeFromString(options_.map_mode);
  if (config_.pose_graph.map_mode != MapMode::kMapping && options_.map_load.empty())
    throw ConfigError("pose_graph.map_mode: " + toString(config_.pose_graph.map_mode) +
                      " uses a loaded map: give --map-load (or map_mode: mapping)");
  // The offline runner must be deterministic: the pose graph works inline in the feed calls.
  config_.pose_graph.synchronous = true;
  std::error_code ec;
  fs::create_directories(options_.out_dir, ec);
  if (ec || !fs::is_directory(options_.out_dir)) {
    throw std::runtime_error("cannot create output directory '" + options_.out_dir + "': " + ec.message());
  }
  const fs::path out(options_.out_dir);
  sonar_filter_ = std::make_unique<SonarAltitudeFilter>(config_.sonar, sequence_.sonar, logger_);
  magnetic_front_end_ =
      std::make_unique<MagneticFrontEnd>(config_.magnetometer, sequence_.magnetometer, sequence_.imu.gravity, logger_);
  sonar_csv_ = std::make_unique<SonarCsvWriter>((out / "sonar_filtered.csv").string());
  signature_csv_ = std::make_unique<SignatureCsvWriter>((out / "mag_signatures.csv").string());
  if (options_.threads != 1 && options_.threads != 2) {
    throw std::runtime_error("threads must be 1 or 2, got " + std::to_string(options_.threads));
  }
  vio_ = std::make_unique<VioSystem>(sequence_, config_, logger_);
  tracker_worker_ = std::make_unique<TrackerWorker>(vio_.get(), options_.threads == 2);
  vio_tum_ = std::make_unique<TumWriter>((out / "vio.tum").string());
  seabed_csv_ = std::make_unique<CsvWriter<SeabedCsv>>((out / "seabed.csv").string());
  if (options_.vio_only) {
    if (!options_.map_load.empty() || !options_.map_save.empty())
      throw std::runtime_error("--vio-only runs no pose graph: it takes no map to load or save");
    return;
  }
  pose_graph_ = std::make_unique<PoseGraphManager>(
      config_.pose_graph, sequence_, PoseGraphManager::loadVocabulary(config_.pose_graph, options_.package_root),
      logger_);
  if (!options_.map_load.empty()) pose_graph_->loadMap(options_.map_load);
  // 100 queued tasks: at most ~25 keyframes (with their images) in flight; signatures and
  // geomagnetic samples make up the rest.
  pose_graph_worker_ = std::make_unique<SerialWorker>(options_.threads == 2, 100);
  loops_csv_ = std::make_unique<LoopCsvWriter>((out / "loops.csv").string());
}

OfflinePipeline::~OfflinePipeline() = default;

template <typename Call>
void OfflinePipeline::timePoseGraph(bool is_keyframe, Call&& call) {
  const Clock::time_point start = Clock::now();
  call();
  const double ms = millisecondsSince(start);
  const std::size_t optimisations = pose_graph_->stats().optimisations;
  if (optimisations != pose_graph_optimisations_seen_) {
    // The call's solves are timed one by one; the rest of the call (description, detection)
    // stays in its own bucket.
    pose_graph_optimisations_seen_ = optimisations;
    const PoseGraphTimings timings = pose_graph_->timings(pose_graph_solves_seen_);
    double solve_ms = 0.0;
    for (const OptimisationRecord& solve : timings.solves) {
      pose_graph_optimisation_ms_.add(solve.solve_ms);
      solve_ms += solve.solve_ms;
    }
    pose_graph_solves_seen_ += timings.solves.size();
    if (is_keyframe)
      place_recognition_ms_.add(std::max(0.0, ms - solve_ms));
    else
      pose_graph_other_ms_ += std::max(0.0, ms - solve_ms);
  } else if (is_keyframe) {
    place_recognition_ms_.add(ms);
  } else {
    pose_graph_other_ms_ += ms;
  }
}

void OfflinePipeline::onImu(const ImuSample& sample) {
  magnetic_front_end_->feedImu(sample);
  const double cpu_start = threadCpuSeconds();
  vio_->feedImu(sample);
  backend_cpu_s_ += threadCpuSeconds() - cpu_start;
  drainEstimator();
}

void OfflinePipeline::onImage(const CameraFrame& frame) {
  // Freed pages of the three threads' arenas back to the OS once a minute of bag time: with a map
  // that has stopped growing, the resident set then stops too (bench/soak.py). No output changes.
  heap_release_.tick(frame.t);
  // Frame k reaches the estimator when frame k+N arrives (N = kFramesInFlight; or at the end of
  // the bag), after every message recorded before that: a fixed point of the message stream, so
  // the outputs do not depend on how long the tracker takes, while frames k+1..k+N are tracked
  // during frame k's back end.
  std::optional<TrackerWorker::Result> oldest;
  if (tracker_worker_->pending() >= TrackerWorker::kFramesInFlight) oldest = tracker_worker_->take();
  tracker_worker_->submit(frame);
  if (oldest) feedTracked(*oldest);
}

void OfflinePipeline::feedTracked(const TrackedResult& tracked) {
  frontend_ms_.add(tracked.ms);
  frontend_cpu_s_ += tracked.cpu_s;
  const double cpu_start = threadCpuSeconds();
  vio_->feedTracked(tracked.tracked, tracked.frame.image);
  backend_cpu_s_ += threadCpuSeconds() - cpu_start;
  drainEstimator();
}

void OfflinePipeline::feedTrackedFrames() {
  while (tracker_worker_->pending() > 0) feedTracked(tracker_worker_->take());
}

void OfflinePipeline::drainEstimator() {
  VioOutputs outputs = vio_->takeOutputs();
  for (const double ms : outputs.backend_ms) backend_ms_.add(ms);
  for (const double t : outputs.non_finite_stamps) {
    logger_->warnThrottled("offline", "non_finite", t, 5.0,
                           VIMS_STR("the VIO frame at t=" << t << " has a non-finite state: left out of vio.tum"));
  }
  for (const VioFrameResult& r : outputs.poses) {
    writeVioTumRow(vio_tum_.get(), r);
    seabed_csv_->write(r);
    ++vio_frames_;
  }
  for (KeyframeData& keyframe : outputs.keyframes) {
    ++vio_keyframes_;
    if (!pose_graph_) continue;
    keyframe.image = keyframe.image.clone();  // the task may run after the frame's buffer is reused
    pose_graph_worker_->submit([this, keyframe = std::move(keyframe)] {
      timePoseGraph(true, [&] { pose_graph_->feedKeyframe(keyframe); });
      drainLoopAttempts();
    });
  }
}

void OfflinePipeline::drainLoopAttempts() {
  for (const LoopAttempt& attempt : pose_graph_->takeNewLoopAttempts()) loops_csv_->write(attempt);
}

void OfflinePipeline::onSonar(const SonarRange& range) {
  sonar_results_.clear();
  sonar_filter_->feed(range, &sonar_results_);
  for (const auto& result : sonar_results_) {
    sonar_csv_->write(result);
    vio_->feedSonar(result);
  }
}

void OfflinePipeline::onPressure(const PressureSample& sample) { vio_->feedPressure(sample); }

void OfflinePipeline::onMag(const MagSample& sample) {
  signature_windows_.clear();
  geomagnetic_samples_.clear();
  const Clock::time_point start = Clock::now();
  magnetic_front_end_->feedMag(sample, &signature_windows_, &geomagnetic_samples_);
  magnetometer_ms_.add(millisecondsSince(start));
  for (const auto& window : signature_windows_) {
    signature_csv_->write(window);
    if (!pose_graph_) continue;
    pose_graph_worker_->submit([this, window] {
      timePoseGraph(false, [&] { pose_graph_->feedSignature(window); });
      drainLoopAttempts();
    });
  }
  for (const auto& geomagnetic : geomagnetic_samples_) {
    if (!pose_graph_) break;
    pose_graph_worker_->submit([this, geomagnetic] {
      timePoseGraph(false, [&] { pose_graph_->feedGeomagnetic(geomagnetic.t, geomagnetic.field_b); });
    });
  }
}

void OfflinePipeline::finishPoseGraph(OfflineSummary* summary) {
  pose_graph_worker_->submit([this] {
    timePoseGraph(false, [&] { pose_graph_->finish(); });
    drainLoopAttempts();
  });
  pose_graph_worker_->wait();
  loops_csv_->flush();
  {
    // global.tum: the final optimised body pose of every keyframe of this run, world frame.
    TumWriter global_tum((fs::path(options_.out_dir) / "global.tum").string());
    for (const KeyframePose& pose : pose_graph_->keyframePoses()) {
      global_tum.write(pose.t, pose.T_w_b.translation(), Eigen::Quaterniond(pose.T_w_b.linear()));
    }
    global_tum.flush();
  }
  if (!options_.map_load.empty()) {
    // map_global.tum: the loaded map's keyframes where the joint graph left them (their times on
    // the teach run's clock), to see whether the repeat run moved the map.
    TumWriter map_tum((fs::path(options_.out_dir) / "map_global.tum").string());
    for (const KeyframePose& pose : pose_graph_->keyframePoses(true)) {
      if (pose.loaded) map_tum.write(pose.t, pose.T_w_b.translation(), Eigen::Quaterniond(pose.T_w_b.linear()));
    }
    map_tum.flush();
  }
  if (!options_.map_save.empty()) pose_graph_->saveMap(options_.map_save);
  summary->pose_graph = pose_graph_->stats();
  const std::vector<double> loop_correction_ms = pose_graph_->timings(pose_graph_solves_seen_).loop_correction_ms;
  // 0 without loops: the summary's figures stay numbers.
  summary->loop_correction_ms_p50 = loop_correction_ms.empty() ? 0.0 : percentile(loop_correction_ms, 0.5);
  summary->loop_correction_ms_p99 = loop_correction_ms.empty() ? 0.0 : percentile(loop_correction_ms, 0.99);
}

OfflineSummary OfflinePipeline::run() {
  SequenceBagReader reader(paths_.bag, sequence_);
  // Camera and IMU carry the odometry: without them there is nothing to run. Sonar and
  // magnetometer only improve it: their absence is worth a warning, not a failure.
  reader.requireTopic(sequence_.topics.image);
  reader.requireTopic(sequence_.topics.imu);
  for (const std::string& topic : reader.missingTopics()) {
    logger_->warn("offline", "the bag has no '" + topic + "' messages: running without that sensor");
  }
  const auto wall_start = std::chrono::steady_clock::now();
  auto wall_seconds = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  };
  ProgressPrinter progress(options_.show_progress);
  const double span = reader.endTime() - reader.startTime();

  SequenceBagReader::Handlers handlers;
  handlers.imu = [this](const ImuSample& s) { onImu(s); };
  handlers.image = [this](const CameraFrame& f) { onImage(f); };
  handlers.sonar = [this](const SonarRange& r) { onSonar(r); };
  handlers.mag = [this](const MagSample& m) { onMag(m); };
  handlers.pressure = [this](const PressureSample& p) { onPressure(p); };
  handlers.rejected = [this](const std::string& topic, double t, const std::string& why) {
    logger_->warnThrottled("offline", "reject" + topic, t, 5.0, "dropping a message on " + topic + ": " + why);
  };
  handlers.progress = [&](double fraction) { progress.update(fraction, wall_seconds(), fraction * span); };

  OfflineSummary summary;
  summary.sequence_name = paths_.name;
  summary.topics = reader.run(handlers);
  feedTrackedFrames();  // the last frames
  sonar_results_.clear();
  sonar_filter_->flush(&sonar_results_);
  for (const auto& result : sonar_results_) sonar_csv_->write(result);
  sonar_csv_->flush();
  drainEstimator();
  vio_tum_->flush();
  seabed_csv_->flush();
  if (pose_graph_) finishPoseGraph(&summary);
  summary.frontend_ms_p50 = frontend_ms_.percentile(0.5);
  summary.frontend_ms_p99 = frontend_ms_.percentile(0.99);
  summary.backend_ms_p50 = backend_ms_.percentile(0.5);
  summary.backend_ms_p99 = backend_ms_.percentile(0.99);
  summary.magnetometer_ms_p50 = magnetometer_ms_.percentile(0.5);
  summary.magnetometer_ms_p99 = magnetometer_ms_.percentile(0.99);
  summary.place_recognition_ms_p50 = place_recognition_ms_.percentile(0.5);
  summary.place_recognition_ms_p99 = place_recognition_ms_.percentile(0.99);
  summary.pose_graph_optimisation_ms_p50 = pose_graph_optimisation_ms_.percentile(0.5);
  summary.pose_graph_optimisation_ms_p99 = pose_graph_optimisation_ms_.percentile(0.99);
  summary.pose_graph_optimisation_calls = static_cast<long>(pose_graph_optimisation_ms_.count());
  summary.frontend_total_s = 1e-3 * frontend_ms_.sum();
  summary.backend_total_s = 1e-3 * backend_ms_.sum();
  summary.magnetometer_total_s = 1e-3 * magnetometer_ms_.sum();
  summary.pose_graph_total_s =
      1e-3 * place_recognition_ms_.sum() + 1e-3 * pose_graph_optimisation_ms_.sum() + 1e-3 * pose_graph_other_ms_;
  summary.threads = options_.threads;
  summary.frontend_cpu_s = frontend_cpu_s_;
  summary.backend_cpu_s = backend_cpu_s_;
  summary.vio_cpu_real_time_factor =
      frontend_cpu_s_ + backend_cpu_s_ > 0 ? span / (frontend_cpu_s_ + backend_cpu_s_) : 0.0;
  summary.vio_frames = vio_frames_;
  summary.vio_keyframes = vio_keyframes_;
  summary.vio_resets = vio_->estimator().resets();  // also resets from IMU input (gap, clock)
  summary.vio_sessions = vio_->estimator().session() + 1;
  summary.vio_td_s = vio_->estimator().td();
  if (vio_->estimator().options().estimate_extrinsic)
    summary.vio_extrinsic = extrinsicChange(sequence_.camera.T_b_c, vio_->estimator().extrinsicCamera());
  signature_csv_->flush();
  summary.sonar = sonar_filter_->stats();
  summary.magnetometer = magnetic_front_end_->stats();
  summary.coil_frequency_hz = magnetic_front_end_->coilFrequency();
  summary.wall_time_s = wall_seconds();
  summary.sequence_duration_s = span;
  summary.real_time_factor = summary.wall_time_s > 0 ? span / summary.wall_time_s : 0.0;
  const double vio_s = summary.frontend_total_s + summary.backend_total_s;
  summary.vio_real_time_factor = vio_s > 0 ? span / vio_s : 0.0;
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) == 0) summary.peak_rss_mb = static_cast<double>(usage.ru_maxrss) / 1024.0;  // KiB
  summary.cpu_total_s = processCpuSeconds();
  summary.cpu_per_sequence_s = span > 0 ? summary.cpu_total_s / span : 0.0;
  // Where the resident memory is (glibc, all arenas): what the program holds, and what it freed
  // but the allocator keeps (fragmentation), so a soak can tell growth from retention.
  const struct mallinfo2 heap = mallinfo2();
  summary.heap_in_use_mb = static_cast<double>(heap.uordblks + heap.hblkhd) / (1024.0 * 1024.0);
  summary.heap_free_retained_mb = static_cast<double>(heap.fordblks) / (1024.0 * 1024.0);
  writeSummary(summary);
  return summary;
}

void OfflinePipeline::writeSummary(const OfflineSummary& s) const {
  const std::string path = (fs::path(options_.out_dir) / "summary.yaml").string();
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
  out << std::setprecision(10);
  out << "# vims_offline run summary (columns and files: docs/offline_outputs.md)\n";
  out << "sequence: " << s.sequence_name << "\n";
  out << "sequence_dir: " << fs::absolute(options_.sequence_dir).string() << "\n";
  std::string config_files;
  for (const std::string& path : options_.config_paths) config_files += (config_files.empty() ? "" : " ") + path;
  out << "config: " << (config_files.empty() ? "built-in defaults" : config_files) << "\n";
  out << "wall_time_s: " << s.wall_time_s << "\n";
  out << "sequence_duration_s: " << s.sequence_duration_s << "\n";
  out << "real_time_factor: " << s.real_time_factor << "\n";
  out << "vio_real_time_factor: " << s.vio_real_time_factor << "\n";
  out << "threads: " << s.threads << "\n";
  out << "peak_rss_mb: " << s.peak_rss_mb << "\n";
  out << "heap_mb: {in_use: " << s.heap_in_use_mb << ", free_retained: " << s.heap_free_retained_mb << "}\n";
  out << "sonar_filter: {samples: " << s.sonar.samples << ", accepted: " << s.sonar.accepted
      << ", outliers: " << s.sonar.outliers << ", dropouts: " << s.sonar.dropouts
      << ", warming_up: " << s.sonar.warming_up << ", resets: " << s.sonar.resets << "}\n";
  out << "magnetometer: {samples: " << s.magnetometer.mag_samples << ", windows: " << s.magnetometer.windows
      << ", valid_windows: " << s.magnetometer.valid_windows << ", resets: " << s.magnetometer.resets
      << ", nonfinite: " << s.magnetometer.nonfinite << ", duplicates: " << s.magnetometer.duplicates
      << ", coil_frequency_hz: " << s.coil_frequency_hz << ", tracked_frequency_hz: " << s.magnetometer.frequency_hz
      << "}\n";
  out << "mode: " << options_.mode << (options_.vio_only ? "\nvio_only: true" : "") << "\n";
  out << "vio: {frames: " << s.vio_frames << ", keyframes: " << s.vio_keyframes << ", resets: " << s.vio_resets
      << ", sessions: " << s.vio_sessions << ", td_s: " << s.vio_td_s << "}\n";
  if (!s.vio_extrinsic.empty()) out << "vio_extrinsic: \"" << s.vio_extrinsic << "\"\n";
  const PoseGraphManagerStats& pg = s.pose_graph;
  out << "pose_graph: {keyframes: " << pg.keyframes << ", empty_keyframes: " << pg.empty_keyframes
      << ", culled_submaps: " << pg.culled_submaps << ", localisation_keyframes: " << pg.localisation_keyframes
      << ", localisation_skipped_queries: " << pg.localisation_skipped_queries
      << ", thinned_places: " << pg.thinned_places << ", sessions: " << pg.sessions
      << ", loop_queries: " << pg.loop_queries << ", loop_attempts: " << pg.loop_attempts
      << ", loops_accepted: " << pg.loops_accepted << ", yaw_factors: " << pg.yaw_factors
      << ", yaw_rejected: " << pg.yaw_rejected
      << ", vehicle_field_taken_out: " << (pg.vehicle_field_taken_out ? "true" : "false")
      << ", vehicle_field_explained: " << pg.vehicle_field_explained << ", magnetic_submaps: " << pg.magnetic_submaps
      << ", optimisations: " << pg.optimisations << ", relocalised: " << (pg.relocalised ? "true" : "false");
  if (pg.relocalised) {
    char stamp[32];  // a stamp needs its milliseconds, beyond the stream's 10 significant digits
    std::snprintf(stamp, sizeof(stamp), "%.3f", pg.relocalised_t);
    out << ", relocalised_t: " << stamp;
  }
  out << ", map_mode: " << toString(config_.pose_graph.map_mode) << ", loops_into_map: " << pg.loops_into_map;
  out << "}\n";
  out << "latency_ms: {frontend_p50: " << s.frontend_ms_p50 << ", frontend_p99: " << s.frontend_ms_p99
      << ", backend_p50: " << s.backend_ms_p50 << ", backend_p99: " << s.backend_ms_p99
      << ", magnetometer_p50: " << s.magnetometer_ms_p50 << ", magnetometer_p99: " << s.magnetometer_ms_p99
      << ", place_recognition_p50: " << s.place_recognition_ms_p50
      << ", place_recognition_p99: " << s.place_recognition_ms_p99
      << ", pose_graph_optimisation_p50: " << s.pose_graph_optimisation_ms_p50
      << ", pose_graph_optimisation_p99: " << s.pose_graph_optimisation_ms_p99
      << ", loop_correction_p50: " << s.loop_correction_ms_p50 << ", loop_correction_p99: " << s.loop_correction_ms_p99
      << "}\n";
  out << "stage_total_s: {frontend: " << s.frontend_total_s << ", backend: " << s.backend_total_s
      << ", magnetometer: " << s.magnetometer_total_s << ", pose_graph: " << s.pose_graph_total_s
      << ", pose_graph_optimisations: " << s.pose_graph_optimisation_calls << "}\n";
  out << "vio_cpu_s: {frontend: " << s.frontend_cpu_s << ", backend: " << s.backend_cpu_s
      << ", real_time_factor: " << s.vio_cpu_real_time_factor << "}\n";
  out << "cpu_s: {total: " << s.cpu_total_s << ", per_sequence_s: " << s.cpu_per_sequence_s << "}\n";
  out << "messages:\n";
  for (const auto& [topic, stats] : s.topics) {
    out << "  " << topic << ": {type: " << stats.type << ", count: " << stats.messages
        << ", rejected: " << stats.rejected << "}\n";
  }
}

}  // namespace vims
