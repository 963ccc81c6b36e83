#pragma once
/// @file revisit.h
/// @brief Revisit events: the places where a loop closure was possible, found from the
/// ground truth alone, and which of them the loop-closure module actually closed.
///
/// Definition. A ground-truth sample i is *revisiting* when some earlier sample j with
/// t_j <= t_i - min_gap_s lies within radius_m of it horizontally (x-y distance: the seabed
/// below is the same place from any height). Height and heading may differ between the visits;
/// each event reports both, because they are what makes a revisit hard: a height change scales
/// the image (and the coil's field falls off with distance), a heading change rotates it.
/// A revisit event is a maximal run of consecutive revisiting samples, reported as the time
/// interval [t_start, t_end]. An event is *closed* when at least one accepted and correct loop
/// has t_query inside [t_start - margin_s, t_end + margin_s].

#include <Eigen/Core>
#include <vector>

#include "vims_common/trajectory_io.h"
#include "vims_eval/loops.h"

namespace vims {
namespace eval {

struct RevisitOptions {
  double radius_m = 1.5;    ///< horizontal distance to an earlier position
  double min_gap_s = 60.0;  ///< how much earlier that position must have been occupied
  double margin_s = 0.0;    ///< slack around an event when looking for a closing loop
  /// Events within this horizontal distance of a coil count for that coil (the nearest one):
  /// a coil's signatures tell places apart out to ~15 m (docs/real_vehicle.md, "Deploying the coil").
  double coil_radius_m = 15.0;
};

struct RevisitEvent {
  double t_start = 0.0;
  double t_end = 0.0;
  std::size_t first_index = 0;  ///< ground-truth sample indices of the run (inclusive)
  std::size_t last_index = 0;
  double t_previous = 0.0;  ///< time of an earlier visit within radius_m of the first sample
  Eigen::Vector3d p_w_start = Eigen::Vector3d::Zero();
  double height_change_m = 0.0;     ///< z of the first sample minus z of the earlier visit
  double heading_change_deg = 0.0;  ///< |yaw difference| between them, in [0, 180]
  bool closed = false;
  double t_closing_query = 0.0;  ///< t_query of the first correct accepted loop in the event (if closed)
};

/// Finds the revisit events of a ground-truth trajectory (sorted by time). Uses a horizontal
/// grid of cell size radius_m, so long sequences cost O(n) neighbour look-ups.
std::vector<RevisitEvent> detectRevisitEvents(const std::vector<StampedPose>& gt, const RevisitOptions& options);

/// Sets `closed` / `t_closing_query` of each event from the accepted, correct loops of `score`.
void markClosedEvents(const LoopScore& score, double margin_s, std::vector<RevisitEvent>* events);

struct RevisitSummary {
  std::size_t events = 0;
  std::size_t closed = 0;
  /// closed / events in percent (0 when there is no event).
  double closedPercent() const { return events == 0 ? 0.0 : 100.0 * static_cast<double>(closed) / events; }
};

RevisitSummary summarizeRevisits(const std::vector<RevisitEvent>& events);

/// What happened near one coil: the revisit events whose first sample lies within coil_radius_m
/// (horizontally) of this coil and of no nearer one, and the accepted loops whose query lies there
/// (ground-truth position of the query keyframe).
struct CoilRevisits {
  int coil = 0;  ///< index in the sequence's coil list
  Eigen::Vector3d position_w = Eigen::Vector3d::Zero();
  RevisitSummary summary;
  std::size_t loops_correct = 0;  ///< accepted loops near this coil within the scoring tolerance
  std::size_t loops_wrong = 0;    ///< accepted loops near this coil outside it
};

/// One entry per coil position (in the order given), so a sequence of several coils shows
/// whether loops close near each of them and not only near the strongest. Loops without ground
/// truth at a stamp are not counted.
std::vector<CoilRevisits> revisitsNearCoils(const std::vector<RevisitEvent>& events, const LoopScore& score,
                                            const std::vector<Eigen::Vector3d>& coil_positions_w, double radius_m);

/// Everything `vims_eval loops` reports: the scored log and the revisit events it closed.
struct LoopEvaluation {
  LoopScore score;
  std::vector<RevisitEvent> events;
  RevisitSummary revisits;
};

/// scoreLoops + detectRevisitEvents + markClosedEvents.
LoopEvaluation evaluateLoops(const std::vector<LoopRecord>& records, const std::vector<StampedPose>& gt,
                             const LoopScoringOptions& loop_options, const RevisitOptions& revisit_options);

}  // namespace eval
}  // namespace vims
