#include "vims_pose_graph/loop_closing_options.h"

#include <filesystem>
#include <sstream>
#include <stdexcept>

namespace vims {

namespace {
constexpr double kDeg = M_PI / 180.0;

/// Indents every line of a YAML block (for nested option blocks in toYaml()).
std::string indent(const std::string& block, const std::string& prefix) {
  std::istringstream in(block);
  std::ostringstream out;
  std::string line;
  while (std::getline(in, line)) out << prefix << line << "\n";
  return out.str();
}

void check(bool ok, const char* owner, const char* field) {
  if (!ok) throw std::invalid_argument(std::string(owner) + ": invalid " + field);
}
}  // namespace

std::string toString(LoopClosingMode mode) {
  switch (mode) {
    case LoopClosingMode::kFull:
      return "full";
    case LoopClosingMode::kViSlam:
      return "vi_slam";
    case LoopClosingMode::kNoAlter:
      return "no_alter";
    case LoopClosingMode::kNoOrb:
      return "no_orb";
    case LoopClosingMode::kNoGeom:
      return "no_geom";
  }
  return "full";
}

LoopClosingMode loopClosingModeFromString(const std::string& name) {
  if (name == "full") return LoopClosingMode::kFull;
  if (name == "vi_slam") return LoopClosingMode::kViSlam;
  if (name == "no_alter") return LoopClosingMode::kNoAlter;
  if (name == "no_orb") return LoopClosingMode::kNoOrb;
  if (name == "no_geom") return LoopClosingMode::kNoGeom;
  throw std::invalid_argument("unknown loop closing mode '" + name +
                              "' (expected full, vi_slam, no_alter, no_orb or no_geom)");
}

ModeSettings ModeSettings::forMode(LoopClosingMode mode) {
  ModeSettings s;
  switch (mode) {
    case LoopClosingMode::kFull:
      break;
    case LoopClosingMode::kViSlam:
      // The paper: "VI-SLAM can be regarded as equivalent to the combination of w/o Alter.,
      // w/o ORB, and w/o Geom", plus verification of every candidate above the threshold.
      s.descriptor = DescriptorType::kBrief;
      s.magnetic_stage = false;
      s.verify_all_bow_candidates = true;
      s.geomagnetic_yaw = false;
      break;
    case LoopClosingMode::kNoAlter:
      s.magnetic_stage = false;
      break;
    case LoopClosingMode::kNoOrb:
      s.descriptor = DescriptorType::kBrief;
      break;
    case LoopClosingMode::kNoGeom:
      s.geomagnetic_yaw = false;
      break;
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// MagneticSubmapOptions
// ---------------------------------------------------------------------------------------------

MagneticSubmapOptions MagneticSubmapOptions::fromReader(const ConfigReader& reader) {
  reader.rejectUnknownKeys({"max_relative_variation", "min_amplitude_tesla", "min_members", "max_members",
                            "max_time_gap_s", "smoothing_half_window", "min_radius_m", "max_radius_m",
                            "cluster_margin_m"});
  MagneticSubmapOptions o;
  readInRange(reader, "max_relative_variation", &o.max_relative_variation, 1e-3, 10.0);
  readInRange(reader, "min_amplitude_tesla", &o.min_amplitude_tesla, 0.0, 1e-3);
  readInRange(reader, "min_members", &o.min_members, 1, 100000);
  readInRange(reader, "max_members", &o.max_members, o.min_members, 100000);
  o.max_time_gap_s = reader.get<double>("max_time_gap_s", o.max_time_gap_s);
  requirePositive(reader, "max_time_gap_s", o.max_time_gap_s);
  readInRange(reader, "smoothing_half_window", &o.smoothing_half_window, 0, 1000);
  o.min_radius_m = reader.get<double>("min_radius_m", o.min_radius_m);
  requireNonNegative(reader, "min_radius_m", o.min_radius_m);
  readInRange(reader, "max_radius_m", &o.max_radius_m, std::max(o.min_radius_m, 1e-3), 1e4);
  readInRange(reader, "cluster_margin_m", &o.cluster_margin_m, 0.0, 1e3);
  return o;
}

void MagneticSubmapOptions::validate() const {
  const char* w = "MagneticSubmapOptions";
  check(max_relative_variation > 0.0 && max_relative_variation <= 10.0, w, "max_relative_variation");
  check(min_amplitude_tesla >= 0.0, w, "min_amplitude_tesla");
  check(min_members >= 1, w, "min_members");
  check(max_members >= min_members, w, "max_members");
  check(max_time_gap_s > 0.0, w, "max_time_gap_s");
  check(smoothing_half_window >= 0, w, "smoothing_half_window");
  check(min_radius_m >= 0.0, w, "min_radius_m");
  check(max_radius_m > 0.0 && max_radius_m >= min_radius_m, w, "max_radius_m");
  check(cluster_margin_m >= 0.0, w, "cluster_margin_m");
}

std::string MagneticSubmapOptions::toYaml() const {
  std::ostringstream os;
  os.precision(10);
  os << "max_relative_variation: " << max_relative_variation << "\n"
     << "min_amplitude_tesla: " << min_amplitude_tesla << "\n"
     << "min_members: " << min_members << "\n"
     << "max_members: " << max_members << "\n"
     << "max_time_gap_s: " << max_time_gap_s << "\n"
     << "smoothing_half_window: " << smoothing_half_window << "\n"
     << "min_radius_m: " << min_radius_m << "\n"
     << "max_radius_m: " << max_radius_m << "\n"
     << "cluster_margin_m: " << cluster_margin_m << "\n";
  return os.str();
}

// ---------------------------------------------------------------------------------------------
// LoopDetectorOptions
// ---------------------------------------------------------------------------------------------

LoopDetectorOptions LoopDetectorOptions::fromReader(const ConfigReader& reader) {
  reader.rejectUnknownKeys({"exclude_recent_keyframes",
                            "exclude_recent_s",
                            "redundant_submap_radius_m",
                            "redundant_submap_max_height_difference_m",
                            "keep_culled_bow_vectors",
                            "query_signature_max_dt_s",
                            "mag_distance_relative",
                            "mag_distance_floor_tesla",
                            "mag_max_candidates",
                            "bow_min_score",
                            "bow_max_candidates",
                            "bow_max_candidates_all",
                            "harris_threshold",
                            "submap_include_tracked_corners",
                            "submap_dense_corners",
                            "query_local_map_keyframes",
                            "submap_corner_min_distance_px",
                            "submap_corner_max_level",
                            "match_ratio",
                            "match_max_distance",
                            "match_max_level_difference",
                            "match_duplicate_radius_px",
                            "match_level_from_altitude",
                            "match_predicted_level_tolerance",
                            "proximity_candidates",
                            "proximity_radius_m",
                            "submap_dense_corners_per_level",
                            "query_seabed_corners",
                            "query_seabed_min_level_shift",
                            "pnp_reprojection_px",
                            "pnp_iterations",
                            "pnp_confidence",
                            "pnp_min_inliers",
                            "pnp_max_tilt_error_deg",
                            "pnp_known_vertical_refinement",
                            "pnp_vertical_check_threshold_scale",
                            "covisibility_neighbours",
                            "covisibility_min_points",
                            "covisibility_min_ratio",
                            "covisibility_min_neighbours",
                            "covisibility_search_radius_px",
                            "record_prefilter_rejections"});
  LoopDetectorOptions o;
  readInRange(reader, "exclude_recent_keyframes", &o.exclude_recent_keyframes, 0, 1000000);
  o.exclude_recent_s = reader.get<double>("exclude_recent_s", o.exclude_recent_s);
  requireNonNegative(reader, "exclude_recent_s", o.exclude_recent_s);
  readInRange(reader, "redundant_submap_radius_m", &o.redundant_submap_radius_m, 0.0, 100.0);
  readInRange(reader, "redundant_submap_max_height_difference_m", &o.redundant_submap_max_height_difference_m, 0.0,
              100.0);
  o.keep_culled_bow_vectors = reader.get<bool>("keep_culled_bow_vectors", o.keep_culled_bow_vectors);
  readInRange(reader, "query_signature_max_dt_s", &o.query_signature_max_dt_s, 0.0, 60.0);
  readInRange(reader, "mag_distance_relative", &o.mag_distance_relative, 0.0, 100.0);
  readInRange(reader, "mag_distance_floor_tesla", &o.mag_distance_floor_tesla, 0.0, 1e-3);
  readInRange(reader, "mag_max_candidates", &o.mag_max_candidates, 1, 100000);
  readInRange(reader, "bow_min_score", &o.bow_min_score, 0.0, 1.0);
  readInRange(reader, "bow_max_candidates", &o.bow_max_candidates, 1, 100000);
  readInRange(reader, "bow_max_candidates_all", &o.bow_max_candidates_all, 1, 100000);
  readInRange(reader, "harris_threshold", &o.harris_threshold, 0.0, 1.0);
  o.submap_include_tracked_corners =
      reader.get<bool>("submap_include_tracked_corners", o.submap_include_tracked_corners);
  readInRange(reader, "submap_dense_corners", &o.submap_dense_corners, 0, 100000);
  readInRange(reader, "query_local_map_keyframes", &o.query_local_map_keyframes, 0, 100);
  readInRange(reader, "submap_corner_min_distance_px", &o.submap_corner_min_distance_px, 1.0, 1000.0);
  readInRange(reader, "submap_corner_max_level", &o.submap_corner_max_level, 0, 16);
  o.submap_dense_corners_per_level =
      reader.get<bool>("submap_dense_corners_per_level", o.submap_dense_corners_per_level);
  readInRange(reader, "query_seabed_corners", &o.query_seabed_corners, 0, 100000);
  readInRange(reader, "query_seabed_min_level_shift", &o.query_seabed_min_level_shift, 0.0, 64.0);
  readInRange(reader, "match_ratio", &o.match_ratio, 0.01, 1.0);
  readInRange(reader, "match_max_distance", &o.match_max_distance, 0, 256);
  readInRange(reader, "match_max_level_difference", &o.match_max_level_difference, -1, 64);
  readInRange(reader, "match_duplicate_radius_px", &o.match_duplicate_radius_px, 0.0, 100.0);
  o.match_level_from_altitude = reader.get<bool>("match_level_from_altitude", o.match_level_from_altitude);
  readInRange(reader, "match_predicted_level_tolerance", &o.match_predicted_level_tolerance, 0.0, 64.0);
  readInRange(reader, "proximity_candidates", &o.proximity_candidates, 0, 1000);
  readInRange(reader, "proximity_radius_m", &o.proximity_radius_m, 0.0, 1000.0);
  readInRange(reader, "pnp_reprojection_px", &o.pnp_reprojection_px, 0.1, 100.0);
  readInRange(reader, "pnp_iterations", &o.pnp_iterations, 1, 100000);
  readInRange(reader, "pnp_confidence", &o.pnp_confidence, 0.5, 0.999999);
  readInRange(reader, "pnp_min_inliers", &o.pnp_min_inliers, 6, 100000);
  readInRange(reader, "pnp_max_tilt_error_deg", &o.pnp_max_tilt_error_deg, 0.0, 180.0);
  o.pnp_known_vertical_refinement = reader.get<bool>("pnp_known_vertical_refinement", o.pnp_known_vertical_refinement);
  readInRange(reader, "pnp_vertical_check_threshold_scale", &o.pnp_vertical_check_threshold_scale, 0.0, 100.0);
  readInRange(reader, "covisibility_neighbours", &o.covisibility_neighbours, 0, 100);
  readInRange(reader, "covisibility_min_points", &o.covisibility_min_points, 1, 100000);
  readInRange(reader, "covisibility_min_ratio", &o.covisibility_min_ratio, 0.0, 1.0);
  readInRange(reader, "covisibility_min_neighbours", &o.covisibility_min_neighbours, 1, 200);
  readInRange(reader, "covisibility_search_radius_px", &o.covisibility_search_radius_px, 0.5, 200.0);
  o.record_prefilter_rejections = reader.get<bool>("record_prefilter_rejections", o.record_prefilter_rejections);
  return o;
}

void LoopDetectorOptions::validate() const {
  const char* w = "LoopDetectorOptions";
  check(exclude_recent_keyframes >= 0, w, "exclude_recent_keyframes");
  check(exclude_recent_s >= 0.0, w, "exclude_recent_s");
  check(redundant_submap_radius_m >= 0.0 && redundant_submap_radius_m <= 100.0, w, "redundant_submap_radius_m");
  check(redundant_submap_max_height_difference_m >= 0.0 && redundant_submap_max_height_difference_m <= 100.0, w,
        "redundant_submap_max_height_difference_m");
  check(query_signature_max_dt_s >= 0.0, w, "query_signature_max_dt_s");
  check(mag_distance_relative >= 0.0, w, "mag_distance_relative");
  check(mag_distance_floor_tesla >= 0.0, w, "mag_distance_floor_tesla");
  check(mag_max_candidates >= 1, w, "mag_max_candidates");
  check(bow_min_score >= 0.0 && bow_min_score <= 1.0, w, "bow_min_score");
  check(bow_max_candidates >= 1, w, "bow_max_candidates");
  check(bow_max_candidates_all >= 1, w, "bow_max_candidates_all");
  check(harris_threshold >= 0.0, w, "harris_threshold");
  check(submap_dense_corners >= 0, w, "submap_dense_corners");
  check(query_local_map_keyframes >= 0, w, "query_local_map_keyframes");
  check(submap_corner_min_distance_px >= 1.0, w, "submap_corner_min_distance_px");
  check(submap_corner_max_level >= 0, w, "submap_corner_max_level");
  check(query_seabed_corners >= 0, w, "query_seabed_corners");
  check(query_seabed_min_level_shift >= 0.0, w, "query_seabed_min_level_shift");
  check(match_ratio > 0.0 && match_ratio <= 1.0, w, "match_ratio");
  check(match_max_distance >= 0 && match_max_distance <= 256, w, "match_max_distance");
  check(match_max_level_difference >= -1, w, "match_max_level_difference");
  check(match_duplicate_radius_px >= 0.0, w, "match_duplicate_radius_px");
  check(match_predicted_level_tolerance >= 0.0, w, "match_predicted_level_tolerance");
  check(proximity_candidates >= 0, w, "proximity_candidates");
  check(proximity_radius_m >= 0.0, w, "proximity_radius_m");
  check(pnp_reprojection_px > 0.0, w, "pnp_reprojection_px");
  check(pnp_iterations >= 1, w, "pnp_iterations");
  check(pnp_confidence > 0.0 && pnp_confidence < 1.0, w, "pnp_confidence");
  check(pnp_min_inliers >= 6, w, "pnp_min_inliers");
  check(pnp_max_tilt_error_deg >= 0.0, w, "pnp_max_tilt_error_deg");
  check(pnp_vertical_check_threshold_scale >= 0.0, w, "pnp_vertical_check_threshold_scale");
  check(covisibility_neighbours >= 0, w, "covisibility_neighbours");
  check(covisibility_min_points >= 1, w, "covisibility_min_points");
  check(covisibility_min_ratio >= 0.0 && covisibility_min_ratio <= 1.0, w, "covisibility_min_ratio");
  check(covisibility_min_neighbours >= 1, w, "covisibility_min_neighbours");
  check(covisibility_search_radius_px > 0.0, w, "covisibility_search_radius_px");
}

std::string LoopDetectorOptions::toYaml() const {
  std::ostringstream os;
  os.precision(10);
  os << "exclude_recent_keyframes: " << exclude_recent_keyframes << "\n"
     << "exclude_recent_s: " << exclude_recent_s << "\n"
     << "redundant_submap_radius_m: " << redundant_submap_radius_m << "\n"
     << "redundant_submap_max_height_difference_m: " << redundant_submap_max_height_difference_m << "\n"
     << "keep_culled_bow_vectors: " << (keep_culled_bow_vectors ? "true" : "false") << "\n"
     << "query_signature_max_dt_s: " << query_signature_max_dt_s << "\n"
     << "mag_distance_relative: " << mag_distance_relative << "\n"
     << "mag_distance_floor_tesla: " << mag_distance_floor_tesla << "\n"
     << "mag_max_candidates: " << mag_max_candidates << "\n"
     << "bow_min_score: " << bow_min_score << "\n"
     << "bow_max_candidates: " << bow_max_candidates << "\n"
     << "bow_max_candidates_all: " << bow_max_candidates_all << "\n"
     << "harris_threshold: " << harris_threshold << "\n"
     << "submap_include_tracked_corners: " << (submap_include_tracked_corners ? "true" : "false") << "\n"
     << "submap_dense_corners: " << submap_dense_corners << "\n"
     << "query_local_map_keyframes: " << query_local_map_keyframes << "\n"
     << "submap_corner_min_distance_px: " << submap_corner_min_distance_px << "\n"
     << "submap_corner_max_level: " << submap_corner_max_level << "\n"
     << "submap_dense_corners_per_level: " << (submap_dense_corners_per_level ? "true" : "false") << "\n"
     << "query_seabed_corners: " << query_seabed_corners << "\n"
     << "query_seabed_min_level_shift: " << query_seabed_min_level_shift << "\n"
     << "match_ratio: " << match_ratio << "\n"
     << "match_max_distance: " << match_max_distance << "\n"
     << "match_max_level_difference: " << match_max_level_difference << "\n"
     << "match_duplicate_radius_px: " << match_duplicate_radius_px << "\n"
     << "match_level_from_altitude: " << (match_level_from_altitude ? "true" : "false") << "\n"
     << "match_predicted_level_tolerance: " << match_predicted_level_tolerance << "\n"
     << "proximity_candidates: " << proximity_candidates << "\n"
     << "proximity_radius_m: " << proximity_radius_m << "\n"
     << "pnp_reprojection_px: " << pnp_reprojection_px << "\n"
     << "pnp_iterations: " << pnp_iterations << "\n"
     << "pnp_confidence: " << pnp_confidence << "\n"
     << "pnp_min_inliers: " << pnp_min_inliers << "\n"
     << "pnp_max_tilt_error_deg: " << pnp_max_tilt_error_deg << "\n"
     << "pnp_known_vertical_refinement: " << (pnp_known_vertical_refinement ? "true" : "false") << "\n"
     << "pnp_vertical_check_threshold_scale: " << pnp_vertical_check_threshold_scale << "\n"
     << "covisibility_neighbours: " << covisibility_neighbours << "\n"
     << "covisibility_min_points: " << covisibility_min_points << "\n"
     << "covisibility_min_ratio: " << covisibility_min_ratio << "\n"
     << "covisibility_min_neighbours: " << covisibility_min_neighbours << "\n"
     << "covisibility_search_radius_px: " << covisibility_search_radius_px << "\n"
     << "record_prefilter_rejections: " << (record_prefilter_rejections ? "true" : "false") << "\n";
  return os.str();
}

// ---------------------------------------------------------------------------------------------
// PoseGraphManagerOptions
// ---------------------------------------------------------------------------------------------

const std::string& PoseGraphManagerOptions::vocabularyPath() const {
  return modeSettings().descriptor == DescriptorType::kOrb ? vocabulary_orb : vocabulary_brief;
}

FeatureExtractionOptions PoseGraphManagerOptions::featureOptions() const {
  FeatureExtractionOptions f = features;
  f.descriptor = modeSettings().descriptor;
  return f;
}

PoseGraphManagerOptions PoseGraphManagerOptions::fromReader(const ConfigReader& reader) {
  reader.rejectUnknownKeys({"mode", "vocabulary_orb", "vocabulary_brief", "synchronous", "optimise_every_n_keyframes",
                            "magnetic_wait_s", "geomagnetic_max_dt_s", "signature_max_extrapolation_s",
                            "session_link_position_sigma_m", "session_link_position_sigma_per_s",
                            "session_link_yaw_sigma_deg", "session_link_yaw_sigma_per_s_deg", "record_inputs_path",
                            "features", "magnetic_submaps", "loop_closing", "pose_graph"});
  PoseGraphManagerOptions o;
  const std::string mode = reader.get<std::string>("mode", toString(o.mode));
  try {
    o.mode = loopClosingModeFromString(mode);
  } catch (const std::invalid_argument& e) {
    throw reader.error("mode", e.what());
  }
  o.vocabulary_orb = reader.get<std::string>("vocabulary_orb", o.vocabulary_orb);
  if (o.vocabulary_orb.empty()) throw reader.error("vocabulary_orb", "must not be empty");
  o.vocabulary_brief = reader.get<std::string>("vocabulary_brief", o.vocabulary_brief);
  if (o.vocabulary_brief.empty()) throw reader.error("vocabulary_brief", "must not be empty");
  o.synchronous = reader.get<bool>("synchronous", o.synchronous);
  readInRange(reader, "optimise_every_n_keyframes", &o.optimise_every_n_keyframes, 1, 1000000);
  readInRange(reader, "magnetic_wait_s", &o.magnetic_wait_s, 0.0, 600.0);
  readInRange(reader, "geomagnetic_max_dt_s", &o.geomagnetic_max_dt_s, 0.0, 60.0);
  readInRange(reader, "signature_max_extrapolation_s", &o.signature_max_extrapolation_s, 0.0, 60.0);
  o.session_link_position_sigma_m =
      reader.get<double>("session_link_position_sigma_m", o.session_link_position_sigma_m);
  requirePositive(reader, "session_link_position_sigma_m", o.session_link_position_sigma_m);
  o.session_link_position_sigma_per_s =
      reader.get<double>("session_link_position_sigma_per_s", o.session_link_position_sigma_per_s);
  requireNonNegative(reader, "session_link_position_sigma_per_s", o.session_link_position_sigma_per_s);
  const double yaw_deg = reader.get<double>("session_link_yaw_sigma_deg", o.session_link_yaw_sigma_rad / kDeg);
  requireInRange(reader, "session_link_yaw_sigma_deg", yaw_deg, 1e-3, 360.0);
  o.session_link_yaw_sigma_rad = yaw_deg * kDeg;
  const double yaw_rate_deg =
      reader.get<double>("session_link_yaw_sigma_per_s_deg", o.session_link_yaw_sigma_per_s_rad / kDeg);
  requireInRange(reader, "session_link_yaw_sigma_per_s_deg", yaw_rate_deg, 0.0, 360.0);
  o.session_link_yaw_sigma_per_s_rad = yaw_rate_deg * kDeg;
  o.record_inputs_path = reader.get<std::string>("record_inputs_path", o.record_inputs_path);

  if (reader.has("features")) {
    const ConfigReader features = reader.child("features");
    if (features.has("descriptor"))
      throw features.error("descriptor", "is set by the mode (orb, or brief for vi_slam/no_orb); remove it");
    o.features = FeatureExtractionOptions::fromReader(features);
  }
  if (reader.has("magnetic_submaps")) o.magnetic = MagneticSubmapOptions::fromReader(reader.child("magnetic_submaps"));
  if (reader.has("loop_closing")) o.loop = LoopDetectorOptions::fromReader(reader.child("loop_closing"));
  if (reader.has("pose_graph")) o.graph = PoseGraphOptions::fromReader(reader.child("pose_graph"));
  return o;
}

void PoseGraphManagerOptions::validate() const {
  const char* w = "PoseGraphManagerOptions";
  check(!vocabulary_orb.empty(), w, "vocabulary_orb");
  check(!vocabulary_brief.empty(), w, "vocabulary_brief");
  check(optimise_every_n_keyframes >= 1, w, "optimise_every_n_keyframes");
  check(magnetic_wait_s >= 0.0, w, "magnetic_wait_s");
  check(geomagnetic_max_dt_s >= 0.0, w, "geomagnetic_max_dt_s");
  check(signature_max_extrapolation_s >= 0.0, w, "signature_max_extrapolation_s");
  check(session_link_position_sigma_m > 0.0, w, "session_link_position_sigma_m");
  check(session_link_position_sigma_per_s >= 0.0, w, "session_link_position_sigma_per_s");
  check(session_link_yaw_sigma_rad > 0.0, w, "session_link_yaw_sigma_rad");
  check(session_link_yaw_sigma_per_s_rad >= 0.0, w, "session_link_yaw_sigma_per_s_rad");
  check(features.max_features >= 1 && features.orb_levels >= 1 && features.orb_scale_factor > 1.0 &&
            features.fast_threshold >= 1,
        w, "features");
  magnetic.validate();
  loop.validate();
  graph.validate();
}

std::string PoseGraphManagerOptions::toYaml() const {
  std::ostringstream os;
  os.precision(10);
  FeatureExtractionOptions f = features;
  std::string feature_yaml;
  {
    // The descriptor line is implied by the mode; leave it out so the dump can be read back.
    std::istringstream in(f.toYaml());
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("descriptor:", 0) != 0) feature_yaml += line + "\n";
  }
  os << "mode: " << toString(mode) << "\n"
     << "vocabulary_orb: " << vocabulary_orb << "\n"
     << "vocabulary_brief: " << vocabulary_brief << "\n"
     << "synchronous: " << (synchronous ? "true" : "false") << "\n"
     << "optimise_every_n_keyframes: " << optimise_every_n_keyframes << "\n"
     << "magnetic_wait_s: " << magnetic_wait_s << "\n"
     << "geomagnetic_max_dt_s: " << geomagnetic_max_dt_s << "\n"
     << "signature_max_extrapolation_s: " << signature_max_extrapolation_s << "\n"
     << "session_link_position_sigma_m: " << session_link_position_sigma_m << "\n"
     << "session_link_position_sigma_per_s: " << session_link_position_sigma_per_s << "\n"
     << "session_link_yaw_sigma_deg: " << session_link_yaw_sigma_rad / kDeg << "\n"
     << "session_link_yaw_sigma_per_s_deg: " << session_link_yaw_sigma_per_s_rad / kDeg << "\n"
     << "record_inputs_path: \"" << record_inputs_path << "\"\n"
     << "features:\n"
     << indent(feature_yaml, "  ") << "magnetic_submaps:\n"
     << indent(magnetic.toYaml(), "  ") << "loop_closing:\n"
     << indent(loop.toYaml(), "  ") << "pose_graph:\n"
     << indent(graph.toYaml(), "  ");
  return os.str();
}

std::string resolveVocabularyPath(const std::string& path, const std::string& package_root) {
  const std::filesystem::path p(path);
  if (p.is_absolute() || package_root.empty()) return path;
  return (std::filesystem::path(package_root) / p).string();
}

}  // namespace vims
