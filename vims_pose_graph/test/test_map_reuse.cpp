/// A second run in the first run's saved map (teach and repeat): relocalisation, and the map
/// modes mapping, extend and localisation (docs/pose_graph.md, "Map modes").

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "manager_test_runs.h"

namespace vims {
namespace {

using namespace manager_test;  // NOLINT: the shared runs and helpers

std::vector<char> fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Run A's map saved to a file; returns T_map_w (run A's map frame against the world).
Eigen::Isometry3d teachMap(const std::string& path) {
  const PoseGraphManagerOptions o = testOptions();
  PoseGraphManager teach(o, test::testSequence(), vocabularyFor(o));
  feed(teach, runA());
  teach.saveMap(path);
  return frameOf(teach.keyframePoses(), runA());
}

TEST(PoseGraphManager, RelocalisesASecondRunIntoTheFirstRunsFrame) {
  const SimRun& a = runA();
  const SimRun& b = runB();
  const PoseGraphManagerOptions o = testOptions();
  const std::string path = tempPath("teach.vmap");
  const Eigen::Isometry3d T_map_w = teachMap(path);
  test::LogRecorder log;
  PoseGraphManager repeat(o, test::testSequence(), vocabularyFor(o), log.logger());
  repeat.loadMap(path);
  feed(repeat, b);
  const PoseGraphManagerStats st = repeat.stats();
  ASSERT_TRUE(st.relocalised);
  EXPECT_TRUE(log.contains("relocalised into the loaded map"));
  EXPECT_GT(st.relocalised_t, 0.0);
  EXPECT_GE(st.loops_accepted, 1u);
  EXPECT_GE(st.loops_into_map, 1u);
  // Loops into the loaded map are verified against run A's truth.
  for (const LoopAttempt& l : repeat.loopAttempts()) {
    if (!l.accepted) continue;
    bool match_in_a = false;
    for (const KeyframeData& kf : a.keyframes) match_in_a |= std::abs(kf.t - l.t_match) < 1e-6;
    if (!match_in_a) continue;
    const Eigen::Isometry3d gt = truthAt(a, l.t_match).inverse() * truthAt(b, l.t_query);
    EXPECT_LT((l.T_match_query.translation() - gt.translation()).norm(), 0.1);
  }
  // SimRun B's trajectory is expressed in run A's map frame.
  const std::vector<KeyframePose> poses = repeat.keyframePoses();
  ASSERT_EQ(poses.size(), b.keyframes.size());
  EXPECT_LT(maxPositionError(poses, b, T_map_w), 0.2);
  // The loaded map did not move (it is the reference).
  const auto map_poses = repeat.keyframePoses(true);
  double map_shift = 0.0;
  for (const KeyframePose& k : map_poses)
    if (k.loaded)
      map_shift = std::max(map_shift, (k.T_w_b.translation() - (T_map_w * truthAt(a, k.t)).translation()).norm());
  EXPECT_LT(map_shift, 0.2);

  // Held (map mode extend): the loaded keyframes stay exactly where the map file had them, and
  // run B is still placed in the map's frame.
  std::vector<KeyframePose> saved;
  {
    PoseGraphManager reloaded(o, test::testSequence(), vocabularyFor(o));
    reloaded.loadMap(path);
    saved = reloaded.keyframePoses(true);
  }
  PoseGraphManagerOptions held_options = o;
  held_options.map_mode = MapMode::kExtend;
  PoseGraphManager held(held_options, test::testSequence(), vocabularyFor(held_options));
  held.loadMap(path);
  feed(held, b);
  ASSERT_TRUE(held.stats().relocalised);
  const auto held_poses = held.keyframePoses(true);
  size_t compared = 0;
  for (size_t i = 0; i < held_poses.size() && i < saved.size(); ++i) {
    if (!held_poses[i].loaded) continue;
    EXPECT_TRUE(held_poses[i].T_w_b.isApprox(saved[i].T_w_b, 1e-12)) << "loaded keyframe " << i << " moved";
    ++compared;
  }
  EXPECT_EQ(compared, saved.size());
  EXPECT_LT(maxPositionError(held.keyframePoses(), b, T_map_w), 0.2);
  std::remove(path.c_str());
}

TEST(PoseGraphManager, LocalisationPlacesTheRunInTheMapAndAddsNothingToIt) {
  const SimRun& b = runB();
  const std::string teach_path = tempPath("loc_teach.vmap");
  const std::string saved_path = tempPath("loc_saved.vmap");
  const Eigen::Isometry3d T_map_w = teachMap(teach_path);
  size_t loaded_magnetic = 0;
  std::vector<KeyframePose> loaded_poses;
  {
    const PoseGraphManagerOptions o = testOptions();
    PoseGraphManager reloaded(o, test::testSequence(), vocabularyFor(o));
    reloaded.loadMap(teach_path);
    loaded_poses = reloaded.keyframePoses(true);
    reloaded.inspectMap([&](const MultiScaleMap& map) { loaded_magnetic = map.magneticSubmaps().size(); });
  }
  ASSERT_GT(loaded_magnetic, 0u);

  PoseGraphManagerOptions o = testOptions();
  o.map_mode = MapMode::kLocalisation;
  PoseGraphManager loc(o, test::testSequence(), vocabularyFor(o));
  loc.loadMap(teach_path);
  feed(loc, b);
  const PoseGraphManagerStats st = loc.stats();
  ASSERT_TRUE(st.relocalised);
  // Every loop goes into the map: the run's keyframes are no candidates.
  EXPECT_GE(st.loops_into_map, 1u);
  EXPECT_EQ(st.loops_into_map, st.loops_accepted);
  EXPECT_EQ(st.localisation_keyframes + st.empty_keyframes + st.localisation_skipped_queries, b.keyframes.size());
  EXPECT_EQ(st.magnetic_submaps, 0u);
  for (const VisualSubmapMarker& v : loc.mapContents().visual) EXPECT_TRUE(v.loaded) << "run keyframe stored";
  loc.inspectMap([&](const MultiScaleMap& map) { EXPECT_EQ(map.magneticSubmaps().size(), loaded_magnetic); });
  // The map is held and run B is placed in it.
  const std::vector<KeyframePose> poses = loc.keyframePoses(true);
  for (size_t i = 0; i < loaded_poses.size(); ++i)
    EXPECT_TRUE(poses[i].T_w_b.isApprox(loaded_poses[i].T_w_b, 1e-12)) << "loaded keyframe " << i << " moved";
  EXPECT_LT(maxPositionError(loc.keyframePoses(), b, T_map_w), 0.2);

  // The status a mission planner reads.
  const RelocalisationStatus status = loc.relocalisationStatus();
  EXPECT_EQ(status.map_mode, MapMode::kLocalisation);
  EXPECT_TRUE(status.map_loaded);
  EXPECT_EQ(status.map_path, teach_path);
  EXPECT_EQ(status.loaded_keyframes, loaded_poses.size());
  EXPECT_EQ(status.run_keyframes, b.keyframes.size());
  EXPECT_TRUE(status.relocalised);
  EXPECT_EQ(status.loops_into_map, st.loops_into_map);
  EXPECT_GE(status.last_loop_into_map_t, status.relocalised_t);
  EXPECT_DOUBLE_EQ(status.latest_keyframe_t, b.keyframes.back().t);
  EXPECT_TRUE(status.T_map_odom.isApprox(loc.T_map_odom()));

  // Saved while localising, the map is the loaded one, byte for byte.
  loc.saveMap(saved_path);
  EXPECT_EQ(fileBytes(saved_path), fileBytes(teach_path));
  std::remove(teach_path.c_str());
  std::remove(saved_path.c_str());
}

TEST(PoseGraphManager, LocalisedRunsQueryOnlyEveryIntervalWhileLoopsIntoTheMapKeepComing) {
  const SimRun& b = runB();
  const std::string teach_path = tempPath("throttle_teach.vmap");
  const Eigen::Isometry3d T_map_w = teachMap(teach_path);
  auto localise = [&](double interval_s, double lost_after_s) {
    PoseGraphManagerOptions o = testOptions();
    o.map_mode = MapMode::kLocalisation;
    o.localisation_query_interval_s = interval_s;
    o.localisation_lost_after_s = lost_after_s;
    auto m = std::make_unique<PoseGraphManager>(o, test::testSequence(), vocabularyFor(o));
    m->loadMap(teach_path);
    feed(*m, b);
    return m;
  };
  const auto every = localise(0.0, 5.0);
  const auto throttled = localise(2.5, 5.0);
  const PoseGraphManagerStats all = every->stats(), few = throttled->stats();
  ASSERT_TRUE(few.relocalised);
  EXPECT_EQ(all.localisation_skipped_queries, 0u);
  // Keyframes are 1 s apart: once localised, about one in three queries.
  EXPECT_GT(few.localisation_skipped_queries, b.keyframes.size() / 3);
  EXPECT_EQ(few.loop_queries + few.localisation_skipped_queries, all.loop_queries);
  EXPECT_GE(few.loops_into_map, 1u);
  EXPECT_LT(few.loops_into_map, all.loops_into_map);
  EXPECT_DOUBLE_EQ(few.relocalised_t, all.relocalised_t);  // the search before it is untouched
  EXPECT_LT(maxPositionError(throttled->keyframePoses(), b, T_map_w), 0.2);
  // No loop into the map within lost_after_s of a keyframe (here never, the loops lag the
  // keyframes by a second): every keyframe queries.
  EXPECT_EQ(localise(2.5, 0.5)->stats().localisation_skipped_queries, 0u);
  std::remove(teach_path.c_str());
}

TEST(PoseGraphManager, PlacesAreThinnedToTheIntervalButALoadedMapIsSearchedByEveryKeyframe) {
  const SimRun& a = runA();
  PoseGraphManagerOptions o = testOptions();
  o.place_min_interval_s = 2.5;
  PoseGraphManager thinned(o, test::testSequence(), vocabularyFor(o));
  feed(thinned, a);
  const PoseGraphManagerStats st = thinned.stats();
  EXPECT_EQ(st.keyframes, a.keyframes.size());
  // Keyframes are 1 s apart: two of every three are odometry nodes without a place.
  EXPECT_GT(st.thinned_places, a.keyframes.size() / 2);
  EXPECT_EQ(st.loop_queries + st.thinned_places, a.keyframes.size());
  EXPECT_EQ(st.localisation_skipped_queries, 0u);
  EXPECT_EQ(thinned.mapContents().visual.size(), st.loop_queries) << "only the places keep a submap";
  EXPECT_EQ(st.yaw_factors, a.keyframes.size()) << "every keyframe is still a node with its yaw factor";
  // The places left still close the run's loops, correctly, and correct its drift.
  EXPECT_GE(st.loops_accepted, 1u);
  expectAcceptedLoopsCorrect(thinned.loopAttempts(), a, a);
  EXPECT_LT(maxPositionError(thinned.keyframePoses(), a, frameOf(thinned.keyframePoses(), a)), 0.25);

  // A repeat run in a loaded map queries every keyframe until it is found, then thins.
  const SimRun& b = runB();
  const std::string teach_path = tempPath("thin_teach.vmap");
  teachMap(teach_path);
  auto repeat = [&](double interval_s) {
    PoseGraphManagerOptions r = testOptions();
    r.place_min_interval_s = interval_s;
    auto m = std::make_unique<PoseGraphManager>(r, test::testSequence(), vocabularyFor(r));
    m->loadMap(teach_path);
    feed(*m, b);
    return m->stats();
  };
  const PoseGraphManagerStats every = repeat(0.0), few = repeat(2.5);
  ASSERT_TRUE(few.relocalised);
  EXPECT_DOUBLE_EQ(few.relocalised_t, every.relocalised_t);
  EXPECT_EQ(every.thinned_places, 0u);
  EXPECT_GT(few.thinned_places, 0u);
  std::remove(teach_path.c_str());
}

TEST(PoseGraphManager, ExtendAddsTheRunsPlacesSoTheMapHoldsBothMissionsAndModesSwitchWhileRunning) {
  const SimRun& b = runB();
  const std::string teach_path = tempPath("ext_teach.vmap");
  teachMap(teach_path);
  PoseGraphManagerOptions o = testOptions();
  o.map_mode = MapMode::kLocalisation;
  PoseGraphManager m(o, test::testSequence(), vocabularyFor(o));
  m.loadMap(teach_path);
  // The first half localising, then extending: only the second half's keyframes become places.
  const double t_switch = b.keyframes[b.keyframes.size() / 2].t;
  SimRun first = b, second = b;
  first.keyframes.resize(b.keyframes.size() / 2);
  second.keyframes.erase(second.keyframes.begin(), second.keyframes.begin() + b.keyframes.size() / 2);
  first.signatures.clear();
  second.signatures.clear();
  for (const SignatureWindow& w : b.signatures) (w.t < t_switch ? first : second).signatures.push_back(w);
  first.geomagnetic.clear();
  second.geomagnetic.clear();
  for (const auto& g : b.geomagnetic) (g.first < t_switch ? first : second).geomagnetic.push_back(g);
  feed(m, first);
  EXPECT_GT(m.stats().localisation_keyframes, 0u);
  m.setMapMode(MapMode::kExtend);
  EXPECT_EQ(m.relocalisationStatus().map_mode, MapMode::kExtend);
  feed(m, second);
  size_t run_places = 0;
  for (const VisualSubmapMarker& v : m.mapContents().visual)
    if (!v.loaded) {
      ++run_places;
      EXPECT_GE(v.t, t_switch);
    }
  EXPECT_GT(run_places, 0u);
  // The extended map holds both missions; a third run localises in it.
  const std::string two_missions = tempPath("ext_two_missions.vmap");
  m.saveMap(two_missions);
  PoseGraphManager third(o, test::testSequence(), vocabularyFor(o));
  third.loadMap(two_missions);
  third.inspectMap([&](const MultiScaleMap& map) {
    EXPECT_EQ(map.numNodes(), runA().keyframes.size() + b.keyframes.size());
    ASSERT_EQ(map.sessions().size(), 2u);
    for (const MapSession& session : map.sessions()) EXPECT_TRUE(session.loaded);
  });
  feed(third, runA());
  EXPECT_TRUE(third.stats().relocalised);
  EXPECT_EQ(third.stats().loops_into_map, third.stats().loops_accepted);
  std::remove(two_missions.c_str());
  // Extend and localisation need a loaded map; an unknown mode name is refused.
  const PoseGraphManagerOptions plain = testOptions();
  PoseGraphManager no_map(plain, test::testSequence(), vocabularyFor(plain));
  EXPECT_THROW(no_map.setMapMode(MapMode::kLocalisation), std::invalid_argument);
  EXPECT_THROW(no_map.setMapMode(MapMode::kExtend), std::invalid_argument);
  EXPECT_NO_THROW(no_map.setMapMode(MapMode::kMapping));
  EXPECT_THROW(mapModeFromString("localization"), std::invalid_argument);
  EXPECT_EQ(mapModeFromString(toString(MapMode::kExtend)), MapMode::kExtend);
  std::remove(teach_path.c_str());
}

TEST(PoseGraphManager, LocalisationWithoutAMapFallsBackToMappingWithAWarning) {
  PoseGraphManagerOptions o = testOptions();
  o.map_mode = MapMode::kLocalisation;
  test::LogRecorder log;
  PoseGraphManager m(o, test::testSequence(), vocabularyFor(o), log.logger());
  feed(m, runA());
  EXPECT_TRUE(log.contains("without a loaded map: mapping instead"));
  EXPECT_EQ(m.relocalisationStatus().map_mode, MapMode::kMapping);
  EXPECT_FALSE(m.relocalisationStatus().map_loaded);
  EXPECT_GT(m.stats().loops_accepted, 0u);  // it maps and closes its own loops
  EXPECT_EQ(m.stats().loops_into_map, 0u);
}

}  // namespace
}  // namespace vims
