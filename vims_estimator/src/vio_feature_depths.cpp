// Feature depths of the sliding-window VIO: seabed or triangulated starts, image velocities, outliers.
#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "vims_estimator/factors/imu_factor.h"
#include "vims_estimator/factors/marginalization_factor.h"
#include "vims_estimator/factors/pose_prior_factor.h"
#include "vims_estimator/factors/reprojection_factor.h"
#include "vims_estimator/factors/sonar_depth_factor.h"
#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"
#include "vims_estimator/vio_estimator.h"
#include "vio_window.h"

namespace vims {

using namespace vio_window;

// ---------------------------------------------------------------------------------------------
// Feature depths
// ---------------------------------------------------------------------------------------------

Eigen::Vector3d VioEstimator::featureWorld(const Feature& feature) const {
  const Frame::Obs& obs = feature.anchor->obs.at(feature.id);
  const Eigen::Vector3d f_c = feature.lambda[0] * unitBearing(obs.fo, td_[0]);
  return feature.anchor->T_l_b() * (extrinsicCamera() * f_c);
}

Eigen::Vector3d VioEstimator::gyroAt(double t) const {
  if (imu_.empty()) return Eigen::Vector3d::Zero();
  auto it = std::lower_bound(imu_.begin(), imu_.end(), t, [](const ImuSample& s, double value) { return s.t < value; });
  if (it == imu_.begin()) return imu_.front().gyro;
  if (it == imu_.end()) return imu_.back().gyro;
  const ImuSample& a = *(it - 1);
  const double w = (t - a.t) / (it->t - a.t);
  return (1.0 - w) * a.gyro + w * it->gyro;
}

// The td correction uv + (td - td_frame) velocity needs each observation's image velocity. It is
// the velocity the current state predicts, not a difference of the tracker's positions: KLT
// tracks frame to frame, so its position error is a random walk along the track (measured on
// tank60 against the ground-truth projections: 0.22 px rms per frame, 0.5 px at age 2, 3.5 px
// at age 38), and any difference of a track's positions shares increments with the later
// positions of the same track. That correlation biases td (errors in variables): -0.06 s on a
// sequence without offset. For a static point X_c in the camera frame at the state time,
//   dX_c/dt = -w_c x X_c - v_c,   w_c = R_bc^T (gyro - b_g),   v_c = R_bc^T (R_lb^T v_l + w_b x p_bc),
//   d(uv)/dt = (dX_c.xy - uv dX_c.z) / X_c.z,
// with X_c from the feature's anchor and depth. It is refreshed before every solve and held
// constant within it (first order, like the correction itself); an observation of a feature
// without depth gets none (it is in no factor).
void VioEstimator::predictImageVelocities() {
  // Without estimate_td, td == td_frame for every observation: the velocity has no effect.
  if (!options_.estimate_td) return;
  const Eigen::Isometry3d T_b_c = extrinsicCamera();
  const Eigen::Matrix3d R_cb = T_b_c.linear().transpose();
  // World points first: featureWorld reads the anchor observation's current velocity.
  std::map<std::uint64_t, Eigen::Vector3d> points;
  for (const auto& [id, feature] : features_) {
    if (feature.has_depth && feature.lambda[0] > 0.0) points.emplace(id, featureWorld(feature));
  }
  for (auto& frame : frames_) {
    const Eigen::Isometry3d T_l_b = frame->T_l_b();
    const Eigen::Isometry3d T_c_l = (T_l_b * T_b_c).inverse();
    const Eigen::Vector3d w_b = frame->gyro_at_state - sbGyroBias(frame->sb);
    const Eigen::Vector3d w_c = R_cb * w_b;
    const Eigen::Vector3d v_c =
        R_cb * (T_l_b.linear().transpose() * sbVelocity(frame->sb) + w_b.cross(T_b_c.translation()));
    for (auto& [id, obs] : frame->obs) {
      obs.fo.velocity.setZero();
      auto it = points.find(id);
      if (it == points.end()) continue;
      const Eigen::Vector3d X_c = T_c_l * it->second;
      if (!(X_c.z() > kMinTargetDepth)) continue;
      const Eigen::Vector3d dX_c = -w_c.cross(X_c) - v_c;
      const Eigen::Vector2d uv = X_c.head<2>() / X_c.z();
      const Eigen::Vector2d velocity = (dX_c.head<2>() - uv * dX_c.z()) / X_c.z();
      if (velocity.allFinite()) obs.fo.velocity = velocity;
    }
  }
}

bool VioEstimator::seabedDepth(const Feature& feature, double* lambda) const {
  const Frame& a = *feature.anchor;
  const Eigen::Isometry3d T_l_b = a.T_l_b();
  // The seabed plane: through the anchor's beam hit with the anchor's gradient, or (sonar outage)
  // the last measured one.
  SeabedPlane plane;
  const SonarDepthOptions& sonar_depth = options_.factors.sonar_depth;
  if (a.sonar_range) {
    const Eigen::Vector3d hit = T_l_b * sonarHitInBody(*a.sonar_range, sequence_.sonar.T_b_s);
    plane = SeabedPlane{hit.z(), hit.head<2>(), Eigen::Vector2d(a.slope[0], a.slope[1])};
  } else if (seabed_fix_ && sonar_depth.carry_seabed_through_outages &&
             (T_l_b.translation().head<2>() - seabed_fix_->xy).norm() <= sonar_depth.carry_max_distance_m) {
    plane = SeabedPlane{seabed_fix_->height, seabed_fix_->xy, seabed_fix_->slope};
  } else {
    return false;
  }
  if (!slopedSeabed()) plane.slope.setZero();
  const Eigen::Isometry3d T_l_c = T_l_b * extrinsicCamera();
  const Eigen::Vector3d ray = T_l_c.linear() * unitBearing(a.obs.at(feature.id).fo, td_[0]);
  // Ray c + l r meets the plane where n^T (c + l r) = n^T (hit): l = (h(c_xy) - c_z) / (n^T r).
  const Eigen::Vector3d n(-plane.slope.x(), -plane.slope.y(), 1.0);
  const double n_ray = plane.slope.isZero(0.0) ? ray.z() : n.dot(ray);
  if (n_ray > -kMinRayDownComponent) return false;
  const double l = (plane.heightAt(T_l_c.translation().head<2>()) - T_l_c.translation().z()) / n_ray;
  if (!(l >= options_.min_feature_depth_m && l <= options_.max_feature_depth_m)) return false;
  *lambda = l;
  return true;
}

bool VioEstimator::triangulate(const Feature& feature, double* lambda) const {
  const Frame& a = *feature.anchor;
  const Eigen::Isometry3d T_l_ca = a.T_l_b() * extrinsicCamera();
  const Eigen::Vector3d ra = T_l_ca.linear() * unitBearing(a.obs.at(feature.id).fo, td_[0]);
  const Eigen::Vector3d ca = T_l_ca.translation();
  double best_angle = 0.0;
  double best_lambda = -1.0;
  for (const auto& frame : frames_) {
    if (frame.get() == &a) continue;
    auto it = frame->obs.find(feature.id);
    if (it == frame->obs.end()) continue;
    const Eigen::Isometry3d T_l_cb = frame->T_l_b() * extrinsicCamera();
    const Eigen::Vector3d rb = T_l_cb.linear() * unitBearing(it->second.fo, td_[0]);
    const double angle = std::acos(std::clamp(ra.dot(rb), -1.0, 1.0));
    if (angle <= best_angle) continue;
    // Closest points of the rays ca + l ra and cb + m rb.
    const Eigen::Vector3d d = T_l_cb.translation() - ca;
    const double a11 = 1.0, a12 = -ra.dot(rb), a22 = 1.0;  // unit rays; system [1 -c; c -1][l m] = [d.ra d.rb]
    const double det = -a11 * a22 + a12 * a12;
    if (std::abs(det) < 1e-12) continue;
    const double b1 = d.dot(ra), b2 = d.dot(rb);
    const double l = (-a22 * b1 - a12 * b2) / det;
    const double m = (a11 * b2 + a12 * b1) / det;
    if (l < options_.min_feature_depth_m || m < options_.min_feature_depth_m || l > options_.max_feature_depth_m)
      continue;
    best_angle = angle;
    best_lambda = l;
  }
  if (best_lambda <= 0.0 || best_angle < options_.triangulation_min_angle_deg * M_PI / 180.0) return false;
  *lambda = best_lambda;
  return true;
}

void VioEstimator::initializeFeatureDepths() {
  for (auto& [id, feature] : features_) {
    if (feature.has_depth) continue;
    double lambda = 0.0;
    bool ok = false;
    if (options_.use_sonar) ok = seabedDepth(feature, &lambda);
    if (!ok) ok = triangulate(feature, &lambda);
    if (ok) {
      feature.lambda[0] = lambda;
      feature.has_depth = true;
    }
  }
}

void VioEstimator::removeOutliers() {
  const Eigen::Isometry3d T_bc = extrinsicCamera();
  std::vector<std::uint64_t> remove;
  for (auto& [id, feature] : features_) {
    if (!feature.has_depth) continue;
    if (!std::isfinite(feature.lambda[0]) || feature.lambda[0] < options_.min_feature_depth_m ||
        feature.lambda[0] > options_.max_feature_depth_m) {
      feature.has_depth = false;  // re-initialised from the seabed or triangulation
      continue;
    }
    const auto& anchor = feature.anchor->obs.at(id).fo;
    const Eigen::Isometry3d T_l_bi = feature.anchor->T_l_b();
    for (const auto& frame : frames_) {
      if (frame.get() == feature.anchor) continue;
      auto it = frame->obs.find(id);
      if (it == frame->obs.end()) continue;
      double z = 0.0;
      const Eigen::Vector2d r = reprojectionResidual(anchor, it->second.fo, T_l_bi, frame->T_l_b(), T_bc,
                                                     feature.lambda[0], td_[0], nullptr, &z);
      // In pixels through the lens; with the pinhole's scaling, the mean focal length's.
      const double error_px = weigh_through_lens_ ? (it->second.pixel_from_uv * r).norm() : focal_ * r.norm();
      if (z > kMinTargetDepth && error_px <= options_.outlier_reprojection_px) continue;
      remove.push_back(id);
      break;
    }
  }
  for (std::uint64_t id : remove) {
    for (auto& frame : frames_) frame->obs.erase(id);
    features_.erase(id);
  }
}

}  // namespace vims
