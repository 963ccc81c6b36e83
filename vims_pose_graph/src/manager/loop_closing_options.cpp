#include "vims_pose_graph/loop_closing_options.h"

#include <filesystem>
#include <stdexcept>

#include "vims_common/option_table.h"

namespace vims {

namespace {
constexpr double kDeg = M_PI / 180.0;
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

std::string toString(MapMode mode) {
  switch (mode) {
    case MapMode::kMapping:
      return "mapping";
    case MapMode::kExtend:
      return "extend";
    case MapMode::kLocalisation:
      return "localisation";
  }
  return "unknown";
}

MapMode mapModeFromString(const std::string& name) {
  if (name == "mapping") return MapMode::kMapping;
  if (name == "extend") return MapMode::kExtend;
  if (name == "localisation") return MapMode::kLocalisation;
  throw std::invalid_argument("unknown map mode '" + name + "' (expected mapping, extend or localisation)");
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

const OptionTable<MagneticSubmapOptions>& MagneticSubmapOptions::optionTable() {
  using O = MagneticSubmapOptions;
  static const auto table =
      OptionTable<O>()
          .number("max_relative_variation", &O::max_relative_variation, Bounds::closed(1e-3, 10.0))
          .number("min_amplitude_tesla", &O::min_amplitude_tesla, Bounds::closed(0.0, 1e-3))
          .integer("min_members", &O::min_members, Bounds::closed(1, 100000))
          .integer("max_members", &O::max_members, Bounds::closed(1, 100000))
          .number("max_time_gap_s", &O::max_time_gap_s, Bounds::positive())
          .integer("smoothing_half_window", &O::smoothing_half_window, Bounds::closed(0, 1000))
          .number("min_radius_m", &O::min_radius_m, Bounds::nonNegative())
          .number("max_radius_m", &O::max_radius_m, Bounds::closed(1e-3, 1e4))
          .number("cluster_margin_m", &O::cluster_margin_m, Bounds::closed(0.0, 1e3))
          .rule([](const O& o) {
            return violationIf(o.max_members < o.min_members, "max_members", "must be >= min_members");
          })
          .rule([](const O& o) {
            return violationIf(o.max_radius_m < o.min_radius_m, "max_radius_m", "must be >= min_radius_m");
          });
  return table;
}

MagneticSubmapOptions MagneticSubmapOptions::fromReader(const ConfigReader& reader) {
  return readOptions<MagneticSubmapOptions>(reader);
}

void MagneticSubmapOptions::validate() const { throwIfInvalid(optionTable(), *this, "MagneticSubmapOptions"); }

std::string MagneticSubmapOptions::toYaml() const { return optionTable().toYaml(*this); }

// ---------------------------------------------------------------------------------------------
// LoopDetectorOptions
// ---------------------------------------------------------------------------------------------

const OptionTable<LoopDetectorOptions>& LoopDetectorOptions::optionTable() {
  using O = LoopDetectorOptions;
  static const auto table =
      OptionTable<O>()
          .integer("exclude_recent_keyframes", &O::exclude_recent_keyframes, Bounds::closed(0, 1000000))
          .number("exclude_recent_s", &O::exclude_recent_s, Bounds::nonNegative())
          .number("redundant_submap_radius_m", &O::redundant_submap_radius_m, Bounds::closed(0.0, 100.0))
          .number("redundant_submap_max_height_difference_m", &O::redundant_submap_max_height_difference_m,
                  Bounds::closed(0.0, 100.0))
          .flag("keep_culled_bow_vectors", &O::keep_culled_bow_vectors)
          .number("query_signature_max_dt_s", &O::query_signature_max_dt_s, Bounds::closed(0.0, 60.0))
          .number("mag_distance_relative", &O::mag_distance_relative, Bounds::closed(0.0, 100.0))
          .number("mag_distance_floor_tesla", &O::mag_distance_floor_tesla, Bounds::closed(0.0, 1e-3))
          .integer("mag_max_candidates", &O::mag_max_candidates, Bounds::closed(1, 100000))
          .number("bow_min_score", &O::bow_min_score, Bounds::closed(0.0, 1.0))
          .integer("bow_max_candidates", &O::bow_max_candidates, Bounds::closed(1, 100000))
          .integer("bow_max_candidates_all", &O::bow_max_candidates_all, Bounds::closed(1, 100000))
          .number("harris_threshold", &O::harris_threshold, Bounds::closed(0.0, 1.0))
          .flag("submap_include_tracked_corners", &O::submap_include_tracked_corners)
          .integer("submap_dense_corners", &O::submap_dense_corners, Bounds::closed(0, 100000))
          .integer("query_local_map_keyframes", &O::query_local_map_keyframes, Bounds::closed(0, 100))
          .number("submap_corner_min_distance_px", &O::submap_corner_min_distance_px, Bounds::closed(1.0, 1000.0))
          .integer("submap_corner_max_level", &O::submap_corner_max_level, Bounds::closed(0, 16))
          .flag("submap_dense_corners_per_level", &O::submap_dense_corners_per_level)
          .integer("query_seabed_corners", &O::query_seabed_corners, Bounds::closed(0, 100000))
          .number("query_seabed_min_level_shift", &O::query_seabed_min_level_shift, Bounds::closed(0.0, 64.0))
          .number("match_ratio", &O::match_ratio, Bounds::closed(0.01, 1.0))
          .integer("match_max_distance", &O::match_max_distance, Bounds::closed(0, 256))
          .integer("match_max_level_difference", &O::match_max_level_difference, Bounds::closed(-1, 64))
          .number("match_duplicate_radius_px", &O::match_duplicate_radius_px, Bounds::closed(0.0, 100.0))
          .flag("match_level_from_altitude", &O::match_level_from_altitude)
          .number("match_predicted_level_tolerance", &O::match_predicted_level_tolerance, Bounds::closed(0.0, 64.0))
          .integer("proximity_candidates", &O::proximity_candidates, Bounds::closed(0, 1000))
          .number("proximity_radius_m", &O::proximity_radius_m, Bounds::closed(0.0, 1000.0))
          .integer("track_map_candidates", &O::track_map_candidates, Bounds::closed(0, 1000))
          .number("pnp_reprojection_px", &O::pnp_reprojection_px, Bounds::closed(0.1, 100.0))
          .integer("pnp_iterations", &O::pnp_iterations, Bounds::closed(1, 100000))
          .number("pnp_confidence", &O::pnp_confidence, Bounds::closed(0.5, 0.999999))
          .integer("pnp_min_inliers", &O::pnp_min_inliers, Bounds::closed(6, 100000))
          .number("pnp_max_tilt_error_deg", &O::pnp_max_tilt_error_deg, Bounds::closed(0.0, 180.0))
          .flag("pnp_known_vertical_refinement", &O::pnp_known_vertical_refinement)
          .number("pnp_vertical_check_threshold_scale", &O::pnp_vertical_check_threshold_scale,
                  Bounds::closed(0.0, 100.0))
          .integer("guided_min_inliers", &O::guided_min_inliers, Bounds::closed(0, 100000))
          .number("guided_search_radius_px", &O::guided_search_radius_px, Bounds::closed(0.5, 200.0))
          .integer("covisibility_neighbours", &O::covisibility_neighbours, Bounds::closed(0, 100))
          .integer("covisibility_min_points", &O::covisibility_min_points, Bounds::closed(1, 100000))
          .number("covisibility_min_ratio", &O::covisibility_min_ratio, Bounds::closed(0.0, 1.0))
          .integer("covisibility_min_neighbours", &O::covisibility_min_neighbours, Bounds::closed(1, 200))
          .number("covisibility_search_radius_px", &O::covisibility_search_radius_px, Bounds::closed(0.5, 200.0))
          .flag("record_prefilter_rejections", &O::record_prefilter_rejections);
  return table;
}

LoopDetectorOptions LoopDetectorOptions::fromReader(const ConfigReader& reader) {
  return readOptions<LoopDetectorOptions>(reader);
}

void LoopDetectorOptions::validate() const { throwIfInvalid(optionTable(), *this, "LoopDetectorOptions"); }

std::string LoopDetectorOptions::toYaml() const { return optionTable().toYaml(*this); }

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

const OptionTable<PoseGraphManagerOptions>& PoseGraphManagerOptions::optionTable() {
  using O = PoseGraphManagerOptions;
  const std::vector<LoopClosingMode> modes = {LoopClosingMode::kFull, LoopClosingMode::kViSlam,
                                              LoopClosingMode::kNoAlter, LoopClosingMode::kNoOrb,
                                              LoopClosingMode::kNoGeom};
  const std::vector<MapMode> map_modes = {MapMode::kMapping, MapMode::kExtend, MapMode::kLocalisation};
  // The descriptor is set by the mode (orb, or brief for vi_slam and no_orb), not by the features section.
  static const auto table =
      OptionTable<O>()
          .choice<LoopClosingMode>("mode", &O::mode, modes, [](LoopClosingMode m) { return toString(m); })
          .choice<MapMode>("map_mode", &O::map_mode, map_modes, [](MapMode m) { return toString(m); })
          .number("localisation_query_interval_s", &O::localisation_query_interval_s, Bounds::closed(0.0, 600.0))
          .number("localisation_lost_after_s", &O::localisation_lost_after_s, Bounds::closed(0.0, 3600.0))
          .number("place_min_interval_s", &O::place_min_interval_s, Bounds::closed(0.0, 600.0))
          .text("vocabulary_orb", &O::vocabulary_orb, false)
          .text("vocabulary_brief", &O::vocabulary_brief, false)
          .flag("synchronous", &O::synchronous)
          .integer("optimise_every_n_keyframes", &O::optimise_every_n_keyframes, Bounds::closed(1, 1000000))
          .number("magnetic_wait_s", &O::magnetic_wait_s, Bounds::closed(0.0, 600.0))
          .number("geomagnetic_max_dt_s", &O::geomagnetic_max_dt_s, Bounds::closed(0.0, 60.0))
          .number("signature_max_extrapolation_s", &O::signature_max_extrapolation_s, Bounds::closed(0.0, 60.0))
          .number("session_link_position_sigma_m", &O::session_link_position_sigma_m, Bounds::positive())
          .number("session_link_position_sigma_per_s", &O::session_link_position_sigma_per_s, Bounds::nonNegative())
          .scaledNumber("session_link_yaw_sigma_deg", &O::session_link_yaw_sigma_rad, kDeg, Bounds::closed(1e-3, 360.0))
          .scaledNumber("session_link_yaw_sigma_per_s_deg", &O::session_link_yaw_sigma_per_s_rad, kDeg,
                        Bounds::closed(0.0, 360.0))
          .text("record_inputs_path", &O::record_inputs_path, true)
          .section<GeomagneticGateOptions>("geomagnetic_gate", &O::geomagnetic_gate,
                                           GeomagneticGateOptions::optionTable())
          .section<VehicleFieldOptions>("vehicle_field", &O::vehicle_field, VehicleFieldOptions::optionTable())
          .section<FeatureExtractionOptions>("features", &O::features,
                                             FeatureExtractionOptions::optionTable().without("descriptor"))
          .section<MagneticSubmapOptions>("magnetic_submaps", &O::magnetic, MagneticSubmapOptions::optionTable())
          .section<LoopDetectorOptions>("loop_closing", &O::loop, LoopDetectorOptions::optionTable())
          .section<PoseGraphOptions>("pose_graph", &O::graph, PoseGraphOptions::optionTable());
  return table;
}

PoseGraphManagerOptions PoseGraphManagerOptions::fromReader(const ConfigReader& reader) {
  if (reader.has("features") && reader.child("features").has("descriptor")) {
    throw reader.child("features")
        .error("descriptor", "is set by the mode (orb, or brief for vi_slam/no_orb); remove it");
  }
  return readOptions<PoseGraphManagerOptions>(reader);
}

void PoseGraphManagerOptions::validate() const { throwIfInvalid(optionTable(), *this, "PoseGraphManagerOptions"); }

std::string PoseGraphManagerOptions::toYaml() const { return optionTable().toYaml(*this); }

std::string resolveVocabularyPath(const std::string& path, const std::string& package_root) {
  const std::filesystem::path p(path);
  if (p.is_absolute() || package_root.empty()) return path;
  return (std::filesystem::path(package_root) / p).string();
}

}  // namespace vims
