#pragma once
/// @file map_figures.h
/// @brief The paper's trajectory and map figures from vims_offline outputs: ground truth and
/// several global trajectories in one top view, and the multi-scale map (visual submaps at
/// their keyframes, magnetic submaps as circles of their radius) of a saved map file.

#include <cstddef>
#include <memory>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "vims_common/trajectory_io.h"
#include "vims_pose_graph/multiscale_map.h"

namespace vims {
namespace eval {

/// The source tree vims_eval was built from (root for the committed vocabularies).
std::string defaultPackageRoot();

/// A map saved by `vims_offline --map-save` with the vocabulary it was built with.
struct LoadedMap {
  std::shared_ptr<const BinaryVocabulary> vocabulary;
  std::unique_ptr<MultiScaleMap> map;
};

/// Loads a saved map. `descriptor` ("orb" or "brief") selects the committed vocabulary of
/// PoseGraphManagerOptions (vocabulary_orb / vocabulary_brief, relative to package_root).
/// Throws MapFileError / VocabularyFileError / std::invalid_argument with the reason.
LoadedMap loadSavedMap(const std::string& map_file, const std::string& descriptor, const std::string& package_root);

/// Top view of the ground truth and each (label, TUM file) estimate after SE3 alignment to
/// it (legend gives each ATE RMSE). Writes `png_path`; returns it. Throws when an estimate
/// cannot be read or aligned.
std::string writeTrajectoryComparison(const std::vector<StampedPose>& gt,
                                      const std::vector<std::pair<std::string, std::string>>& estimates,
                                      const std::string& png_path);

/// Top view of a saved map in its world frame: keyframe path, visual submaps (keyframes with a
/// visual submap) as dots, magnetic submaps as circles of their radius around their position
/// (their tied keyframe's) with a centre marker. Writes `png_path`; returns it.
std::string writeMultiScaleMapFigure(const std::string& map_file, const std::string& descriptor,
                                     const std::string& package_root, const std::string& png_path);

/// What a saved map holds for one keyframe (map order = time order within a run).
struct MapGrowthRow {
  double t = 0.0;
  bool visual_submap = false;  ///< keypoints stored (a loop candidate); else culled or empty
  std::size_t keypoints = 0;
  std::size_t bytes = 0;  ///< heap bytes of its keypoints, descriptors and BoW vector once read
};
std::vector<MapGrowthRow> mapGrowth(const MultiScaleMap& map);

/// `vims_eval map-size --map FILE [--descriptor orb|brief] [--csv OUT] [--package-root DIR]`:
/// the map's submap memory per keyframe (bench/soak.py puts it next to the process's RSS, so
/// that what grows besides the map is visible). Prints one `VIMS_MAP_SIZE ...` line, ending with
/// `load_s`: the seconds MultiScaleMap::load took (as a repeat run loads it; the per-keyframe
/// figures then read every submap from the file).
int runMapSizeCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace eval
}  // namespace vims
