// The window solves of the sliding-window VIO and the sonar ranges they use.
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
#include "vims_estimator/factors/pressure_depth_factor.h"
#include "vims_estimator/factors/reprojection_factor.h"
#include "vims_estimator/factors/sonar_depth_factor.h"
#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"
#include "vims_estimator/vio_estimator.h"
#include "vio_window.h"

namespace vims {

using namespace vio_window;

namespace {

constexpr const char* kComponent = "vio";

/// The anchor observation of a feature the sonar ties to the seabed (depth set, not gated out,
/// its anchor has a range), else nullptr.
template <class FeatureT>
const FeatureObservation* sonarTiedObservation(const FeatureT& feature) {
  const auto* a = feature.anchor;
  if (!feature.has_depth || !feature.sonar_ok || !(feature.lambda[0] > 0.0) || !a->sonar_range) return nullptr;
  const auto obs = a->obs.find(feature.id);
  return obs == a->obs.end() ? nullptr : &obs->second.fo;
}

}  // namespace

void VioEstimator::optimize(VioFrameResult* result) {
  predictImageVelocities();
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold pose_manifold;
  ceres::HuberLoss huber(options_.reprojection_loss_scale);
  ceres::CauchyLoss cauchy(options_.sonar_loss_scale);

  for (auto& frame : frames_) {
    problem.AddParameterBlock(frame->pose, kPoseSize, &pose_manifold);
    problem.AddParameterBlock(frame->sb, kSpeedBiasSize);
  }
  problem.AddParameterBlock(T_b_c_block_, kPoseSize, &pose_manifold);
  if (options_.estimate_extrinsic) {
    // The calibration's prior, once per solve (what the marginalised windows knew of T_b_c is in
    // the marginalisation prior, which does not contain this factor).
    Matrix6d sqrt_information = Matrix6d::Zero();
    sqrt_information.topLeftCorner<3, 3>().diagonal().setConstant(1.0 / options_.extrinsic_prior_translation_m);
    sqrt_information.bottomRightCorner<3, 3>().diagonal().setConstant(1.0 / options_.extrinsic_prior_rotation_rad);
    problem.AddResidualBlock(new PosePriorFactor(sequence_.camera.T_b_c.translation(),
                                                 Eigen::Quaterniond(sequence_.camera.T_b_c.linear()), sqrt_information),
                             nullptr, T_b_c_block_);
  } else {
    problem.SetParameterBlockConstant(T_b_c_block_);
  }
  problem.AddParameterBlock(td_, 1);
  // Mean image speed of the window's tracked observations: td is only estimated with motion.
  double speed_sum = 0.0;
  int speed_count = 0;
  for (const auto& frame : frames_) {
    for (const auto& [id, obs] : frame->obs) {
      if (obs.fo.velocity.isZero()) continue;  // new feature: no velocity yet
      speed_sum += focal_ * obs.fo.velocity.norm();
      ++speed_count;
    }
  }
  const bool td_observable = speed_count > 0 && speed_sum / speed_count > options_.td_min_image_speed_px_s;
  if (options_.estimate_td && td_observable) {
    problem.SetParameterLowerBound(td_, 0, -options_.max_abs_td_s);
    problem.SetParameterUpperBound(td_, 0, options_.max_abs_td_s);
  } else {
    problem.SetParameterBlockConstant(td_);
  }

  for (std::size_t i = 1; i < frames_.size(); ++i) {
    Frame* fi = frames_[i - 1].get();
    Frame* fj = frames_[i].get();
    fj->preintegration->repropagateIfNeeded(sbAccelBias(fi->sb), sbGyroBias(fi->sb),
                                            options_.factors.imu_preintegration);
    problem.AddResidualBlock(new ImuFactor(fj->preintegration, g_l_), nullptr, fi->pose, fi->sb, fj->pose, fj->sb);
  }
  for (const auto& prior : priors_) problem.AddResidualBlock(new MarginalizationFactor(prior), nullptr, prior->blocks);
  Frame* first = frames_.front().get();
  if (first->has_first_state_prior) {
    problem.AddResidualBlock(
        new PosePriorFactor(first->prior_p, first->prior_q,
                            PosePriorFactor::positionYawSqrtInformation(kGaugeSigmaPosition, kGaugeSigmaYaw)),
        nullptr, first->pose);
    Eigen::Matrix<double, 9, 1> inv_sigma;
    inv_sigma << Eigen::Vector3d::Constant(1.0 / options_.init_velocity_sigma),
        Eigen::Vector3d::Constant(1.0 / options_.init_accel_bias_sigma),
        Eigen::Vector3d::Constant(1.0 / options_.init_gyro_bias_sigma);
    problem.AddResidualBlock(new SpeedBiasPriorFactor(first->prior_sb, inv_sigma), nullptr, first->sb);
  }

  const bool sloped = slopedSeabed();
  if (sloped) addSeabedSlopeBlocks(&problem);
  ceres::HuberLoss pressure_loss(options_.pressure.loss_scale);
  result->pressure_factors = addPressureFactors(&problem, &pressure_loss, false);

  int n_features = 0, n_sonar = 0;
  const SeabedTies seabed = seabedTies(sloped, true);
  std::vector<ResidualSpec> specs;
  int n_gated = 0;
  for (auto& [id, feature] : features_) {
    specs.clear();
    const bool was_on_seabed = feature.sonar_ok;
    featureResiduals(feature, frames_, T_b_c_block_, td_, options_.factors.reprojection.pixel_sigma, seabed, true,
                     &specs);
    if (was_on_seabed && !feature.sonar_ok) ++n_gated;
    if (specs.empty()) continue;
    problem.AddParameterBlock(feature.lambda, 1);
    problem.SetParameterLowerBound(feature.lambda, 0, options_.min_feature_depth_m);
    problem.SetParameterUpperBound(feature.lambda, 0, options_.max_feature_depth_m);
    ++n_features;
    for (const ResidualSpec& s : specs) {
      if (s.sonar) ++n_sonar;
      problem.AddResidualBlock(s.cost, s.sonar ? static_cast<ceres::LossFunction*>(&cauchy) : &huber, s.blocks);
    }
  }
  if (n_features == 0 && options_.estimate_td && td_observable)
    problem.SetParameterBlockConstant(td_);  // no visual factor
  if (n_gated > 0) {
    logger_->warnThrottled(
        kComponent, "seabed_gate", frames_.back()->t_stamp, 30.0,
        VIMS_STR(n_gated << " feature(s) off the seabed plane through their anchor's sonar hit (a rock "
                            "or a fish under the beam, a rock or a structure in view): their sonar "
                            "factors are dropped, vision holds them; further cases within 30 s are "
                            "counted, not logged"));
  }

  ceres::Solver::Summary summary;
  ceres::Solve(windowSolverOptions(options_, ceres::DENSE_SCHUR), &problem, &summary);
  result->features_in_window = n_features;
  result->sonar_factors = n_sonar;
}

void VioEstimator::optimizeNewest(VioFrameResult* result) {
  // Only the newest frame's pose and speed-bias are free; the previous frame's state, the
  // anchors' poses, the depths, T_b_c and td are constants. Residuals: the IMU factor from the
  // previous frame and the newest frame's reprojections of every landmark anchored elsewhere.
  // Features anchored in the newest frame (new ones) constrain nothing yet.
  predictImageVelocities();
  const std::size_t n = frames_.size();
  Frame* prev = frames_[n - 2].get();
  Frame* newest = frames_[n - 1].get();
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold pose_manifold;
  ceres::HuberLoss huber(options_.reprojection_loss_scale);

  auto add_constant = [&](double* block, int size, ceres::Manifold* manifold) {
    if (problem.HasParameterBlock(block)) return;
    problem.AddParameterBlock(block, size, manifold);
    problem.SetParameterBlockConstant(block);
  };
  problem.AddParameterBlock(newest->pose, kPoseSize, &pose_manifold);
  problem.AddParameterBlock(newest->sb, kSpeedBiasSize);
  add_constant(prev->pose, kPoseSize, &pose_manifold);
  add_constant(prev->sb, kSpeedBiasSize, nullptr);
  add_constant(T_b_c_block_, kPoseSize, &pose_manifold);
  add_constant(td_, 1, nullptr);
  newest->preintegration->repropagateIfNeeded(sbAccelBias(prev->sb), sbGyroBias(prev->sb),
                                              options_.factors.imu_preintegration);
  problem.AddResidualBlock(new ImuFactor(newest->preintegration, g_l_), nullptr, prev->pose, prev->sb, newest->pose,
                           newest->sb);

  const double pixel_sigma = options_.factors.reprojection.pixel_sigma;
  const Eigen::Isometry3d T_bc = extrinsicCamera();
  const Eigen::Isometry3d T_l_bk = newest->T_l_b();
  int n_features = 0;
  for (auto& [id, feature] : features_) {
    if (!feature.has_depth || !(feature.lambda[0] > 0.0) || feature.anchor == newest) continue;
    auto it = newest->obs.find(id);
    if (it == newest->obs.end()) continue;
    const auto& anchor = feature.anchor->obs.at(id).fo;
    double z = 0.0;
    reprojectionResidual(anchor, it->second.fo, feature.anchor->T_l_b(), T_l_bk, T_bc, feature.lambda[0], td_[0],
                         nullptr, &z);
    if (!(z > kMinTargetDepth)) continue;
    add_constant(feature.anchor->pose, kPoseSize, &pose_manifold);
    add_constant(feature.lambda, 1, nullptr);
    problem.AddResidualBlock(new ReprojectionFactor(anchor, it->second.fo, it->second.pixel_from_uv / pixel_sigma),
                             &huber, feature.anchor->pose, newest->pose, T_b_c_block_, feature.lambda, td_);
    ++n_features;
  }
  ceres::HuberLoss pressure_loss(options_.pressure.loss_scale);
  result->pressure_factors = addPressureFactors(&problem, &pressure_loss, true);

  ceres::Solver::Summary summary;
  // 15 unknowns: nothing to eliminate.
  ceres::Solve(windowSolverOptions(options_, ceres::DENSE_QR), &problem, &summary);
  result->features_in_window = n_features;
  result->sonar_factors = 0;
}

SeabedTies VioEstimator::seabedTies(bool sloped, bool update_relief) {
  SeabedTies seabed;
  seabed.use_sonar = options_.use_sonar;
  seabed.T_b_s = sequence_.sonar.T_b_s;
  seabed.sonar_sigma = sonar_sigma_;
  seabed.options = &options_.factors.sonar_depth;
  seabed.carried = seabed_fix_ ? &*seabed_fix_ : nullptr;
  seabed.sloped = sloped;
  seabed.carried_features = carriedFeatureCount(seabed);
  if (options_.use_sonar && options_.factors.sonar_depth.tie_to_nearest_hit)
    seabed.nearest_hit_ties = nearestHitTies(sloped);
  const bool learn = update_relief && options_.use_sonar && options_.factors.sonar_depth.learn_misfit;
  const std::vector<double> distances = countSonarFeatures(learn, seabed.nearest_hit_ties);
  if (learn) updateSeabedRelief(distances, sloped);
  if (relief_) seabed.relief_per_m = relief_->misfit_per_m;
  return seabed;
}

std::vector<double> VioEstimator::countSonarFeatures(bool with_distances,
                                                     const std::map<std::uint64_t, HitTie>& nearest_hit_ties) {
  for (auto& frame : frames_) frame->sonar_features = 0;
  std::vector<double> distances;
  if (!options_.use_sonar) return distances;
  const Eigen::Isometry3d T_bc = poseBlockToIsometry(T_b_c_block_);
  for (const auto& [id, feature] : features_) {
    const FeatureObservation* fo = sonarTiedObservation(feature);
    if (!fo) continue;
    Frame* a = feature.anchor;
    if (const auto tie = nearest_hit_ties.find(id); tie != nearest_hit_ties.end()) {
      if (tie->second.window_frame) ++frames_.at(*tie->second.window_frame)->sonar_features;
      if (with_distances) distances.push_back(tie->second.distance);
      continue;
    }
    ++a->sonar_features;
    if (!with_distances) continue;
    distances.push_back(
        sonarHitDistance(*fo, *a->sonar_range, sequence_.sonar.T_b_s, a->T_l_b(), T_bc, feature.lambda[0], td_[0]));
  }
  return distances;
}

std::map<std::uint64_t, HitTie> VioEstimator::nearestHitTies(bool sloped) const {
  std::map<std::uint64_t, HitTie> ties;
  const SonarDepthOptions& o = options_.factors.sonar_depth;
  std::map<const Frame*, int> anchor_features;
  for (const auto& [id, feature] : features_)
    if (sonarTiedObservation(feature)) ++anchor_features[feature.anchor];
  // The window's hits at the current estimate: they move with their keyframes' poses.
  std::vector<std::pair<std::size_t, Eigen::Vector2d>> window_hits;
  for (std::size_t i = 0; i < frames_.size(); ++i)
    if (auto sample = seabedSample(*frames_[i], false)) window_hits.emplace_back(i, sample->xy);
  const Eigen::Isometry3d T_bc = poseBlockToIsometry(T_b_c_block_);
  std::map<std::uint64_t, std::size_t> kept_hit_of;
  std::map<std::size_t, int> sharing;
  for (const auto& [id, feature] : features_) {
    const FeatureObservation* fo = sonarTiedObservation(feature);
    if (!fo) continue;
    const Frame* a = feature.anchor;
    // A window keyframe's hit is a state like the anchor's: always a candidate. A kept hit only
    // where the relief sets the anchor's own factors' growth: below the floor the plane's own
    // error does, which a kept hit shares and adds its stale pose to (docs/factors.md 5f).
    const bool relief_sets = relief_ && o.misfitPerM(relief_->misfit_per_m, anchor_features[a]) > o.misfit_per_m;
    const Eigen::Isometry3d T_l_ba = a->T_l_b();
    const Eigen::Vector2d xy = featureInL(*fo, T_l_ba, T_bc, feature.lambda[0], td_[0]).head<2>();
    double nearest =
        sonarHitDistance(*fo, *a->sonar_range, sequence_.sonar.T_b_s, T_l_ba, T_bc, feature.lambda[0], td_[0]);
    std::optional<std::size_t> nearest_frame;
    for (const auto& [index, hit_xy] : window_hits) {
      const double d = (xy - hit_xy).norm();
      if (frames_[index].get() != a && d < nearest) {
        nearest = d;
        nearest_frame = index;
      }
    }
    const auto kept = relief_sets ? seabed_relief_.nearestKeptHit(xy, nearest) : std::nullopt;
    if (kept) {
      const SeabedSample& h = seabed_relief_.keptHit(kept->first);
      HitTie& tie = ties[id];
      tie.plane = SeabedPlane{h.height, h.xy, sloped ? h.slope : Eigen::Vector2d::Zero()};
      tie.distance = kept->second;
      kept_hit_of[id] = kept->first;
      ++sharing[kept->first];
    } else if (nearest_frame) {
      HitTie& tie = ties[id];
      tie.window_frame = nearest_frame;
      tie.distance = nearest;
    }
  }
  for (auto& [id, hit] : kept_hit_of) ties[id].sharing = sharing[hit];
  return ties;
}

std::optional<SeabedSample> VioEstimator::seabedSample(const Frame& f, bool sloped) const {
  if (!f.sonar_range) return std::nullopt;
  const Eigen::Vector3d hit = f.T_l_b() * sonarHitInBody(*f.sonar_range, sequence_.sonar.T_b_s);
  SeabedSample sample;
  sample.xy = hit.head<2>();
  sample.height = hit.z();
  if (sloped) sample.slope = Eigen::Vector2d(f.slope[0], f.slope[1]);
  return sample;
}

void VioEstimator::updateSeabedRelief(const std::vector<double>& feature_distances, bool sloped) {
  if (feature_distances.empty()) return;
  std::vector<double> d = feature_distances;
  const auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
  std::nth_element(d.begin(), mid, d.end());
  std::vector<SeabedSample> window;
  for (const auto& frame : frames_)
    if (auto sample = seabedSample(*frame, sloped)) window.push_back(*sample);
  const SonarDepthOptions& o = options_.factors.sonar_depth;
  auto estimate = seabed_relief_.estimate(window, sonar_sigma_, *mid, o.misfit_min_pairs);
  if (!estimate) return;  // too few pairs (start, outage, hovering): keep what was learnt
  relief_ = estimate;
  const double t = frames_.back()->t_stamp;
  if (t - last_relief_log_t_ >= 60.0) {
    last_relief_log_t_ = t;
    logger_->info(kComponent, VIMS_STR("seabed relief " << std::fixed << std::setprecision(3) << relief_->misfit_per_m
                                                        << " m/m from " << relief_->pairs << " pairs of sonar hits "
                                                        << std::setprecision(2) << relief_->pair_distance_m
                                                        << " m apart (the features' median distance from their hit)"));
  }
}

int VioEstimator::carriedFeatureCount(const SeabedTies& seabed) const {
  int n = 0;
  for (const auto& [id, feature] : features_) n += tiedToCarriedSeabed<Frame>(feature, seabed) ? 1 : 0;
  return n;
}

void VioEstimator::fillMissingSonarRanges() {
  if (!options_.use_sonar) return;
  for (auto& frame : frames_) {
    if (!frame->sonar_range) frame->sonar_range = sonarRangeAt(frame->t_state);
    if (!frame->depth) frame->depth = pressureDepthAt(frame->t_state);
  }
  // The newest frame's range may still be on its way; one frame later a missing range is a gap.
  const std::size_t n = frames_.size();
  if (n >= 2 && !frames_[n - 2]->sonar_range) {
    const Frame& f = *frames_[n - 2];
    std::ostringstream fallback;
    fallback << std::fixed << std::setprecision(3);
    if (seabed_fix_ && options_.factors.sonar_depth.carry_seabed_through_outages)
      fallback << "features held at the seabed height the sonar last measured (z=" << seabed_fix_->height
               << " m at t=" << seabed_fix_->t << ") within " << options_.factors.sonar_depth.carry_max_distance_m
               << " m of it, visual-inertial beyond";
    else
      fallback << "visual-inertial only until it returns";
    logger_->warnThrottled(kComponent, "no_sonar", f.t_stamp, 10.0,
                           VIMS_STR("sonar gap: no filtered range within "
                                    << sonarInterpolationGapS() << " s of the frame at t=" << std::fixed
                                    << std::setprecision(3) << f.t_stamp << ": " << fallback.str()));
  }
}

void VioEstimator::updateSeabedFix() {
  for (auto it = frames_.rbegin(); it != frames_.rend(); ++it) {
    const Frame& f = **it;
    if (!f.sonar_range) continue;
    if (seabed_fix_ && seabed_fix_->t > f.t_state) return;  // an older frame: keep the newer fix
    const Eigen::Isometry3d T_l_b = f.T_l_b();
    SeabedFix fix;
    fix.height = seabedSample(f, false)->height;
    fix.xy = T_l_b.translation().head<2>();
    fix.t = f.t_state;
    fix.slope = Eigen::Vector2d(f.slope[0], f.slope[1]);
    if (!std::isfinite(fix.height) || !fix.xy.allFinite() || !fix.slope.allFinite()) return;
    seabed_fix_ = fix;
    return;
  }
}

double VioEstimator::slopeStepSigma(const Frame& a, const Frame& b) const {
  const double distance = (posePosition(b.pose) - posePosition(a.pose)).head<2>().norm();
  const SeabedModelOptions& o = options_.seabed;
  return std::sqrt(o.slope_random_walk * o.slope_random_walk * distance + o.slope_step_std * o.slope_step_std);
}

void VioEstimator::addSeabedSlopeBlocks(ceres::Problem* problem) {
  const SeabedModelOptions& o = options_.seabed;
  for (auto& frame : frames_) {
    problem->AddParameterBlock(frame->slope, 2);
    for (int i = 0; i < 2; ++i) {
      problem->SetParameterLowerBound(frame->slope, i, -o.max_slope);
      problem->SetParameterUpperBound(frame->slope, i, o.max_slope);
    }
  }
  for (std::size_t i = 1; i < frames_.size(); ++i) {
    problem->AddResidualBlock(new SlopeRandomWalkFactor(slopeStepSigma(*frames_[i - 1], *frames_[i])), nullptr,
                              frames_[i - 1]->slope, frames_[i]->slope);
  }
  Frame* first = frames_.front().get();
  if (first->has_first_state_prior)
    problem->AddResidualBlock(new SlopePriorFactor(Eigen::Vector2d::Zero(), o.slope_prior_std), nullptr, first->slope);
}

void VioEstimator::initializeSurface() {
  if (surface_initialized_ || !usePressure()) return;
  const Eigen::Vector3d& p_bp = sequence_.pressure->T_b_p.translation();
  for (const auto& frame : frames_) {
    if (!frame->depth) continue;
    // The surface is depth above the port: the first depth fixes it, later ones refine it.
    surface_z_[0] = (frame->T_l_b() * p_bp).z() + *frame->depth;
    surface_initialized_ = true;
    return;
  }
}

int VioEstimator::addPressureFactors(ceres::Problem* problem, ceres::LossFunction* loss, bool newest_only) {
  if (!usePressure()) return 0;
  initializeSurface();
  if (!surface_initialized_) return 0;
  const Eigen::Vector3d& p_bp = sequence_.pressure->T_b_p.translation();
  int n = 0;
  for (std::size_t i = newest_only ? frames_.size() - 1 : 0; i < frames_.size(); ++i) {
    Frame* frame = frames_[i].get();
    if (!frame->depth) continue;
    if (!problem->HasParameterBlock(surface_z_)) {
      problem->AddParameterBlock(surface_z_, 1);
      if (newest_only) problem->SetParameterBlockConstant(surface_z_);
    }
    problem->AddResidualBlock(new PressureDepthFactor(*frame->depth, p_bp, pressure_sigma_), loss, frame->pose,
                              surface_z_);
    ++n;
  }
  return n;
}

std::optional<double> vio_window::interpolateSeries(const std::deque<std::pair<double, double>>& series, double t,
                                                    double gap) {
  if (series.empty()) return std::nullopt;
  auto it = std::lower_bound(series.begin(), series.end(), t,
                             [](const std::pair<double, double>& s, double value) { return s.first < value; });
  if (it != series.end() && it != series.begin()) {
    const auto& a = *(it - 1);
    const auto& b = *it;
    if (t - a.first <= gap && b.first - t <= gap) {
      const double w = (t - a.first) / (b.first - a.first);
      return a.second + w * (b.second - a.second);
    }
  }
  // No bracketing pair (the newest sample is older than t): hold the nearest sample if it is
  // within half the gap.
  double best_dt = std::numeric_limits<double>::infinity();
  double best = 0.0;
  if (it != series.end()) {
    best_dt = it->first - t;
    best = it->second;
  }
  if (it != series.begin() && t - (it - 1)->first < best_dt) {
    best_dt = t - (it - 1)->first;
    best = (it - 1)->second;
  }
  if (best_dt <= 0.5 * gap) return best;
  return std::nullopt;
}

}  // namespace vims
