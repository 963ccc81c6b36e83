#include "vims_eval/alignment.h"

#include <Eigen/SVD>
#include <cmath>
#include <stdexcept>

namespace vims {
namespace eval {
namespace {

void checkSizes(const std::vector<Eigen::Vector3d>& points_v, const std::vector<Eigen::Vector3d>& points_w,
                std::size_t min_pairs, const char* what) {
  if (points_v.size() != points_w.size())
    throw std::invalid_argument(std::string(what) + ": point lists differ in length");
  if (points_v.size() < min_pairs)
    throw std::runtime_error(std::string(what) + ": needs at least " + std::to_string(min_pairs) +
                             " associated poses, got " + std::to_string(points_v.size()));
}

Eigen::Vector3d mean(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : points) sum += p;
  return sum / static_cast<double>(points.size());
}

}  // namespace

const char* alignmentModeName(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kNone:
      return "none";
    case AlignmentMode::kSe3:
      return "se3";
    case AlignmentMode::kSim3:
      return "sim3";
    case AlignmentMode::kPosYaw:
      return "posyaw";
  }
  return "unknown";
}

AlignmentMode parseAlignmentMode(const std::string& name) {
  for (AlignmentMode mode : {AlignmentMode::kNone, AlignmentMode::kSe3, AlignmentMode::kSim3, AlignmentMode::kPosYaw})
    if (name == alignmentModeName(mode)) return mode;
  throw std::invalid_argument("unknown alignment '" + name + "' (expected se3, sim3, posyaw or none)");
}

StampedPose Similarity3::transformPose(const StampedPose& T_v_b) const {
  StampedPose T_w_b;
  T_w_b.t = T_v_b.t;
  T_w_b.p = transformPoint(T_v_b.p);
  T_w_b.q = Eigen::Quaterniond(R_w_v * T_v_b.q.toRotationMatrix()).normalized();
  return T_w_b;
}

std::vector<StampedPose> Similarity3::transformPoses(const std::vector<StampedPose>& poses_v) const {
  std::vector<StampedPose> poses_w;
  poses_w.reserve(poses_v.size());
  for (const auto& p : poses_v) poses_w.push_back(transformPose(p));
  return poses_w;
}

Similarity3 umeyamaAlignment(const std::vector<Eigen::Vector3d>& points_v, const std::vector<Eigen::Vector3d>& points_w,
                             bool with_scale) {
  checkSizes(points_v, points_w, 3, with_scale ? "sim3 alignment" : "se3 alignment");
  const std::size_t n = points_v.size();
  const Eigen::Vector3d mean_v = mean(points_v);
  const Eigen::Vector3d mean_w = mean(points_w);
  Eigen::Matrix3d cov_w_v = Eigen::Matrix3d::Zero();  // (1/n) sum (p_w - mean_w)(p_v - mean_v)^T
  double var_v = 0.0;                                 // (1/n) sum |p_v - mean_v|^2
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d dv = points_v[i] - mean_v;
    cov_w_v += (points_w[i] - mean_w) * dv.transpose();
    var_v += dv.squaredNorm();
  }
  cov_w_v /= static_cast<double>(n);
  var_v /= static_cast<double>(n);
  if (var_v < 1e-12) throw std::runtime_error("alignment: the estimated positions do not move (zero spread)");

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov_w_v, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // S flips the weakest singular direction when U V^T would be a reflection (Umeyama eq. 39).
  Eigen::Vector3d s_diag = Eigen::Vector3d::Ones();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) s_diag(2) = -1.0;

  Similarity3 S_w_v;
  S_w_v.R_w_v = svd.matrixU() * s_diag.asDiagonal() * svd.matrixV().transpose();
  S_w_v.scale = with_scale ? svd.singularValues().dot(s_diag) / var_v : 1.0;
  S_w_v.t_w_v = mean_w - S_w_v.scale * S_w_v.R_w_v * mean_v;
  return S_w_v;
}

Similarity3 positionYawAlignment(const std::vector<Eigen::Vector3d>& points_v,
                                 const std::vector<Eigen::Vector3d>& points_w) {
  checkSizes(points_v, points_w, 2, "posyaw alignment");
  const Eigen::Vector3d mean_v = mean(points_v);
  const Eigen::Vector3d mean_w = mean(points_w);
  // For R_z(yaw) the cost is constant minus 2 (cos(yaw) A + sin(yaw) B), maximised at atan2(B, A).
  double a = 0.0, b = 0.0, spread = 0.0;
  for (std::size_t i = 0; i < points_v.size(); ++i) {
    const Eigen::Vector3d dv = points_v[i] - mean_v;
    const Eigen::Vector3d dw = points_w[i] - mean_w;
    a += dv.x() * dw.x() + dv.y() * dw.y();
    b += dv.x() * dw.y() - dv.y() * dw.x();
    spread += dv.head<2>().squaredNorm();
  }
  if (spread < 1e-12) throw std::runtime_error("posyaw alignment: the estimated positions do not move horizontally");
  Similarity3 S_w_v;
  S_w_v.R_w_v = Eigen::AngleAxisd(std::atan2(b, a), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  S_w_v.t_w_v = mean_w - S_w_v.R_w_v * mean_v;
  return S_w_v;
}

Similarity3 computeAlignment(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                             AlignmentMode mode) {
  if (gt.size() != est.size()) throw std::invalid_argument("alignment: trajectories differ in length");
  if (mode == AlignmentMode::kNone) return Similarity3{};
  std::vector<Eigen::Vector3d> points_v, points_w;
  points_v.reserve(est.size());
  points_w.reserve(gt.size());
  for (std::size_t i = 0; i < est.size(); ++i) {
    points_v.push_back(est[i].p);
    points_w.push_back(gt[i].p);
  }
  switch (mode) {
    case AlignmentMode::kSe3:
      return umeyamaAlignment(points_v, points_w, false);
    case AlignmentMode::kSim3:
      return umeyamaAlignment(points_v, points_w, true);
    case AlignmentMode::kPosYaw:
      return positionYawAlignment(points_v, points_w);
    case AlignmentMode::kNone:
      break;
  }
  return Similarity3{};
}

}  // namespace eval
}  // namespace vims
