#include "vims_pose_graph/loop_csv.h"

#include <cmath>
#include <cstdio>

namespace vims {

namespace {
/// Diagnostic columns: empty when not available (vims_eval reads empty as "not available").
std::string optional(double v, const char* format) {
  if (!std::isfinite(v)) return "";
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}
}  // namespace

const char* LoopCsv::header() {
  return "t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,bow_score,stage,sigma_x,sigma_y,sigma_z,"
         "sigma_yaw_deg,match_in_map";
}

std::string LoopCsv::row(const LoopAttempt& a) {
  Eigen::Quaterniond q(a.T_match_query.linear());
  q.normalize();
  const Eigen::Vector3d& p = a.T_match_query.translation();
  char buf[512];
  // Bag-clock stamps need microseconds; poses 1e-6 m / 1e-9 in the quaternion.
  std::snprintf(buf, sizeof(buf), "%.6f,%.6f,%d,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f,%d,", a.t_query, a.t_match,
                a.accepted ? 1 : 0, p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w(), a.inliers);
  return std::string(buf) + optional(a.mag_distance, "%.6e") + "," + optional(a.bow_score, "%.6f") + "," +
         toString(a.stage) + "," + optional(a.sigma[0], "%.6f") + "," + optional(a.sigma[1], "%.6f") + "," +
         optional(a.sigma[2], "%.6f") + "," + optional(a.sigma[3] * 180.0 / M_PI, "%.6f") + "," +
         (a.match_in_map ? "1" : "0");
}

}  // namespace vims
