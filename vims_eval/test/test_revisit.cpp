#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vims_eval/association.h"
#include "vims_eval/revisit.h"

using vims::StampedPose;
using namespace vims::eval;

namespace {

/// Figure-eight x = A sin(2 pi t / P), y = A/2 sin(4 pi t / P), A = 20 m, P = 100 s, 10 Hz,
/// t in [0, 150]: it crosses the origin at t = 0, 50, 100 and 150 (at right angles, about
/// 1.78 m/s), and from t = 100 on it retraces the first lap.
std::vector<StampedPose> figureEight() {
  std::vector<StampedPose> gt;
  for (int i = 0; i <= 1500; ++i) {
    StampedPose p;
    p.t = 0.1 * i;
    p.p = Eigen::Vector3d(20.0 * std::sin(2 * M_PI * p.t / 100.0), 10.0 * std::sin(4 * M_PI * p.t / 100.0),
                          -10.0 + 0.5 * std::sin(p.t));  // depth changes do not matter
    gt.push_back(p);
  }
  return gt;
}

/// An accepted loop whose relative pose is the ground truth's (correct) or far off (wrong).
LoopRecord loopAt(const std::vector<StampedPose>& gt, double t_query, double t_match, bool correct) {
  const auto q = interpolatePose(gt, t_query, 1.0);
  const auto m = interpolatePose(gt, t_match, 1.0);
  LoopRecord r;
  r.t_query = t_query;
  r.t_match = t_match;
  r.accepted = true;
  r.T_match_query = Eigen::Isometry3d::Identity();
  r.T_match_query.translation() =
      m->q.conjugate() * (q->p - m->p) + (correct ? Eigen::Vector3d::Zero() : Eigen::Vector3d(3, 0, 0));
  r.T_match_query.linear() = (m->q.conjugate() * q->q).toRotationMatrix();
  return r;
}

}  // namespace

TEST(Revisit, FigureEightEvents) {
  const auto gt = figureEight();
  // Default gap 60 s: the crossing at t = 50 is too soon after t = 0; the second lap is one
  // event that starts when the vehicle comes within 1.5 m of the start (1.5 / 1.78 = 0.84 s
  // before t = 100) and lasts to the end.
  const auto events = detectRevisitEvents(gt, RevisitOptions{});
  ASSERT_EQ(events.size(), 1u);
  EXPECT_NEAR(events[0].t_start, 100.0 - 1.5 / (2 * M_PI * 0.2 * std::sqrt(2.0)), 0.15);
  EXPECT_DOUBLE_EQ(events[0].t_end, 150.0);
  EXPECT_LE(events[0].t_previous, events[0].t_start - 60.0);

  // With a 40 s gap the crossing at t = 50 (revisiting the start) is an event of its own.
  RevisitOptions short_gap;
  short_gap.min_gap_s = 40.0;
  const auto events40 = detectRevisitEvents(gt, short_gap);
  ASSERT_EQ(events40.size(), 2u);
  EXPECT_NEAR(events40[0].t_start, 49.16, 0.15);
  EXPECT_NEAR(events40[0].t_end, 50.84, 0.15);
  EXPECT_NEAR(events40[0].p_w_start.head<2>().norm(), 1.5, 0.2);
  EXPECT_NEAR(events40[1].t_start, 99.16, 0.15);
  EXPECT_DOUBLE_EQ(events40[1].t_end, 150.0);

  // A larger radius makes the events longer.
  RevisitOptions wide = short_gap;
  wide.radius_m = 3.0;
  const auto events_wide = detectRevisitEvents(gt, wide);
  ASSERT_EQ(events_wide.size(), 2u);
  EXPECT_GT(events_wide[0].t_end - events_wide[0].t_start, events40[0].t_end - events40[0].t_start + 1.0);
}

TEST(Revisit, EventsReportHeightAndHeadingChange) {
  // East along y = 0 at 4 m, then 100 s later north along x = 0 at 2.5 m: one event around the
  // crossing at the origin, 1.5 m lower and turned by 90 deg.
  std::vector<StampedPose> gt;
  const Eigen::Quaterniond north(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  for (int i = 0; i <= 200; ++i) {
    StampedPose p;
    p.t = 0.1 * i;
    p.p = Eigen::Vector3d(-10.0 + 0.1 * i, 0.0, 4.0);
    gt.push_back(p);
  }
  for (int i = 0; i <= 200; ++i) {
    StampedPose p;
    p.t = 100.0 + 0.1 * i;
    p.p = Eigen::Vector3d(0.0, -10.0 + 0.1 * i, 2.5);
    p.q = north;
    gt.push_back(p);
  }
  const auto events = detectRevisitEvents(gt, RevisitOptions{});
  ASSERT_EQ(events.size(), 1u);
  EXPECT_NEAR(events[0].height_change_m, -1.5, 1e-12);
  EXPECT_NEAR(events[0].heading_change_deg, 90.0, 1e-9);
}

TEST(Revisit, ClosedByAcceptedCorrectLoopsOnly) {
  const auto gt = figureEight();
  RevisitOptions options;
  options.min_gap_s = 40.0;
  // A wrong loop in the second event does not close it; a correct one in the first does.
  std::vector<LoopRecord> records = {loopAt(gt, 50.0, 0.0, true), loopAt(gt, 120.0, 20.0, false)};
  LoopEvaluation ev = evaluateLoops(records, gt, LoopScoringOptions{}, options);
  ASSERT_EQ(ev.events.size(), 2u);
  EXPECT_TRUE(ev.events[0].closed);
  EXPECT_DOUBLE_EQ(ev.events[0].t_closing_query, 50.0);
  EXPECT_FALSE(ev.events[1].closed);
  EXPECT_EQ(ev.revisits.events, 2u);
  EXPECT_EQ(ev.revisits.closed, 1u);
  EXPECT_DOUBLE_EQ(ev.revisits.closedPercent(), 50.0);

  records.push_back(loopAt(gt, 120.0, 20.0, true));
  records.back().accepted = false;  // rejected: still does not count
  ev = evaluateLoops(records, gt, LoopScoringOptions{}, options);
  EXPECT_FALSE(ev.events[1].closed);
  records.push_back(loopAt(gt, 121.0, 21.0, true));
  ev = evaluateLoops(records, gt, LoopScoringOptions{}, options);
  EXPECT_TRUE(ev.events[1].closed);
  EXPECT_EQ(ev.revisits.closed, 2u);

  // A correct loop just before an event counts only with a margin.
  const double t_before = ev.events[0].t_start - 0.5;
  const std::vector<LoopRecord> early = {loopAt(gt, t_before, 0.0, true)};
  EXPECT_FALSE(evaluateLoops(early, gt, LoopScoringOptions{}, options).events[0].closed);
  RevisitOptions with_margin = options;
  with_margin.margin_s = 1.0;
  EXPECT_TRUE(evaluateLoops(early, gt, LoopScoringOptions{}, with_margin).events[0].closed);
}

TEST(Revisit, GridSearchMatchesBruteForce) {
  // A random walk that wanders back over itself; compare against the O(n^2) definition.
  std::mt19937 rng(3);
  std::normal_distribution<double> step(0.0, 0.4);
  std::vector<StampedPose> gt(1200);
  for (std::size_t i = 1; i < gt.size(); ++i) {
    gt[i].t = 0.5 * i;
    gt[i].p = gt[i - 1].p + Eigen::Vector3d(step(rng), step(rng), step(rng));
  }
  RevisitOptions options;
  options.radius_m = 1.0;
  options.min_gap_s = 30.0;
  std::vector<bool> revisiting(gt.size(), false);
  for (std::size_t i = 0; i < gt.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (gt[j].t <= gt[i].t - options.min_gap_s && (gt[i].p - gt[j].p).head<2>().norm() <= options.radius_m)
        revisiting[i] = true;
  std::size_t expected_events = 0;
  for (std::size_t i = 0; i < gt.size(); ++i)
    if (revisiting[i] && (i == 0 || !revisiting[i - 1])) ++expected_events;
  ASSERT_GT(expected_events, 3u);

  const auto events = detectRevisitEvents(gt, options);
  ASSERT_EQ(events.size(), expected_events);
  std::vector<bool> covered(gt.size(), false);
  for (const auto& e : events)
    for (std::size_t i = e.first_index; i <= e.last_index; ++i) covered[i] = true;
  EXPECT_EQ(covered, revisiting);
}

TEST(Revisit, EventsAndLoopsCountForTheNearestCoilWithinTheRadius) {
  std::vector<RevisitEvent> events(4);
  events[0].p_w_start = Eigen::Vector3d(1, 0, -10);   // 1 m from coil 0, 29 m from coil 1
  events[1].p_w_start = Eigen::Vector3d(16, 0, -10);  // 16 m from coil 0, 14 m from coil 1
  events[2].p_w_start = Eigen::Vector3d(30, 3, 5);    // on coil 1 (height does not matter)
  events[3].p_w_start = Eigen::Vector3d(0, 40, -10);  // beyond 15 m of both: no coil's
  events[0].closed = true;
  events[2].closed = true;
  // Loops by their query's true position: two correct near coil 0, one wrong near coil 1, and
  // three that do not count (rejected, no ground truth, beyond both radii).
  LoopScore score;
  const auto loop = [&](const Eigen::Vector3d& p, bool accepted, bool has_gt, bool right) {
    ScoredLoop l;
    l.record.accepted = accepted;
    l.has_gt = has_gt;
    l.within_tolerance = right;
    l.p_w_query_gt = p;
    score.loops.push_back(l);
  };
  loop(Eigen::Vector3d(2, 1, -10), true, true, true);
  loop(Eigen::Vector3d(-5, 0, -10), true, true, true);
  loop(Eigen::Vector3d(28, 0, -10), true, true, false);
  loop(Eigen::Vector3d(29, 0, -10), false, true, true);
  loop(Eigen::Vector3d(30, 0, -10), true, false, true);
  loop(Eigen::Vector3d(0, 40, -10), true, true, true);
  const auto coils = revisitsNearCoils(events, score, {Eigen::Vector3d(0, 0, -12), Eigen::Vector3d(30, 0, -12)}, 15.0);
  ASSERT_EQ(coils.size(), 2u);
  EXPECT_EQ(coils[0].coil, 0);
  EXPECT_EQ(coils[0].summary.events, 1u);
  EXPECT_EQ(coils[0].summary.closed, 1u);
  EXPECT_EQ(coils[0].loops_correct, 2u);
  EXPECT_EQ(coils[0].loops_wrong, 0u);
  EXPECT_EQ(coils[1].coil, 1);
  EXPECT_EQ(coils[1].summary.events, 2u);
  EXPECT_EQ(coils[1].summary.closed, 1u);
  EXPECT_EQ(coils[1].loops_correct, 0u);
  EXPECT_EQ(coils[1].loops_wrong, 1u);
  EXPECT_DOUBLE_EQ(coils[1].position_w.x(), 30.0);
  // A smaller radius drops the event 14 m from coil 1 and the loop 5 m from coil 0.
  const auto near = revisitsNearCoils(events, score, {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(30, 0, 0)}, 4.0);
  EXPECT_EQ(near[1].summary.events, 1u);
  EXPECT_EQ(near[0].loops_correct, 1u);
}
