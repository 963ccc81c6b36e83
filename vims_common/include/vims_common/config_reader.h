#pragma once
/// @file config_reader.h
/// @brief Typed, path-aware access to YAML configuration.
///
/// Every VIMS options struct is filled through ConfigReader so that a missing key, a value of
/// the wrong type, a value out of range, or an unknown (misspelt) key produces a ConfigError
/// whose message names the full key path, e.g. `camera.intrinsics: expected 4 numbers, got 3`.

#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace vims {

/// Thrown for any invalid configuration; what() names the offending key and the source file.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A view on one YAML mapping plus the dotted path that led to it (for error messages).
class ConfigReader {
 public:
  /// Parses a file. Throws ConfigError if it cannot be read or is not a YAML mapping.
  static ConfigReader fromFile(const std::string& path);
  /// Parses a YAML string (used by tests and for embedded defaults).
  static ConfigReader fromString(const std::string& yaml, const std::string& source_name = "<string>");

  ConfigReader(YAML::Node node, std::string path, std::string source);

  bool has(const std::string& key) const;

  /// Required scalar. Throws ConfigError naming the key if missing or of the wrong type.
  template <typename T>
  T get(const std::string& key) const;

  /// Optional scalar: `fallback` when the key is absent; a present but malformed value still throws.
  template <typename T>
  T get(const std::string& key, const T& fallback) const;

  /// Required sequence of numbers with an exact length (expected_size < 0: any length).
  std::vector<double> getVector(const std::string& key, int expected_size = -1) const;

  /// A 4x4 row-major homogeneous transform given as 16 numbers. Checks the last row is
  /// [0 0 0 1] and the rotation block is orthonormal with det +1 (tolerance 1e-3).
  Eigen::Isometry3d getTransform(const std::string& key) const;

  /// Sub-mapping. `child` throws when absent; `childOrEmpty` returns an empty reader.
  ConfigReader child(const std::string& key) const;
  ConfigReader childOrEmpty(const std::string& key) const;

  /// Throws ConfigError naming the first key of this mapping that is not in `allowed`
  /// (catches misspelt options, which would otherwise be silently ignored).
  void rejectUnknownKeys(const std::set<std::string>& allowed) const;
  /// Same check, but returns the unknown keys instead of throwing (for files from other
  /// recorders, where extra keys are legal and only worth a warning).
  std::vector<std::string> unknownKeys(const std::set<std::string>& allowed) const;

  /// Full dotted path of `key` below this reader, e.g. "imu.rate_hz".
  std::string keyPath(const std::string& key) const;
  /// Builds a ConfigError "<source>: <key path>: <message>".
  ConfigError error(const std::string& key, const std::string& message) const;

  const std::string& source() const { return source_; }
  const YAML::Node& node() const { return node_; }

 private:
  YAML::Node node_;
  std::string path_;
  std::string source_;
};

/// Range checks that throw ConfigError naming the key.
void requirePositive(const ConfigReader& reader, const std::string& key, double value);
void requireNonNegative(const ConfigReader& reader, const std::string& key, double value);
void requireInRange(const ConfigReader& reader, const std::string& key, double value, double lo, double hi);
/// Overwrites *value with the key's value when present, then requires it in [lo, hi] (the
/// default too): the read-and-check pair of every bounded option.
template <typename T>
void readInRange(const ConfigReader& reader, const std::string& key, T* value, double lo, double hi) {
  *value = reader.get<T>(key, *value);
  requireInRange(reader, key, static_cast<double>(*value), lo, hi);
}

// ---- template implementation ----
template <typename T>
T ConfigReader::get(const std::string& key) const {
  if (!has(key)) throw error(key, "required key is missing");
  try {
    return node_[key].as<T>();
  } catch (const YAML::Exception&) {
    throw error(key, "value '" + YAML::Dump(node_[key]) + "' has the wrong type");
  }
}

template <typename T>
T ConfigReader::get(const std::string& key, const T& fallback) const {
  if (!has(key)) return fallback;
  return get<T>(key);
}

}  // namespace vims
