#pragma once
/// @file offline_pipeline.h
/// @brief The whole VIMS system in one process, driven message by message from a bag.
///
/// The offline runner feeds every message of a sequence, in recorded order (the order
/// `rosbag play` publishes them), into the same core libraries the ROS nodes wrap, wired the
/// same way the launch files wire the nodes. It runs as fast as the CPU allows and, being
/// single-threaded and driven only by bag data, is deterministic: two runs give identical files.

#include <map>
#include <memory>
#include <string>

#include "vims_common/log.h"
#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_ros/sequence_bag_reader.h"

namespace vims {

struct OfflineOptions {
  std::string sequence_dir;
  std::string out_dir;
  std::string config_path;  ///< system configuration (config/vims.yaml); empty = built-in defaults
  bool show_progress = true;
};

/// What summary.yaml reports.
struct OfflineSummary {
  std::string sequence_name;
  double wall_time_s = 0.0;
  double sequence_duration_s = 0.0;
  double real_time_factor = 0.0;
  std::map<std::string, TopicStats> topics;
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
  void writeSummary(const OfflineSummary& summary) const;

  OfflineOptions options_;
  LoggerPtr logger_;
  SequencePaths paths_;
  SequenceConfig sequence_;
};

}  // namespace vims
