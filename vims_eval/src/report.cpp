#include "vims_eval/report.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "vims_eval/plot.h"

namespace fs = std::filesystem;

namespace vims {
namespace eval {
namespace {

std::string num(double v, int decimals) { return formatFixed(v, decimals); }

std::string deltaTag(double delta_m) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "rpe%g", delta_m);
  return buf;
}

/// Labels become keys of `key=value` summaries: no whitespace or '='.
std::string sanitizeLabel(const std::string& label) {
  std::string out = label.empty() ? "est" : label;
  for (char& c : out)
    if (std::isspace(static_cast<unsigned char>(c)) || c == '=') c = '_';
  return out;
}

double statOrNan(const ErrorStats& s, double value) { return s.count > 0 ? value : std::nan(""); }

/// yaml-cpp stores a double as text with max_digits10 digits ("0.10000000000000001"); 15
/// significant digits keep bag-clock stamps (1e9 s to 1e-6 s) and read back to the same value
/// for any figure we print. Non-finite values become null.
YAML::Node yamlNumber(double v) {
  if (!std::isfinite(v)) return YAML::Node(YAML::NodeType::Null);
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.15g", v);
  return YAML::Node(std::string(buf));
}

YAML::Node statsNode(const ErrorStats& s) {
  YAML::Node node;
  node["count"] = s.count;
  const std::pair<const char*, double> fields[] = {{"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
                                                   {"std", s.std},   {"min", s.min},   {"max", s.max}};
  for (const auto& [key, value] : fields) {
    if (s.count > 0)
      node[key] = yamlNumber(value);
    else
      node[key] = YAML::Node(YAML::NodeType::Null);
  }
  return node;
}

YAML::Node flowSeq(const std::vector<double>& values) {
  YAML::Node node(YAML::NodeType::Sequence);
  for (double v : values) node.push_back(yamlNumber(v));
  node.SetStyle(YAML::EmitterStyle::Flow);
  return node;
}

void ensureDirectory(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) throw std::runtime_error("cannot create plot directory '" + dir + "'");
}

}  // namespace

// ------------------------------------------------------------------------------------------
// Trajectories
// ------------------------------------------------------------------------------------------

void printTrajectoryReport(std::ostream& out, const TrajectoryEvaluation& ev) {
  const auto& a = ev.associated;
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "== %s: %zu of %zu estimate poses associated with %zu ground-truth poses (max |dt| %.4f s)\n"
                "   ground-truth distance %.2f m over %.1f s\n",
                ev.label.c_str(), a.size(), a.est_total, a.gt_total, a.max_abs_dt_s, ev.gt_distance_m, ev.duration_s);
  out << buf;
  const double delta = ev.primary().rpe.delta_m;
  std::snprintf(buf, sizeof(buf), "   %-7s %9s %9s %9s %9s %8s %9s %9s %11s %9s %6s %9s\n", "align", "ATE rmse", "mean",
                "median", "max", "%dist", "rot rmse", "rot max", "RPE trans", "RPE rot", "pairs", "scale");
  out << buf;
  std::snprintf(buf, sizeof(buf), "   %-7s %9s %9s %9s %9s %8s %9s %9s %11s %9s %6s %9s\n", "", "[m]", "[m]", "[m]",
                "[m]", "[%]", "[deg]", "[deg]", ("[m/" + num(delta, 0) + "m]").c_str(), "[deg]", "", "");
  out << buf;
  for (const auto& r : ev.results) {
    std::snprintf(
        buf, sizeof(buf), "   %-7s %9s %9s %9s %9s %8s %9s %9s %11s %9s %6zu %9s\n", alignmentModeName(r.mode),
        num(r.ate.rmse, 4).c_str(), num(r.ate.mean, 4).c_str(), num(r.ate.median, 4).c_str(), num(r.ate.max, 4).c_str(),
        num(r.ate_rmse_pct, 3).c_str(), num(r.rot.rmse, 3).c_str(), num(r.rot.max, 3).c_str(),
        num(statOrNan(r.rpe.trans, r.rpe.trans.rmse), 4).c_str(), num(statOrNan(r.rpe.rot, r.rpe.rot.rmse), 3).c_str(),
        r.rpe.pairs.size(), num(r.S_w_v.scale, 5).c_str());
    out << buf;
  }
  if (ev.primary().rpe.pairs.empty())
    out << "   (no RPE: the ground-truth path is shorter than two " << num(delta, 1) << " m segments)\n";
}

std::string formatFixed(double v, int decimals) {
  if (!std::isfinite(v)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

GlobalVsVio compareGlobalWithVio(const TrajectoryEvaluation& global, const TrajectoryEvaluation& vio) {
  GlobalVsVio r;
  r.trans_ratio = global.primary().ate.rmse / vio.primary().ate.rmse;
  r.rot_ratio = global.primary().rot.rmse / vio.primary().rot.rmse;
  return r;
}

std::string globalVsVioSummaryLine(const GlobalVsVio& ratio) {
  std::ostringstream os;
  os << "VIMS_EVAL_GLOBAL_VS_VIO trans_ratio=" << num(ratio.trans_ratio, 4) << " rot_ratio=" << num(ratio.rot_ratio, 4)
     << " global_better=" << (ratio.globalBetter() ? "yes" : "no");
  return os.str();
}

std::string trajectorySummaryLine(const TrajectoryEvaluation& ev) {
  const AlignedErrors& primary = ev.primary();
  std::ostringstream os;
  os << "VIMS_EVAL label=" << sanitizeLabel(ev.label) << " align=" << alignmentModeName(primary.mode)
     << " poses=" << ev.associated.size() << " dist_m=" << num(ev.gt_distance_m, 3)
     << " duration_s=" << num(ev.duration_s, 3);
  for (const auto& r : ev.results) {
    const std::string mode = alignmentModeName(r.mode);
    os << " ate_" << mode << "_m=" << num(r.ate.rmse, 4) << " ate_" << mode << "_pct=" << num(r.ate_rmse_pct, 4);
  }
  if (const AlignedErrors* sim3 = ev.find(AlignmentMode::kSim3)) os << " scale=" << num(sim3->S_w_v.scale, 6);
  const std::string rpe = deltaTag(primary.rpe.delta_m);
  const double rpe_trans = statOrNan(primary.rpe.trans, primary.rpe.trans.rmse);
  os << " rot_rmse_deg=" << num(primary.rot.rmse, 4) << " " << rpe << "_trans_m=" << num(rpe_trans, 4) << " " << rpe
     << "_trans_pct=" << num(100.0 * rpe_trans / primary.rpe.delta_m, 4) << " " << rpe
     << "_rot_deg=" << num(statOrNan(primary.rpe.rot, primary.rpe.rot.rmse), 4) << " " << rpe
     << "_pairs=" << primary.rpe.pairs.size();
  // Tilt and height after the yaw-only alignment when there is one: an SE3 fit may tilt the
  // estimate, which turns a vertical drift into a rotation error.
  const AlignedErrors* posyaw = ev.find(AlignmentMode::kPosYaw);
  const AlignedErrors& yaw_only = posyaw ? *posyaw : primary;
  os << " tilt_rmse_deg=" << num(yaw_only.tilt.rmse, 4) << " height_rmse_m=" << num(yaw_only.height.rmse, 4);
  return os.str();
}

YAML::Node trajectoryToYaml(const TrajectoryEvaluation& ev) {
  YAML::Node node;
  node["label"] = ev.label;
  node["est_poses"] = ev.associated.est_total;
  node["gt_poses"] = ev.associated.gt_total;
  node["associated_poses"] = ev.associated.size();
  node["max_abs_dt_s"] = yamlNumber(ev.associated.max_abs_dt_s);
  node["duration_s"] = yamlNumber(ev.duration_s);
  node["gt_distance_m"] = yamlNumber(ev.gt_distance_m);
  node["primary_alignment"] = alignmentModeName(ev.primary().mode);
  YAML::Node alignments;
  for (const auto& r : ev.results) {
    YAML::Node a;
    a["scale"] = yamlNumber(r.S_w_v.scale);
    std::vector<double> R(9);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R[3 * i + j] = r.S_w_v.R_w_v(i, j);
    a["R_w_v"] = flowSeq(R);
    a["t_w_v"] = flowSeq({r.S_w_v.t_w_v.x(), r.S_w_v.t_w_v.y(), r.S_w_v.t_w_v.z()});
    a["ate_m"] = statsNode(r.ate);
    a["ate_rmse_pct"] = yamlNumber(r.ate_rmse_pct);
    a["rot_deg"] = statsNode(r.rot);
    a["tilt_deg"] = statsNode(r.tilt);
    a["height_m"] = statsNode(r.height);
    YAML::Node rpe;
    rpe["delta_m"] = yamlNumber(r.rpe.delta_m);
    rpe["pairs"] = r.rpe.pairs.size();
    rpe["trans_m"] = statsNode(r.rpe.trans);
    if (r.rpe.trans.count > 0)
      rpe["trans_rmse_pct"] = yamlNumber(100.0 * r.rpe.trans.rmse / r.rpe.delta_m);
    else
      rpe["trans_rmse_pct"] = YAML::Node(YAML::NodeType::Null);
    rpe["rot_deg"] = statsNode(r.rpe.rot);
    a["rpe"] = rpe;
    alignments[alignmentModeName(r.mode)] = a;
  }
  node["alignments"] = alignments;
  node["summary"] = trajectorySummaryLine(ev);
  return node;
}

std::vector<std::string> writeTrajectoryPlots(const TrajectoryEvaluation& ev, const std::string& dir) {
  ensureDirectory(dir);
  const std::string label = sanitizeLabel(ev.label);
  std::vector<std::string> written;
  const auto& gt = ev.associated.gt;
  const AlignedErrors& primary = ev.primary();
  const auto& est = primary.est_aligned;

  {
    std::vector<double> gx, gy, ex, ey;
    for (const auto& p : gt) gx.push_back(p.p.x()), gy.push_back(p.p.y());
    for (const auto& p : est) ex.push_back(p.p.x()), ey.push_back(p.p.y());
    Plot2D plot(900, 800);
    plot.setTitle(ev.label + ": top view, " + alignmentModeName(primary.mode) + "-aligned (ATE " +
                  num(primary.ate.rmse, 3) + " m)")
        .setAxisLabels("x [m]", "y [m]")
        .setEqualAspect(true);
    plot.addLine(gx, gy, cv::Scalar(60, 60, 60), "ground truth", 2);
    plot.addLine(ex, ey, plotColor(0), ev.label, 2);
    plot.addScatter({gx.front()}, {gy.front()}, plotColor(2), "start", 7, MarkerShape::kSquare);
    plot.addScatter({gx.back()}, {gy.back()}, cv::Scalar(60, 60, 60), "end (ground truth)", 7, MarkerShape::kTriangle);
    plot.addScatter({ex.back()}, {ey.back()}, plotColor(0), "end (" + ev.label + ")", 7, MarkerShape::kTriangle);
    const std::string path = (fs::path(dir) / (label + "_top.png")).string();
    plot.savePng(path);
    written.push_back(path);
  }
  {
    Plot2D plot(1000, 500);
    plot.setTitle(ev.label + ": translation error over time").setAxisLabels("time since start [s]", "error [m]");
    const double t0 = ev.associated.est.front().t;
    std::vector<double> ts;
    for (const auto& p : ev.associated.est) ts.push_back(p.t - t0);
    for (std::size_t k = 0; k < ev.results.size(); ++k) {
      const auto& r = ev.results[k];
      plot.addLine(ts, r.trans_errors_m, plotColor(k),
                   std::string(alignmentModeName(r.mode)) + " (rmse " + num(r.ate.rmse, 3) + " m)", 1);
    }
    plot.setLegendLocation(LegendLocation::kTopLeft);
    const std::string path = (fs::path(dir) / (label + "_ate.png")).string();
    plot.savePng(path);
    written.push_back(path);
  }
  return written;
}

// ------------------------------------------------------------------------------------------
// Loops
// ------------------------------------------------------------------------------------------

void printLoopReport(std::ostream& out, const LoopEvaluation& ev, const LoopScoringOptions& loop_options,
                     const RevisitOptions& revisit_options) {
  const LoopScore& s = ev.score;
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "== loops (correct: translation error <= %.3f m and rotation error <= %.2f deg of the ground truth's "
                "T_match_query)\n"
                "   verifications %zu, accepted %zu: correct %zu, wrong %zu, without ground truth %zu"
                " (precision %.1f %%)\n"
                "   rejected although within tolerance: %zu\n",
                loop_options.trans_tol_m, loop_options.rot_tol_deg, s.verifications, s.accepted, s.correct, s.wrong,
                s.accepted_no_gt, 100.0 * s.precision(), s.rejected_correct);
  out << buf;
  const LoopAccuracy accuracy = loopAccuracy(s);
  if (accuracy.loops > 0) {
    std::snprintf(buf, sizeof(buf),
                  "   accepted loops against the ground truth: translation error median %.4f m, p90 %.4f m; "
                  "rotation error median %.3f deg\n",
                  accuracy.trans_error_median_m, accuracy.trans_error_p90_m, accuracy.rot_error_median_deg);
    out << buf;
  }
  for (const auto& l : s.loops) {
    if (!l.record.accepted || !l.has_gt || l.within_tolerance) continue;
    std::snprintf(
        buf, sizeof(buf), "   wrong loop (line %d): t_query %.3f t_match %.3f error %.3f m %.2f deg stage '%s'\n",
        l.record.line, l.record.t_query, l.record.t_match, l.trans_error_m, l.rot_error_deg, l.record.stage.c_str());
    out << buf;
  }
  std::snprintf(buf, sizeof(buf),
                "== revisit events (within %.2f m horizontally of a place visited >= %.1f s earlier; margin %.1f s): "
                "%zu, closed %zu (%.1f %%)\n",
                revisit_options.radius_m, revisit_options.min_gap_s, revisit_options.margin_s, ev.revisits.events,
                ev.revisits.closed, ev.revisits.closedPercent());
  out << buf;
  for (const auto& e : ev.events) {
    std::snprintf(buf, sizeof(buf),
                  "   [%.3f, %.3f] (%.1f s, earlier visit at %.3f, height %+.2f m, heading %.0f deg): %s\n", e.t_start,
                  e.t_end, e.t_end - e.t_start, e.t_previous, e.height_change_m, e.heading_change_deg,
                  e.closed ? "closed" : "missed");
    out << buf;
  }
}

void printCoilRevisits(std::ostream& out, const std::vector<CoilRevisits>& coils, double radius_m) {
  out << "== revisit events and accepted loops near the coils (first sample / query within " << num(radius_m, 1)
      << " m horizontally, counted for the nearest coil):\n";
  char buf[256];
  for (const auto& c : coils) {
    std::snprintf(buf, sizeof(buf),
                  "   coil %d at (%.2f, %.2f): %zu events, closed %zu (%.1f %%); loops %zu correct, %zu wrong\n",
                  c.coil, c.position_w.x(), c.position_w.y(), c.summary.events, c.summary.closed,
                  c.summary.closedPercent(), c.loops_correct, c.loops_wrong);
    out << buf;
  }
}

std::string coilRevisitsSummaryLine(const std::vector<CoilRevisits>& coils) {
  std::ostringstream os;
  os << "VIMS_EVAL_COILS coils=" << coils.size();
  for (const auto& c : coils)
    os << " coil" << c.coil << "_events=" << c.summary.events << " coil" << c.coil << "_closed=" << c.summary.closed
       << " coil" << c.coil << "_loops_correct=" << c.loops_correct << " coil" << c.coil
       << "_loops_wrong=" << c.loops_wrong;
  return os.str();
}

YAML::Node coilRevisitsToYaml(const std::vector<CoilRevisits>& coils) {
  YAML::Node list(YAML::NodeType::Sequence);
  for (const auto& c : coils) {
    YAML::Node node;
    node["coil"] = c.coil;
    for (int k = 0; k < 3; ++k) node["position_enu"].push_back(yamlNumber(c.position_w[k]));
    node["events"] = c.summary.events;
    node["closed"] = c.summary.closed;
    node["loops_correct"] = c.loops_correct;
    node["loops_wrong"] = c.loops_wrong;
    list.push_back(node);
  }
  return list;
}

std::string loopSummaryLine(const LoopEvaluation& ev) {
  const LoopScore& s = ev.score;
  std::ostringstream os;
  os << "VIMS_EVAL_LOOPS verifications=" << s.verifications << " accepted=" << s.accepted << " correct=" << s.correct
     << " wrong=" << s.wrong << " accepted_no_gt=" << s.accepted_no_gt << " rejected_correct=" << s.rejected_correct
     << " precision=" << num(s.precision(), 4) << " revisit_events=" << ev.revisits.events
     << " closed=" << ev.revisits.closed << " closed_pct=" << num(ev.revisits.closedPercent(), 2);
  const LoopAccuracy accuracy = loopAccuracy(s);
  os << " loop_trans_err_median_m=" << num(accuracy.trans_error_median_m, 4)
     << " loop_trans_err_p90_m=" << num(accuracy.trans_error_p90_m, 4)
     << " loop_rot_err_median_deg=" << num(accuracy.rot_error_median_deg, 3);
  return os.str();
}

YAML::Node loopsToYaml(const LoopEvaluation& ev, const LoopScoringOptions& loop_options,
                       const RevisitOptions& revisit_options) {
  const LoopScore& s = ev.score;
  YAML::Node node;
  node["trans_tol_m"] = yamlNumber(loop_options.trans_tol_m);
  node["rot_tol_deg"] = yamlNumber(loop_options.rot_tol_deg);
  node["verifications"] = s.verifications;
  node["accepted"] = s.accepted;
  node["rejected"] = s.verifications - s.accepted;
  node["correct"] = s.correct;
  node["wrong"] = s.wrong;
  node["accepted_no_gt"] = s.accepted_no_gt;
  node["rejected_correct"] = s.rejected_correct;
  node["precision"] = yamlNumber(s.precision());
  YAML::Node accepted(YAML::NodeType::Sequence);
  for (const auto& l : s.loops) {
    if (!l.record.accepted) continue;
    YAML::Node a;
    a["line"] = l.record.line;
    a["t_query"] = yamlNumber(l.record.t_query);
    a["t_match"] = yamlNumber(l.record.t_match);
    a["stage"] = l.record.stage;
    a["has_gt"] = l.has_gt;
    if (l.has_gt) {
      a["correct"] = l.within_tolerance;
      a["trans_error_m"] = yamlNumber(l.trans_error_m);
      a["rot_error_deg"] = yamlNumber(l.rot_error_deg);
    }
    accepted.push_back(a);
  }
  node["accepted_loops"] = accepted;
  YAML::Node revisit;
  revisit["radius_m"] = yamlNumber(revisit_options.radius_m);
  revisit["gap_s"] = yamlNumber(revisit_options.min_gap_s);
  revisit["margin_s"] = yamlNumber(revisit_options.margin_s);
  revisit["events"] = ev.revisits.events;
  revisit["closed"] = ev.revisits.closed;
  revisit["closed_pct"] = yamlNumber(ev.revisits.closedPercent());
  YAML::Node list(YAML::NodeType::Sequence);
  for (const auto& e : ev.events) {
    YAML::Node item;
    item["t_start"] = yamlNumber(e.t_start);
    item["t_end"] = yamlNumber(e.t_end);
    item["duration_s"] = yamlNumber(e.t_end - e.t_start);
    item["t_previous"] = yamlNumber(e.t_previous);
    item["x"] = yamlNumber(e.p_w_start.x());
    item["y"] = yamlNumber(e.p_w_start.y());
    item["height_change_m"] = yamlNumber(e.height_change_m);
    item["heading_change_deg"] = yamlNumber(e.heading_change_deg);
    item["closed"] = e.closed;
    if (e.closed)
      item["t_closing_query"] = yamlNumber(e.t_closing_query);
    else
      item["t_closing_query"] = YAML::Node(YAML::NodeType::Null);
    list.push_back(item);
  }
  revisit["list"] = list;
  node["revisit"] = revisit;
  node["summary"] = loopSummaryLine(ev);
  return node;
}

std::vector<std::string> writeLoopPlots(const std::vector<StampedPose>& gt, const LoopEvaluation& ev,
                                        const std::string& dir) {
  ensureDirectory(dir);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Plot2D plot(900, 800);
  plot.setTitle("loops: " + std::to_string(ev.score.correct) + " correct, " + std::to_string(ev.score.wrong) +
                " wrong; revisits closed " + std::to_string(ev.revisits.closed) + "/" +
                std::to_string(ev.revisits.events))
      .setAxisLabels("x [m]", "y [m]")
      .setEqualAspect(true);
  std::vector<double> gx, gy;
  for (const auto& p : gt) gx.push_back(p.p.x()), gy.push_back(p.p.y());
  plot.addLine(gx, gy, cv::Scalar(170, 170, 170), "ground truth", 1);
  // All events in one series, separated by NaN breaks, so they share one legend entry.
  std::vector<double> rx, ry, closed_x, closed_y, missed_x, missed_y;
  for (const auto& e : ev.events) {
    for (std::size_t i = e.first_index; i <= e.last_index && i < gt.size(); ++i) {
      rx.push_back(gt[i].p.x());
      ry.push_back(gt[i].p.y());
    }
    rx.push_back(nan);
    ry.push_back(nan);
    (e.closed ? closed_x : missed_x).push_back(e.p_w_start.x());
    (e.closed ? closed_y : missed_y).push_back(e.p_w_start.y());
  }
  if (!ev.events.empty()) plot.addLine(rx, ry, plotColor(1), "revisit events", 3);
  // Accepted loops: a link between the ground-truth positions of query and match (short for a
  // true loop) plus a marker at the query, so that loops closed on the spot stay visible.
  std::vector<double> cx0, cy0, cx1, cy1, wx0, wy0, wx1, wy1;
  for (const auto& l : ev.score.loops) {
    if (!l.record.accepted || !l.has_gt) continue;
    auto& x0 = l.within_tolerance ? cx0 : wx0;
    auto& y0 = l.within_tolerance ? cy0 : wy0;
    auto& x1 = l.within_tolerance ? cx1 : wx1;
    auto& y1 = l.within_tolerance ? cy1 : wy1;
    x0.push_back(l.p_w_query_gt.x());
    y0.push_back(l.p_w_query_gt.y());
    x1.push_back(l.p_w_match_gt.x());
    y1.push_back(l.p_w_match_gt.y());
  }
  if (!closed_x.empty())
    plot.addScatter(closed_x, closed_y, plotColor(2), "event closed (start)", 7, MarkerShape::kSquare);
  if (!missed_x.empty())
    plot.addScatter(missed_x, missed_y, plotColor(3), "event missed (start)", 7, MarkerShape::kSquare);
  if (!cx0.empty()) {
    plot.addSegments(cx0, cy0, cx1, cy1, plotColor(2), "", 2);
    plot.addScatter(cx0, cy0, plotColor(2), "correct loop (query)", 4, MarkerShape::kCircle);
  }
  if (!wx0.empty()) {
    plot.addSegments(wx0, wy0, wx1, wy1, plotColor(3), "", 2);
    plot.addScatter(wx0, wy0, plotColor(3), "wrong loop (query)", 5, MarkerShape::kCross);
  }
  const std::string path = (fs::path(dir) / "loops_top.png").string();
  plot.savePng(path);
  return {path};
}

// ------------------------------------------------------------------------------------------
// YAML output
// ------------------------------------------------------------------------------------------

std::string emitYaml(const YAML::Node& node) {
  YAML::Emitter emitter;
  emitter << node;
  return std::string(emitter.c_str()) + "\n";
}

void writeYamlFile(const std::string& path, const YAML::Node& node) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
  out << emitYaml(node);
  if (!out) throw std::runtime_error("error while writing '" + path + "'");
}

}  // namespace eval
}  // namespace vims
