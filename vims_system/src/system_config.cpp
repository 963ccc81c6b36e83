#include "vims_system/system_config.h"

#include <algorithm>
#include <map>
#include <set>

#include "vims_common/config_reader.h"
#include "vims_common/option_table.h"

namespace vims {

const std::vector<std::string>& SystemConfig::sections() {
  static const std::vector<std::string> kSections = {"sonar", "magnetometer", "tracker", "estimator", "pose_graph"};
  return kSections;
}

const std::vector<std::string>& SystemConfig::modes() {
  static const std::vector<std::string> kModes = {"full", "vi_slam", "no_sonar", "no_alter", "no_orb", "no_geom"};
  return kModes;
}

std::vector<OptionRow> SystemConfig::optionRows() {
  using C = SystemConfig;
  const auto table =
      OptionTable<C>()
          .section<SonarFilterOptions>("sonar", &C::sonar, SonarFilterOptions::optionTable())
          .section<MagnetometerOptions>("magnetometer", &C::magnetometer, MagnetometerOptions::optionTable())
          .section<TrackerOptions>("tracker", &C::tracker, TrackerOptions::optionTable())
          .section<EstimatorOptions>("estimator", &C::estimator, EstimatorOptions::optionTable())
          .section<PoseGraphManagerOptions>("pose_graph", &C::pose_graph, PoseGraphManagerOptions::optionTable());
  return table.rows();
}

SystemConfig SystemConfig::load(const std::vector<std::string>& paths, const SequenceConfig& sequence) {
  const std::set<std::string> allowed(sections().begin(), sections().end());
  std::map<std::string, ConfigReader> given;  // section -> its mapping in the file that holds it
  for (const std::string& path : paths) {
    const ConfigReader file = ConfigReader::fromFile(path);
    file.rejectUnknownKeys(allowed);
    for (const std::string& section : sections()) {
      if (!file.has(section)) continue;
      const auto earlier = given.find(section);
      if (earlier != given.end()) {
        throw ConfigError(path + ": " + section + ": the section is also given in " + earlier->second.source() +
                          " (give each section once)");
      }
      given.emplace(section, file.child(section));
    }
  }
  const ConfigReader defaults = ConfigReader::fromString("{}", "built-in defaults");
  auto section = [&](const std::string& name) {
    const auto it = given.find(name);
    return it == given.end() ? defaults : it->second;
  };
  SystemConfig config;
  config.sonar = SonarFilterOptions::fromReader(section("sonar"));
  const ConfigReader magnetometer = section("magnetometer");
  config.magnetometer = MagnetometerOptions::fromReader(magnetometer);
  config.magnetometer.validateFor(sequence.magnetometer, magnetometer);
  config.tracker = TrackerOptions::fromReader(section("tracker"));
  config.estimator = EstimatorOptions::fromReader(section("estimator"));
  config.pose_graph = PoseGraphManagerOptions::fromReader(section("pose_graph"));
  return config;
}

void SystemConfig::applyMode(const std::string& mode) {
  if (std::find(modes().begin(), modes().end(), mode) == modes().end()) {
    std::string known;
    for (const std::string& m : modes()) known += (known.empty() ? "" : ", ") + m;
    throw ConfigError("unknown mode '" + mode + "' (known: " + known + ")");
  }
  // no_sonar is the estimator's ablation: its loop closing is the full one.
  estimator.use_sonar = mode != "no_sonar" && estimator.use_sonar;
  pose_graph.mode = loopClosingModeFromString(mode == "no_sonar" ? "full" : mode);
}

}  // namespace vims
