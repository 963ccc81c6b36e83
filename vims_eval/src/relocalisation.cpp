#include "vims_eval/relocalisation.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <unordered_map>

#include "vims_eval/alignment.h"
#include "vims_eval/association.h"

namespace vims {
namespace eval {
namespace {

/// The teach run's track on a horizontal grid of cell size radius: a point is within the radius
/// of the track when a sample in its cell or the eight around it is.
class TrackGrid {
 public:
  TrackGrid(const std::vector<StampedPose>& track, double radius) : radius_(radius) {
    for (const StampedPose& p : track) cells_[key(cell(p.p.x()), cell(p.p.y()))].push_back(p.p.head<2>());
  }
  bool near(const Eigen::Vector3d& p) const {
    const int64_t cx = cell(p.x()), cy = cell(p.y());
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find(key(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (const Eigen::Vector2d& q : it->second)
          if ((q - p.head<2>()).norm() <= radius_) return true;
      }
    }
    return false;
  }

 private:
  int64_t cell(double v) const { return static_cast<int64_t>(std::floor(v / radius_)); }
  static uint64_t key(int64_t x, int64_t y) {
    return (static_cast<uint64_t>(x) * 0x9E3779B97F4A7C15ull) ^ static_cast<uint64_t>(y);
  }
  double radius_;
  std::unordered_map<uint64_t, std::vector<Eigen::Vector2d>> cells_;
};

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
  return buf;
}

}  // namespace

std::string RelocalisationEvaluation::summaryLine() const {
  return "VIMS_EVAL_RELOC relocalised=" + std::to_string(relocalised ? 1 : 0) +
         " correct=" + std::to_string(correct ? 1 : 0) + " entered=" + std::to_string(t_entered ? 1 : 0) +
         " t_entered=" + fixed(t_entered.value_or(0.0), 3) + " t_relocalised=" + fixed(t_relocalised, 3) +
         " delay_s=" + fixed(delay_s, 2) + " error_at_relocalisation_m=" + fixed(error_at_relocalisation_m, 3) +
         " poses_after=" + std::to_string(poses_after) + " ate_map_rmse_m=" + fixed(ate_after_rmse_m, 4) +
         " ate_map_max_m=" + fixed(ate_after_max_m, 4) + " teach_ate_rmse_m=" + fixed(teach_ate_rmse_m, 4) +
         " ratio=" + fixed(ratio(), 2) + " map_loops_correct=" + std::to_string(map_loops_correct) +
         " map_loops_wrong=" + std::to_string(map_loops_wrong);
}

RelocalisationEvaluation evaluateRelocalisation(const std::vector<StampedPose>& teach_gt,
                                                const std::vector<StampedPose>& teach_global,
                                                const std::vector<StampedPose>& repeat_gt,
                                                const std::vector<StampedPose>& repeat_global,
                                                const RelocalisationReport& report,
                                                const RelocalisationOptions& options, const LoopScore* repeat_loops) {
  AssociationOptions association;
  association.max_dt_s = options.max_dt_s;
  association.interpolate = true;
  // The map's frame in the world: the teach run aligned by position and yaw.
  const AssociatedTrajectories teach = associate(teach_gt, teach_global, association);
  if (teach.size() < 2) throw std::runtime_error("the teach run's global trajectory has fewer than 2 poses with truth");
  const Similarity3 S_w_map = computeAlignment(teach.gt, teach.est, AlignmentMode::kPosYaw);

  RelocalisationEvaluation ev;
  double teach_sq = 0.0;
  for (std::size_t i = 0; i < teach.size(); ++i)
    teach_sq += (S_w_map.transformPoint(teach.est[i].p) - teach.gt[i].p).squaredNorm();
  ev.teach_ate_rmse_m = std::sqrt(teach_sq / static_cast<double>(teach.size()));

  const TrackGrid track(teach_gt, options.map_radius_m);
  for (const StampedPose& p : repeat_gt) {
    if (track.near(p.p)) {
      ev.t_entered = p.t;
      break;
    }
  }

  if (repeat_loops) {
    for (const ScoredLoop& loop : repeat_loops->loops) {
      if (!loop.record.accepted || !loop.record.match_in_map || !loop.has_gt) continue;
      ++(loop.within_tolerance ? ev.map_loops_correct : ev.map_loops_wrong);
    }
  }
  ev.relocalised = report.relocalised;
  ev.t_relocalised = report.t_relocalised;
  if (!ev.relocalised) return ev;
  if (ev.t_entered) ev.delay_s = ev.t_relocalised - *ev.t_entered;
  const AssociatedTrajectories repeat = associate(repeat_gt, repeat_global, association);
  double sq = 0.0;
  bool have_first = false;
  for (std::size_t i = 0; i < repeat.size(); ++i) {
    if (repeat.est[i].t < ev.t_relocalised - options.max_dt_s) continue;
    const double error = (S_w_map.transformPoint(repeat.est[i].p) - repeat.gt[i].p).norm();
    if (!have_first) {
      have_first = true;
      ev.error_at_relocalisation_m = error;
    }
    sq += error * error;
    ev.ate_after_max_m = std::max(ev.ate_after_max_m, error);
    ++ev.poses_after;
  }
  if (ev.poses_after > 0) ev.ate_after_rmse_m = std::sqrt(sq / static_cast<double>(ev.poses_after));
  ev.correct = have_first && ev.error_at_relocalisation_m <= options.correct_tol_m;
  return ev;
}

void printRelocalisationReport(std::ostream& out, const RelocalisationEvaluation& ev,
                               const RelocalisationOptions& options) {
  out << "== relocalisation into the teach run's map (its frame placed in the world by the teach run's "
         "position-and-yaw alignment, teach ATE "
      << fixed(ev.teach_ate_rmse_m, 4) << " m)\n";
  if (ev.t_entered)
    out << "   entered the mapped area (within " << fixed(options.map_radius_m, 1)
        << " m of the teach track) at t=" << fixed(*ev.t_entered, 3) << "\n";
  else
    out << "   never came within " << fixed(options.map_radius_m, 1) << " m of the teach track\n";
  out << "   accepted loops into the map: " << ev.map_loops_correct << " correct, " << ev.map_loops_wrong
      << " wrong (against the teach run's truth)\n";
  if (!ev.relocalised) {
    out << "   not relocalised\n";
    return;
  }
  out << "   relocalised at t=" << fixed(ev.t_relocalised, 3);
  if (ev.t_entered) out << ", " << fixed(ev.delay_s, 2) << " s after entering";
  out << "; error there " << fixed(ev.error_at_relocalisation_m, 3) << " m: " << (ev.correct ? "correct" : "WRONG")
      << " (tolerance " << fixed(options.correct_tol_m, 2) << " m)\n";
  out << "   from then on, in the map's frame: " << ev.poses_after << " poses, ATE RMSE "
      << fixed(ev.ate_after_rmse_m, 4) << " m, max " << fixed(ev.ate_after_max_m, 4) << " m, " << fixed(ev.ratio(), 2)
      << "x the teach run's own\n";
}

YAML::Node relocalisationToYaml(const RelocalisationEvaluation& ev) {
  YAML::Node node;
  node["entered"] = static_cast<bool>(ev.t_entered);
  if (ev.t_entered) node["t_entered"] = fixed(*ev.t_entered, 3);
  node["relocalised"] = ev.relocalised;
  if (ev.relocalised) {
    node["t_relocalised"] = fixed(ev.t_relocalised, 3);
    if (ev.t_entered) node["delay_s"] = ev.delay_s;
    node["error_at_relocalisation_m"] = ev.error_at_relocalisation_m;
    node["correct"] = ev.correct;
    node["poses_after"] = ev.poses_after;
    node["ate_map_rmse_m"] = ev.ate_after_rmse_m;
    node["ate_map_max_m"] = ev.ate_after_max_m;
    node["ratio_to_teach"] = ev.ratio();
  }
  node["teach_ate_rmse_m"] = ev.teach_ate_rmse_m;
  node["map_loops_correct"] = ev.map_loops_correct;
  node["map_loops_wrong"] = ev.map_loops_wrong;
  return node;
}

RelocalisationReport readRelocalisationReport(const std::string& summary_path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(summary_path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("cannot read '" + summary_path + "': " + e.what());
  }
  const YAML::Node pose_graph = root.IsMap() ? root["pose_graph"] : YAML::Node(YAML::NodeType::Undefined);
  if (!pose_graph.IsDefined() || !pose_graph.IsMap() || !pose_graph["relocalised"].IsDefined())
    throw std::runtime_error("'" + summary_path + "' has no pose_graph.relocalised (a vims_offline summary.yaml?)");
  RelocalisationReport report;
  try {
    report.relocalised = pose_graph["relocalised"].as<bool>();
    if (report.relocalised) {
      if (!pose_graph["relocalised_t"].IsDefined())
        throw std::runtime_error("'" + summary_path + "': pose_graph.relocalised_t is missing");
      report.t_relocalised = pose_graph["relocalised_t"].as<double>();
    }
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("'" + summary_path + "': pose_graph.relocalised[_t] is malformed: " + e.what());
  }
  return report;
}

}  // namespace eval
}  // namespace vims
