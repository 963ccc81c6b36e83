// vims_sonar_filter_node: a thin ROS wrapper around vims::SonarAltitudeFilter.
//
// Subscribes  <topics.sonar of the sequence YAML> (sensor_msgs/Range, default /sonar/range)
// Publishes   sonar/filtered (vims/FilteredSonarRange): the filter's verdict on every input range,
//             in input order (held samples once the filter decides): the input's stamp and frame,
//             the raw range, the trend-following median, accepted or not and why. Consumers (the
//             VIO's sonar factors) use the accepted ones, exactly as vims_offline feeds them.
// Params      ~sequence_config (string, required): the sequence YAML (noise, min/max range, topics)
//             ~config_file     (string or list of strings, optional): system configuration files
//                              (vims::SystemConfig); the node uses the section sonar (e.g.
//                              config/sonar.yaml); empty = the defaults
//             ~sonar_topic     (string, optional): input topic instead of topics.sonar
#include <ros/ros.h>
#include <sensor_msgs/Range.h>
#include <vims/FilteredSonarRange.h>

#include <cmath>

#include "vims_common/config_reader.h"
#include "vims_common/sequence_config.h"
#include "vims_ros/conversions.h"
#include "vims_ros/node_config.h"
#include "vims_ros/ros_logger.h"
#include "vims_ros/sonar_conversions.h"
#include "vims_sonar/sonar_altitude_filter.h"
#include "vims_system/system_config.h"

namespace {

class SonarFilterNode {
 public:
  SonarFilterNode(ros::NodeHandle& nh, const vims::SequenceConfig& sequence, const vims::SonarFilterOptions& options,
                  const std::string& input_topic)
      : filter_(options, sequence.sonar, vims::rosLogger()) {
    pub_ = nh.advertise<vims::FilteredSonarRange>("sonar/filtered", 50);
    sub_ = nh.subscribe(input_topic, 50, &SonarFilterNode::onRange, this);
    ROS_INFO_STREAM("sonar filter: " << sub_.getTopic() << " -> " << pub_.getTopic() << ", noise " << filter_.noiseStd()
                                     << " m, options:\n"
                                     << options.toYaml());
  }

 private:
  void onRange(const sensor_msgs::Range::ConstPtr& msg) {
    vims::SonarRange sample;
    std::string why;
    if (!vims::toSonarRange(*msg, &sample, &why)) {
      ROS_WARN_STREAM_THROTTLE(5.0, "sonar range rejected: " << why);
      return;
    }
    frame_id_ = msg->header.frame_id;
    results_.clear();
    filter_.feed(sample, &results_);
    for (const vims::SonarFilterResult& r : results_) {
      vims::FilteredSonarRange out;
      if (!vims::toFilteredSonarRangeMsg(r, frame_id_, &out, &why)) {
        ROS_WARN_STREAM_THROTTLE(5.0, "filtered range at t=" << r.t << " not published: " << why);
        continue;
      }
      pub_.publish(out);
    }
  }

  vims::SonarAltitudeFilter filter_;
  std::vector<vims::SonarFilterResult> results_;
  std::string frame_id_;  ///< the sonar's frame, from its messages
  ros::Publisher pub_;
  ros::Subscriber sub_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "vims_sonar_filter");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string sequence_path;
  if (!pnh.getParam("sequence_config", sequence_path)) {
    ROS_FATAL("parameter ~sequence_config (path of the sequence YAML) is required");
    return 1;
  }
  try {
    std::vector<std::string> unknown;
    const vims::SequenceConfig sequence = vims::SequenceConfig::load(sequence_path, &unknown);
    for (const auto& key : unknown) ROS_WARN_STREAM(sequence_path << ": key '" << key << "' is not in the contract");
    const vims::SystemConfig config = vims::SystemConfig::load(vims::configFilesParam(pnh), sequence);
    SonarFilterNode node(nh, sequence, config.sonar, pnh.param<std::string>("sonar_topic", sequence.topics.sonar));
    ros::spin();
  } catch (const vims::ConfigError& e) {
    ROS_FATAL_STREAM("configuration error: " << e.what());
    return 1;
  }
  return 0;
}
