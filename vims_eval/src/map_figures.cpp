#include "vims_eval/map_figures.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "vims_common/timing.h"
#include "vims_eval/cli.h"
#include "vims_eval/cli_args.h"
#include "vims_eval/metrics.h"
#include "vims_eval/plot.h"
#include "vims_eval/report.h"
#include "vims_pose_graph/pose_graph_manager.h"

namespace fs = std::filesystem;

namespace vims {
namespace eval {
namespace {

std::string fixed(double v, int decimals) { return formatFixed(v, decimals); }

void ensureParent(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (!fs::is_directory(parent)) throw std::runtime_error("cannot create directory '" + parent.string() + "'");
}

}  // namespace

std::string defaultPackageRoot() { return VIMS_PACKAGE_ROOT; }

LoadedMap loadSavedMap(const std::string& map_file, const std::string& descriptor, const std::string& package_root) {
  PoseGraphManagerOptions options;
  // The mode only selects which committed vocabulary is loaded (ORB for full, BRIEF for vi_slam).
  options.mode =
      descriptorTypeFromString(descriptor) == DescriptorType::kOrb ? LoopClosingMode::kFull : LoopClosingMode::kViSlam;
  LoadedMap loaded;
  loaded.vocabulary = PoseGraphManager::loadVocabulary(options, package_root);
  loaded.map = std::make_unique<MultiScaleMap>(loaded.vocabulary, options.graph, 0.0);
  loaded.map->load(map_file);
  return loaded;
}

std::string writeTrajectoryComparison(const std::vector<StampedPose>& gt,
                                      const std::vector<std::pair<std::string, std::string>>& estimates,
                                      const std::string& png_path) {
  ensureParent(png_path);
  TrajectoryEvalOptions options;
  options.alignments = {AlignmentMode::kSe3};
  Plot2D plot(1000, 850);
  plot.setTitle("Trajectories (SE3-aligned to the ground truth), top view")
      .setAxisLabels("x [m]", "y [m]")
      .setEqualAspect(true);
  std::vector<double> gx, gy;
  for (const auto& p : gt) gx.push_back(p.p.x()), gy.push_back(p.p.y());
  plot.addLine(gx, gy, cv::Scalar(60, 60, 60), "GT", 3);
  for (std::size_t k = 0; k < estimates.size(); ++k) {
    const auto& [label, path] = estimates[k];
    const auto est = readTumFile(path);
    if (est.empty()) throw std::runtime_error("'" + path + "' holds no pose");
    const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options, label);
    std::vector<double> ex, ey;
    for (const auto& p : ev.primary().est_aligned) ex.push_back(p.p.x()), ey.push_back(p.p.y());
    // tab10 colours 1 (orange) and 0 (blue): VI-SLAM first, VIMS second, as in the paper.
    plot.addLine(ex, ey,
                 plotColor(k == 0   ? 1
                           : k == 1 ? 0
                                    : k),
                 label + " (ATE " + fixed(ev.primary().ate.rmse, 3) + " m)", 2);
  }
  plot.addScatter({gx.front()}, {gy.front()}, plotColor(2), "start", 8, MarkerShape::kSquare);
  plot.savePng(png_path);
  return png_path;
}

std::string writeMultiScaleMapFigure(const std::string& map_file, const std::string& descriptor,
                                     const std::string& package_root, const std::string& png_path) {
  ensureParent(png_path);
  const LoadedMap loaded = loadSavedMap(map_file, descriptor, package_root);
  const MultiScaleMap& map = *loaded.map;
  std::vector<double> px, py, vx, vy;
  for (const MapNode& n : map.nodes()) {
    px.push_back(n.pose.p_w_b.x());
    py.push_back(n.pose.p_w_b.y());
    if (n.hasVisualSubmap()) vx.push_back(n.pose.p_w_b.x()), vy.push_back(n.pose.p_w_b.y());
  }
  Plot2D plot(1100, 950);
  plot.setTitle("Multi-scale map: " + std::to_string(vx.size()) + " visual submaps, " +
                std::to_string(map.magneticSubmaps().size()) + " magnetic submaps (map frame)")
      .setAxisLabels("x (east) [m]", "y (north) [m]")
      .setEqualAspect(true);
  plot.addLine(px, py, cv::Scalar(170, 170, 170), "keyframe path", 1);
  plot.addScatter(vx, vy, plotColor(0), "visual submap (keyframe)", 2);
  // Circles as one polyline with NaN breaks (a non-finite point splits a line).
  std::vector<double> cx, cy, mx, my;
  constexpr int kCircleSegments = 48;
  for (const MagneticSubmap& s : map.magneticSubmaps()) {
    const Eigen::Vector3d c = map.magneticSubmapPosition(s);
    mx.push_back(c.x());
    my.push_back(c.y());
    for (int i = 0; i <= kCircleSegments; ++i) {
      const double a = 2.0 * M_PI * i / kCircleSegments;
      cx.push_back(c.x() + s.radius_m * std::cos(a));
      cy.push_back(c.y() + s.radius_m * std::sin(a));
    }
    cx.push_back(std::nan(""));
    cy.push_back(std::nan(""));
  }
  if (!mx.empty()) {
    plot.addLine(cx, cy, plotColor(3), "magnetic submap radius", 1);
    plot.addScatter(mx, my, plotColor(3), "magnetic submap", 4, MarkerShape::kCross);
  }
  plot.savePng(png_path);
  return png_path;
}

std::vector<MapGrowthRow> mapGrowth(const MultiScaleMap& map) {
  std::vector<MapGrowthRow> rows;
  rows.reserve(map.numNodes());
  for (PoseGraphNodeId id = 0; id < map.numNodes(); ++id) {
    const MapNode& n = map.node(id);
    MapGrowthRow r;
    r.t = n.pose.t;
    r.visual_submap = n.hasVisualSubmap();
    r.keypoints = n.num_keypoints;
    r.bytes = visualSubmapMemoryBytes(map, id);
    rows.push_back(r);
  }
  return rows;
}

int runMapSizeCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& /*err*/) {
  const CliArgs a(args, 1, {{"map", true}, {"descriptor", true}, {"csv", true}, {"package-root", true}}, "map-size");
  const std::string map_file = a.required("map", "map-size");
  const std::string descriptor = a.get("descriptor", "orb");
  if (descriptor != "orb" && descriptor != "brief") throw UsageError("map-size: --descriptor must be orb or brief");
  const auto start = std::chrono::steady_clock::now();
  const LoadedMap loaded = loadSavedMap(map_file, descriptor, a.get("package-root", defaultPackageRoot()));
  const double load_s = 1e-3 * millisecondsSince(start);
  const std::vector<MapGrowthRow> rows = mapGrowth(*loaded.map);
  std::size_t submaps = 0, keypoints = 0, bytes = 0;
  std::ofstream csv;
  if (a.has("csv")) {
    const std::string path = a.get("csv", "");
    ensureParent(path);
    csv.open(path);
    if (!csv) throw std::runtime_error("cannot write '" + path + "'");
    csv << "t,visual_submap,keypoints,bytes,cumulative_mb\n";
  }
  for (const MapGrowthRow& r : rows) {
    submaps += r.visual_submap ? 1 : 0;
    keypoints += r.keypoints;
    bytes += r.bytes;
    if (csv.is_open())
      csv << fixed(r.t, 6) << "," << (r.visual_submap ? 1 : 0) << "," << r.keypoints << "," << r.bytes << ","
          << fixed(1e-6 * static_cast<double>(bytes), 6) << "\n";
  }
  out << "VIMS_MAP_SIZE keyframes=" << rows.size() << " visual_submaps=" << submaps
      << " without_submap=" << rows.size() - submaps << " keypoints=" << keypoints
      << " submap_mb=" << fixed(1e-6 * static_cast<double>(bytes), 2) << " load_s=" << fixed(load_s, 3) << "\n";
  return kExitOk;
}

}  // namespace eval
}  // namespace vims
