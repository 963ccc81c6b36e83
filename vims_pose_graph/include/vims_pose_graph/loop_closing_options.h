#pragma once
/// @file loop_closing_options.h
/// @brief Typed options of the multi-scale map, the hierarchical loop closer and the pose-graph
/// manager (docs/pose_graph.md, "Loop closing"), and the ablation modes of the paper.
///
/// Every threshold of every stage is here with the reason for its default. All structs have
/// `fromReader` (rejects unknown keys, range-checks every value, ConfigError names the key),
/// `validate` (for options built in code) and `toYaml`.

#include <string>

#include "vims_common/config_reader.h"
#include "vims_pose_graph/feature_extraction.h"
#include "vims_pose_graph/geomagnetic_gate.h"
#include "vims_pose_graph/pose_graph.h"
#include "vims_pose_graph/vehicle_field.h"

namespace vims {

template <typename Options>
class OptionTable;

/// The paper's ablation modes, all on the same code path.
enum class LoopClosingMode {
  kFull,     ///< magnetic + BoW + ORB verification, geomagnetic yaw factors
  kViSlam,   ///< baseline: BRIEF, BoW over all past submaps, every candidate above threshold verified, no magnetism
  kNoAlter,  ///< no magnetic (alternating field) stage: BoW over all past submaps
  kNoOrb,    ///< BRIEF instead of ORB everywhere (visual submaps and tracked points)
  kNoGeom,   ///< no geomagnetic yaw factors
};
/// "full" / "vi_slam" / "no_alter" / "no_orb" / "no_geom".
std::string toString(LoopClosingMode mode);
/// Throws std::invalid_argument naming the value for anything else.
LoopClosingMode loopClosingModeFromString(const std::string& name);

/// What a run does with a loaded map (teach and repeat; docs/pose_graph.md, "Map modes"). Without
/// a loaded map only kMapping makes sense (PoseGraphManager refuses the others).
enum class MapMode {
  kMapping,       ///< the loaded map is optimised with the run; the run's submaps join the map
  kExtend,        ///< the loaded map is held fixed; the run's submaps join it (its new places)
  kLocalisation,  ///< the loaded map is held fixed; the run only queries it and adds no submap
};
/// "mapping" / "extend" / "localisation".
std::string toString(MapMode mode);
/// Throws std::invalid_argument naming the value for anything else.
MapMode mapModeFromString(const std::string& name);

/// What a mode switches on. Derived from the mode only (never configured separately), so a mode
/// name in a results table means exactly one set of stages.
struct ModeSettings {
  DescriptorType descriptor = DescriptorType::kOrb;  ///< visual submaps and tracked points
  bool magnetic_stage = true;                        ///< magnetic place recognition restricts the BoW search
  bool verify_all_bow_candidates = false;            ///< every BoW candidate above threshold is verified (vi_slam)
  bool geomagnetic_yaw = true;                       ///< geomagnetic yaw factors in the pose graph

  static ModeSettings forMode(LoopClosingMode mode);
};

/// Grouping of magnetic signatures into magnetic submaps (paper, "Magnetic Submaps").
struct MagneticSubmapOptions {
  /// A submap's radius is where its signature varies by less than this fraction of its own
  /// magnitude: |s - s_submap| <= max_relative_variation * |s_submap|. At the extractor's
  /// min_snr (100) noise moves an amplitude by ~7 %, so 0.25 is over three times the noise (noise
  /// alone does not cut submaps); a dipole field (~r^-3) changes by 25 % over ~8 % of the range
  /// to the coil: submaps span ~0.25 m of track at 3 m from the coil and ~1 m at 12 m.
  double max_relative_variation = 0.25;
  /// Signatures weaker than this [T] are not mapped: a relative variation of a near-zero vector
  /// is meaningless. 3 nT is well above the amplitude noise of a 2 s window (~0.2 nT at 5 nT per
  /// 1 kHz sample) and below the coil field at ~15 m.
  double min_amplitude_tesla = 3.0e-9;
  /// Members needed for a submap. 1: close to the coil the field changes so fast that a group
  /// may hold a single window, and dropping it would leave exactly the most distinctive places
  /// without a magnetic submap (their keyframes would be unreachable by the magnetic stage).
  int min_members = 1;
  /// A submap is closed after this many members (40 s at 0.4 s hops), so a hovering vehicle
  /// still produces submaps and the grouping cost stays bounded.
  int max_members = 100;
  /// A time gap between consecutive valid signatures larger than this [s] closes the submap
  /// (invalid windows, magnetometer dropout): 2.5 hops.
  double max_time_gap_s = 1.0;
  /// The sparse representation is the mean of the members within this many places of the
  /// median member (2 -> 5 windows, 1.6 s of overlapping windows) -- the "smoothed value at the
  /// median point".
  int smoothing_half_window = 2;
  /// Radius bounds [m]. The minimum covers the keyframes next to the tied one when the vehicle
  /// hovers; the maximum keeps a submap far from the coil (field nearly constant) from clustering
  /// the whole map, where the magnetic stage cannot discriminate anyway.
  double min_radius_m = 0.3;
  double max_radius_m = 5.0;
  /// Visual submaps up to radius + margin (horizontal distance) are clustered under a magnetic
  /// submap: a downward camera at 2-3 m altitude sees ~3 x 2 m of seabed, so keyframes within
  /// about half of that of the submap still view the same place.
  double cluster_margin_m = 1.0;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<MagneticSubmapOptions>& optionTable();

  static MagneticSubmapOptions fromReader(const ConfigReader& reader);
  void validate() const;
  std::string toYaml() const;
};

/// Hierarchical place recognition and loop verification (paper, "Hierarchical Place
/// Recognition" and "Loop Closure Verification").
struct LoopDetectorOptions {
  // --- candidates
  /// Keyframes of the current run this recent are never candidates (the paper excludes
  /// x < y + 50 submaps; 30 s covers slow hovering with many keyframes). Loaded-map keyframes
  /// are never recent.
  int exclude_recent_keyframes = 50;
  double exclude_recent_s = 30.0;

  // --- redundant visual submaps (a bounded map over an already-mapped area)
  /// A new keyframe stores no visual submap (it stays a pose-graph node and still runs its loop
  /// query, but is no loop candidate) when a keyframe of the same connected component that has a
  /// visual submap and is not recent (exclude_recent_keyframes / exclude_recent_s, as for loop
  /// candidates; keyframes of a loaded map are never recent) lies within this horizontal
  /// distance [m] of the new keyframe's current world position and within
  /// redundant_submap_max_height_difference_m vertically: that older submap already shows the
  /// place to a later revisit, so re-flying a mapped area does not grow the map. 0 disables.
  /// 0.5 m: the camera sees 1.51 h x 1.13 h of seabed at altitude h, 3.2 x 2.4 m at tank750's
  /// lowest 2.1 m, so a culled view overlaps the kept one by >= 79 %; and it stays below
  /// MagneticSubmapOptions::cluster_margin_m, so a magnetic submap tied to a culled keyframe
  /// still clusters the kept submap of its place.
  double redundant_submap_radius_m = 0.5;
  /// Submaps of the same place seen from another altitude are kept: the seabed appears at
  /// another scale, and a later revisit at that altitude matches them with fewer pyramid levels
  /// apart. 0.5 m [m]: 2.6 / 2.1 = 1.24, about one ORB level (1.2) at the lowest altitude.
  double redundant_submap_max_height_difference_m = 0.5;
  /// A culled keyframe keeps its BoW vector (~5 KB; a submap is ~200 KB), though it is no loop
  /// candidate, so that `vims_eval place-recognition` can score every keyframe of a run. It is
  /// the only part of the map that grows with time once culling has stopped new submaps: false
  /// on long missions (config/long_mission.yaml), where memory then stops with the map.
  bool keep_culled_bow_vectors = true;

  // --- magnetic stage
  /// The query's signature of each coil is that coil's valid one nearest in time within this [s]
  /// (hop 0.4 s: one is always within 0.2 s while the coil is heard). None: the stage is skipped with a warning.
  double query_signature_max_dt_s = 0.5;
  /// A magnetic submap i is a candidate when |s_q - s_i| <= relative * |s_i| + floor, s_q the
  /// query's signature of submap i's coil (submaps of coils the query did not hear are not).
  /// relative = 2 x max_relative_variation: the query may lie anywhere inside the submap's radius
  /// and margin (up to the variation threshold from the representative) plus its own noise; the
  /// floor is the amplitude noise of two windows (tesla).
  double mag_distance_relative = 0.5;
  double mag_distance_floor_tesla = 1.0e-9;
  /// Candidates kept per coil (smallest distance first). Overlapping submaps make several near-equal
  /// candidates at a revisit; 5 keeps them without letting a weak, ambiguous field open the whole map.
  int mag_max_candidates = 5;

  // --- bag of words
  /// Minimum L1 score. Measured with the k8l4 vocabulary on the simulated seabed: overlapping
  /// views (turned, other altitude) 0.09-0.21, unrelated places 0.03-0.15 -- the seabed looks
  /// alike everywhere, so BoW ranks candidates rather than decides; 0.04 only drops feature-poor
  /// or clearly unrelated images, and the geometric stages decide.
  double bow_min_score = 0.04;
  /// Candidates verified per query (best score first; the first accepted one wins). vi_slam
  /// verifies every candidate above the threshold (the paper's enhanced VINS-Mono), capped by
  /// bow_max_candidates_all to bound the cost of one query.
  int bow_max_candidates = 3;
  int bow_max_candidates_all = 50;

  // --- corner replication (tracked 3D points described for 3D-2D matching)
  /// Harris response (ORB units: 7x7 block, k = 0.04, normalised as cv::ORB does) below which a
  /// replicated keypoint is dropped. Tracked Shi-Tomasi corners are corners at level 0 but
  /// often blur into edges or flat patches at coarse levels, where their descriptor is noise.
  /// On the simulated seabed ORB's keypoints respond 3e-8..2e-6 (10th percentile 6e-8); 1e-8
  /// drops the flat and edge-like levels and keeps every level where ORB itself could find a corner.
  double harris_threshold = 1.0e-8;
  /// Add the keyframe's own tracked corners (replicated like a query's) to its visual submap's
  /// matching keypoints (not to its BoW vector). Queries are tracked corners; the same detector
  /// on both sides re-finds the same corners (~40 % more correct matches on the simulated seabed).
  bool submap_include_tracked_corners = true;
  /// Also add up to this many Shi-Tomasi corners detected in the keyframe image (the tracker's
  /// detector: block 3, down to 0.1 % of the strongest response, submap_corner_min_distance_px
  /// apart), replicated on pyramid levels 0..submap_corner_max_level like the tracked points
  /// (matching keypoints only; 0 disables). Reason: the VIO keeps only ~150 corners 30 px apart,
  /// chosen by track history, so at a real revisit only ~6 of ~117 visible query points have a
  /// tracked corner of the candidate within 3 px, and ~12 an ORB keypoint; a dense set of the
  /// same detector's corners re-finds ~40 (tank750, vims_pose_graph_replay --diagnose).
  int submap_dense_corners = 800;
  /// The query's 3D points are those of the query keyframe and of the described ones among this
  /// many preceding keyframes of its VIO session (a local map, as VINS-Mono's window / ORB-SLAM's local map):
  /// one keyframe's ~125 describable points see too little of a revisit (0-6 correct matches at
  /// tank750 revisits); neighbours add the area around it and more views of each point.
  int query_local_map_keyframes = 5;
  double submap_corner_min_distance_px = 4.0;
  int submap_corner_max_level = 3;
  /// Detect the dense corners on each pyramid level 0..submap_corner_max_level (level l: up to
  /// submap_dense_corners / scale^(2l), described on level l) instead of on level 0 replicated
  /// upwards. A corner of the seabed seen from higher up is smaller in the image: the level-0
  /// detector of a lower visit finds other (finer) corners there, and replicating those upwards
  /// does not re-find it; the same detector on the level where it has the query's size does.
  bool submap_dense_corners_per_level = true;
  /// The query keyframe's own seabed corners (KeyframeDescriber::describeSeabedCorners): up to
  /// this many Shi-Tomasi corners on pyramid level 1 (fewer by area up to
  /// submap_corner_max_level) of the query image, each described on its level, placed in 3D on
  /// the local plane of the nearest tracked points' inverse depths. They give a query flown
  /// lower than the first visit coarse corners at the candidate's scale (its tracked corners
  /// are level-0 corners, finer than anything the higher candidate resolves). Only the query
  /// keyframe's, not its local map's. 0 disables.
  int query_seabed_corners = 400;
  /// The seabed corners are matched only against candidates whose predicted level shift
  /// (LoopVerifier::levelWindow) is at least this many levels either way (1: a 1.2x scale
  /// change): their depths are interpolated between landmarks, less exact than the VIO's own, and
  /// at about the same altitude the tracked points match on their own. 0: always.
  double query_seabed_min_level_shift = 1.0;

  // --- 3D-2D matching
  /// Lowe's 2-nearest-neighbour ratio: best < ratio * second best. Lowe's 0.8 is for one
  /// descriptor per feature; here a point's distance is the minimum over its replicated levels,
  /// which also pulls the second best down. Measured on simulated seabed revisits (90 deg
  /// turns included): 0.9 rejects ~60 % of the wrong matches and keeps ~90 % of the correct ones,
  /// 0.8 rejects ~90 % but also ~20 % of the correct ones and halves the verified revisits;
  /// PnP and covisibility reject what remains (no wrong place accepted either way).
  double match_ratio = 0.9;
  /// Maximum Hamming distance of a match (of 256 bits); ORB-SLAM's loose threshold is 100,
  /// 80 is stricter because the ratio test alone passes unique but poor matches.
  int match_max_distance = 80;
  /// A query descriptor of pyramid level l is compared with candidate keypoints of octave o only
  /// when |l - o| <= this: the replication covers scale changes between visits, and 2 levels
  /// (1.2^2 = 1.44) cover altitude changes of +-44 %, while comparing every level with every
  /// octave only adds chances for a wrong keypoint to look close. -1 compares all levels.
  int match_max_level_difference = 2;
  /// Scale-aware matching across altitude changes: when the query and the candidate are in one
  /// connected component (their world heights are comparable), the level at which a query
  /// descriptor of level l should be found in the candidate is predicted from the two camera
  /// altitudes: l + log(d_q / d_c) / log(orb_scale_factor), with d_q the median depth of the
  /// query's 3D points in its camera and d_c = d_q + (camera height of the candidate - that of
  /// the query) (the same seabed under both if the candidate is the right place). Only octaves
  /// within match_predicted_level_tolerance of the prediction are compared (instead of
  /// +-match_max_level_difference around l), so a revisit 1.3-1.8x in scale compares the
  /// corresponding levels and has fewer competitors in the ratio test. Otherwise (another
  /// component, no depth) the +-match_max_level_difference window applies.
  bool match_level_from_altitude = true;
  /// Half-width [levels] of the predicted window (real-valued centre). 1.0: the depths are
  /// medians over a non-flat seabed and the camera tilts by a few degrees (0.1-0.2 levels), and a
  /// corner's best-matching level varies by one level from ORB's 1.2x pyramid sampling.
  double match_predicted_level_tolerance = 1.0;
  /// ORB detects one corner on several pyramid levels; the second-best neighbour is taken among
  /// keypoints farther than this [px] from the best one, so those duplicates do not fail the ratio test.
  double match_duplicate_radius_px = 4.0;

  // --- candidates from the pose graph's own estimate
  /// Besides the magnetic + BoW candidates, verify up to this many keyframes (not recent, with a
  /// visual submap, in the query's connected component) whose current world position is nearest
  /// horizontally to the query's, within proximity_radius_m (nearest first, after the BoW
  /// candidates, skipping those BoW already verified). Reason: a place flown again at another
  /// height looks different to BoW (the true candidate ranked 450-1000th of ~1000 at tank750's
  /// missed revisits) and to the magnetic stage (the coil's field changes with height), while
  /// the globally optimised pose graph (geomagnetic yaw, earlier loops) knows where it is to a
  /// few decimetres. Verification (2NN, PnP, covisibility) is unchanged. 0 (default) disables:
  /// the paper's hierarchy decides which places are verified and the ablation modes compare it;
  /// with the scale-aware matching it already closes 8 of 9 revisits on tank750 seeds 1-3.
  int proximity_candidates = 0;
  /// Horizontal radius [m]: the pose graph's drift between loops stays well below this, and a
  /// keyframe this far away still shares most of the view (1.51 h x 1.13 h of seabed at altitude h;
  /// at tank750's lowest 2.1 m, 3.2 x 2.4 m).
  double proximity_radius_m = 1.0;
  /// Localising in a loaded map the run is joined to (map modes localisation and extend, after
  /// relocalisation), also verify up to this many of the map's keyframes nearest the query's
  /// position (within proximity_radius_m) from the pose graph's prediction of their relative
  /// pose (LoopVerifier::verifyFromPrediction: matching near the predicted projections, the
  /// pose levelled on those, then the usual inlier count and covisibility), as ORB-SLAM tracks
  /// its local map. Reason: in murky water high over the seabed the images are too poor for the
  /// bag of words (scores 0.01-0.02) and for the ratio test over the whole image (11-22 matches),
  /// and without loops the repeat drifted 0.1 m in 100 s. 0 disables.
  int track_map_candidates = 1;

  // --- PnP RANSAC
  /// Inlier threshold in the candidate image [px]. It must cover the error of the VIO's 3D
  /// points, not only keypoint quantisation: on tank750 a landmark reprojects with a median of
  /// 1.1 px (p90 3.4 px) into a keyframe only ~0.2 m away, and correct matches at revisits
  /// 0.5-1.5 m apart reproject with a median of 2 px (p90 4 px) under the true pose, so 3 px
  /// discarded about half of the correct matches. A wrong match lands within 5 px of a
  /// hypothesis' prediction with probability ~3e-4 per match (640 x 480 image), so 25 such
  /// inliers stay out of reach of chance; repeated structure is the covisibility check's job.
  double pnp_reprojection_px = 5.0;
  /// RANSAC hypotheses: at the ~20-35 % inlier rates of real revisits a clean 4-point sample
  /// has probability 0.002-0.015; 200 hypotheses often stopped at a partial consensus (14
  /// instead of 24 inliers in RevisitWithTrackerSelectedCornersNeedsDenseCornersAndLocalMap).
  int pnp_iterations = 1000;
  double pnp_confidence = 0.99;
  /// Minimum inliers (VINS-Mono's MIN_LOOP_NUM): fewer cannot tell a revisit from an
  /// accidental small consistent set (a repeated object).
  int pnp_min_inliers = 25;
  /// Reject a PnP pose whose gravity direction disagrees with the VIO's by more than this [deg]
  /// (both VIO frames are gravity-aligned; roll and pitch are observable to the VIO to a few
  /// tenths of a degree). Over a flat seabed PnP trades tilt for lateral shift: a loop tilted
  /// by t is off by ~depth x t in position, and 2 deg at 3 m is 0.1 m, the loop edge's position
  /// sigma. tank750 with the scale-aware matching: the loops found 5-10 deg off were all tilt
  /// errors (0.3-0.8 m off). 0 disables.
  double pnp_max_tilt_error_deg = 2.0;
  /// Refine an accepted PnP pose with both keyframes' roll and pitch held at their VIO attitudes
  /// (refineLoopMeasurement): the 4-DoF edge then carries no PnP tilt error turned into a lateral
  /// shift, and gets a covariance from its inliers (PoseGraphOptions::loop_sigma_from_inliers).
  /// false = the 6-DoF PnP pose, and every loop edge the constant loop sigmas.
  bool pnp_known_vertical_refinement = true;
  /// Before the P3P RANSAC, a 2-point RANSAC with the candidate camera's tilt taken from its VIO
  /// attitude (only yaw and position unknown) must find pnp_min_inliers within this many times
  /// pnp_reprojection_px, or the candidate is rejected at the PnP stage. It needs ~1/w^2 samples
  /// to rule a consensus out where P3P needs ~1/w^4 (w: inlier rate). Wider than the PnP
  /// threshold because it is only a necessary condition: the VIO's tilt error, which P3P
  /// absorbs, adds to its residuals. 0 disables.
  double pnp_vertical_check_threshold_scale = 2.0;

  // --- relocalisation: guided matching
  /// Against a candidate the query's run is not joined to yet (another connected component: a
  /// loaded map before relocalisation, or the run's session before a VIO reset) verification
  /// tries harder, as ORB-SLAM's relocalisation does: the query's seabed corners are matched
  /// too, whatever the altitudes, and a PnP consensus of at least this many inliers that falls
  /// short of pnp_min_inliers or is tilted beyond pnp_max_tilt_error_deg is a hypothesis: it is
  /// levelled (both keyframes' roll and pitch from their VIO attitudes, refineLoopMeasurement),
  /// widened by matching every query point near its projection (matchPointsByProjection) and
  /// levelled again on what it explains; then its inliers are recounted against pnp_min_inliers
  /// and the covisibility check follows as for any candidate. Reason: a place flown again the
  /// other way and 1-1.5 m to the side shares half of its view; the ratio test over the whole
  /// image found 9-24 of the hundreds of corners both images see, and the PnP pose of such a
  /// one-sided consensus was tilted 2-7 deg (docs/pose_graph.md, "Relocalisation: guided
  /// matching"). Loops within a component, which come by the hundred, keep the plain checks.
  /// 0 disables.
  int guided_min_inliers = 12;
  /// [px] Radius of the guided search around each projection: covers the error of a levelled
  /// pose from a dozen inliers at the image's edge.
  double guided_search_radius_px = 10.0;

  // --- covisibility
  /// The match's temporal neighbours (same session, up to this many keyframes with a visual
  /// submap either side, stepping over ones without within 2x this many keyframes) must
  /// also see the PnP inliers: each inlier is projected into a neighbour with the neighbour's
  /// VIO pose relative to the match, and is confirmed by a neighbour keypoint within
  /// covisibility_search_radius_px whose descriptor is within match_max_distance. 0 disables.
  int covisibility_neighbours = 2;
  /// A neighbour confirms when at least this many inliers project into it and at least this
  /// fraction of those are confirmed; the candidate passes when covisibility_min_neighbours
  /// neighbours confirm. A wrong PnP pose predicts the neighbours' views wrongly (~0 %),
  /// a correct one gets 30-70 % (the neighbour keeps only its 500 strongest corners).
  int covisibility_min_points = 10;
  double covisibility_min_ratio = 0.25;
  int covisibility_min_neighbours = 1;
  /// VIO relative poses between neighbouring keyframes are accurate to a few mm; 8 px covers
  /// that plus the PnP pose error at a few metres.
  double covisibility_search_radius_px = 8.0;

  // --- loops.csv
  /// Also record, per query, the best candidate that failed the magnetic or BoW stage (at most
  /// one row per query), so precision-recall of the prefilters can be computed from loops.csv.
  bool record_prefilter_rejections = true;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<LoopDetectorOptions>& optionTable();

  static LoopDetectorOptions fromReader(const ConfigReader& reader);
  void validate() const;
  std::string toYaml() const;
};

/// Options of the PoseGraphManager (the key `pose_graph_manager` or a file like
/// config/pose_graph.yaml).
struct PoseGraphManagerOptions {
  LoopClosingMode mode = LoopClosingMode::kFull;
  /// What the run does with a loaded map (MapMode); switchable while running
  /// (PoseGraphManager::setMapMode). Teach and repeat (tank seed 3 taught, seed 4 repeated):
  /// mapping refines the map with the run (the map moves 0.02 m rms, its own ATE 0.026 -> 0.018
  /// m; the repeat in it 1.05x the teach run's), extend and localisation hold it where the teach
  /// run left it (1.12x; docs/benchmarks.md, "Teach and repeat").
  MapMode map_mode = MapMode::kMapping;
  /// Localising (map_mode localisation), once relocalised and while loops into the map keep
  /// coming (the newest within localisation_lost_after_s of a keyframe), a keyframe is described
  /// and queried only when this long [s] has passed since the last one that was; the others are
  /// odometry nodes without a query. The run stores no place, so a skipped query loses nothing
  /// but a loop edge among hundreds. 0: every keyframe queries, as in the other modes. 2 s (the
  /// 300 s tank repeat): the pose graph's time 0.30x mapping mode's, the ATE in the map's frame
  /// +2 % (docs/benchmarks.md, "Teach and repeat").
  double localisation_query_interval_s = 2.0;
  /// [s] no loop into the map for this long (by keyframe time; a query waits up to
  /// magnetic_wait_s for its signature): every keyframe queries again until one is found.
  double localisation_lost_after_s = 5.0;
  /// Mapping and extending: a keyframe becomes a place (visual submap stored, loop query run) only
  /// when this long [s] has passed since the last one that did; the others are odometry nodes
  /// (edges, yaw and depth factors) without a description. A slow vehicle makes a keyframe every
  /// 0.3-0.5 s, and describing and querying them is most of the pose graph's CPU; places half a
  /// second apart still overlap by most of the image. While a loaded map is not yet found, every
  /// keyframe queries. 0: every keyframe is a place (the default: docs/benchmarks.md, "Speed").
  double place_min_interval_s = 0.0;
  /// Vocabulary per descriptor type (relative paths are relative to the package root; the
  /// caller resolves them, see resolveVocabularyPath). The mode picks one.
  std::string vocabulary_orb = "config/vocabulary/orb_k8l4.vocab";
  std::string vocabulary_brief = "config/vocabulary/brief_k8l4.vocab";
  /// Keypoint extraction of visual submaps; must equal the vocabulary's training settings.
  /// `descriptor` is set by the mode and must not be given.
  FeatureExtractionOptions features;
  MagneticSubmapOptions magnetic;
  LoopDetectorOptions loop;
  PoseGraphOptions graph;

  /// true: everything runs inline in the feed calls (deterministic; offline runner, tests).
  /// false: a processing thread describes keyframes and detects loops and an optimiser thread
  /// runs the Ceres solve on a snapshot, so feed calls only enqueue.
  bool synchronous = false;
  /// Besides after every accepted loop, optimise every this many keyframes so the geomagnetic
  /// yaw factors act even without loops (10 keyframes: a few seconds).
  int optimise_every_n_keyframes = 10;
  /// Loop detection of a keyframe waits until magnetic data up to its time has arrived (the
  /// signature of a 2 s window is published ~1.1 s after its centre) or until a keyframe this
  /// much newer [s] arrives (magnetometer silent).
  double magnetic_wait_s = 2.5;
  /// A geomagnetic sample becomes a yaw factor of the keyframe nearest in time if within this
  /// [s]; at most one per keyframe (the low-passed samples are strongly correlated, more would
  /// overweight the compass). 0.2 s: the AUV yaws at most a few degrees in that time.
  double geomagnetic_max_dt_s = 0.2;
  /// Which geomagnetic samples may become yaw factors (geomagnetic_gate.h).
  GeomagneticGateOptions geomagnetic_gate;
  /// The vehicle's own field taken out of the geomagnetic samples first (vehicle_field.h).
  VehicleFieldOptions vehicle_field;
  /// A signature is placed on the trajectory by interpolating the keyframes around it; past the
  /// last keyframe of its session it may use the nearest one within this [s].
  double signature_max_extrapolation_s = 0.5;
  /// VIO reset inside a run: the new session is linked to the last keyframe of the previous one
  /// by a weak "the vehicle did not move far" edge: sigma = base + rate * time gap, position [m]
  /// and yaw [deg] (the AUV moves < 0.5 m/s and turns < 10 deg/s). Loops and yaw factors dominate it.
  double session_link_position_sigma_m = 1.0;
  double session_link_position_sigma_per_s = 0.5;
  double session_link_yaw_sigma_rad = 20.0 * M_PI / 180.0;        ///< key session_link_yaw_sigma_deg
  double session_link_yaw_sigma_per_s_rad = 10.0 * M_PI / 180.0;  ///< key session_link_yaw_sigma_per_s_deg
  /// Non-empty: every input fed to the manager is also written to this file (input_recording.h),
  /// for re-running loop closing offline on a run's real keyframes (vims_pose_graph_replay).
  std::string record_inputs_path;

  ModeSettings modeSettings() const { return ModeSettings::forMode(mode); }
  /// The vocabulary path of the mode's descriptor type.
  const std::string& vocabularyPath() const;
  /// Feature options with the mode's descriptor.
  FeatureExtractionOptions featureOptions() const;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<PoseGraphManagerOptions>& optionTable();

  /// Keys: mode, map_mode, localisation_query_interval_s, localisation_lost_after_s, vocabulary_orb, vocabulary_brief,
  /// synchronous, optimise_every_n_keyframes, magnetic_wait_s, geomagnetic_max_dt_s, signature_max_extrapolation_s,
  /// session_link_*, and the mappings geomagnetic_gate, vehicle_field, features, magnetic_submaps, loop_closing,
  /// pose_graph.
  static PoseGraphManagerOptions fromReader(const ConfigReader& reader);
  void validate() const;
  std::string toYaml() const;
};

/// A relative vocabulary path resolved against `package_root` (absolute paths unchanged).
std::string resolveVocabularyPath(const std::string& path, const std::string& package_root);

}  // namespace vims
