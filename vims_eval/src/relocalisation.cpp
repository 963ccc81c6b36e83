#include "vims_eval/relocalisation.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "horizontal_grid.h"
#include "vims_eval/alignment.h"
#include "vims_eval/association.h"
#include "vims_eval/report.h"

namespace vims {
namespace eval {

std::string RelocalisationEvaluation::summaryLine() const {
  return "VIMS_EVAL_RELOC relocalised=" + std::to_string(relocalised ? 1 : 0) +
         " correct=" + std::to_string(correct ? 1 : 0) + " entered=" + std::to_string(t_entered ? 1 : 0) +
         " t_entered=" + formatFixed(t_entered.value_or(0.0), 3) + " t_relocalised=" + formatFixed(t_relocalised, 3) +
         " delay_s=" + formatFixed(delay_s, 2) +
         " error_at_relocalisation_m=" + formatFixed(error_at_relocalisation_m, 3) +
         " poses_after=" + std::to_string(poses_after) + " ate_map_rmse_m=" + formatFixed(ate_after_rmse_m, 4) +
         " ate_map_max_m=" + formatFixed(ate_after_max_m, 4) + " teach_ate_rmse_m=" + formatFixed(teach_ate_rmse_m, 4) +
         " ratio=" + formatFixed(ratio(), 2) + " map_loops_correct=" + std::to_string(map_loops_correct) +
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

  HorizontalGrid track(options.map_radius_m);
  for (std::size_t i = 0; i < teach_gt.size(); ++i) track.insert(teach_gt[i].p, i);
  for (const StampedPose& p : repeat_gt) {
    if (track.findWithin(p.p, options.map_radius_m, teach_gt)) {
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
      << formatFixed(ev.teach_ate_rmse_m, 4) << " m)\n";
  if (ev.t_entered)
    out << "   entered the mapped area (within " << formatFixed(options.map_radius_m, 1)
        << " m of the teach track) at t=" << formatFixed(*ev.t_entered, 3) << "\n";
  else
    out << "   never came within " << formatFixed(options.map_radius_m, 1) << " m of the teach track\n";
  out << "   accepted loops into the map: " << ev.map_loops_correct << " correct, " << ev.map_loops_wrong
      << " wrong (against the teach run's truth)\n";
  if (!ev.relocalised) {
    out << "   not relocalised\n";
    return;
  }
  out << "   relocalised at t=" << formatFixed(ev.t_relocalised, 3);
  if (ev.t_entered) out << ", " << formatFixed(ev.delay_s, 2) << " s after entering";
  out << "; error there " << formatFixed(ev.error_at_relocalisation_m, 3)
      << " m: " << (ev.correct ? "correct" : "WRONG") << " (tolerance " << formatFixed(options.correct_tol_m, 2)
      << " m)\n";
  out << "   from then on, in the map's frame: " << ev.poses_after << " poses, ATE RMSE "
      << formatFixed(ev.ate_after_rmse_m, 4) << " m, max " << formatFixed(ev.ate_after_max_m, 4) << " m, "
      << formatFixed(ev.ratio(), 2) << "x the teach run's own\n";
}

YAML::Node relocalisationToYaml(const RelocalisationEvaluation& ev) {
  YAML::Node node;
  node["entered"] = static_cast<bool>(ev.t_entered);
  if (ev.t_entered) node["t_entered"] = formatFixed(*ev.t_entered, 3);
  node["relocalised"] = ev.relocalised;
  if (ev.relocalised) {
    node["t_relocalised"] = formatFixed(ev.t_relocalised, 3);
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
