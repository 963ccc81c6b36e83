#include "vims_common/config_reader.h"

#include <cmath>
#include <fstream>
#include <sstream>

namespace vims {

ConfigReader ConfigReader::fromFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open configuration file");
  try {
    YAML::Node root = YAML::LoadFile(path);
    if (!root.IsMap()) throw ConfigError(path + ": top level is not a YAML mapping");
    return ConfigReader(root, "", path);
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ": YAML parse error: " + e.what());
  }
}

ConfigReader ConfigReader::fromString(const std::string& yaml, const std::string& source_name) {
  try {
    YAML::Node root = YAML::Load(yaml);
    if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
    if (!root.IsMap()) throw ConfigError(source_name + ": top level is not a YAML mapping");
    return ConfigReader(root, "", source_name);
  } catch (const YAML::Exception& e) {
    throw ConfigError(source_name + ": YAML parse error: " + e.what());
  }
}

ConfigReader::ConfigReader(YAML::Node node, std::string path, std::string source)
    : node_(std::move(node)), path_(std::move(path)), source_(std::move(source)) {}

bool ConfigReader::has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
}

std::string ConfigReader::keyPath(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

ConfigError ConfigReader::error(const std::string& key, const std::string& message) const {
  return ConfigError(source_ + ": " + keyPath(key) + ": " + message);
}

std::vector<double> ConfigReader::getVector(const std::string& key, int expected_size) const {
  if (!has(key)) throw error(key, "required key is missing");
  const YAML::Node value = node_[key];
  if (!value.IsSequence()) throw error(key, "expected a list of numbers");
  std::vector<double> out;
  out.reserve(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    try {
      out.push_back(value[i].as<double>());
    } catch (const YAML::Exception&) {
      throw error(key, "element " + std::to_string(i) + " is not a number");
    }
    if (!std::isfinite(out.back())) throw error(key, "element " + std::to_string(i) + " is not finite");
  }
  if (expected_size >= 0 && static_cast<int>(out.size()) != expected_size) {
    throw error(key, "expected " + std::to_string(expected_size) + " numbers, got " + std::to_string(out.size()));
  }
  return out;
}

Eigen::Isometry3d ConfigReader::getTransform(const std::string& key) const {
  const std::vector<double> v = getVector(key, 16);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = v[4 * r + c];
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-6) {
    throw error(key, "last row of the row-major 4x4 transform must be [0 0 0 1]");
  }
  const Eigen::Matrix3d rot = m.topLeftCorner<3, 3>();
  if ((rot * rot.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3 || rot.determinant() < 0.0) {
    throw error(key, "rotation block is not a proper rotation (orthonormal, det +1)");
  }
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  // Re-orthonormalise so small rounding in the file does not leak into the estimator.
  iso.linear() = Eigen::Quaterniond(rot).normalized().toRotationMatrix();
  iso.translation() = m.topRightCorner<3, 1>();
  return iso;
}

ConfigReader ConfigReader::child(const std::string& key) const {
  if (!has(key)) throw error(key, "required section is missing");
  if (!node_[key].IsMap()) throw error(key, "expected a mapping (a section of keys)");
  return ConfigReader(node_[key], keyPath(key), source_);
}

ConfigReader ConfigReader::childOrEmpty(const std::string& key) const {
  if (!has(key)) return ConfigReader(YAML::Node(YAML::NodeType::Map), keyPath(key), source_);
  return child(key);
}

std::vector<std::string> ConfigReader::unknownKeys(const std::set<std::string>& allowed) const {
  std::vector<std::string> unknown;
  if (!node_.IsMap()) return unknown;
  for (const auto& kv : node_) {
    const std::string name = kv.first.as<std::string>();
    if (!allowed.count(name)) unknown.push_back(keyPath(name));
  }
  return unknown;
}

void ConfigReader::rejectUnknownKeys(const std::set<std::string>& allowed) const {
  const std::vector<std::string> unknown = unknownKeys(allowed);
  if (unknown.empty()) return;
  std::ostringstream known;
  for (const auto& k : allowed) known << (known.tellp() > 0 ? ", " : "") << k;
  throw ConfigError(source_ + ": " + unknown.front() + ": unknown key (known keys here: " + known.str() + ")");
}

void requirePositive(const ConfigReader& reader, const std::string& key, double value) {
  if (!(value > 0.0) || !std::isfinite(value)) throw reader.error(key, "must be > 0, got " + std::to_string(value));
}

void requireNonNegative(const ConfigReader& reader, const std::string& key, double value) {
  if (!(value >= 0.0) || !std::isfinite(value)) throw reader.error(key, "must be >= 0, got " + std::to_string(value));
}

void requireInRange(const ConfigReader& reader, const std::string& key, double value, double lo, double hi) {
  if (!(value >= lo && value <= hi)) {
    throw reader.error(
        key, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(value));
  }
}

}  // namespace vims
