// Sliding the window: marginalising the oldest keyframe or dropping the second newest frame.
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

}  // namespace

// ---------------------------------------------------------------------------------------------
// Optimisation
// ---------------------------------------------------------------------------------------------

bool VioEstimator::priorTouches(const MarginalizationPrior& prior, const Frame* frame) {
  for (const double* blk : prior.blocks) {
    if (blk == frame->pose || blk == frame->sb || blk == frame->slope) return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// Sliding the window
// ---------------------------------------------------------------------------------------------

void VioEstimator::reanchorFeaturesOf(const Frame* frame) {
  // Features anchored in `frame` move to their next observing frame: the point is transferred
  // (with the current depth) and lambda becomes its distance from the new anchor camera.
  const Eigen::Isometry3d T_bc = extrinsicCamera();
  std::vector<std::uint64_t> remove;
  for (auto& [id, feature] : features_) {
    if (feature.anchor != frame) continue;
    Frame* next = nullptr;
    for (const auto& f : frames_) {
      if (f.get() != frame && f->obs.count(id)) {
        next = f.get();
        break;
      }
    }
    if (next == nullptr) {
      remove.push_back(id);
      continue;
    }
    if (feature.has_depth) {
      const Eigen::Vector3d p_l = featureWorld(feature);
      const Eigen::Vector3d p_c = (next->T_l_b() * T_bc).inverse() * p_l;
      if (p_c.z() > kMinTargetDepth && std::isfinite(p_c.norm())) {
        feature.lambda[0] = p_c.norm();
      } else {
        feature.has_depth = false;
      }
    }
    feature.anchor = next;
    feature.sonar_ok = true;  // the new anchor has its own sonar range; the gate judges again
  }
  for (std::uint64_t id : remove) {
    for (auto& f : frames_) f->obs.erase(id);
    features_.erase(id);
  }
}

void VioEstimator::marginalizeOldest() {
  Frame* old = frames_.front().get();
  Frame* next = frames_[1].get();
  MarginalizationInfo info(options_.factors.marginalization);
  std::vector<double*> drop = {old->pose, old->sb};
  const bool sloped = slopedSeabed();
  auto declare_frame = [&](Frame* f) {
    info.addParameterBlock(f->pose, kPoseSize, BlockManifold::kPose);
    info.addParameterBlock(f->sb, kSpeedBiasSize, BlockManifold::kEuclidean);
    if (sloped) info.addParameterBlock(f->slope, 2, BlockManifold::kEuclidean);
  };
  for (auto& f : frames_) declare_frame(f.get());
  if (sloped) drop.push_back(old->slope);
  info.addParameterBlock(T_b_c_block_, kPoseSize, BlockManifold::kPose);
  info.addParameterBlock(td_, 1, BlockManifold::kEuclidean);
  const bool pressure = usePressure() && surface_initialized_;
  if (pressure) info.addParameterBlock(surface_z_, 1, BlockManifold::kEuclidean);
  try {
    // Priors that touch the dropped states are folded into the new one; the others stay.
    std::vector<std::shared_ptr<const MarginalizationPrior>> untouched;
    for (const auto& prior : priors_) {
      if (priorTouches(*prior, old)) {
        info.addResidualBlock(std::make_shared<MarginalizationFactor>(prior), nullptr, prior->blocks);
      } else {
        untouched.push_back(prior);
      }
    }
    info.addResidualBlock(std::make_shared<ImuFactor>(next->preintegration, g_l_), nullptr,
                          {old->pose, old->sb, next->pose, next->sb});
    if (sloped) {
      info.addResidualBlock(std::make_shared<SlopeRandomWalkFactor>(slopeStepSigma(*old, *next)), nullptr,
                            {old->slope, next->slope});
      if (old->has_first_state_prior)
        info.addResidualBlock(
            std::make_shared<SlopePriorFactor>(Eigen::Vector2d::Zero(), options_.seabed.slope_prior_std), nullptr,
            {old->slope});
    }
    if (pressure && old->depth) {
      auto pressure_loss = std::make_shared<ceres::HuberLoss>(options_.pressure.loss_scale);
      info.addResidualBlock(
          std::make_shared<PressureDepthFactor>(*old->depth, sequence_.pressure->T_b_p.translation(), pressure_sigma_),
          pressure_loss, {old->pose, surface_z_});
    }
    if (old->has_first_state_prior) {
      info.addResidualBlock(std::make_shared<PosePriorFactor>(
                                old->prior_p, old->prior_q,
                                PosePriorFactor::positionYawSqrtInformation(kGaugeSigmaPosition, kGaugeSigmaYaw)),
                            nullptr, {old->pose});
      Eigen::Matrix<double, 9, 1> inv_sigma;
      inv_sigma << Eigen::Vector3d::Constant(1.0 / options_.init_velocity_sigma),
          Eigen::Vector3d::Constant(1.0 / options_.init_accel_bias_sigma),
          Eigen::Vector3d::Constant(1.0 / options_.init_gyro_bias_sigma);
      info.addResidualBlock(std::make_shared<SpeedBiasPriorFactor>(old->prior_sb, inv_sigma), nullptr, {old->sb});
    }
    auto huber = std::make_shared<ceres::HuberLoss>(options_.reprojection_loss_scale);
    auto cauchy = std::make_shared<ceres::CauchyLoss>(options_.sonar_loss_scale);
    const SeabedTies seabed = seabedTies(sloped, false);
    std::vector<ResidualSpec> specs;
    for (auto& [id, feature] : features_) {
      if (feature.anchor != old) continue;
      specs.clear();
      featureResiduals(feature, frames_, T_b_c_block_, td_, options_.factors.reprojection.pixel_sigma, seabed, false,
                       &specs);
      if (specs.empty()) continue;
      info.addParameterBlock(feature.lambda, 1, BlockManifold::kEuclidean);
      drop.push_back(feature.lambda);
      for (const ResidualSpec& s : specs) {
        std::shared_ptr<const ceres::LossFunction> loss =
            s.sonar ? std::static_pointer_cast<const ceres::LossFunction>(cauchy)
                    : std::static_pointer_cast<const ceres::LossFunction>(huber);
        info.addResidualBlock(std::shared_ptr<const ceres::CostFunction>(s.cost), loss, s.blocks);
      }
    }
    // With estimate_td, td stays in the prior: one window of this slow motion observes it only
    // to about +-0.1 s (the tracker's random-walk errors, see predictImageVelocities), so the
    // estimate needs the information of every window since the start (tank60, tracker
    // features: the final td went from a wandering -0.08 s to a steady -0.002 s). Without
    // estimate_td it is marginalised as before.
    if (!options_.estimate_td) drop.push_back(td_);
    auto prior = info.marginalize(drop);
    priors_ = untouched;
    if (prior) priors_.push_back(prior);
  } catch (const std::exception& e) {
    logger_->warn(kComponent, std::string("marginalisation failed, priors dropped: ") + e.what());
    priors_.clear();
  }
  const bool had_gauge = old->has_first_state_prior;
  reanchorFeaturesOf(old);
  if (auto sample = seabedSample(*old, sloped)) seabed_relief_.addHistory(*sample);
  frames_.pop_front();
  next->preintegration.reset();
  if (priors_.empty()) {
    // Without a prior the gauge would float: pin the new oldest frame where it is.
    next->has_first_state_prior = true;
    next->prior_p = posePosition(next->pose);
    next->prior_q = Eigen::Quaterniond(poseRotation(next->pose));
    next->prior_sb = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(next->sb);
    if (!had_gauge) logger_->warn(kComponent, "no marginalisation prior: the gauge is re-pinned at the oldest frame");
  }
}

void VioEstimator::dropSecondNewest() {
  const std::size_t n = frames_.size();
  Frame* a = frames_[n - 3].get();
  Frame* b = frames_[n - 2].get();
  Frame* c = frames_[n - 1].get();
  std::vector<std::shared_ptr<const MarginalizationPrior>> kept;
  for (const auto& prior : priors_) {
    if (!priorTouches(*prior, b)) {
      kept.push_back(prior);
      continue;
    }
    // Only the prior knows this frame's states (its visual factors are simply dropped, as in
    // VINS-Mono): marginalise them out of it.
    MarginalizationInfo info(options_.factors.marginalization);
    for (std::size_t i = 0; i < prior->blocks.size(); ++i) {
      info.addParameterBlock(prior->blocks[i], prior->ambient_sizes[i], prior->manifolds[i]);
    }
    try {
      info.addResidualBlock(std::make_shared<MarginalizationFactor>(prior), nullptr, prior->blocks);
      std::vector<double*> drop;
      for (double* blk : {b->pose, b->sb, b->slope}) {
        if (std::find(prior->blocks.begin(), prior->blocks.end(), blk) != prior->blocks.end()) drop.push_back(blk);
      }
      auto reduced = info.marginalize(drop);
      if (reduced) kept.push_back(reduced);
    } catch (const std::exception& e) {
      logger_->warn(kComponent, std::string("marginalisation failed, prior dropped: ") + e.what());
    }
  }
  priors_ = kept;
  // Merge the IMU intervals a->b and b->c into a->c (shared boundary sample counted once).
  std::vector<ImuSample> samples = b->preintegration->samples();
  const auto& tail = c->preintegration->samples();
  samples.insert(samples.end(), tail.begin() + 1, tail.end());
  c->preintegration = std::make_shared<ImuPreintegration>(
      ImuPreintegration::fromSamples(samples, sbAccelBias(a->sb), sbGyroBias(a->sb), noise_));
  reanchorFeaturesOf(b);
  frames_.erase(frames_.begin() + static_cast<long>(n - 2));
  if (priors_.empty() && !frames_.front()->has_first_state_prior) {
    Frame* f = frames_.front().get();
    f->has_first_state_prior = true;
    f->prior_p = posePosition(f->pose);
    f->prior_q = Eigen::Quaterniond(poseRotation(f->pose));
    f->prior_sb = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(f->sb);
  }
}

}  // namespace vims
