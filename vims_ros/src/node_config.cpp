#include "vims_ros/node_config.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include "vims_common/config_reader.h"

namespace vims {

std::vector<std::string> configFilesParam(const ros::NodeHandle& private_nh) {
  if (private_nh.hasParam("options_file")) {
    throw ConfigError(
        "parameter ~options_file is now ~config_file: a system configuration whose keys sit in the "
        "module's section (sonar:, magnetometer:, pose_graph:, ...; see config/*.yaml)");
  }
  XmlRpc::XmlRpcValue value;
  if (!private_nh.getParam("config_file", value)) return {};
  std::vector<std::string> paths;
  if (value.getType() == XmlRpc::XmlRpcValue::TypeString) {
    const std::string path = static_cast<std::string>(value);
    if (!path.empty()) paths.push_back(path);
    return paths;
  }
  if (value.getType() == XmlRpc::XmlRpcValue::TypeArray) {
    for (int i = 0; i < value.size(); ++i) {
      if (value[i].getType() != XmlRpc::XmlRpcValue::TypeString) {
        throw ConfigError("parameter ~config_file: entry " + std::to_string(i) + " is not a path (a string)");
      }
      paths.push_back(static_cast<std::string>(value[i]));
    }
    return paths;
  }
  throw ConfigError("parameter ~config_file: expected a path or a list of paths");
}

}  // namespace vims
