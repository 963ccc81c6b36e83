#include "pose_graph_manager_core.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <stdexcept>

#include "vims_pose_graph/angles.h"

namespace vims {

namespace {
constexpr const char* kComponent = "pose_graph_manager";
constexpr double kDeg = M_PI / 180.0;
// The vehicle-field model's velocity and acceleration at a keyframe come from the keyframes
// within this time of it [s] (at most kMotionMaxNeighbours either side): a few keyframes, short
// against the seconds over which an AUV's thrust changes.
constexpr double kMotionHalfWindowS = 2.0;
constexpr PoseGraphNodeId kMotionMaxNeighbours = 8;
// While the vehicle-field fit is used, the gate's site values are re-measured with it every this
// many samples (the fit keeps improving; a sort of the run's samples, a millisecond).
constexpr size_t kSiteRestartSamples = 100;

bool isValidPose(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  return T.translation().allFinite() && R.allFinite() &&
         (R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 && R.determinant() > 0.0;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Construction
// ---------------------------------------------------------------------------------------------

PoseGraphManagerCore::PoseGraphManagerCore(const PoseGraphManagerOptions& options, const SequenceConfig& sequence,
                                           std::shared_ptr<const BinaryVocabulary> vocabulary, LoggerPtr logger)
    : options_(options),
      mode_(options.modeSettings()),
      sequence_(sequence),
      vocabulary_(std::move(vocabulary)),
      logger_(logger ? std::move(logger) : Logger::nullLogger()),
      describer_(options.featureOptions(), options.loop.harris_threshold, sequence.camera,
                 options.loop.submap_include_tracked_corners),
      detector_(options.loop, options.magnetic, options.modeSettings(), sequence.camera, logger_,
                options.featureOptions()),
      map_(vocabulary_, options.graph, sequence.magnetometer.declination_deg * kDeg, logger_),
      geomagnetic_gate_(options.geomagnetic_gate),
      vehicle_field_(options.vehicle_field),
      scheduler_(options, logger_, map_, run_nodes_) {
  options_.validate();
  map_mode_ = options_.map_mode;
  scheduler_.setHoldLoadedMap(map_mode_ != MapMode::kMapping);
  map_.setRunCameraExtrinsic(sequence.camera.T_b_c);
  describer_.setDenseCorners(options_.loop.submap_dense_corners, options_.loop.submap_corner_min_distance_px,
                             options_.loop.submap_corner_max_level);
  describer_.setDenseCornersPerLevel(options_.loop.submap_dense_corners_per_level);
  describer_.setSeabedCorners(options_.loop.query_seabed_corners, options_.loop.submap_corner_min_distance_px,
                              options_.loop.submap_corner_max_level);
  if (!vocabulary_ || vocabulary_->empty())
    throw std::invalid_argument("PoseGraphManager: no vocabulary (load " + options_.vocabularyPath() + ")");
  if (vocabulary_->descriptorType() != toString(mode_.descriptor))
    throw std::invalid_argument("PoseGraphManager: mode '" + toString(options_.mode) + "' needs a '" +
                                toString(mode_.descriptor) + "' vocabulary, got a '" + vocabulary_->descriptorType() +
                                "' one");
}

void PoseGraphManagerCore::handOptimisationRequestsTo(std::function<void(OptimisationTrigger)> handler) {
  optimisation_handler_ = std::move(handler);
}

void PoseGraphManagerCore::requestOptimisation(OptimisationTrigger trigger) {
  recorrectYawFactors();
  scheduler_.optimisationRequested();
  if (optimisation_handler_)
    optimisation_handler_(trigger);
  else
    scheduler_.solveNow(trigger);
}

// ---------------------------------------------------------------------------------------------
// Inputs
// ---------------------------------------------------------------------------------------------

KeyframeDescription PoseGraphManagerCore::describe(const KeyframeData& kf) {
  if (!std::isfinite(kf.t) || !isValidPose(kf.T_odom_b)) return {};
  // Submap, tracked points and (query_seabed_corners, via setSeabedCorners) seabed corners in
  // one pass: one pyramid, corner response and ORB description for the keyframe.
  return describer_.describeKeyframeAndSeabed(
      kf.image, kf.features, kf.T_odom_b * kf.T_b_c.value_or(sequence_.camera.T_b_c), vocabulary_.get());
}

bool PoseGraphManagerCore::wantsQuery(double t) const {
  if (map_mode_ != MapMode::kLocalisation) {
    if (!(options_.place_min_interval_s > 0.0)) return true;
    if (map_loaded_ && !stats_.relocalised) return true;  // the loaded map is still to be found
    return !(t - last_queried_keyframe_t_ < options_.place_min_interval_s);
  }
  if (!stats_.relocalised || !(options_.localisation_query_interval_s > 0.0)) return true;
  if (!(t - stats_.last_loop_into_map_t < options_.localisation_lost_after_s)) return true;  // lost: search
  return !(t - last_queried_keyframe_t_ < options_.localisation_query_interval_s);
}

void PoseGraphManagerCore::addKeyframe(const KeyframeData& kf, KeyframeDescription description, bool queried) {
  VisualSubmap& submap = description.submap;
  if (!std::isfinite(kf.t) || !isValidPose(kf.T_odom_b)) {
    ++stats_.keyframes_rejected;
    logger_->warnThrottled(kComponent, "bad_keyframe", std::isfinite(kf.t) ? kf.t : 0.0, 5.0,
                           VIMS_STR("keyframe at t=" << kf.t << " dropped: non-finite time or invalid pose"));
    return;
  }
  if (!run_nodes_.empty() && !(kf.t > map_.node(run_nodes_.back()).pose.t)) {
    ++stats_.keyframes_rejected;
    logger_->warnThrottled(kComponent, "keyframe_time", kf.t, 5.0,
                           VIMS_STR("keyframe at t=" << kf.t << " dropped: not after the previous keyframe (t="
                                                     << map_.node(run_nodes_.back()).pose.t << ")"));
    return;
  }
  if (run_nodes_.empty() && !map_loaded_ && map_mode_ != MapMode::kMapping) {
    logger_->warn(kComponent, VIMS_STR("map mode " << toString(map_mode_) << " without a loaded map: mapping instead"));
    setMapMode(MapMode::kMapping);
  }
  if (kf.T_b_c) {
    // The VIO refines the camera extrinsic online: loops verified from now on and this run's
    // sessions in a saved map use its latest estimate (a keyframe's submap keeps image
    // coordinates and odom points only, so none depends on the earlier estimates).
    if (!kf.T_b_c->matrix().allFinite()) {
      logger_->warnThrottled(kComponent, "bad_extrinsic", kf.t, 5.0,
                             VIMS_STR("keyframe at t=" << kf.t << ": non-finite camera extrinsic ignored"));
    } else {
      map_.setRunCameraExtrinsic(*kf.T_b_c);
      detector_.setRunCameraExtrinsic(*kf.T_b_c);
    }
  }
  const bool new_session = !current_session_ || kf.session != current_vio_session_;
  const bool has_previous = !run_nodes_.empty();
  const PoseGraphNodeId previous = has_previous ? run_nodes_.back() : 0;
  Eigen::Vector3d p_w_b;
  double yaw_w_b = 0.0;
  uint32_t session = 0;
  if (new_session) {
    session = map_.addSession(kf.session, false);
    if (has_previous) {
      // A VIO reset: the new odom frame is unrelated to the old one, but the vehicle is where
      // it was a moment ago; start the new chain there (and link it with a weak edge below).
      const MapNode& prev = map_.node(previous);
      p_w_b = prev.pose.p_w_b;
      yaw_w_b = prev.pose.yaw_w_b;
      logger_->warn(kComponent,
                    VIMS_STR("VIO session " << current_vio_session_ << " -> " << kf.session << " at t=" << kf.t
                                            << ": new chain, linked to the previous one by a weak prior"));
    } else {
      // The run's first keyframe: the map frame starts as its VIO frame (or, with a loaded map,
      // as a provisional frame until the first loop into the map relocalises the run).
      p_w_b = kf.T_odom_b.translation();
      yaw_w_b = yawPitchRollFromRotation(kf.T_odom_b.linear()).yaw;
    }
    current_session_ = session;
    current_vio_session_ = kf.session;
    ++stats_.sessions;
  } else {
    session = *current_session_;
    const Eigen::Isometry3d T_w_b = map_.T_map_odom(previous) * kf.T_odom_b;
    p_w_b = T_w_b.translation();
    yaw_w_b = yawPitchRollFromRotation(T_w_b.linear()).yaw;
  }
  const bool has_visual = !submap.empty() && !submap.bow.empty();
  BowVector bow = submap.bow;
  // Re-flying a mapped place: the node, its edges and yaw factor are added and the keyframe
  // still queries (with its own described points and BoW vector, kept in `pending` below), but
  // its keypoints and descriptors are not stored and it is not a loop candidate (no entry in
  // the BoW database). Its BoW vector (~5 KB against ~200 KB for a whole submap) stays in the
  // node unless keep_culled_bow_vectors is false, so that place recognition can be evaluated on
  // every keyframe of a run (vims_eval place-recognition). The run's first keyframe has no component
  // to compare with (a loaded map is in another one until relocalisation).
  // Localising, no keyframe of the run is stored as a place: the map stays the loaded one.
  const bool localising = map_mode_ == MapMode::kLocalisation;
  const bool culled = has_visual && has_previous && !localising &&
                      submapIsRedundant(static_cast<PoseGraphNodeId>(map_.numNodes()), kf.t, p_w_b, previous);
  if (culled || (has_visual && localising)) {
    VisualSubmap bow_only;
    if (options_.loop.keep_culled_bow_vectors) bow_only.bow = submap.bow;
    submap = std::move(bow_only);
    ++(culled ? stats_.culled_submaps : stats_.localisation_keyframes);
  }
  const PoseGraphNodeId id = map_.addNode(kf.t, session, kf.T_odom_b, p_w_b, yaw_w_b, std::move(submap), false);
  if (has_previous) {
    if (new_session) {
      const double dt = std::max(0.0, kf.t - map_.node(previous).pose.t);
      const double sigma_p = options_.session_link_position_sigma_m + options_.session_link_position_sigma_per_s * dt;
      const double sigma_yaw =
          std::min(M_PI, options_.session_link_yaw_sigma_rad + options_.session_link_yaw_sigma_per_s_rad * dt);
      map_.addSessionLink(previous, id, sigma_p, sigma_yaw);
    } else {
      map_.addSequentialEdge(previous, id);
    }
  }
  if (kf.port_depth && sequence_.pressure)
    map_.addDepthMeasurement(id, *kf.port_depth, sequence_.pressure->T_b_p.translation());
  run_nodes_.push_back(id);
  latest_keyframe_t_ = kf.t;
  ++stats_.keyframes;
  if (queried) last_queried_keyframe_t_ = kf.t;
  if (!queried) {
    ++(localising ? stats_.localisation_skipped_queries : stats_.thinned_places);
  } else if (!has_visual) {
    ++stats_.empty_keyframes;
    logger_->warnThrottled(kComponent, "empty_keyframe", kf.t, 5.0,
                           VIMS_STR("keyframe at t=" << kf.t << " has no usable image corners (empty or dark image):"
                                                     << " pose-graph node without visual submap"));
  }
  PendingKeyframe pending;
  pending.node = id;
  pending.t = kf.t;
  pending.bow = std::move(bow);
  pending.points = std::move(description.points);
  pending.seabed_points = std::move(description.seabed_points);
  pending.has_visual = has_visual;
  pending_.push_back(std::move(pending));
  scheduler_.keyframeAdded();
  processReady(false);
  if (const std::optional<OptimisationTrigger> trigger = scheduler_.triggerAfterKeyframe())
    requestOptimisation(*trigger);
}

bool PoseGraphManagerCore::submapIsRedundant(PoseGraphNodeId new_node, double t, const Eigen::Vector3d& p_w_b,
                                             PoseGraphNodeId component_node) const {
  const LoopDetectorOptions& o = options_.loop;
  if (!(o.redundant_submap_radius_m > 0.0)) return false;
  const double r2 = o.redundant_submap_radius_m * o.redundant_submap_radius_m;
  const uint32_t component = map_.componentOf(component_node);
  for (PoseGraphNodeId i = 0; i < map_.numNodes(); ++i) {
    const MapNode& n = map_.node(i);
    if (n.bow_image < 0) continue;  // no visual submap (culled, empty image)
    if ((n.pose.p_w_b.head<2>() - p_w_b.head<2>()).squaredNorm() > r2) continue;
    if (std::abs(n.pose.p_w_b.z() - p_w_b.z()) > o.redundant_submap_max_height_difference_m) continue;
    // Not recent, with the loop candidates' exclusion: the VIO's own latest keyframes overlap
    // by construction and would cull each other before any of them could be a loop candidate.
    if (isRecentKeyframe(o, map_, new_node, t, i)) continue;
    if (map_.componentOf(i) != component) continue;
    return true;
  }
  return false;
}

void PoseGraphManagerCore::addSignature(const SignatureWindow& w) {
  if (!mode_.magnetic_stage || !std::isfinite(w.t)) return;
  if (w.t < latest_signature_t_) {
    logger_->warnThrottled(kComponent, "signature_time", w.t, 10.0,
                           VIMS_STR("signature window at t=" << w.t << " dropped: older than the previous one (t="
                                                             << latest_signature_t_ << ")"));
    return;
  }
  if (w.coil < 0 || w.coil > kMaxCoilIndex) {
    logger_->warnThrottled(kComponent, "signature_coil", w.t, 10.0,
                           VIMS_STR("signature window at t=" << w.t << " dropped: coil index " << w.coil
                                                             << " outside 0.." << kMaxCoilIndex));
    return;
  }
  StoredWindow s;
  s.t = w.t;
  s.coil = w.coil;
  s.valid = w.valid && w.amplitude_enu.allFinite();
  s.amplitude_enu = s.valid ? w.amplitude_enu : Eigen::Vector3d::Zero();
  windows_.push_back(s);
  unplaced_.push_back(s);
  latest_signature_t_ = w.t;
  processReady(false);
}

void PoseGraphManagerCore::addGeomagnetic(double t, const Eigen::Vector3d& field_body) {
  if (!mode_.geomagnetic_yaw || !std::isfinite(t)) return;
  if (!field_body.allFinite()) {
    logger_->warnThrottled(kComponent, "geomagnetic_nan", t, 10.0, "non-finite geomagnetic field ignored");
    return;
  }
  if (t < latest_geomagnetic_t_) return;
  geomagnetic_.push_back(GeomagneticMeasurement{t, field_body});
  latest_geomagnetic_t_ = t;
  processReady(false);
}

void PoseGraphManagerCore::finish() {
  processReady(true);
  if (mode_.geomagnetic_yaw) {
    applyGeomagneticVerdicts(geomagnetic_gate_.flush());
    if (geomagnetic_gate_.numSamples() > 0)
      logger_->info(kComponent, VIMS_STR(std::fixed << std::setprecision(2) << "geomagnetic gate: site field "
                                                    << geomagnetic_gate_.siteMagnitude() * 1e6 << " uT, inclination "
                                                    << geomagnetic_gate_.siteInclination() / kDeg << " deg; rejected "
                                                    << geomagnetic_gate_.numRejected() << " of "
                                                    << geomagnetic_gate_.numJudged() << " yaw measurements"));
    if (vehicle_field_.numSamples() > 0) logVehicleField();
  }
  if (mode_.magnetic_stage)
    for (auto& [coil, builder] : magnetic_builders_) addMagneticDraft(builder.breakGroup());
  if (map_.numNodes() > 0) requestOptimisation(OptimisationTrigger::kFinish);
}

void PoseGraphManagerCore::logVehicleField() const {
  auto uT = [](const Eigen::Vector3d& v) {
    return VIMS_STR(std::fixed << std::setprecision(2) << "[" << v.x() * 1e6 << ", " << v.y() * 1e6 << ", "
                               << v.z() * 1e6 << "] uT");
  };
  const VehicleFieldEstimator& f = vehicle_field_;
  logger_->info(kComponent,
                VIMS_STR("vehicle field "
                         << (f.applied() ? "taken out" : "not taken out") << " (body, fitted on " << f.numSamples()
                         << " samples): constant " << uT(f.parameters().segment<3>(0)) << ", at 0.5 m/s "
                         << uT(f.fittedField({0.5, 0.0})) << ", per m/s^2 " << uT(f.parameters().segment<3>(9))
                         << "; residual " << std::fixed << std::setprecision(1) << f.residualRms() * 1e9
                         << " nT, explains " << 100.0 * f.explainedFraction() << " % of the samples' spread"));
}

GeomagneticCandidate PoseGraphManagerCore::candidateOf(const MeasuredGeomagnetic& m) const {
  return GeomagneticGate::levelled(m.node, m.session, m.t, m.field_b - vehicle_field_.vehicleField(m.motion),
                                   m.R_odom_b);
}

void PoseGraphManagerCore::gateGeomagnetic(PoseGraphNodeId id, const Eigen::Vector3d& field_b) {
  const MapNode& node = map_.node(id);
  MeasuredGeomagnetic m{id, node.session, node.pose.t, field_b, ForwardMotion{}, node.pose.T_odom_b.linear()};
  // Without the motion (a session's first two keyframes) only the constant part is known.
  const std::optional<ForwardMotion> motion = forwardMotionAt(id);
  if (motion) {
    m.motion = *motion;
    const bool was_applied = vehicle_field_.applied();
    vehicle_field_.add(m.session, m.t, m.R_odom_b, field_b, *motion);
    const bool applied = vehicle_field_.applied();
    yaw_factors_may_hold_correction_ = yaw_factors_may_hold_correction_ || applied;
    if (applied != was_applied)
      logger_->info(kComponent,
                    VIMS_STR(std::fixed << std::setprecision(1) << "vehicle field "
                                        << (was_applied ? "no longer taken out" : "taken out") << " from t=" << m.t
                                        << " (the fit explains " << 100.0 * vehicle_field_.explainedFraction()
                                        << " % of the geomagnetic samples' spread)"));
    // The gate's site values and heading reference rest on the samples seen so far: measure them
    // again with the fit now used (else the uncorrected ones hold the medians for minutes).
    if (applied != was_applied || (applied && geomagnetic_history_.size() % kSiteRestartSamples == 0)) {
      std::vector<GeomagneticCandidate> history;
      history.reserve(geomagnetic_history_.size());
      for (const MeasuredGeomagnetic& h : geomagnetic_history_) history.push_back(candidateOf(h));
      geomagnetic_gate_.restartSite(history);
    }
  }
  geomagnetic_history_.push_back(m);
  gated_[id] = geomagnetic_history_.size() - 1;
  applyGeomagneticVerdicts(geomagnetic_gate_.add(candidateOf(m)));
}

void PoseGraphManagerCore::recorrectYawFactors() {
  // A vehicle whose fit was never used has its factors as measured: nothing to redo.
  if (!yaw_factors_may_hold_correction_) return;
  for (const auto& [measurement, sample] : run_yaw_factors_) {
    const MeasuredGeomagnetic& m = geomagnetic_history_[sample];
    map_.setYawMeasurementField(measurement, m.field_b - vehicle_field_.vehicleField(m.motion));
  }
}

void PoseGraphManagerCore::processReady(bool flush) {
  placeSignatures(flush);
  while (!pending_.empty()) {
    const PendingKeyframe& p = pending_.front();
    bool ready = flush || latest_keyframe_t_ >= p.t + options_.magnetic_wait_s;
    if (!ready) {
      const bool signature_ok =
          !mode_.magnetic_stage || latest_signature_t_ >= p.t + options_.loop.query_signature_max_dt_s;
      const bool yaw_ok = !mode_.geomagnetic_yaw || latest_geomagnetic_t_ >= p.t + options_.geomagnetic_max_dt_s;
      ready = signature_ok && yaw_ok;
    }
    if (!ready) break;
    PendingKeyframe item = std::move(pending_.front());
    pending_.pop_front();
    processPending(item);
  }
  pruneBuffers();
}

void PoseGraphManagerCore::applyGeomagneticVerdicts(const std::vector<GeomagneticVerdict>& verdicts) {
  for (const GeomagneticVerdict& v : verdicts) {
    const auto gated = gated_.find(v.candidate.node);
    std::optional<size_t> sample;
    if (gated != gated_.end()) {
      sample = gated->second;
      gated_.erase(gated);
    }
    if (v.accepted) {
      const size_t measurement = map_.yawMeasurements().size();
      if (map_.addYawMeasurement(v.candidate.node, v.candidate.field_b)) {
        ++stats_.yaw_factors;
        if (sample) run_yaw_factors_.emplace_back(measurement, *sample);
      }
      continue;
    }
    ++stats_.yaw_rejected;
    logger_->warnThrottled(
        kComponent, "geomagnetic_disturbed", v.candidate.t, 10.0,
        VIMS_STR(std::fixed << std::setprecision(3) << "geomagnetic yaw rejected at t=" << v.candidate.t
                            << ": disturbed field (magnitude " << std::showpos << 100.0 * v.magnitude_error_fraction
                            << " %, inclination " << v.inclination_error_rad / kDeg << " deg from the site's, azimuth "
                            << v.heading_error_rad / kDeg << std::noshowpos << " deg from the recent ones)"));
  }
}

std::optional<ForwardMotion> PoseGraphManagerCore::forwardMotionAt(PoseGraphNodeId id) const {
  // The nodes of the node's session within kMotionHalfWindowS of it (a session's nodes are
  // consecutive ids; the ones after it are usually in the map already, loop detection waits for
  // the magnetic data).
  const MapNode& centre = map_.node(id);
  std::vector<TimedPosition> positions;
  const PoseGraphNodeId first = id >= kMotionMaxNeighbours ? id - kMotionMaxNeighbours : 0;
  const PoseGraphNodeId last = std::min<PoseGraphNodeId>(id + kMotionMaxNeighbours, map_.numNodes() - 1);
  for (PoseGraphNodeId k = first; k <= last; ++k) {
    const MapNode& n = map_.node(k);
    if (n.session == centre.session && std::abs(n.pose.t - centre.pose.t) <= kMotionHalfWindowS)
      positions.push_back(TimedPosition{n.pose.t, n.pose.T_odom_b.translation()});
  }
  return forwardMotion(positions, centre.pose.t, centre.pose.T_odom_b.linear());
}

void PoseGraphManagerCore::processPending(PendingKeyframe& p) {
  if (mode_.geomagnetic_yaw) {
    const GeomagneticMeasurement* nearest = nullptr;
    for (const GeomagneticMeasurement& g : geomagnetic_)
      if (std::abs(g.t - p.t) <= options_.geomagnetic_max_dt_s &&
          (nearest == nullptr || std::abs(g.t - p.t) < std::abs(nearest->t - p.t)))
        nearest = &g;
    if (nearest != nullptr) gateGeomagnetic(p.node, nearest->field_body);
  }

  std::map<int, Eigen::Vector3d> signatures;  // by coil
  bool magnetometer_heard = false;
  if (mode_.magnetic_stage) {
    std::map<int, double> best_dt;
    for (const StoredWindow& w : windows_) {
      const double dt = std::abs(w.t - p.t);
      if (dt > options_.loop.query_signature_max_dt_s) continue;
      magnetometer_heard = true;
      if (!w.valid || w.amplitude_enu.norm() < options_.magnetic.min_amplitude_tesla) continue;
      const auto best = best_dt.find(w.coil);
      if (best != best_dt.end() && dt >= best->second) continue;
      best_dt[w.coil] = dt;
      signatures[w.coil] = w.amplitude_enu;
    }
    map_.setMagneticCoverage(p.node, magnetometer_heard);
  }
  if (!p.has_visual) return;
  if (mode_.magnetic_stage && signatures.empty()) {
    if (!magnetometer_heard)
      logger_->warnThrottled(
          kComponent, "magnetometer_silent", p.t, 10.0,
          VIMS_STR(std::fixed << std::setprecision(3) << "no magnetic signature near t=" << p.t
                              << " (magnetometer silent): magnetic stage skipped, loops from vision alone"));
    else
      logger_->debug(kComponent, VIMS_STR(std::fixed << std::setprecision(3) << "no valid signature near t=" << p.t
                                                     << " (coil not heard): magnetic stage skipped"));
  }

  LoopQuery query;
  query.node = p.node;
  query.t = p.t;
  query.T_odom_b = map_.node(p.node).pose.T_odom_b;
  query.bow = std::move(p.bow);
  query.points = std::move(p.points);
  if (options_.loop.query_local_map_keyframes > 0) {
    const uint32_t session = map_.node(p.node).session;
    // The local map spans the last query_local_map_keyframes keyframes, described or not: with
    // places thinned (place_min_interval_s) the last N described ones reach further back, where
    // the VIO's drift no longer fits the query's points together.
    const auto window = static_cast<PoseGraphNodeId>(options_.loop.query_local_map_keyframes);
    while (!recent_points_.empty() && recent_points_.front().node + window < p.node) recent_points_.pop_front();
    DescribedPoints own = query.points;  // the keyframe's own points, for the next queries
    for (auto it = recent_points_.rbegin(); it != recent_points_.rend(); ++it)
      if (it->session == session) mergeDescribedPoints(&query.points, it->points);
    recent_points_.push_back(RecentPoints{p.node, session, std::move(own)});
    while (recent_points_.size() > static_cast<size_t>(options_.loop.query_local_map_keyframes))
      recent_points_.pop_front();
  }
  query.seabed_points = std::move(p.seabed_points);
  query.signatures_enu = std::move(signatures);
  query.track_loaded_map = map_loaded_ && stats_.relocalised && map_mode_ != MapMode::kMapping;
  ++stats_.loop_queries;
  DetectionResult result = detector_.detect(query, map_);
  attempts_.insert(attempts_.end(), result.attempts.begin(), result.attempts.end());
  stats_.loop_attempts += result.attempts.size();
  const std::optional<LoopAttempt> accepted = result.accepted;
  last_detection_ = std::move(result);
  if (accepted) acceptLoop(*accepted);
}

void PoseGraphManagerCore::acceptLoop(const LoopAttempt& a) {
  const PoseGraphNodeId m = a.match_node;
  const PoseGraphNodeId q = a.query_node;
  if (!map_.sameComponent(m, q)) {
    // The loop joins two components whose frames are unrelated (a run and a loaded map before
    // relocalisation): move one rigidly (4-DoF) so the loop holds, then join them. The
    // reference component (the loaded map's frame) never moves.
    const MapNode& nm = map_.node(m);
    const MapNode& nq = map_.node(q);
    const RelativePose4Dof z = relativePose4DofFromRelative(a.T_match_query, nm.pose.pitch, nm.pose.roll);
    const bool q_in_reference = map_.inReferenceComponent(q);
    const bool m_in_reference = map_.inReferenceComponent(m);
    if (!q_in_reference) {
      const double yaw_q = wrapAngle(nm.pose.yaw_w_b + z.yaw_i_j);
      const Eigen::Vector3d p_q = nm.pose.p_w_b + rotationZ(nm.pose.yaw_w_b) * z.p_li_j;
      map_.moveComponent(map_.componentOf(q), correctionBetween(nq.pose.p_w_b, nq.pose.yaw_w_b, p_q, yaw_q));
    } else {
      const double yaw_m = wrapAngle(nq.pose.yaw_w_b - z.yaw_i_j);
      const Eigen::Vector3d p_m = nq.pose.p_w_b - rotationZ(yaw_m) * z.p_li_j;
      map_.moveComponent(map_.componentOf(m), correctionBetween(nm.pose.p_w_b, nm.pose.yaw_w_b, p_m, yaw_m));
    }
    if ((q_in_reference || m_in_reference) && map_loaded_ && !stats_.relocalised) {
      stats_.relocalised = true;
      stats_.relocalised_t = a.t_query;
      logger_->info(kComponent,
                    VIMS_STR("relocalised into the loaded map at t=" << a.t_query << " (match t=" << a.t_match << ", "
                                                                     << a.inliers << " inliers)"));
    }
  }
  const LoopEdgeId loop_id = map_.addLoopEdge(m, q, a.T_match_query, a.sigma);
  ++stats_.loops_accepted;
  if (map_.sessions()[map_.node(m).session].loaded) {
    ++stats_.loops_into_map;
    stats_.last_loop_into_map_t = std::max(stats_.last_loop_into_map_t, a.t_query);
  }
  if (options_.graph.learn_odometry_drift) learnOdometryDrift(a.t_query);
  scheduler_.loopAccepted(loop_id, m, q);
  logger_->info(kComponent,
                VIMS_STR(std::fixed << std::setprecision(3) << "loop accepted: t_query=" << a.t_query
                                    << " t_match=" << a.t_match << " inliers=" << a.inliers << " bow=" << a.bow_score));
  requestOptimisation(OptimisationTrigger::kLoop);
}

void PoseGraphManagerCore::learnOdometryDrift(double t) {
  const OdometryDriftScale before = map_.odometryDrift().scale;
  const OdometryDriftFit& fit = map_.learnOdometryDrift();
  if (!fit.fitted || (fit.scale.position == before.position && fit.scale.yaw == before.yaw)) return;
  logger_->info(kComponent,
                VIMS_STR("odometry drift learnt at t="
                         << std::fixed << std::setprecision(3) << t << std::defaultfloat << " from " << fit.chains_used
                         << " loop chains (" << fit.chains_rejected << " rejected, mean " << fit.mean_chain_length_m
                         << " m): sequential sigmas x" << std::sqrt(fit.scale.position) << " (position), x"
                         << std::sqrt(fit.scale.yaw) << " (yaw)"));
}

void PoseGraphManagerCore::placeSignatures(bool flush) {
  auto nodeTime = [&](PoseGraphNodeId id) { return map_.node(id).pose.t; };
  while (!unplaced_.empty()) {
    if (run_nodes_.empty()) {
      if (!flush) return;  // keyframes may still come
      unplaced_.clear();
      return;
    }
    const StoredWindow w = unplaced_.front();
    // Wait for the keyframe after the window, so it is interpolated rather than extrapolated.
    if (w.t > nodeTime(run_nodes_.back()) && !flush) return;
    unplaced_.pop_front();
    MagneticSubmapBuilder& builder = magnetic_builders_.try_emplace(w.coil, options_.magnetic).first->second;
    if (!w.valid) {
      addMagneticDraft(builder.breakGroup());
      continue;
    }
    const auto after = std::upper_bound(run_nodes_.begin(), run_nodes_.end(), w.t,
                                        [&](double t, PoseGraphNodeId id) { return t < nodeTime(id); });
    std::optional<PoseGraphNodeId> a, b;
    if (after != run_nodes_.begin()) a = *(after - 1);
    if (after != run_nodes_.end()) b = *after;
    PlacedSignature ps;
    ps.t = w.t;
    ps.coil = w.coil;
    ps.signature_enu = w.amplitude_enu;
    bool placed = false;
    if (a && b && map_.node(*a).session == map_.node(*b).session) {
      const MapNode& na = map_.node(*a);
      const MapNode& nb = map_.node(*b);
      const double span = nb.pose.t - na.pose.t;
      const double f = span > 0.0 ? (w.t - na.pose.t) / span : 0.0;
      ps.p_odom = (1.0 - f) * na.pose.T_odom_b.translation() + f * nb.pose.T_odom_b.translation();
      ps.session = na.session;
      ps.nearest_node = f <= 0.5 ? *a : *b;
      placed = true;
    } else {
      for (const std::optional<PoseGraphNodeId>& c : {a, b}) {
        if (!c || std::abs(nodeTime(*c) - w.t) > options_.signature_max_extrapolation_s) continue;
        if (placed && std::abs(nodeTime(*c) - w.t) >= std::abs(nodeTime(ps.nearest_node) - w.t)) continue;
        ps.p_odom = map_.node(*c).pose.T_odom_b.translation();
        ps.session = map_.node(*c).session;
        ps.nearest_node = *c;
        placed = true;
      }
    }
    if (!placed) {
      addMagneticDraft(builder.breakGroup());
      continue;
    }
    addMagneticDraft(builder.add(ps));
  }
}

void PoseGraphManagerCore::addMagneticDraft(const std::optional<MagneticSubmapDraft>& draft) {
  // Localising, the run's signatures still query the map (LoopQuery::signatures_enu) but do not
  // become places of it.
  if (!draft || map_mode_ == MapMode::kLocalisation) return;
  map_.addMagneticSubmap(*draft);
  ++stats_.magnetic_submaps;
}

void PoseGraphManagerCore::pruneBuffers() {
  // Keep what a waiting keyframe may still need (its time +- the association windows) and at
  // most a minute of history when no keyframe comes (VIO not initialised yet).
  const double margin = std::max(options_.loop.query_signature_max_dt_s, options_.geomagnetic_max_dt_s) + 1.0;
  double horizon = pending_.empty() ? latest_keyframe_t_ - margin : pending_.front().t - margin;
  horizon = std::max(horizon, std::max(latest_signature_t_, latest_geomagnetic_t_) - 60.0);
  while (!windows_.empty() && windows_.front().t < horizon) windows_.pop_front();
  while (!geomagnetic_.empty() && geomagnetic_.front().t < horizon) geomagnetic_.pop_front();
}

// ---------------------------------------------------------------------------------------------
// Map files
// ---------------------------------------------------------------------------------------------

void PoseGraphManagerCore::loadMap(const std::string& path) {
  if (!run_nodes_.empty() || map_loaded_)
    throw std::logic_error("PoseGraphManager::loadMap: load the map before the first keyframe (and only once)");
  map_.load(path);
  map_loaded_ = true;
  map_path_ = path;
  stats_.loaded_keyframes = map_.numNodes();
}

void PoseGraphManagerCore::saveMap(const std::string& path) const {
  if (map_mode_ == MapMode::kLocalisation) {
    map_.save(path, options_.vocabularyPath(), MapSaveScope::kLoadedSessions);
    logger_->info(kComponent, VIMS_STR("saved map '" << path << "': the loaded map's " << stats_.loaded_keyframes
                                                     << " keyframes (localisation: this run is not part of it)"));
    return;
  }
  map_.save(path, options_.vocabularyPath());
  logger_->info(kComponent,
                VIMS_STR("saved map '" << path << "': " << map_.numNodes() << " keyframes, " << map_.loopEdges().size()
                                       << " loops, " << map_.magneticSubmaps().size() << " magnetic submaps"));
}

void PoseGraphManagerCore::setMapMode(MapMode mode) {
  if (mode != MapMode::kMapping && !map_loaded_)
    throw std::invalid_argument("map mode " + toString(mode) + " needs a loaded map, and none is loaded");
  if (mode == map_mode_) return;
  logger_->info(kComponent, VIMS_STR("map mode " << toString(map_mode_) << " -> " << toString(mode)));
  map_mode_ = mode;
  scheduler_.setHoldLoadedMap(mode != MapMode::kMapping);
}

RelocalisationStatus PoseGraphManagerCore::relocalisationStatus() const {
  RelocalisationStatus s;
  s.map_mode = map_mode_;
  s.map_loaded = map_loaded_;
  s.map_path = map_path_;
  s.loaded_keyframes = stats_.loaded_keyframes;
  s.relocalised = stats_.relocalised;
  s.relocalised_t = stats_.relocalised_t;
  s.loops_into_map = stats_.loops_into_map;
  s.last_loop_into_map_t = stats_.last_loop_into_map_t;
  s.run_keyframes = run_nodes_.size();
  if (!run_nodes_.empty()) s.latest_keyframe_t = map_.node(run_nodes_.back()).pose.t;
  s.T_map_odom = T_map_odom();
  return s;
}

// ---------------------------------------------------------------------------------------------
// Outputs
// ---------------------------------------------------------------------------------------------

std::vector<KeyframePose> PoseGraphManagerCore::keyframePoses(bool include_loaded) const {
  std::vector<KeyframePose> out;
  for (PoseGraphNodeId i = 0; i < map_.numNodes(); ++i) {
    const MapNode& n = map_.node(i);
    const MapSession& s = map_.sessions()[n.session];
    if (s.loaded && !include_loaded) continue;
    KeyframePose k;
    k.node = i;
    k.t = n.pose.t;
    k.vio_session = s.vio_session;
    k.loaded = s.loaded;
    k.T_w_b = n.pose.T_w_b();
    out.push_back(k);
  }
  return out;
}

Eigen::Isometry3d PoseGraphManagerCore::T_map_odom() const {
  if (run_nodes_.empty()) return Eigen::Isometry3d::Identity();
  return map_.T_map_odom(run_nodes_.back());
}

std::vector<LoopEdgeInfo> PoseGraphManagerCore::loopEdges() const {
  std::vector<LoopEdgeInfo> out;
  for (const LoopEdge& e : map_.loopEdges()) {
    LoopEdgeInfo i;
    i.id = e.id;
    i.match = e.match;
    i.query = e.query;
    i.t_match = map_.node(e.match).pose.t;
    i.t_query = map_.node(e.query).pose.t;
    i.T_match_query = e.T_match_query;
    i.p_w_match = map_.node(e.match).pose.p_w_b;
    i.p_w_query = map_.node(e.query).pose.p_w_b;
    i.enabled = e.enabled;
    out.push_back(i);
  }
  return out;
}

std::vector<LoopAttempt> PoseGraphManagerCore::takeNewLoopAttempts() {
  std::vector<LoopAttempt> out;
  out.swap(attempts_);
  return out;
}

MapContents PoseGraphManagerCore::mapContents() const {
  MapContents c;
  for (PoseGraphNodeId i = 0; i < map_.numNodes(); ++i) {
    const MapNode& n = map_.node(i);
    if (!n.hasVisualSubmap()) continue;
    VisualSubmapMarker v;
    v.node = i;
    v.t = n.pose.t;
    v.p_w = n.pose.p_w_b;
    v.num_keypoints = n.num_keypoints;
    v.loaded = map_.sessions()[n.session].loaded;
    c.visual.push_back(v);
  }
  for (const MagneticSubmap& s : map_.magneticSubmaps()) {
    MagneticSubmapMarker m;
    m.id = s.id;
    m.tied_node = s.tied_node;
    m.p_w = map_.magneticSubmapPosition(s);
    m.radius_m = s.radius_m;
    m.signature_enu = s.signature_enu;
    m.clustered = map_.clusteredNodes(s, options_.magnetic.cluster_margin_m);
    c.magnetic.push_back(m);
  }
  return c;
}

PoseGraphManagerStats PoseGraphManagerCore::stats() const {
  PoseGraphManagerStats stats = stats_;
  stats.optimisations = scheduler_.optimisations();
  stats.vehicle_field_taken_out = vehicle_field_.applied();
  stats.vehicle_field_explained = vehicle_field_.explainedFraction();
  return stats;
}

}  // namespace vims
