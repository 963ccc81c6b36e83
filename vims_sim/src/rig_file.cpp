#include "vims_sim/rig_file.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <stdexcept>

namespace vims {
namespace sim {

const std::vector<std::string>& rigFlagNames() {
  static const std::vector<std::string> names = {
      "distortion-model", "image-width",    "image-height", "camera-tilt-deg", "camera-roll-deg",
      "image-format",     "camera-rate-hz", "imu-rate-hz",  "sonar-rate-hz",   "mag-rate-hz"};
  return names;
}

std::vector<std::string> rigFileArguments(const std::string& path) {
  const std::string where = "--rig " + path + ": ";
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw std::invalid_argument(where + "cannot read the file");
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument(where + "not valid YAML (" + e.what() + ")");
  }
  if (!root.IsMap()) throw std::invalid_argument(where + "expected a mapping of flag: value");
  const std::vector<std::string>& allowed = rigFlagNames();
  std::vector<std::string> args;
  for (const auto& entry : root) {
    const std::string key = entry.first.as<std::string>();
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      std::string list;
      for (const std::string& name : allowed) list += (list.empty() ? "" : ", ") + name;
      throw std::invalid_argument(where + "'" + key + "' is not a rig flag (one of: " + list + ")");
    }
    if (!entry.second.IsScalar()) throw std::invalid_argument(where + key + ": expected a single value");
    args.push_back("--" + key);
    args.push_back(entry.second.as<std::string>());
  }
  return args;
}

}  // namespace sim
}  // namespace vims
