#include "vims_sim/sequence_generator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <filesystem>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <thread>
#include <vector>

#include "vims_common/sequence_paths.h"
#include "vims_common/trajectory_io.h"
#include "vims_sim/random.h"
#include "vims_sim/seabed_renderer.h"

namespace vims {
namespace sim {
namespace {

enum : uint64_t {
  kStreamImuNoise = 0x1a0,
  kStreamSonarNoise = 0x50a,
  kStreamMagNoise = 0x3a6,
  kStreamCameraNoise = 0xca3,
  kStreamPressureNoise = 0x9e5,
};

constexpr int kCornerStride = 5;  // count corners on every 5th lit frame (cheap, still a robust median)

struct FrameJob {
  int64_t index = 0;  ///< frame number k (exposure at k * period)
  int64_t t_ns = 0;   ///< true exposure time from the sequence start
  bool lamp_on = true;
  bool count_corners = false;
};

struct RenderedFrame {
  cv::Mat image;
  int corners = -1;  ///< -1: not counted
};

/// Renders frames on worker threads at most `max_ahead` frames ahead of the consumer, and
/// hands them out in order.
class FramePipeline {
 public:
  FramePipeline(const SeabedRenderer& renderer, const Trajectory& trajectory, const Eigen::Isometry3d& T_b_c,
                std::vector<FrameJob> jobs, uint64_t noise_seed, int threads)
      : renderer_(renderer),
        trajectory_(trajectory),
        T_b_c_(T_b_c),
        jobs_(std::move(jobs)),
        noise_seed_(noise_seed),
        max_ahead_(static_cast<size_t>(2 * threads + 2)) {
    for (int i = 0; i < threads; ++i) workers_.emplace_back([this] { work(); });
  }

  ~FramePipeline() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    for (auto& w : workers_) w.join();
  }

  FramePipeline(const FramePipeline&) = delete;
  FramePipeline& operator=(const FramePipeline&) = delete;

  /// The next frame in order (blocks until rendered). Rethrows a worker's exception.
  RenderedFrame next() {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [&] { return error_ || done_.count(consumed_) > 0; });
    if (error_) std::rethrow_exception(error_);
    RenderedFrame frame = std::move(done_[consumed_]);
    done_.erase(consumed_);
    ++consumed_;
    cv_.notify_all();
    return frame;
  }

 private:
  void work() {
    SeabedRenderer::Workspace workspace;
    for (;;) {
      size_t job_index;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [&] { return stop_ || (next_job_ < jobs_.size() && next_job_ < consumed_ + max_ahead_); });
        if (stop_) return;
        job_index = next_job_++;
      }
      RenderedFrame frame;
      try {
        const FrameJob& job = jobs_[job_index];
        const double t = static_cast<double>(job.t_ns) * 1e-9;
        const Eigen::Isometry3d T_w_c = trajectory_.pose(t) * T_b_c_;
        frame.image = renderer_.render(T_w_c, hashCoords(noise_seed_, job.index), job.lamp_on, workspace);
        if (job.count_corners) {
          std::vector<cv::Point2f> corners;
          cv::goodFeaturesToTrack(frame.image, corners, 300, 0.01, 15);
          frame.corners = static_cast<int>(corners.size());
        }
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!error_) error_ = std::current_exception();
        cv_.notify_all();
        return;
      }
      std::lock_guard<std::mutex> lock(mutex_);
      done_[job_index] = std::move(frame);
      cv_.notify_all();
    }
  }

  const SeabedRenderer& renderer_;
  const Trajectory& trajectory_;
  Eigen::Isometry3d T_b_c_;
  std::vector<FrameJob> jobs_;
  uint64_t noise_seed_;
  size_t max_ahead_;
  std::mutex mutex_;
  std::condition_variable cv_;
  size_t next_job_ = 0;
  size_t consumed_ = 0;
  std::map<size_t, RenderedFrame> done_;
  std::exception_ptr error_;
  bool stop_ = false;
  std::vector<std::thread> workers_;
};

int64_t periodNs(double rate_hz) { return secondsToNanoseconds(1.0 / rate_hz); }

/// The camera's exposures in [0, duration), without the frames inside a camera_off span.
std::vector<FrameJob> frameJobs(int64_t camera_period, int64_t duration_ns, const DropoutSpans& spans) {
  std::vector<FrameJob> jobs;
  for (int64_t k = 0; k * camera_period < duration_ns; ++k) {
    FrameJob job;
    job.index = k;
    job.t_ns = k * camera_period;
    const double t = static_cast<double>(job.t_ns) * 1e-9;
    if (anySpanContains(spans.camera_off, t)) continue;
    job.lamp_on = !anySpanContains(spans.camera_blackout, t);
    job.count_corners = job.lamp_on && k % kCornerStride == 0;
    jobs.push_back(job);
  }
  return jobs;
}

/// The bag's message streams. The order of the ids breaks ties between equal stamps.
enum StreamId { kImu = 0, kMag, kPose, kSonar, kPressure, kCamera, kNumStreams };

/// The streams on their nanosecond grids; the next event is the one with the smallest stamp
/// (ties: IMU, magnetometer, pose, sonar, pressure, camera).
class MessageSchedule {
 public:
  MessageSchedule(const SequenceConfig& cfg, bool has_pressure, const std::vector<FrameJob>& jobs, int64_t delay_ns,
                  int64_t duration_ns)
      : has_pressure_(has_pressure), jobs_(jobs), delay_ns_(delay_ns), duration_ns_(duration_ns) {
    grids_[kImu] = {periodNs(cfg.imu.rate_hz), 0, 0};
    grids_[kMag] = {periodNs(cfg.magnetometer.rate_hz), 0, 0};
    grids_[kPose] = {periodNs(50.0), 0, 0};
    grids_[kSonar] = {periodNs(cfg.sonar.rate_hz), periodNs(cfg.sonar.rate_hz) / 2, 0};
    if (has_pressure_) grids_[kPressure] = {periodNs(cfg.pressure->rate_hz), periodNs(cfg.pressure->rate_hz) / 4, 0};
  }

  /// The StreamId of the next message and its stamp from the sequence start (*stamp), or -1 when
  /// every stream is done.
  int next(int64_t* stamp) const {
    int best = -1;
    int64_t best_stamp = 0;
    for (int s = 0; s < kNumStreams; ++s) {
      int64_t candidate;
      if (s == kCamera) {
        if (next_frame_ >= jobs_.size()) continue;
        candidate = jobs_[next_frame_].t_ns + delay_ns_;
      } else if (s == kPressure && !has_pressure_) {
        continue;
      } else {
        const int64_t t_ns = grids_[s].phase + grids_[s].next * grids_[s].period;
        if (t_ns >= duration_ns_) continue;
        candidate = t_ns;
      }
      if (best < 0 || candidate < best_stamp) {
        best = s;
        best_stamp = candidate;
      }
    }
    *stamp = best_stamp;
    return best;
  }

  /// Consumes the next sample of a grid stream (any but the camera): its true time [ns].
  int64_t takeSample(int stream) {
    Grid& grid = grids_[stream];
    const int64_t t_ns = grid.phase + grid.next * grid.period;
    ++grid.next;
    return t_ns;
  }

  /// Consumes the next camera frame.
  const FrameJob& takeFrame() { return jobs_[next_frame_++]; }

 private:
  struct Grid {
    int64_t period = 0;
    int64_t phase = 0;
    int64_t next = 0;  ///< sample index
  };
  Grid grids_[kNumStreams];
  bool has_pressure_;
  const std::vector<FrameJob>& jobs_;
  size_t next_frame_ = 0;
  int64_t delay_ns_;
  int64_t duration_ns_;
};

/// The sensors sampled on their own grids from the trajectory (all but the camera).
struct GridSensors {
  ImuSimulator imu;
  SonarSimulator sonar;
  MagnetometerSimulator mag;
  std::optional<PressureSimulator> pressure;  ///< when the sequence has a pressure sensor
};

/// Measures grid stream `stream` (not the camera) at its true time t_ns and writes the message
/// at stamp_ns, unless the sample is inside one of the stream's dropout spans.
void writeGridSample(int stream, int64_t t_ns, int64_t stamp_ns, const SimSetup& setup, GridSensors& sensors,
                     TumWriter& tum, SimSink& sink, GenerationStats* stats) {
  const DropoutSpans& spans = setup.options.spans;
  const double t = static_cast<double>(t_ns) * 1e-9;
  if (stream == kImu) {
    const TrajectoryState state = setup.trajectory.sample(t);
    const ImuMeasurement m = sensors.imu.measure(state);  // the bias walks on during gaps too
    tum.write(static_cast<double>(stamp_ns) * 1e-9, state.p_w_b, state.q_w_b);
    if (!anySpanContains(spans.imu_gap, t)) {
      sink.imu(stamp_ns, m);
      ++stats->imu_messages;
    }
  } else if (stream == kMag) {
    Eigen::Vector3d field = sensors.mag.measure(setup.trajectory.pose(t), t);
    if (sensors.mag.hasThrusters()) field += sensors.mag.thrusterField(setup.trajectory.sample(t));
    if (!anySpanContains(spans.mag_off, t)) {
      sink.magnetometer(stamp_ns, field);
      ++stats->mag_messages;
    }
  } else if (stream == kPose) {
    sink.groundTruth(stamp_ns, setup.trajectory.pose(t));
    ++stats->pose_messages;
  } else if (stream == kSonar) {
    const SonarReading reading = sensors.sonar.measure(setup.trajectory.pose(t));
    if (!anySpanContains(spans.sonar_off, t)) {
      sink.sonar(stamp_ns, reading.range);
      ++stats->sonar_messages;
    }
  } else if (stream == kPressure) {
    const PressureReading reading = sensors.pressure->measure(setup.trajectory.pose(t));
    if (!anySpanContains(spans.pressure_off, t)) {
      sink.pressure(stamp_ns, reading.pressure);
      ++stats->pressure_messages;
    }
  }
}

/// Corner statistics of the frames whose corners were counted.
void addCornerStats(std::vector<int> corner_counts, GenerationStats* stats) {
  stats->corner_frames = static_cast<int>(corner_counts.size());
  if (!corner_counts.empty()) {
    std::sort(corner_counts.begin(), corner_counts.end());
    const size_t n = corner_counts.size();
    stats->median_corners = n % 2 ? corner_counts[n / 2] : 0.5 * (corner_counts[n / 2 - 1] + corner_counts[n / 2]);
    stats->min_corners = corner_counts.front();
  }
}

}  // namespace

int64_t secondsToNanoseconds(double seconds) { return static_cast<int64_t>(std::llround(seconds * 1e9)); }

GenerationStats generateSequence(const SimSetup& setup, SimSink& sink, const ProgressCallback& progress) {
  const auto wall_start = std::chrono::steady_clock::now();
  const SimOptions& opt = setup.options;
  const SequenceConfig& cfg = setup.config;
  const SimTruth& truth = setup.truth;

  std::filesystem::create_directories(opt.out_dir);
  const SequencePaths paths = SequencePaths::forWriting(opt.out_dir, opt.sequenceName());
  cfg.save(paths.yaml);
  truth.save(paths.truth);
  TumWriter tum(paths.gt);

  const int64_t start_ns = secondsToNanoseconds(opt.start_time);
  const int64_t duration_ns = secondsToNanoseconds(opt.duration);
  const int64_t delay_ns = secondsToNanoseconds(opt.camera_delay);

  GridSensors sensors{
      ImuSimulator(setup.imu, truth.gyro_bias, truth.accel_bias, deriveSeed(opt.seed, kStreamImuNoise)),
      SonarSimulator(setup.sonar, cfg.sonar.T_b_s, deriveSeed(opt.seed, kStreamSonarNoise), setup.terrain),
      MagnetometerSimulator(setup.magnetometer, cfg.magnetometer.T_b_m, truth.magneticWorld(),
                            deriveSeed(opt.seed, kStreamMagNoise)),
      std::nullopt};
  if (truth.thrusters) sensors.mag.setThrusters(*truth.thrusters);
  if (truth.magnetometer_iron) sensors.mag.setIron(*truth.magnetometer_iron);

  auto texture = std::make_shared<SeabedTexture>(opt.worldSeed(), setup.texture);
  const SeabedRenderer renderer(cfg.camera, texture, setup.optics, setup.terrain);
  if (cfg.pressure && truth.pressure) {
    sensors.pressure.emplace(setup.pressure, cfg.pressure->T_b_p, truth.pressure->water,
                             deriveSeed(opt.seed, kStreamPressureNoise));
  }
  const std::vector<FrameJob> jobs = frameJobs(periodNs(cfg.camera.rate_hz), duration_ns, opt.spans);
  const int threads =
      opt.render_threads > 0 ? opt.render_threads : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  FramePipeline pipeline(renderer, setup.trajectory, truth.trueCameraExtrinsic(cfg.camera.T_b_c), jobs,
                         deriveSeed(opt.seed, kStreamCameraNoise), threads);
  MessageSchedule schedule(cfg, sensors.pressure.has_value(), jobs, delay_ns, duration_ns);

  GenerationStats stats;
  std::vector<int> corner_counts;
  const int64_t progress_step = std::max<int64_t>(duration_ns / 50, 1);
  int64_t next_progress = progress_step;
  for (;;) {
    int64_t best_stamp = 0;
    const int best = schedule.next(&best_stamp);
    if (best < 0) break;
    const int64_t stamp_ns = start_ns + best_stamp;

    if (best == kCamera) {
      const RenderedFrame frame = pipeline.next();
      const FrameJob& job = schedule.takeFrame();
      sink.image(stamp_ns, frame.image);
      ++stats.image_messages;
      if (!job.lamp_on) ++stats.blackout_frames;
      if (frame.corners >= 0) corner_counts.push_back(frame.corners);
    } else {
      const int64_t t_ns = schedule.takeSample(best);
      writeGridSample(best, t_ns, stamp_ns, setup, sensors, tum, sink, &stats);
    }
    if (progress && best_stamp >= next_progress) {
      next_progress += progress_step;
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
      progress(static_cast<double>(best_stamp) * 1e-9, opt.duration, wall);
    }
  }
  tum.flush();

  stats.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  stats.realtime_factor = opt.duration / std::max(stats.wall_seconds, 1e-9);
  addCornerStats(std::move(corner_counts), &stats);
  stats.tiles_generated = texture->tilesGenerated();
  return stats;
}

}  // namespace sim
}  // namespace vims
