#include "vims_eval/revisit.h"

#include <cmath>
#include <optional>
#include <stdexcept>

#include "horizontal_grid.h"

namespace vims {
namespace eval {
namespace {

/// |yaw(b) - yaw(a)| in degrees, [0, 180]; yaw of the body x axis in the world x-y plane.
double headingChangeDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  const Eigen::Vector3d xa = a * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d xb = b * Eigen::Vector3d::UnitX();
  const double d = std::atan2(xb.y(), xb.x()) - std::atan2(xa.y(), xa.x());
  return std::abs(std::remainder(d, 2.0 * M_PI)) * 180.0 / M_PI;
}

}  // namespace

std::vector<RevisitEvent> detectRevisitEvents(const std::vector<StampedPose>& gt, const RevisitOptions& options) {
  if (!(options.radius_m > 0.0)) throw std::invalid_argument("revisit: radius must be positive");
  if (!(options.min_gap_s >= 0.0)) throw std::invalid_argument("revisit: gap must be non-negative");
  std::vector<RevisitEvent> events;
  HorizontalGrid grid(options.radius_m);
  std::size_t next_to_insert = 0;  // samples [0, next_to_insert) are old enough and in the grid
  std::optional<RevisitEvent> open;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    // Time is increasing, so the set of "old enough" samples only grows.
    while (next_to_insert < i && gt[next_to_insert].t <= gt[i].t - options.min_gap_s) {
      grid.insert(gt[next_to_insert].p, next_to_insert);
      ++next_to_insert;
    }
    const std::optional<std::size_t> earlier = grid.findWithin(gt[i].p, options.radius_m, gt);
    if (earlier) {
      if (!open) {
        open = RevisitEvent{};
        open->t_start = gt[i].t;
        open->first_index = i;
        open->t_previous = gt[*earlier].t;
        open->p_w_start = gt[i].p;
        open->height_change_m = gt[i].p.z() - gt[*earlier].p.z();
        open->heading_change_deg = headingChangeDeg(gt[*earlier].q, gt[i].q);
      }
      open->t_end = gt[i].t;
      open->last_index = i;
    } else if (open) {
      events.push_back(*open);
      open.reset();
    }
  }
  if (open) events.push_back(*open);
  return events;
}

void markClosedEvents(const LoopScore& score, double margin_s, std::vector<RevisitEvent>* events) {
  for (auto& event : *events) {
    event.closed = false;
    for (const auto& loop : score.loops) {
      if (!loop.record.accepted || !loop.has_gt || !loop.within_tolerance) continue;
      const double t = loop.record.t_query;
      if (t < event.t_start - margin_s || t > event.t_end + margin_s) continue;
      if (!event.closed || t < event.t_closing_query) event.t_closing_query = t;
      event.closed = true;
    }
  }
}

RevisitSummary summarizeRevisits(const std::vector<RevisitEvent>& events) {
  RevisitSummary s;
  s.events = events.size();
  for (const auto& e : events)
    if (e.closed) ++s.closed;
  return s;
}

namespace {
/// Index of the coil nearest to p horizontally within radius_m, if any.
std::optional<std::size_t> nearestCoil(const Eigen::Vector3d& p_w, const std::vector<Eigen::Vector3d>& coil_positions_w,
                                       double radius_m) {
  std::optional<std::size_t> nearest;
  double nearest_m = radius_m;
  for (std::size_t i = 0; i < coil_positions_w.size(); ++i) {
    const double d = (p_w.head<2>() - coil_positions_w[i].head<2>()).norm();
    if (d <= nearest_m) {
      nearest_m = d;
      nearest = i;
    }
  }
  return nearest;
}
}  // namespace

std::vector<CoilRevisits> revisitsNearCoils(const std::vector<RevisitEvent>& events, const LoopScore& score,
                                            const std::vector<Eigen::Vector3d>& coil_positions_w, double radius_m) {
  std::vector<CoilRevisits> out(coil_positions_w.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i].coil = static_cast<int>(i);
    out[i].position_w = coil_positions_w[i];
  }
  for (const auto& event : events) {
    const auto coil = nearestCoil(event.p_w_start, coil_positions_w, radius_m);
    if (!coil) continue;
    RevisitSummary& s = out[*coil].summary;
    ++s.events;
    if (event.closed) ++s.closed;
  }
  for (const auto& loop : score.loops) {
    if (!loop.record.accepted || !loop.has_gt) continue;
    const auto coil = nearestCoil(loop.p_w_query_gt, coil_positions_w, radius_m);
    if (!coil) continue;
    ++(loop.within_tolerance ? out[*coil].loops_correct : out[*coil].loops_wrong);
  }
  return out;
}

LoopEvaluation evaluateLoops(const std::vector<LoopRecord>& records, const std::vector<StampedPose>& gt,
                             const LoopScoringOptions& loop_options, const RevisitOptions& revisit_options) {
  LoopEvaluation ev;
  ev.score = scoreLoops(records, gt, loop_options);
  ev.events = detectRevisitEvents(gt, revisit_options);
  markClosedEvents(ev.score, revisit_options.margin_s, &ev.events);
  ev.revisits = summarizeRevisits(ev.events);
  return ev;
}

}  // namespace eval
}  // namespace vims
