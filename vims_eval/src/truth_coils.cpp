#include "vims_eval/truth_coils.h"

#include <yaml-cpp/yaml.h>

#include <stdexcept>

namespace vims {
namespace eval {
namespace {

Eigen::Vector3d readPosition(const YAML::Node& node, const std::string& key, const std::string& path) {
  if (!node.IsDefined() || !node.IsSequence() || node.size() != 3)
    throw std::runtime_error(path + ": " + key + " must be three numbers");
  try {
    return Eigen::Vector3d(node[0].as<double>(), node[1].as<double>(), node[2].as<double>());
  } catch (const YAML::Exception&) {
    throw std::runtime_error(path + ": " + key + " must be three numbers");
  }
}

/// node[key] when node is a map that has it, else an undefined node (yaml-cpp's node for a
/// missing key throws on any question but IsDefined).
YAML::Node childOf(const YAML::Node& node, const std::string& key) {
  if (!node.IsDefined() || !node.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  const YAML::Node child = node[key];
  return child.IsDefined() ? child : YAML::Node(YAML::NodeType::Undefined);
}

}  // namespace

std::vector<Eigen::Vector3d> readTruthCoilPositions(const std::string& truth_path, std::string* why) {
  std::vector<Eigen::Vector3d> positions;
  if (truth_path.empty()) {
    if (why) *why = "the sequence has no truth file";
    return positions;
  }
  YAML::Node loaded;
  try {
    loaded = YAML::LoadFile(truth_path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(truth_path + ": " + e.what());
  }
  const YAML::Node& root = loaded;
  const YAML::Node first = childOf(childOf(root, "coil"), "position_enu");
  if (!first.IsDefined()) {
    if (why) *why = truth_path + " has no coil.position_enu";
    return positions;
  }
  positions.push_back(readPosition(first, "coil.position_enu", truth_path));
  const YAML::Node others = childOf(root, "other_coils");
  if (others.IsDefined() && others.IsSequence()) {
    for (std::size_t i = 0; i < others.size(); ++i) {
      const std::string key = "other_coils[" + std::to_string(i) + "].position_enu";
      positions.push_back(readPosition(childOf(others[i], "position_enu"), key, truth_path));
    }
  }
  return positions;
}

}  // namespace eval
}  // namespace vims
