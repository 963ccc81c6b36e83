// vims_sonar_filter_node: a thin ROS wrapper around vims::SonarAltitudeFilter.
//
// Subscribes  <topics.sonar of the sequence YAML> (sensor_msgs/Range, default /sonar/range)
// Publishes   sonar/filtered (sensor_msgs/Range): one message per *accepted* range, stamped with
//             the input's stamp, range = the filter's trend-following median, min/max_range =
//             the sequence YAML's sonar limits. Rejected ranges
//             (outliers, dropouts, samples held while the filter acquires) are not published, so
//             consumers (the VIO's altitude factor) never see them.
// Params      ~sequence_config (string, required): the sequence YAML (noise, min/max range, topics)
//             ~options_file    (string, optional): filter options, e.g. config/sonar.yaml;
//                              empty = the defaults of SonarFilterOptions
//             ~sonar_topic     (string, optional): input topic instead of topics.sonar
#include <ros/ros.h>
#include <sensor_msgs/Range.h>

#include <cmath>

#include "vims_common/config_reader.h"
#include "vims_common/sequence_config.h"
#include "vims_ros/conversions.h"
#include "vims_ros/ros_logger.h"
#include "vims_sonar/sonar_altitude_filter.h"

namespace {

class SonarFilterNode {
 public:
  SonarFilterNode(ros::NodeHandle& nh, const vims::SequenceConfig& sequence, const vims::SonarFilterOptions& options,
                  const std::string& input_topic)
      : filter_(options, sequence.sonar, vims::rosLogger()) {
    template_.min_range = static_cast<float>(sequence.sonar.min_range);
    template_.max_range = static_cast<float>(sequence.sonar.max_range);
    pub_ = nh.advertise<sensor_msgs::Range>("sonar/filtered", 50);
    sub_ = nh.subscribe(input_topic, 50, &SonarFilterNode::onRange, this);
    ROS_INFO_STREAM("sonar filter: " << sub_.getTopic() << " -> " << pub_.getTopic() << ", noise "
                                     << filter_.noiseStd() << " m, options:\n" << options.toYaml());
  }

 private:
  void onRange(const sensor_msgs::Range::ConstPtr& msg) {
    vims::SonarRange sample;
    std::string why;
    if (!vims::toSonarRange(*msg, &sample, &why)) {
      ROS_WARN_STREAM_THROTTLE(5.0, "sonar range rejected: " << why);
      return;
    }
    // Frame, radiation type and field of view describe the sensor: kept from its messages, except
    // a non-finite field of view (the last finite one stays). The limits are the calibration's,
    // the ones the filter judges ranges against. So no input field can put NaN/Inf in the output.
    template_.header.frame_id = msg->header.frame_id;
    template_.radiation_type = msg->radiation_type;
    if (std::isfinite(msg->field_of_view)) template_.field_of_view = msg->field_of_view;
    results_.clear();
    filter_.feed(sample, &results_);
    for (const vims::SonarFilterResult& r : results_) {
      // An accepted range always has a finite estimate; checked anyway, as nothing non-finite
      // may leave the node.
      if (!r.accepted || !r.has_estimate || !std::isfinite(r.filtered)) continue;
      sensor_msgs::Range out = template_;
      out.header.stamp = ros::Time(r.t);
      out.range = static_cast<float>(r.filtered);
      pub_.publish(out);
    }
  }

  vims::SonarAltitudeFilter filter_;
  std::vector<vims::SonarFilterResult> results_;
  sensor_msgs::Range template_;
  ros::Publisher pub_;
  ros::Subscriber sub_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "vims_sonar_filter");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string sequence_path, options_path;
  if (!pnh.getParam("sequence_config", sequence_path)) {
    ROS_FATAL("parameter ~sequence_config (path of the sequence YAML) is required");
    return 1;
  }
  pnh.param<std::string>("options_file", options_path, "");
  try {
    std::vector<std::string> unknown;
    const vims::SequenceConfig sequence = vims::SequenceConfig::load(sequence_path, &unknown);
    for (const auto& key : unknown) ROS_WARN_STREAM(sequence_path << ": key '" << key << "' is not in the contract");
    const vims::SonarFilterOptions options =
        options_path.empty() ? vims::SonarFilterOptions{}
                             : vims::SonarFilterOptions::fromReader(vims::ConfigReader::fromFile(options_path));
    SonarFilterNode node(nh, sequence, options, pnh.param<std::string>("sonar_topic", sequence.topics.sonar));
    ros::spin();
  } catch (const vims::ConfigError& e) {
    ROS_FATAL_STREAM("configuration error: " << e.what());
    return 1;
  }
  return 0;
}
