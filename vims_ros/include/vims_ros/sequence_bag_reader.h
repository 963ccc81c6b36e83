#pragma once
/// @file sequence_bag_reader.h
/// @brief Reads a contract sequence bag in recorded order (the order `rosbag play` replays it)
/// and hands each sensor message, converted by vims_ros/conversions.h, to a callback.
/// The offline runner and the tests use it; the live nodes receive the same conversions.

#include <rosbag/bag.h>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"

namespace vims {

struct TopicStats {
  std::string type;
  long messages = 0;  ///< messages read from the bag
  long rejected = 0;  ///< messages the conversion refused (NaN, wrong encoding, ...)
};

class SequenceBagReader {
 public:
  struct Handlers {
    std::function<void(const ImuSample&)> imu;
    std::function<void(const CameraFrame&)> image;
    std::function<void(const SonarRange&)> sonar;
    std::function<void(const MagSample&)> mag;
    /// Only for sequences whose YAML has a `pressure` section (contract version 2).
    std::function<void(const PressureSample&)> pressure;
    /// A message the conversion refused: topic, bag time, reason.
    std::function<void(const std::string&, double, const std::string&)> rejected;
    /// Progress in [0, 1] of the bag's time span, called about every 1 % of it.
    std::function<void(double fraction)> progress;
  };

  /// Opens the bag. Throws std::runtime_error if it cannot be opened or if a contract topic
  /// has the wrong message type (the message names the topic). The camera topic may hold
  /// sensor_msgs/Image or sensor_msgs/CompressedImage (jpeg, png): the reader follows its type. Absent topics are
  /// listed by missingTopics(): the caller decides which sensors it cannot run without.
  SequenceBagReader(const std::string& bag_path, const SequenceConfig& config);
  ~SequenceBagReader();

  double startTime() const { return start_time_; }
  double endTime() const { return end_time_; }
  /// Contract topics (as named by the sequence YAML) with no messages in the bag.
  const std::vector<std::string>& missingTopics() const { return missing_topics_; }
  bool hasTopic(const std::string& topic) const;
  /// The camera topic holds sensor_msgs/CompressedImage.
  bool compressedImages() const { return compressed_images_; }
  /// Throws std::runtime_error naming `topic` if the bag does not have it.
  void requireTopic(const std::string& topic) const;

  /// Reads every sensor message in recorded order. Returns per-topic statistics.
  std::map<std::string, TopicStats> run(const Handlers& handlers);

 private:
  std::unique_ptr<rosbag::Bag> bag_;
  SequenceConfig config_;
  double start_time_ = 0.0;
  double end_time_ = 0.0;
  std::string bag_path_;
  std::vector<std::string> missing_topics_;
  bool compressed_images_ = false;
};

}  // namespace vims
