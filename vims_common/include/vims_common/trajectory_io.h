#pragma once
/// @file trajectory_io.h
/// @brief TUM trajectory files: one pose a line, `t x y z qx qy qz qw`, '#' comments allowed.

#include <Eigen/Geometry>
#include <fstream>
#include <string>
#include <vector>

namespace vims {

struct StampedPose {
  double t = 0.0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
};

/// Reads a TUM file. Throws std::runtime_error naming file and line on malformed input
/// (wrong column count, non-numbers, non-finite values, zero quaternion, decreasing time).
std::vector<StampedPose> readTumFile(const std::string& path);

/// Streams poses to a TUM file with enough digits for bag-clock stamps (1e-6 s) and positions (1e-6 m).
class TumWriter {
 public:
  explicit TumWriter(const std::string& path);
  void write(const StampedPose& pose);
  void write(double t, const Eigen::Vector3d& p, const Eigen::Quaterniond& q);
  void flush();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::ofstream out_;
};

void writeTumFile(const std::string& path, const std::vector<StampedPose>& poses);

}  // namespace vims
