#include "vims_pose_graph/loop_detector.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>

#include "point_keypoint_distance.h"
#include "vims_common/magnetic_signature.h"

namespace vims {

namespace {
constexpr const char* kComponent = "loop_closing";

/// One point's descriptors regrouped per keypoint octave: the ones pointDistance() compares with
/// a keypoint of octave o, contiguous (ORB pyramids have 8 levels; octaves outside
/// [0, kOctaves) take the general path). Built once per point instead of filtering the point's
/// descriptors by level for each of the ~3000 keypoints of a candidate; assign() reuses the
/// storage of the previous point (one allocation per matching call, not per point).
class DescriptorsByOctave {
 public:
  static constexpr int kOctaves = 16;

  void assign(const DescribedPoints& points, const std::vector<uint32_t>& descriptor_ids, const LevelWindow& levels) {
    flat_.clear();
    for (int o = 0; o < kOctaves; ++o) {
      begin_[static_cast<size_t>(o)] = flat_.size();
      for (uint32_t d : descriptor_ids)
        if (levels.admits(points.level_of_descriptor[d], o)) flat_.push_back(points.descriptors[d]);
    }
    begin_[kOctaves] = flat_.size();
  }
  static bool covers(int octave) { return octave >= 0 && octave < kOctaves; }
  bool empty(int octave) const {
    return begin_[static_cast<size_t>(octave)] == begin_[static_cast<size_t>(octave) + 1];
  }
  const BinaryDescriptor* begin(int octave) const { return flat_.data() + begin_[static_cast<size_t>(octave)]; }
  const BinaryDescriptor* end(int octave) const { return flat_.data() + begin_[static_cast<size_t>(octave) + 1]; }

 private:
  std::vector<BinaryDescriptor> flat_;
  std::array<size_t, kOctaves + 1> begin_{};
};

/// The candidate's keypoints grouped by octave (counting sort, stable: ascending keypoint index
/// within a group), with their descriptors and pixels copied in that order; group kOctaves holds
/// the octaves DescriptorsByOctave does not cover. Built once per matching call, so each point
/// is compared only with the groups its level window admits, one descriptor set per group,
/// instead of looking up the window for each keypoint (a varying inner loop per keypoint).
class KeypointsByOctave {
 public:
  static constexpr int kGroups = DescriptorsByOctave::kOctaves + 1;

  explicit KeypointsByOctave(const VisualSubmap& candidate) {
    const size_t n = candidate.keypoints.size();
    std::array<size_t, kGroups + 1> next{};
    for (const cv::KeyPoint& kp : candidate.keypoints) ++next[static_cast<size_t>(groupOf(kp.octave)) + 1];
    for (int g = 0; g < kGroups; ++g) next[static_cast<size_t>(g) + 1] += next[static_cast<size_t>(g)];
    begin_ = next;
    index.resize(n);
    descriptor.resize(n);
    pt.resize(n);
    octave.resize(n);
    for (size_t k = 0; k < n; ++k) {
      const size_t at = next[static_cast<size_t>(groupOf(candidate.keypoints[k].octave))]++;
      index[at] = static_cast<uint32_t>(k);
      descriptor[at] = candidate.descriptors[k];
      pt[at] = candidate.keypoints[k].pt;
      octave[at] = candidate.keypoints[k].octave;
    }
  }
  static int groupOf(int octave) {
    return DescriptorsByOctave::covers(octave) ? octave : DescriptorsByOctave::kOctaves;
  }
  size_t begin(int group) const { return begin_[static_cast<size_t>(group)]; }
  size_t end(int group) const { return begin_[static_cast<size_t>(group) + 1]; }
  size_t size() const { return index.size(); }

  std::vector<uint32_t> index;  ///< keypoint index in the candidate
  std::vector<BinaryDescriptor> descriptor;
  std::vector<cv::Point2f> pt;
  std::vector<int> octave;

 private:
  std::array<size_t, kGroups + 1> begin_{};
};

/// Whether a point's distances to the keypoints of `group` were computed (see
/// distancesToKeypoints()); the others are all 257.
using ActiveGroups = std::array<bool, KeypointsByOctave::kGroups>;

/// pointDistance() of one point to the keypoints of every group its level window admits, into
/// `distance` (indexed like `keypoints`); `active` tells which groups were filled. Keypoints of
/// the other groups are at 257 ("no match": no descriptor of the point is compared with them),
/// which never wins and never lowers a second best, so they need no entry. Returns the position
/// of the smallest distance, the lowest keypoint index among equal ones (the first smallest in
/// candidate order), or keypoints.size() when nothing was compared. The loop detector's hot
/// loop, hence the popcount dispatch.
VIMS_POPCOUNT_DISPATCH size_t distancesToKeypoints(const DescribedPoints& points,
                                                   const std::vector<uint32_t>& descriptor_ids,
                                                   const DescriptorsByOctave& by_octave,
                                                   const KeypointsByOctave& keypoints, const LevelWindow& levels,
                                                   std::vector<int>* distance, ActiveGroups* active) {
  size_t best = keypoints.size();
  int best_distance = 257;
  for (int g = 0; g < KeypointsByOctave::kGroups; ++g) {
    const size_t first = keypoints.begin(g);
    const size_t last = keypoints.end(g);
    const bool covered = g < DescriptorsByOctave::kOctaves;
    (*active)[static_cast<size_t>(g)] = first < last && !(covered && by_octave.empty(g));
    if (!(*active)[static_cast<size_t>(g)]) continue;
    size_t group_best = first;
    int group_best_distance = 257;
    if (covered) {
      const BinaryDescriptor* const d_begin = by_octave.begin(g);
      const BinaryDescriptor* const d_end = by_octave.end(g);
      for (size_t j = first; j < last; ++j) {
        const BinaryDescriptor& other = keypoints.descriptor[j];
        int d = hammingDistance(*d_begin, other);
        for (const BinaryDescriptor* it = d_begin + 1; it != d_end; ++it) d = std::min(d, hammingDistance(*it, other));
        (*distance)[j] = d;
        if (d < group_best_distance) {
          group_best_distance = d;
          group_best = j;
        }
      }
    } else {
      for (size_t j = first; j < last; ++j) {
        const int d = pointDistance(points, descriptor_ids, keypoints.descriptor[j], keypoints.octave[j], levels);
        (*distance)[j] = d;
        if (d < group_best_distance) {
          group_best_distance = d;
          group_best = j;
        }
      }
    }
    if (group_best_distance < best_distance || (group_best_distance == best_distance && best_distance < 257 &&
                                                keypoints.index[group_best] < keypoints.index[best])) {
      best_distance = group_best_distance;
      best = group_best;
    }
  }
  return best_distance < 257 ? best : keypoints.size();
}

/// Whether any keypoint of `submap` within sqrt(radius2) px of `uv` is within max_distance of
/// the point (the covisibility check's inner loop).
VIMS_POPCOUNT_DISPATCH bool hasMatchingKeypointNear(const DescribedPoints& points,
                                                    const std::vector<uint32_t>& descriptor_ids,
                                                    const VisualSubmap& submap, const Eigen::Vector2d& uv,
                                                    double radius2, int max_distance, const LevelWindow& levels) {
  for (size_t k = 0; k < submap.keypoints.size(); ++k) {
    const double dx = submap.keypoints[k].pt.x - uv.x();
    const double dy = submap.keypoints[k].pt.y - uv.y();
    if (dx * dx + dy * dy > radius2) continue;
    if (pointDistance(points, descriptor_ids, submap.descriptors[k], submap.keypoints[k].octave, levels) <=
        max_distance)
      return true;
  }
  return false;
}
}  // namespace

std::string toString(LoopStage stage) {
  switch (stage) {
    case LoopStage::kMagnetic:
      return "magnetic";
    case LoopStage::kBow:
      return "bow";
    case LoopStage::kMatching:
      return "matching";
    case LoopStage::kPnp:
      return "pnp";
    case LoopStage::kCovisibility:
      return "covisibility";
    case LoopStage::kAccepted:
      return "accepted";
  }
  return "magnetic";
}

LoopStage loopStageFromString(const std::string& name) {
  for (LoopStage s : {LoopStage::kMagnetic, LoopStage::kBow, LoopStage::kMatching, LoopStage::kPnp,
                      LoopStage::kCovisibility, LoopStage::kAccepted})
    if (toString(s) == name) return s;
  throw std::invalid_argument("unknown loop stage '" + name + "'");
}

// ---------------------------------------------------------------------------------------------
// Matching
// ---------------------------------------------------------------------------------------------

double altitudeLevelShift(double depth_query, double depth_candidate, double scale_factor) {
  if (!(depth_query > 0.0) || !(depth_candidate > 0.0) || !(scale_factor > 1.0) || !std::isfinite(depth_query) ||
      !std::isfinite(depth_candidate))
    return std::numeric_limits<double>::quiet_NaN();
  return std::log(depth_query / depth_candidate) / std::log(scale_factor);
}

double medianQueryDepth(const DescribedPoints& points, const Eigen::Isometry3d& T_odom_c) {
  const Eigen::Isometry3d T_c_odom = T_odom_c.inverse();
  std::vector<double> depth;
  depth.reserve(points.numPoints());
  for (const Eigen::Vector3d& p : points.p_odom) {
    const double z = (T_c_odom * p).z();
    if (z > 0.0 && std::isfinite(z)) depth.push_back(z);
  }
  if (depth.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(depth.begin(), depth.begin() + static_cast<std::ptrdiff_t>(depth.size() / 2), depth.end());
  return depth[depth.size() / 2];
}

std::vector<PointMatch> matchPointsToKeypoints(const DescribedPoints& points, const VisualSubmap& candidate,
                                               double ratio, int max_distance, double duplicate_radius_px,
                                               int max_level_difference) {
  return matchPointsToKeypoints(points, candidate, ratio, max_distance, duplicate_radius_px,
                                LevelWindow::around(max_level_difference));
}

std::vector<PointMatch> matchPointsToKeypoints(const DescribedPoints& points, const VisualSubmap& candidate,
                                               double ratio, int max_distance, double duplicate_radius_px,
                                               const LevelWindow& levels) {
  std::vector<PointMatch> matches;
  const size_t num_keypoints = candidate.keypoints.size();
  if (points.empty() || num_keypoints == 0 || candidate.descriptors.size() != num_keypoints) return matches;
  const std::vector<std::vector<uint32_t>> by_point = descriptorsByPoint(points);
  const KeypointsByOctave keypoints(candidate);
  const double duplicate_r2 = duplicate_radius_px * duplicate_radius_px;
  std::vector<int> distance(num_keypoints);  // indexed like `keypoints` (grouped by octave)
  ActiveGroups active{};
  DescriptorsByOctave by_octave;
  for (uint32_t p = 0; p < by_point.size(); ++p) {
    if (by_point[p].empty()) continue;
    by_octave.assign(points, by_point[p], levels);
    const size_t best = distancesToKeypoints(points, by_point[p], by_octave, keypoints, levels, &distance, &active);
    if (best == keypoints.size() || distance[best] > max_distance) continue;
    const int best_distance = distance[best];
    if (ratio < 1.0) {
      // Second best among keypoints at another place: the same corner detected on another
      // pyramid level is not a competing match. Only the compared groups: the others are at 257,
      // the initial value. Stops as soon as the ratio test fails (a smaller second best cannot
      // make it pass again).
      const cv::Point2f& at = keypoints.pt[best];
      int second = 257;
      bool ambiguous = false;
      for (int g = 0; g < KeypointsByOctave::kGroups && !ambiguous; ++g) {
        if (!active[static_cast<size_t>(g)]) continue;
        for (size_t j = keypoints.begin(g); j < keypoints.end(g); ++j) {
          if (distance[j] >= second || j == best) continue;
          const cv::Point2f d = keypoints.pt[j] - at;
          if (static_cast<double>(d.x) * d.x + static_cast<double>(d.y) * d.y <= duplicate_r2) continue;
          second = distance[j];
          ambiguous = !(best_distance < ratio * second);
          if (ambiguous) break;
        }
      }
      if (ambiguous || !(best_distance < ratio * second)) continue;
    }
    matches.push_back(PointMatch{p, keypoints.index[best], best_distance});
  }
  // One point per keypoint: keep the closest (ties: the lower point index, the order above).
  return closestMatchPerKeypoint(matches, num_keypoints);
}

// ---------------------------------------------------------------------------------------------
// LoopVerifier
// ---------------------------------------------------------------------------------------------

LoopVerifier::LoopVerifier(const LoopDetectorOptions& options, const CameraCalibration& camera,
                           const FeatureExtractionOptions& features)
    : options_(options), camera_(camera), camera_model_(camera), features_(features), T_b_c_(camera.T_b_c) {
  options_.validate();
  if (!(camera.fx > 0.0) || !(camera.fy > 0.0) || camera.width <= 0 || camera.height <= 0)
    throw std::invalid_argument("LoopVerifier: invalid camera calibration");
}

const Eigen::Isometry3d& LoopVerifier::extrinsicOf(const MultiScaleMap& map, PoseGraphNodeId node) const {
  const MapSession& session = map.sessions()[map.node(node).session];
  return session.loaded ? session.T_b_c : T_b_c_;
}

LevelWindow LoopVerifier::levelWindow(const LoopQuery& query, const MultiScaleMap& map,
                                      PoseGraphNodeId candidate) const {
  const LevelWindow around = LevelWindow::around(options_.match_max_level_difference);
  if (!options_.match_level_from_altitude || features_.descriptor != DescriptorType::kOrb || features_.orb_levels < 2 ||
      query.node >= map.numNodes() || candidate >= map.numNodes() || !map.sameComponent(query.node, candidate))
    return around;
  const double depth_query = medianQueryDepth(query.points, query.T_odom_b * T_b_c_);
  // Same place, same seabed: the candidate camera is as much farther from it as it is higher.
  const double height_query = (map.node(query.node).pose.T_w_b() * T_b_c_).translation().z();
  const double height_candidate = (map.node(candidate).pose.T_w_b() * extrinsicOf(map, candidate)).translation().z();
  const double shift =
      altitudeLevelShift(depth_query, depth_query + (height_candidate - height_query), features_.orb_scale_factor);
  if (!std::isfinite(shift)) return around;
  return LevelWindow{shift, options_.match_predicted_level_tolerance};
}

VerificationResult LoopVerifier::verify(const LoopQuery& query, const MultiScaleMap& map,
                                        PoseGraphNodeId candidate) const {
  VerificationResult r;
  const MapNode& cand = map.node(candidate);
  const std::shared_ptr<const VisualSubmap> submap = map.visualSubmap(candidate);
  const VisualSubmap& sub = *submap;
  // The candidate's submap is in its own run's camera (a loaded map's rig may differ from this run's).
  const Eigen::Isometry3d& T_bm_cm = extrinsicOf(map, candidate);
  const LevelWindow levels = levelWindow(query, map, candidate);
  // Relocalisation: a candidate the query's run is not joined to yet (a loaded map, another
  // VIO session) gets the guided search and the query's seabed corners (guided_min_inliers).
  const bool guided = options_.guided_min_inliers > 0 && options_.guided_min_inliers < options_.pnp_min_inliers &&
                      query.node < map.numNodes() && !map.sameComponent(query.node, candidate);
  // Otherwise the query's seabed corners only across a scale change (their interpolated depths
  // are less exact than the VIO's landmarks; at about the same altitude the tracked points
  // suffice).
  DescribedPoints with_seabed;
  const bool use_seabed =
      !query.seabed_points.empty() &&
      (guided || (levels.tolerance >= 0.0 && std::abs(levels.shift) >= options_.query_seabed_min_level_shift));
  if (use_seabed) {
    with_seabed = query.points;
    mergeDescribedPoints(&with_seabed, query.seabed_points);
  }
  const DescribedPoints& points = use_seabed ? with_seabed : query.points;
  std::vector<PointMatch> matches = matchPointsToKeypoints(
      points, sub, options_.match_ratio, options_.match_max_distance, options_.match_duplicate_radius_px, levels);
  r.num_matches = static_cast<int>(matches.size());
  // A weaker consensus is a hypothesis for the guided search.
  const int hypothesis_min_inliers = guided ? options_.guided_min_inliers : options_.pnp_min_inliers;
  if (r.num_matches < hypothesis_min_inliers) {
    r.stage = LoopStage::kMatching;
    return r;
  }
  std::optional<Eigen::Isometry3d> T_cm_odomq =
      pnpPose(points, matches, sub, (cand.pose.T_odom_b * T_bm_cm).linear(), hypothesis_min_inliers, &r.num_inliers);
  if (!T_cm_odomq) {
    r.stage = LoopStage::kPnp;
    return r;
  }
  // Gravity: both VIO frames are gravity-aligned, so the candidate camera's "up" is known from
  // its own VIO attitude and, through the PnP pose, from the query's frame. Over a flat seabed
  // a tilt error and a lateral shift give nearly the same image motion; a PnP pose tilted
  // against the VIO is off in position by ~depth x tilt too.
  const Eigen::Vector3d up_vio = (cand.pose.T_odom_b * T_bm_cm).linear().transpose() * Eigen::Vector3d::UnitZ();
  const auto tiltError = [&up_vio](const Eigen::Isometry3d& T_c_odom) {
    const Eigen::Vector3d up_pnp = T_c_odom.linear() * Eigen::Vector3d::UnitZ();
    return std::acos(std::clamp(up_pnp.dot(up_vio), -1.0, 1.0)) * 180.0 / M_PI;
  };
  if (options_.pnp_max_tilt_error_deg > 0.0) r.tilt_error_deg = tiltError(*T_cm_odomq);
  const bool tilted = options_.pnp_max_tilt_error_deg > 0.0 && r.tilt_error_deg > options_.pnp_max_tilt_error_deg;
  if (tilted || r.num_inliers < options_.pnp_min_inliers) {
    if (!guided) {
      r.stage = LoopStage::kPnp;
      return r;
    }
    T_cm_odomq = guidedPose(query, points, sub, cand, T_bm_cm, *T_cm_odomq, levels, &matches);
    if (!T_cm_odomq) {
      r.stage = LoopStage::kPnp;
      return r;
    }
    r.tilt_error_deg = tiltError(*T_cm_odomq);
  }
  confirm(query, map, candidate, sub, points, matches, *T_cm_odomq, levels, &r);
  return r;
}

VerificationResult LoopVerifier::verifyFromPrediction(const LoopQuery& query, const MultiScaleMap& map,
                                                      PoseGraphNodeId candidate) const {
  VerificationResult r;
  if (query.node >= map.numNodes() || !map.sameComponent(query.node, candidate)) {
    r.stage = LoopStage::kMatching;  // no prediction across components
    return r;
  }
  const MapNode& cand = map.node(candidate);
  const std::shared_ptr<const VisualSubmap> submap = map.visualSubmap(candidate);
  const Eigen::Isometry3d& T_bm_cm = extrinsicOf(map, candidate);
  const LevelWindow levels = levelWindow(query, map, candidate);
  DescribedPoints points = query.points;
  mergeDescribedPoints(&points, query.seabed_points);
  // The graph's prediction: the candidate camera from the query's VIO frame through the world.
  const Eigen::Isometry3d T_cm_odomq_predicted = (cand.pose.T_w_b() * T_bm_cm).inverse() * map.T_map_odom(query.node);
  const std::vector<PointMatch> matches = matchNear(points, *submap, T_cm_odomq_predicted, levels);
  r.num_matches = static_cast<int>(matches.size());
  if (r.num_matches < options_.pnp_min_inliers) {
    r.stage = LoopStage::kMatching;
    return r;
  }
  const std::optional<Eigen::Isometry3d> T_cm_odomq =
      levelledOnMatches(query, points, *submap, cand, T_bm_cm, T_cm_odomq_predicted, matches);
  if (!T_cm_odomq) {
    r.stage = LoopStage::kPnp;
    return r;
  }
  confirm(query, map, candidate, *submap, points, matches, *T_cm_odomq, levels, &r);
  return r;
}

void LoopVerifier::confirm(const LoopQuery& query, const MultiScaleMap& map, PoseGraphNodeId candidate,
                           const VisualSubmap& sub, const DescribedPoints& points,
                           const std::vector<PointMatch>& matches, const Eigen::Isometry3d& T_cm_odomq,
                           const LevelWindow& levels, VerificationResult* result) const {
  VerificationResult& r = *result;
  const MapNode& cand = map.node(candidate);
  const Eigen::Isometry3d& T_bm_cm = extrinsicOf(map, candidate);
  r.inlier_matches = inliersUnder(points, matches, sub, T_cm_odomq);
  r.num_inliers = static_cast<int>(r.inlier_matches.size());
  if (r.num_inliers < options_.pnp_min_inliers) {
    r.stage = LoopStage::kPnp;
    return;
  }
  const Eigen::Isometry3d T_bm_odomq = T_bm_cm * T_cm_odomq;
  r.T_match_query = T_bm_odomq * query.T_odom_b;
  r.has_pose = true;
  if (options_.pnp_known_vertical_refinement) {
    LoopInlierGeometry geometry;
    geometry.points_odom_query.reserve(r.inlier_matches.size());
    geometry.normalized_match.reserve(r.inlier_matches.size());
    for (const auto& [point, keypoint] : r.inlier_matches) {
      geometry.points_odom_query.push_back(points.p_odom[point]);
      geometry.normalized_match.push_back(sub.normalized[keypoint]);
    }
    r.refined =
        refineLoopMeasurement(geometry, r.T_match_query, query.T_odom_b, T_bm_cm, cand.pose.pitch, cand.pose.roll);
    // The covisibility check below keeps the PnP pose: it tests the match, not the edge.
    if (r.refined) r.T_match_query = r.refined->T_match_query;
  }

  if (options_.covisibility_neighbours > 0) {
    r.covisibility_confirming_neighbours =
        covisibleNeighbours(points, map, candidate, T_bm_odomq, r.inlier_matches, levels);
    if (r.covisibility_confirming_neighbours < options_.covisibility_min_neighbours) {
      r.stage = LoopStage::kCovisibility;
      return;
    }
  }
  r.stage = LoopStage::kAccepted;
}

int LoopVerifier::covisibleNeighbours(const DescribedPoints& points, const MultiScaleMap& map, PoseGraphNodeId match,
                                      const Eigen::Isometry3d& T_bm_odomq,
                                      const std::vector<std::pair<uint32_t, uint32_t>>& inliers,
                                      const LevelWindow& levels) const {
  const MapNode& m = map.node(match);
  const std::vector<std::vector<uint32_t>> by_point = descriptorsByPoint(points);
  const double r2 = options_.covisibility_search_radius_px * options_.covisibility_search_radius_px;
  // The match's neighbours: up to covisibility_neighbours keyframes of its session with a visual
  // submap on either side. Keyframes without one (empty image, or a redundant submap culled on
  // a re-flight, see LoopDetectorOptions::redundant_submap_radius_m) are stepped over, looking
  // at most 2 x covisibility_neighbours keyframes away so the VIO relative pose stays local.
  std::vector<PoseGraphNodeId> neighbours;
  for (const int step : {-1, 1}) {
    int found = 0;
    for (int k = 1; k <= 2 * options_.covisibility_neighbours && found < options_.covisibility_neighbours; ++k) {
      const int64_t id = static_cast<int64_t>(match) + step * k;
      if (id < 0 || id >= static_cast<int64_t>(map.numNodes())) break;
      const MapNode& n = map.node(static_cast<PoseGraphNodeId>(id));
      if (n.session != m.session) break;
      if (!n.hasVisualSubmap()) continue;
      neighbours.push_back(static_cast<PoseGraphNodeId>(id));
      ++found;
    }
  }
  int confirming = 0;
  for (const PoseGraphNodeId neighbour : neighbours) {
    const MapNode& n = map.node(neighbour);
    // The neighbour's pose relative to the match from the VIO (locally accurate), chained with
    // the PnP pose: where the neighbour camera must see each inlier if the loop is right.
    const Eigen::Isometry3d T_cn_odomq =
        extrinsicOf(map, neighbour).inverse() * n.pose.T_odom_b.inverse() * m.pose.T_odom_b * T_bm_odomq;
    const std::shared_ptr<const VisualSubmap> submap = map.visualSubmap(neighbour);
    int projected = 0;
    int confirmed = 0;
    for (const auto& [point, keypoint] : inliers) {
      (void)keypoint;
      const std::optional<Eigen::Vector2d> projected_uv = camera_model_.project(T_cn_odomq * points.p_odom[point]);
      if (!projected_uv) continue;
      const Eigen::Vector2d& uv = *projected_uv;
      if (uv.x() < 0.0 || uv.y() < 0.0 || uv.x() >= camera_.width || uv.y() >= camera_.height) continue;
      ++projected;
      // The neighbours were flown at about the match's altitude: the match's level window.
      if (hasMatchingKeypointNear(points, by_point[point], *submap, uv, r2, options_.match_max_distance, levels))
        ++confirmed;
    }
    if (projected >= options_.covisibility_min_points &&
        static_cast<double>(confirmed) >= options_.covisibility_min_ratio * projected)
      ++confirming;
  }
  return confirming;
}

// ---------------------------------------------------------------------------------------------
// HierarchicalLoopDetector
// ---------------------------------------------------------------------------------------------

HierarchicalLoopDetector::HierarchicalLoopDetector(const LoopDetectorOptions& options,
                                                   const MagneticSubmapOptions& magnetic_options,
                                                   const ModeSettings& mode, const CameraCalibration& camera,
                                                   LoggerPtr logger, const FeatureExtractionOptions& features)
    : options_(options),
      magnetic_options_(magnetic_options),
      mode_(mode),
      verifier_(options, camera, features),
      logger_(logger ? std::move(logger) : Logger::nullLogger()) {
  magnetic_options_.validate();
}

std::vector<MagneticStageMatch> magneticStageMatches(const std::map<int, Eigen::Vector3d>& query_signatures,
                                                     const std::vector<MagneticSubmap>& submaps,
                                                     const LoopDetectorOptions& options,
                                                     const std::function<bool(const MagneticSubmap&)>& considered,
                                                     std::optional<MagneticStageMatch>* nearest) {
  std::map<int, std::vector<MagneticStageMatch>> passed_by_coil;
  if (nearest) nearest->reset();
  for (const MagneticSubmap& s : submaps) {
    const auto query = query_signatures.find(s.coil);
    if (query == query_signatures.end() || !considered(s)) continue;
    const MagneticStageMatch m{signatureDistance(query->second, s.signature_enu), s.id};
    if (nearest &&
        (!*nearest || std::tie(m.distance_tesla, m.submap) < std::tie((*nearest)->distance_tesla, (*nearest)->submap)))
      *nearest = m;
    if (m.distance_tesla <= options.mag_distance_relative * s.signature_enu.norm() + options.mag_distance_floor_tesla)
      passed_by_coil[s.coil].push_back(m);
  }
  auto nearer = [](const MagneticStageMatch& a, const MagneticStageMatch& b) {
    return std::tie(a.distance_tesla, a.submap) < std::tie(b.distance_tesla, b.submap);
  };
  std::vector<MagneticStageMatch> passed;
  for (auto& [coil, matches] : passed_by_coil) {
    std::sort(matches.begin(), matches.end(), nearer);
    if (matches.size() > static_cast<size_t>(options.mag_max_candidates))
      matches.resize(static_cast<size_t>(options.mag_max_candidates));
    passed.insert(passed.end(), matches.begin(), matches.end());
  }
  std::sort(passed.begin(), passed.end(), nearer);
  return passed;
}

bool isRecentKeyframe(const LoopDetectorOptions& options, const MultiScaleMap& map, PoseGraphNodeId query,
                      double t_query, PoseGraphNodeId candidate) {
  const MapNode& c = map.node(candidate);
  if (map.sessions().at(c.session).loaded) return false;  // another run: never "recent"
  if (query >= candidate && query - candidate < static_cast<PoseGraphNodeId>(options.exclude_recent_keyframes))
    return true;
  if (candidate > query) return true;  // not older than the query
  return t_query - c.pose.t < options.exclude_recent_s;
}

std::vector<PoseGraphNodeId> HierarchicalLoopDetector::nearestCandidates(
    const LoopQuery& query, const MultiScaleMap& map, int count,
    const std::function<bool(PoseGraphNodeId)>& admit) const {
  std::vector<PoseGraphNodeId> out;
  if (count <= 0 || query.node >= map.numNodes()) return out;
  const Eigen::Vector2d p_query = map.node(query.node).pose.p_w_b.head<2>();
  const double r2 = options_.proximity_radius_m * options_.proximity_radius_m;
  std::vector<std::pair<double, PoseGraphNodeId>> near;  // (squared horizontal distance, node)
  for (PoseGraphNodeId n = 0; n < map.numNodes(); ++n) {
    const MapNode& c = map.node(n);
    if (n == query.node || c.bow_image < 0 || isRecent(map, query.node, n) || !map.sameComponent(n, query.node) ||
        !admit(n))
      continue;
    const double d2 = (c.pose.p_w_b.head<2>() - p_query).squaredNorm();
    if (d2 <= r2) near.emplace_back(d2, n);
  }
  std::sort(near.begin(), near.end());
  for (const auto& [d2, n] : near) {
    (void)d2;
    if (out.size() >= static_cast<size_t>(count)) break;
    out.push_back(n);
  }
  return out;
}

std::vector<PoseGraphNodeId> HierarchicalLoopDetector::proximityCandidates(
    const LoopQuery& query, const MultiScaleMap& map, const std::vector<PoseGraphNodeId>& exclude) const {
  return nearestCandidates(query, map, options_.proximity_candidates, [&exclude](PoseGraphNodeId n) {
    return std::find(exclude.begin(), exclude.end(), n) == exclude.end();
  });
}

std::vector<PoseGraphNodeId> HierarchicalLoopDetector::trackingCandidates(
    const LoopQuery& query, const MultiScaleMap& map, const std::vector<PoseGraphNodeId>& exclude) const {
  return nearestCandidates(query, map, options_.track_map_candidates, [&](PoseGraphNodeId n) {
    return map.sessions()[map.node(n).session].loaded && std::find(exclude.begin(), exclude.end(), n) == exclude.end();
  });
}

bool HierarchicalLoopDetector::isRecent(const MultiScaleMap& map, PoseGraphNodeId query,
                                        PoseGraphNodeId candidate) const {
  return isRecentKeyframe(options_, map, query, map.node(query).pose.t, candidate);
}

DetectionResult HierarchicalLoopDetector::detect(const LoopQuery& query, const MultiScaleMap& map) const {
  DetectionResult res;
  const BowDatabase* db = map.bowDatabase();
  if (db == nullptr || query.bow.empty() || query.points.numPoints() < static_cast<size_t>(options_.pnp_min_inliers) ||
      query.node >= map.numNodes())
    return res;

  auto eligible = [&](PoseGraphNodeId n) {
    return n != query.node && map.node(n).bow_image >= 0 && !isRecent(map, query.node, n);
  };
  auto attemptFor = [&](PoseGraphNodeId n) {
    LoopAttempt a;
    a.t_query = query.t;
    a.t_match = map.node(n).pose.t;
    a.query_node = query.node;
    a.match_node = n;
    a.match_in_map = map.sessions()[map.node(n).session].loaded;
    return a;
  };

  std::vector<PoseGraphNodeId> pool;
  std::map<PoseGraphNodeId, double> mag_distance_of;
  std::optional<LoopAttempt> magnetic_rejection;
  if (mode_.magnetic_stage && !query.signatures_enu.empty()) {
    res.magnetic_stage_used = true;
    std::optional<MagneticStageMatch> nearest;
    const std::vector<MagneticStageMatch> passed = magneticStageMatches(
        query.signatures_enu, map.magneticSubmaps(), options_,
        [&](const MagneticSubmap& s) { return s.tied_node != query.node && !isRecent(map, query.node, s.tied_node); },
        &nearest);
    std::set<PoseGraphNodeId> members;
    for (const auto& [d, id] : passed) {
      res.magnetic_candidates.emplace_back(id, d);
      for (PoseGraphNodeId n : map.clusteredNodes(map.magneticSubmaps()[id], magnetic_options_.cluster_margin_m)) {
        if (!eligible(n)) continue;
        members.insert(n);
        auto it = mag_distance_of.find(n);
        if (it == mag_distance_of.end() || d < it->second) mag_distance_of[n] = d;
      }
    }
    // Keyframes recorded while the magnetometer was silent carry no magnetic information: the
    // magnetic stage cannot exclude them, so they stay in the visual search.
    for (PoseGraphNodeId n = 0; n < map.numNodes(); ++n)
      if (!map.node(n).magnetic_coverage && eligible(n)) members.insert(n);
    pool.assign(members.begin(), members.end());
    if (passed.empty() && nearest) {
      LoopAttempt a = attemptFor(map.magneticSubmaps()[nearest->submap].tied_node);
      a.mag_distance = nearest->distance_tesla;
      a.stage = LoopStage::kMagnetic;
      magnetic_rejection = a;
    }
  } else {
    for (PoseGraphNodeId n = 0; n < map.numNodes(); ++n)
      if (eligible(n)) pool.push_back(n);
  }
  res.bow_pool = pool;
  std::vector<std::pair<PoseGraphNodeId, double>> candidates;
  if (pool.empty()) {
    if (magnetic_rejection && options_.record_prefilter_rejections) res.attempts.push_back(*magnetic_rejection);
  }
  std::vector<BowQueryResult> scores;
  if (!pool.empty()) {
    std::vector<ImageId> images;
    images.reserve(pool.size());
    for (PoseGraphNodeId n : pool) images.push_back(static_cast<ImageId>(map.node(n).bow_image));
    scores = db->queryAmong(query.bow, images, images.size());
    const size_t limit = static_cast<size_t>(mode_.verify_all_bow_candidates ? options_.bow_max_candidates_all
                                                                             : options_.bow_max_candidates);
    for (const BowQueryResult& s : scores) {
      if (s.score < options_.bow_min_score || candidates.size() >= limit) break;
      candidates.emplace_back(map.nodeOfImage(s.image), s.score);
    }
  }
  if (!pool.empty() && candidates.empty()) {
    if (options_.record_prefilter_rejections) {
      if (!scores.empty()) {
        const PoseGraphNodeId n = map.nodeOfImage(scores.front().image);
        LoopAttempt a = attemptFor(n);
        a.bow_score = scores.front().score;
        const auto it = mag_distance_of.find(n);
        if (it != mag_distance_of.end()) a.mag_distance = it->second;
        a.stage = LoopStage::kBow;
        res.attempts.push_back(a);
      } else if (magnetic_rejection) {
        res.attempts.push_back(*magnetic_rejection);
      }
    }
  }
  res.bow_candidates = candidates;

  // Candidates from the pose graph's estimate (LoopDetectorOptions::proximity_candidates),
  // verified after the BoW ones: a place flown again at another height, which the appearance
  // and magnetic stages do not recognise.
  std::vector<std::pair<PoseGraphNodeId, double>> to_verify = candidates;
  const size_t num_bow_candidates = candidates.size();
  if (options_.proximity_candidates > 0) {
    std::vector<PoseGraphNodeId> verified_by_bow;
    for (const auto& c : candidates) verified_by_bow.push_back(c.first);
    res.proximity_candidates = proximityCandidates(query, map, verified_by_bow);
    for (const PoseGraphNodeId n : res.proximity_candidates) {
      double score = std::numeric_limits<double>::quiet_NaN();
      for (const BowQueryResult& s : scores)
        if (map.nodeOfImage(s.image) == n) score = s.score;
      to_verify.emplace_back(n, score);
    }
  }

  // Localising in a joined map, its keyframes nearest the query are verified from the graph's
  // prediction too (track_map_candidates): where the images are too poor for appearance.
  const size_t num_appearance_candidates = to_verify.size();
  if (query.track_loaded_map && options_.track_map_candidates > 0) {
    std::vector<PoseGraphNodeId> verified;
    for (const auto& c : to_verify) verified.push_back(c.first);
    res.tracking_candidates = trackingCandidates(query, map, verified);
    for (const PoseGraphNodeId n : res.tracking_candidates)
      to_verify.emplace_back(n, std::numeric_limits<double>::quiet_NaN());
  }

  for (size_t i = 0; i < to_verify.size(); ++i) {
    const auto& [n, score] = to_verify[i];
    const VerificationResult v =
        i < num_appearance_candidates ? verifier_.verify(query, map, n) : verifier_.verifyFromPrediction(query, map, n);
    LoopAttempt a = attemptFor(n);
    a.bow_score = score;
    a.proximity = i >= num_bow_candidates;
    const auto it = mag_distance_of.find(n);
    if (it != mag_distance_of.end()) a.mag_distance = it->second;
    a.stage = v.stage;
    a.inliers = v.stage == LoopStage::kMatching ? v.num_matches : v.num_inliers;
    if (v.has_pose) a.T_match_query = v.T_match_query;
    if (v.refined) a.sigma = v.refined->covariance.diagonal().cwiseSqrt();
    a.accepted = v.stage == LoopStage::kAccepted;
    res.attempts.push_back(a);
    logger_->debug(kComponent,
                   VIMS_STR(std::fixed << std::setprecision(3) << "loop attempt t_query=" << query.t
                                       << " t_match=" << a.t_match << " bow=" << score << " matches=" << v.num_matches
                                       << " inliers=" << v.num_inliers << " -> " << toString(v.stage)));
    if (a.accepted) {
      res.accepted = a;
      break;
    }
  }
  return res;
}

}  // namespace vims
