/// Monocular structure from motion of the initialisation window (VINS-Mono's GlobalSFM):
/// relative pose of a reference pair by the essential matrix, triangulation, PnP of the other
/// frames against the growing point set, and a bundle adjustment. All observations are
/// undistorted normalised coordinates; poses are kept as world(c0)-to-camera transforms
/// (R_c_c0, t_c) while building and returned as T_c0_c.

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "vims_estimator/initialization/visual_inertial_initializer.h"

namespace vims {

namespace {

/// World(c0)-to-camera pose: x_c = R x_c0 + t.
struct CameraPose {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  bool known = false;
};

/// Linear (DLT) triangulation of x0, x1 seen by P0 = [R0 t0], P1 = [R1 t1]; false when the
/// point is not in front of both cameras.
bool triangulatePoint(const CameraPose& c0, const CameraPose& c1, const Eigen::Vector2d& x0, const Eigen::Vector2d& x1,
                      Eigen::Vector3d* point) {
  Eigen::Matrix<double, 3, 4> P0, P1;
  P0 << c0.q.toRotationMatrix(), c0.t;
  P1 << c1.q.toRotationMatrix(), c1.t;
  Eigen::Matrix4d A;
  A.row(0) = x0.x() * P0.row(2) - P0.row(0);
  A.row(1) = x0.y() * P0.row(2) - P0.row(1);
  A.row(2) = x1.x() * P1.row(2) - P1.row(0);
  A.row(3) = x1.y() * P1.row(2) - P1.row(1);
  const Eigen::Vector4d h = Eigen::JacobiSVD<Eigen::Matrix4d>(A, Eigen::ComputeFullV).matrixV().col(3);
  if (std::abs(h(3)) < 1e-12) return false;
  const Eigen::Vector3d p = h.head<3>() / h(3);
  if ((c0.q * p + c0.t).z() <= 0.0 || (c1.q * p + c1.t).z() <= 0.0) return false;
  if (!p.allFinite()) return false;
  *point = p;
  return true;
}

/// Reprojection residual in normalised coordinates, scaled to pixels (focal).
struct SfmReprojection {
  SfmReprojection(const Eigen::Vector2d& obs, double focal) : obs_(obs), focal_(focal) {}
  template <typename T>
  bool operator()(const T* q, const T* t, const T* point, T* residual) const {
    // q: Eigen order (x, y, z, w); ceres::QuaternionRotatePoint wants (w, x, y, z).
    const T q_wxyz[4] = {q[3], q[0], q[1], q[2]};
    T p[3];
    ceres::QuaternionRotatePoint(q_wxyz, point, p);
    p[0] += t[0];
    p[1] += t[1];
    p[2] += t[2];
    residual[0] = T(focal_) * (p[0] / p[2] - T(obs_.x()));
    residual[1] = T(focal_) * (p[1] / p[2] - T(obs_.y()));
    return true;
  }
  Eigen::Vector2d obs_;
  double focal_;
};

}  // namespace

VisualSfmResult solveVisualSfm(const std::vector<InitFrame>& frames, double focal_px,
                               const VisualInertialInitOptions& options) {
  VisualSfmResult result;
  const int n = static_cast<int>(frames.size());
  if (n < 3) {
    result.message = "fewer than 3 frames";
    return result;
  }
  const int last = n - 1;

  // 1. Reference pair: the earliest frame with enough common features and parallax to the newest.
  int reference = -1;
  Eigen::Matrix3d R_last_ref = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_last_ref = Eigen::Vector3d::Zero();
  for (int l = 0; l < last && reference < 0; ++l) {
    std::vector<cv::Point2d> a, b;
    double parallax = 0.0;
    for (const auto& [id, uv] : frames[l].observations) {
      auto it = frames[last].observations.find(id);
      if (it == frames[last].observations.end()) continue;
      a.emplace_back(uv.x(), uv.y());
      b.emplace_back(it->second.x(), it->second.y());
      parallax += (uv - it->second).norm();
    }
    if (static_cast<int>(a.size()) < options.min_relative_pose_features) continue;
    if (focal_px * parallax / static_cast<double>(a.size()) < options.min_relative_pose_parallax_px) continue;
    cv::Mat mask;
    const cv::Mat E = cv::findEssentialMat(a, b, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.999,
                                           options.ransac_threshold_px / focal_px, mask);
    if (E.rows != 3 || E.cols != 3) continue;
    cv::Mat R, t;
    const int inliers = cv::recoverPose(E, a, b, cv::Mat::eye(3, 3, CV_64F), R, t, mask);
    if (inliers < options.min_relative_pose_features / 2 + 6) continue;
    cv::cv2eigen(R, R_last_ref);
    cv::cv2eigen(t, t_last_ref);
    reference = l;
  }
  if (reference < 0) {
    result.message = "no frame has enough features and parallax with the newest for a relative pose";
    return result;
  }

  std::vector<CameraPose> pose(n);
  pose[reference].known = true;  // identity: c0
  pose[last].q = Eigen::Quaterniond(R_last_ref);
  pose[last].t = t_last_ref;  // unit length: the SfM scale
  pose[last].known = true;

  std::map<std::uint64_t, Eigen::Vector3d> points;
  auto triangulatePair = [&](int i, int j) {
    for (const auto& [id, uv] : frames[i].observations) {
      if (points.count(id)) continue;
      auto it = frames[j].observations.find(id);
      if (it == frames[j].observations.end()) continue;
      Eigen::Vector3d p;
      if (triangulatePoint(pose[i], pose[j], uv, it->second, &p)) points[id] = p;
    }
  };
  auto solvePnp = [&](int k, const CameraPose& guess) -> bool {
    std::vector<cv::Point3d> object;
    std::vector<cv::Point2d> image;
    for (const auto& [id, uv] : frames[k].observations) {
      auto it = points.find(id);
      if (it == points.end()) continue;
      object.emplace_back(it->second.x(), it->second.y(), it->second.z());
      image.emplace_back(uv.x(), uv.y());
    }
    if (object.size() < 15) return false;
    cv::Mat rvec, tvec, R;
    cv::eigen2cv(Eigen::Matrix3d(guess.q.toRotationMatrix()), R);
    cv::Rodrigues(R, rvec);
    cv::eigen2cv(guess.t, tvec);
    if (!cv::solvePnP(object, image, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, true)) return false;
    cv::Rodrigues(rvec, R);
    Eigen::Matrix3d Re;
    Eigen::Vector3d te;
    cv::cv2eigen(R, Re);
    cv::cv2eigen(tvec, te);
    if (!Re.allFinite() || !te.allFinite()) return false;
    pose[k].q = Eigen::Quaterniond(Re).normalized();
    pose[k].t = te;
    pose[k].known = true;
    return true;
  };

  // 2. Forward from the reference to the newest, then the frames between, then backwards.
  triangulatePair(reference, last);
  for (int i = reference + 1; i < last; ++i) {
    if (!solvePnp(i, pose[i - 1])) {
      result.message = "PnP failed for frame " + std::to_string(i);
      return result;
    }
    triangulatePair(i, last);
  }
  for (int i = reference + 1; i < last; ++i) triangulatePair(reference, i);
  for (int i = reference - 1; i >= 0; --i) {
    if (!solvePnp(i, pose[i + 1])) {
      result.message = "PnP failed for frame " + std::to_string(i);
      return result;
    }
    triangulatePair(i, reference);
  }
  // Every other feature seen twice: its first and last observations.
  std::map<std::uint64_t, std::pair<int, int>> span;
  for (int k = 0; k < n; ++k) {
    for (const auto& [id, uv] : frames[k].observations) {
      auto it = span.find(id);
      if (it == span.end())
        span[id] = {k, k};
      else
        it->second.second = k;
    }
  }
  for (const auto& [id, s] : span) {
    if (points.count(id) || s.first == s.second) continue;
    Eigen::Vector3d p;
    if (triangulatePoint(pose[s.first], pose[s.second], frames[s.first].observations.at(id),
                         frames[s.second].observations.at(id), &p)) {
      points[id] = p;
    }
  }

  // 3. Bundle adjustment: the reference pose and the newest position are fixed (gauge and scale).
  ceres::Problem problem;
  ceres::Manifold* quaternion_manifold = new ceres::EigenQuaternionManifold;
  std::vector<std::array<double, 4>> q(n);
  std::vector<std::array<double, 3>> t(n);
  for (int k = 0; k < n; ++k) {
    q[k] = {pose[k].q.x(), pose[k].q.y(), pose[k].q.z(), pose[k].q.w()};
    t[k] = {pose[k].t.x(), pose[k].t.y(), pose[k].t.z()};
  }
  std::map<std::uint64_t, std::array<double, 3>> xyz;
  for (const auto& [id, p] : points) xyz[id] = {p.x(), p.y(), p.z()};
  ceres::LossFunction* loss = new ceres::HuberLoss(2.0);
  int residuals = 0;
  for (int k = 0; k < n; ++k) {
    problem.AddParameterBlock(q[k].data(), 4, quaternion_manifold);
    problem.AddParameterBlock(t[k].data(), 3);
    for (const auto& [id, uv] : frames[k].observations) {
      auto it = xyz.find(id);
      if (it == xyz.end()) continue;
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<SfmReprojection, 2, 4, 3, 3>(new SfmReprojection(uv, focal_px)), loss,
          q[k].data(), t[k].data(), it->second.data());
      ++residuals;
    }
  }
  problem.SetParameterBlockConstant(q[reference].data());
  problem.SetParameterBlockConstant(t[reference].data());
  problem.SetParameterBlockConstant(t[last].data());
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.max_num_iterations = 50;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable() || residuals == 0) {
    result.message = "bundle adjustment failed";
    return result;
  }

  // 4. Output in c0 with the points that reproject well in front of every observing camera.
  result.T_c0_c.resize(n);
  for (int k = 0; k < n; ++k) {
    const Eigen::Quaterniond qk = Eigen::Quaterniond(q[k][3], q[k][0], q[k][1], q[k][2]).normalized();
    const Eigen::Vector3d tk(t[k][0], t[k][1], t[k][2]);
    if (!qk.coeffs().allFinite() || !tk.allFinite()) {
      result.message = "non-finite pose after bundle adjustment";
      return result;
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = qk.conjugate().toRotationMatrix();
    T.translation() = -(qk.conjugate() * tk);
    result.T_c0_c[k] = T;
  }
  double sum_sq = 0.0;
  int count = 0;
  for (const auto& [id, p] : xyz) {
    const Eigen::Vector3d pc0(p[0], p[1], p[2]);
    if (!pc0.allFinite()) continue;
    bool good = true;
    double local_sq = 0.0;
    int local = 0;
    for (int k = 0; k < n && good; ++k) {
      auto it = frames[k].observations.find(id);
      if (it == frames[k].observations.end()) continue;
      const Eigen::Vector3d pc = result.T_c0_c[k].inverse() * pc0;
      if (pc.z() <= 1e-6) {
        good = false;
        break;
      }
      const double e = focal_px * (pc.head<2>() / pc.z() - it->second).norm();
      if (e > 3.0 * options.max_sfm_rms_px) good = false;
      local_sq += e * e;
      ++local;
    }
    if (!good) continue;
    result.points_c0[id] = pc0;
    sum_sq += local_sq;
    count += local;
  }
  result.reference_frame = reference;
  result.rms_px = count > 0 ? std::sqrt(sum_sq / count) : 0.0;
  if (static_cast<int>(result.points_c0.size()) < options.min_sfm_points) {
    result.message = "only " + std::to_string(result.points_c0.size()) + " points triangulated";
    return result;
  }
  if (result.rms_px > options.max_sfm_rms_px) {
    result.message = "bundle adjustment RMS " + std::to_string(result.rms_px) + " px too large";
    return result;
  }
  result.ok = true;
  return result;
}

}  // namespace vims
