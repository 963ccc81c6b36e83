#pragma once
/// @file offline_pipeline.h
/// @brief The whole VIMS system in one process, driven message by message from a bag.
///
/// The offline runner feeds every message of a sequence, in recorded order (the order
/// `rosbag play` publishes them), into the same core libraries the ROS nodes wrap, wired the
/// same way the launch files wire the nodes. It runs as fast as the CPU allows and, being
/// single-threaded and driven only by bag data, is deterministic: two runs give identical files.

#include <exception>
#include <map>
#include <memory>
#include <string>

#include "serial_worker.h"
#include "vims_common/csv_writer.h"
#include "vims_common/heap.h"
#include "vims_common/latency_histogram.h"
#include "vims_common/log.h"
#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/trajectory_io.h"
#include "vims_magnetometer/magnetic_front_end.h"
#include "vims_magnetometer/signature_csv_writer.h"
#include "vims_pose_graph/loop_csv.h"
#include "vims_pose_graph/pose_graph_manager.h"
#include "vims_ros/sequence_bag_reader.h"
#include "vims_sonar/sonar_altitude_filter.h"
#include "vims_sonar/sonar_csv_writer.h"
#include "vims_system/system_config.h"
#include "vims_system/vio_system.h"

namespace vims {

struct SeabedCsv;  // offline_pipeline.cpp

struct OfflineOptions {
  std::string sequence_dir;
  std::string out_dir;
  /// The system configuration's files (SystemConfig::load); none: the built-in defaults.
  std::vector<std::string> config_paths;
  bool show_progress = true;
  /// One of SystemConfig::modes() (the sonar filter runs and writes sonar_filtered.csv in every mode).
  std::string mode = "full";
  std::string map_load;  ///< a saved map to relocalise into (teach and repeat); empty: none
  std::string map_save;  ///< where to save the map at the end; empty: not saved
  std::string map_mode;  ///< overrides pose_graph.map_mode (mapping, extend, localisation); empty: the configuration's
  /// Root that relative vocabulary paths of the configuration are resolved against.
  std::string package_root;
  /// 2: the feature tracker runs on its own thread, one frame ahead of the estimator (the
  /// back end of frame k overlaps the front end of frame k+1); 1: everything on one thread.
  /// Both feed the estimator at the same points of the message stream, so every output file is
  /// identical for either value.
  int threads = 2;
  /// The odometry alone (sensor front-ends, tracker, estimator): no pose graph, so no
  /// global.tum, loops.csv or map; for measuring the VIO's own speed (bench/vio_seeds.sh).
  bool vio_only = false;
};

/// What summary.yaml reports.
struct OfflineSummary {
  std::string sequence_name;
  double wall_time_s = 0.0;
  double sequence_duration_s = 0.0;
  double real_time_factor = 0.0;
  std::map<std::string, TopicStats> topics;
  SonarFilterStats sonar;
  SignatureExtractorStats magnetometer;
  double coil_frequency_hz = 0.0;  ///< in use at the end: the sequence's or the one found (0: none found)
  /// Per-frame wall-clock latency [ms]: front end (tracker) and back end (estimator).
  double frontend_ms_p50 = 0.0, frontend_ms_p99 = 0.0;
  double backend_ms_p50 = 0.0, backend_ms_p99 = 0.0;
  /// Per-call wall-clock latency [ms] of the other stages: magnetometer (MagneticFrontEnd::feedMag
  /// per 1 kHz sample), place recognition (PoseGraphManager::feedKeyframe calls without their
  /// graph solves: describe, detect, verify), pose-graph optimisation (per solve,
  /// PoseGraphManager::timings) and loop correction (per accepted loop: from its acceptance to
  /// its optimised result applied).
  double magnetometer_ms_p50 = 0.0, magnetometer_ms_p99 = 0.0;
  double place_recognition_ms_p50 = 0.0, place_recognition_ms_p99 = 0.0;
  double pose_graph_optimisation_ms_p50 = 0.0, pose_graph_optimisation_ms_p99 = 0.0;
  long pose_graph_optimisation_calls = 0;  ///< solves
  double loop_correction_ms_p50 = 0.0, loop_correction_ms_p99 = 0.0;
  /// Total wall-clock time per stage over the run [s].
  double frontend_total_s = 0.0, backend_total_s = 0.0, magnetometer_total_s = 0.0, pose_graph_total_s = 0.0;
  /// sequence_duration_s / (frontend_total_s + backend_total_s): the VIO's real-time factor with
  /// front and back end run one after the other (a lower bound for the pipelined VIO).
  double vio_real_time_factor = 0.0;
  /// CPU time of the front end (tracker thread) and back end (estimator calls) [s], and
  /// sequence_duration_s over their sum: the VIO's cost, independent of other load on the machine.
  double frontend_cpu_s = 0.0, backend_cpu_s = 0.0, vio_cpu_real_time_factor = 0.0;
  /// CPU time of the whole process (every thread: bag reading, VIO, magnetometer, pose graph;
  /// processCpuSeconds) [s], and that per second of sequence.
  double cpu_total_s = 0.0, cpu_per_sequence_s = 0.0;
  double peak_rss_mb = 0.0;            ///< getrusage ru_maxrss at the end of the run
  double heap_in_use_mb = 0.0;         ///< mallinfo2 uordblks + hblkhd at the end of the run
  double heap_free_retained_mb = 0.0;  ///< mallinfo2 fordblks: freed, still held by the allocator
  int threads = 1;
  long vio_frames = 0;  ///< poses written to vio.tum
  long vio_keyframes = 0;
  long vio_resets = 0;
  std::uint32_t vio_sessions = 0;
  double vio_td_s = 0.0;  ///< final camera-IMU time offset estimate
  /// The estimated camera-IMU extrinsic against the YAML's (estimator.estimate_extrinsic only).
  std::string vio_extrinsic;
  PoseGraphManagerStats pose_graph;
};

class OfflinePipeline {
 public:
  /// Resolves the sequence, loads its YAML and the system configuration, creates OUT.
  /// Throws std::runtime_error / ConfigError with a message naming what is wrong.
  OfflinePipeline(const OfflineOptions& options, LoggerPtr logger);
  ~OfflinePipeline();

  /// Reads the whole bag through the pipeline and writes every output file into OUT.
  OfflineSummary run();

 private:
  void onImu(const ImuSample& sample);
  void onImage(const CameraFrame& frame);
  void onSonar(const SonarRange& range);
  void onMag(const MagSample& sample);
  void onPressure(const PressureSample& sample);
  void writeSummary(const OfflineSummary& summary) const;
  void drainEstimator();
  void drainLoopAttempts();
  /// A camera frame with the tracker's result for it.
  struct TrackedResult {
    CameraFrame frame;
    TrackedFrame tracked;
    double ms = 0.0;           ///< wall time of FeatureTracker::process
    double cpu_s = 0.0;        ///< its CPU time
    std::exception_ptr error;  ///< what the tracker threw on this frame
  };
  void feedTracked(const TrackedResult& tracked);
  /// Feeds the frames still in the tracker to the estimator (end of data).
  void feedTrackedFrames();
  /// End of data for the pose graph: final solve, loops.csv, global.tum, the map; its figures.
  void finishPoseGraph(OfflineSummary* summary);
  /// Runs a pose-graph call and files its duration under place recognition / optimisation.
  template <typename Call>
  void timePoseGraph(bool is_keyframe, Call&& call);

  OfflineOptions options_;
  LoggerPtr logger_;
  SequencePaths paths_;
  SequenceConfig sequence_;
  SystemConfig config_;

  // Sensor front-ends (the same cores vims_sonar_filter_node and vims_magnetometer_node wrap).
  std::unique_ptr<SonarAltitudeFilter> sonar_filter_;
  std::unique_ptr<MagneticFrontEnd> magnetic_front_end_;
  std::unique_ptr<SonarCsvWriter> sonar_csv_;
  std::unique_ptr<SignatureCsvWriter> signature_csv_;
  std::vector<SonarFilterResult> sonar_results_;  // reused buffers: no allocation per message
  // Visual-inertial(-sonar) odometry; its tracking runs on tracker_worker_.
  std::unique_ptr<VioSystem> vio_;
  class TrackerWorker;
  std::unique_ptr<TrackerWorker> tracker_worker_;  ///< runs vio_'s tracking, inline or on its thread
  std::unique_ptr<TumWriter> vio_tum_;
  /// seabed.csv: the estimated seabed under the vehicle at every VIO frame (docs/offline_outputs.md).
  std::unique_ptr<CsvWriter<SeabedCsv>> seabed_csv_;
  // Per-call latencies [ms] in fixed-size histograms: memory must not grow with the run's length.
  LatencyHistogram frontend_ms_;
  LatencyHistogram backend_ms_;
  LatencyHistogram magnetometer_ms_;
  LatencyHistogram place_recognition_ms_;
  LatencyHistogram pose_graph_optimisation_ms_;
  double frontend_cpu_s_ = 0.0;
  double backend_cpu_s_ = 0.0;
  double pose_graph_other_ms_ = 0.0;  ///< pose-graph calls in neither bucket (signatures, geomagnetic field)
  std::size_t pose_graph_optimisations_seen_ = 0;
  std::size_t pose_graph_solves_seen_ = 0;
  PeriodicHeapRelease heap_release_;  ///< on the bag clock
  long vio_frames_ = 0;
  long vio_keyframes_ = 0;
  std::vector<SignatureWindow> signature_windows_;
  std::vector<GeomagneticSample> geomagnetic_samples_;
  // Global pose graph with hierarchical loop closing, run synchronously (deterministic) by
  // pose_graph_worker_: inline, or on its own thread in message-stream order. Only tasks of
  // that worker touch pose_graph_, loops_csv_ and the pose-graph timing members above until
  // run() has waited for it.
  std::unique_ptr<PoseGraphManager> pose_graph_;
  std::unique_ptr<LoopCsvWriter> loops_csv_;
  std::unique_ptr<SerialWorker> pose_graph_worker_;
};

}  // namespace vims
