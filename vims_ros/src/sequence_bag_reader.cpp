#include "vims_ros/sequence_bag_reader.h"

#include <rosbag/view.h>

#include <algorithm>
#include <stdexcept>

#include "vims_ros/conversions.h"

namespace vims {

SequenceBagReader::SequenceBagReader(const std::string& bag_path, const SequenceConfig& config)
    : bag_(std::make_unique<rosbag::Bag>()), config_(config), bag_path_(bag_path) {
  try {
    bag_->open(bag_path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error("cannot open bag '" + bag_path + "': " + e.what());
  }
  std::map<std::string, std::string> expected = {
      {config_.topics.image, kRawImageType},
      {config_.topics.imu, "sensor_msgs/Imu"},
      {config_.topics.sonar, "sensor_msgs/Range"},
      {config_.topics.mag, "sensor_msgs/MagneticField"},
  };
  if (config_.pressure) expected[config_.topics.pressure] = "sensor_msgs/FluidPressure";
  rosbag::View all(*bag_);
  std::map<std::string, std::string> present;
  for (const rosbag::ConnectionInfo* info : all.getConnections()) present[info->topic] = info->datatype;
  for (const auto& [topic, type] : expected) {
    const auto it = present.find(topic);
    if (it == present.end()) {
      missing_topics_.push_back(topic);
      continue;
    }
    if (topic == config_.topics.image && it->second == kCompressedImageType) {
      compressed_images_ = true;  // contract version 2: jpeg or png
      continue;
    }
    if (it->second != type) {
      throw std::runtime_error("bag '" + bag_path + "': topic '" + topic + "' has type " + it->second + ", expected " +
                               type);
    }
  }
  start_time_ = all.getBeginTime().toSec();
  end_time_ = all.getEndTime().toSec();
}

SequenceBagReader::~SequenceBagReader() = default;

bool SequenceBagReader::hasTopic(const std::string& topic) const {
  return std::find(missing_topics_.begin(), missing_topics_.end(), topic) == missing_topics_.end();
}

void SequenceBagReader::requireTopic(const std::string& topic) const {
  if (!hasTopic(topic)) {
    throw std::runtime_error("bag '" + bag_path_ + "' has no topic '" + topic +
                             "'; set the topic names under 'topics:' in the sequence YAML");
  }
}

std::map<std::string, TopicStats> SequenceBagReader::run(const Handlers& handlers) {
  std::vector<std::string> topics = {config_.topics.image, config_.topics.imu, config_.topics.sonar,
                                     config_.topics.mag};
  if (config_.pressure) topics.push_back(config_.topics.pressure);
  std::map<std::string, TopicStats> stats;
  rosbag::View view(*bag_, rosbag::TopicQuery(topics));
  const double span = std::max(end_time_ - start_time_, 1e-9);
  double next_progress = 0.0;
  std::string why;
  auto reject = [&](const std::string& topic, double t) {
    ++stats[topic].rejected;
    if (handlers.rejected) handlers.rejected(topic, t, why);
  };
  for (const rosbag::MessageInstance& m : view) {
    const std::string& topic = m.getTopic();
    TopicStats& s = stats[topic];
    s.type = m.getDataType();
    ++s.messages;
    const double t = m.getTime().toSec();
    if (topic == config_.topics.imu) {
      ImuSample sample;
      const auto msg = m.instantiate<sensor_msgs::Imu>();
      if (msg && toImuSample(*msg, &sample, &why)) {
        if (handlers.imu) handlers.imu(sample);
      } else {
        reject(topic, t);
      }
    } else if (topic == config_.topics.mag) {
      MagSample sample;
      const auto msg = m.instantiate<sensor_msgs::MagneticField>();
      if (msg && toMagSample(*msg, &sample, &why)) {
        if (handlers.mag) handlers.mag(sample);
      } else {
        reject(topic, t);
      }
    } else if (topic == config_.topics.sonar) {
      SonarRange sample;
      const auto msg = m.instantiate<sensor_msgs::Range>();
      if (msg && toSonarRange(*msg, &sample, &why)) {
        if (handlers.sonar) handlers.sonar(sample);
      } else {
        reject(topic, t);
      }
    } else if (config_.pressure && topic == config_.topics.pressure) {
      PressureSample sample;
      const auto msg = m.instantiate<sensor_msgs::FluidPressure>();
      if (msg && toPressureSample(*msg, &sample, &why)) {
        if (handlers.pressure) handlers.pressure(sample);
      } else {
        reject(topic, t);
      }
    } else if (topic == config_.topics.image) {
      // Images are only decoded when someone consumes them: counting runs stay fast.
      if (!handlers.image) continue;
      CameraFrame frame;
      bool ok = false;
      if (compressed_images_) {
        const auto msg = m.instantiate<sensor_msgs::CompressedImage>();
        ok = msg && toCameraFrame(*msg, config_.camera.width, config_.camera.height, &frame, &why);
      } else {
        const auto msg = m.instantiate<sensor_msgs::Image>();
        ok = msg && toCameraFrame(*msg, config_.camera.width, config_.camera.height, &frame, &why);
      }
      if (ok) {
        handlers.image(frame);
      } else {
        reject(topic, t);
      }
    }
    if (handlers.progress && (t - start_time_) / span >= next_progress) {
      handlers.progress((t - start_time_) / span);
      next_progress += 0.01;
    }
  }
  if (handlers.progress) handlers.progress(1.0);
  return stats;
}

}  // namespace vims
