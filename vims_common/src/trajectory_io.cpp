#include "vims_common/trajectory_io.h"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace vims {

std::vector<StampedPose> readTumFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open trajectory file '" + path + "'");
  std::vector<StampedPose> poses;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    for (char& ch : line)
      if (ch == ',') ch = ' ';
    std::istringstream is(line);
    double v[8];
    int n = 0;
    while (n < 8 && is >> v[n]) ++n;
    std::string rest;
    if (n != 8 || (is >> rest)) {
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": expected 8 numbers 't x y z qx qy qz qw'");
    }
    for (double x : v)
      if (!std::isfinite(x)) throw std::runtime_error(path + ":" + std::to_string(line_no) + ": non-finite value");
    StampedPose pose;
    pose.t = v[0];
    pose.p = Eigen::Vector3d(v[1], v[2], v[3]);
    pose.q = Eigen::Quaterniond(v[7], v[4], v[5], v[6]);
    const double norm = pose.q.norm();
    if (norm < 1e-6) throw std::runtime_error(path + ":" + std::to_string(line_no) + ": zero quaternion");
    pose.q.coeffs() /= norm;
    if (!poses.empty() && pose.t <= poses.back().t) {
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": timestamps must increase");
    }
    poses.push_back(pose);
  }
  return poses;
}

TumWriter::TumWriter(const std::string& path) : path_(path), out_(path) {
  if (!out_) throw std::runtime_error("cannot write trajectory file '" + path + "'");
}

void TumWriter::write(double t, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%.6f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", t, p.x(), p.y(), p.z(), q.x(), q.y(),
                q.z(), q.w());
  out_ << buf;
}

void TumWriter::write(const StampedPose& pose) { write(pose.t, pose.p, pose.q); }

void TumWriter::flush() { out_.flush(); }

void writeTumFile(const std::string& path, const std::vector<StampedPose>& poses) {
  TumWriter writer(path);
  for (const auto& p : poses) writer.write(p);
  writer.flush();
}

}  // namespace vims
