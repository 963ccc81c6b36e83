/// vims_pose_graph_replay: re-runs the pose graph and hierarchical loop closing on the inputs a
/// run recorded (PoseGraphManagerOptions::record_inputs_path), without the front end and the
/// VIO, and optionally diagnoses loop verification against ground truth: for every keyframe with
/// a ground-truth revisit, what each stage produced against the ground-truth nearest keyframe.
/// docs/pose_graph.md, "Replaying recorded inputs".

#include <sys/resource.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "vims_common/camera_model.h"
#include "vims_common/config_reader.h"
#include "vims_common/log.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/timing.h"
#include "vims_common/trajectory_io.h"
#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/input_recording.h"
#include "vims_pose_graph/loop_csv.h"
#include "vims_pose_graph/loop_detector.h"
#include "vims_pose_graph/pose_graph_manager.h"
#include "vims_system/system_config.h"

namespace fs = std::filesystem;
using namespace vims;

namespace {

const char* kUsage =
    "usage: vims_pose_graph_replay --sequence DIR --inputs FILE --out OUT [--options FILE] [--mode MODE]\n"
    "                              [--package-root DIR] [--diagnose] [--revisit-radius M] [--quiet]\n"
    "  --sequence DIR      the sequence the inputs were recorded on (camera, magnetometer from its YAML;\n"
    "                      with --diagnose also its ground truth)\n"
    "  --inputs FILE       a recording (pose_graph.record_inputs_path of vims_offline --config)\n"
    "  --out OUT           writes OUT/loops.csv and OUT/global.tum (as vims_offline; `vims_eval run` reads them)\n"
    "                      and OUT/optimisations.csv (one row per pose-graph solve: trigger, times, iterations)\n"
    "  --options FILE      system configuration whose pose_graph section is used (default: config/pose_graph.yaml\n"
    "                      under the package root)\n"
    "  --mode MODE         full, vi_slam, no_alter, no_orb or no_geom (default: the options' mode)\n"
    "  --package-root DIR  for relative vocabulary paths (default: current directory)\n"
    "  --diagnose          also write OUT/loop_diagnosis.csv (per ground-truth revisit keyframe) and\n"
    "                      OUT/landmark_accuracy.csv (per keyframe: landmark reprojection under ground truth)\n"
    "  --revisit-radius M  horizontal ground-truth distance of a revisit (default 1.5)\n";

/// The command line (see kUsage).
struct ReplayArguments {
  std::string sequence_dir;
  std::string inputs;
  std::string out_dir;
  std::string options_file;  ///< empty: config/pose_graph.yaml under package_root
  std::string mode;          ///< empty: the options' mode
  std::string package_root = ".";
  bool diagnose = false;
  bool quiet = false;
  double revisit_radius = 1.5;
};

/// Parses the command line; on a bad or missing argument prints the usage to stderr and returns
/// nothing (exit code 2).
std::optional<ReplayArguments> parseArguments(int argc, char** argv) {
  ReplayArguments args;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](std::string* v) {
      if (i + 1 >= argc) return false;
      *v = argv[++i];
      return true;
    };
    std::string radius;
    if (arg == "--sequence" && value(&args.sequence_dir)) continue;
    if (arg == "--inputs" && value(&args.inputs)) continue;
    if (arg == "--out" && value(&args.out_dir)) continue;
    if (arg == "--options" && value(&args.options_file)) continue;
    if (arg == "--mode" && value(&args.mode)) continue;
    if (arg == "--package-root" && value(&args.package_root)) continue;
    if (arg == "--revisit-radius" && value(&radius)) {
      args.revisit_radius = std::stod(radius);
      continue;
    }
    if (arg == "--diagnose") {
      args.diagnose = true;
      continue;
    }
    if (arg == "--quiet") {
      args.quiet = true;
      continue;
    }
    std::cerr << "bad argument '" << arg << "'\n" << kUsage;
    return std::nullopt;
  }
  if (args.sequence_dir.empty() || args.inputs.empty() || args.out_dir.empty()) {
    std::cerr << kUsage;
    return std::nullopt;
  }
  return args;
}

/// Ground-truth pose at t (linear / slerp interpolation); false outside the trajectory.
bool gtPoseAt(const std::vector<StampedPose>& gt, double t, Eigen::Isometry3d* T) {
  if (gt.empty() || t < gt.front().t || t > gt.back().t) return false;
  auto it = std::lower_bound(gt.begin(), gt.end(), t, [](const StampedPose& p, double v) { return p.t < v; });
  if (it == gt.begin()) ++it;
  if (it == gt.end()) --it;
  const StampedPose& b = *it;
  const StampedPose& a = *(it - 1);
  const double s = b.t > a.t ? std::clamp((t - a.t) / (b.t - a.t), 0.0, 1.0) : 0.0;
  *T = Eigen::Isometry3d::Identity();
  T->translation() = (1.0 - s) * a.p + s * b.p;
  T->linear() = a.q.slerp(s, b.q).normalized().toRotationMatrix();
  return true;
}

struct RecordedKeyframe {
  KeyframeData data;
  Eigen::Isometry3d T_w_b_gt = Eigen::Isometry3d::Identity();
  bool has_gt = false;
};

/// What the replay fed to the manager.
struct ReplayResult {
  std::vector<RecordedKeyframe> keyframes;  ///< kept for the diagnosis only (empty without it)
  size_t num_keyframes = 0;
  size_t num_signatures = 0;
  size_t num_geomagnetic = 0;
};

/// Feeds the recording `inputs` to `manager`, writing its loop attempts to `loops` as they come,
/// then finishes the manager. With `diagnose`, keeps the keyframes with their poses in `gt`.
ReplayResult replayInputs(const std::string& inputs, bool diagnose, const std::vector<StampedPose>& gt,
                          PoseGraphManager* manager, LoopCsvWriter* loops) {
  ReplayResult result;
  InputReader reader(inputs);
  RecordedInput input;
  while (reader.next(&input)) {
    if (auto* kf = std::get_if<KeyframeData>(&input)) {
      manager->feedKeyframe(*kf);
      ++result.num_keyframes;
      if (diagnose) {
        RecordedKeyframe r;
        r.data = std::move(*kf);
        r.has_gt = gtPoseAt(gt, r.data.t, &r.T_w_b_gt);
        result.keyframes.push_back(std::move(r));
      }
    } else if (auto* w = std::get_if<SignatureWindow>(&input)) {
      manager->feedSignature(*w);
      ++result.num_signatures;
    } else if (auto* g = std::get_if<RecordedGeomagnetic>(&input)) {
      manager->feedGeomagnetic(g->t, g->field_body);
      ++result.num_geomagnetic;
    }
    for (const LoopAttempt& a : manager->takeNewLoopAttempts()) loops->write(a);
  }
  manager->finish();
  for (const LoopAttempt& a : manager->takeNewLoopAttempts()) loops->write(a);
  loops->flush();
  return result;
}

/// OUT/global.tum: the manager's keyframe poses.
void writeGlobalTrajectory(const PoseGraphManager& manager, const std::string& out_dir) {
  TumWriter global((fs::path(out_dir) / "global.tum").string());
  for (const KeyframePose& p : manager.keyframePoses())
    global.write(p.t, p.T_w_b.translation(), Eigen::Quaterniond(p.T_w_b.linear()));
  global.flush();
}

/// Prints the size of the map: the visual submaps held in memory (vector capacities) and the map
/// file.
void printMapSize(const PoseGraphManager& manager, const PoseGraphManagerOptions& options,
                  const PoseGraphManagerStats& stats) {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);  // before serialising (the bytes below are a second copy of the map)
  size_t submaps = 0, keypoints = 0, submap_bytes = 0, file_bytes = 0;
  manager.inspectMap([&](const MultiScaleMap& map) {
    for (PoseGraphNodeId id = 0; id < map.numNodes(); ++id) {
      const MapNode& n = map.node(id);
      if (!n.hasVisualSubmap()) continue;
      ++submaps;
      keypoints += n.num_keypoints;
      submap_bytes += visualSubmapMemoryBytes(map, id);
    }
    file_bytes = map.serialize(options.vocabularyPath()).size();
  });
  std::cout << std::fixed << std::setprecision(2) << "map: " << stats.keyframes << " keyframes, " << submaps
            << " visual submaps (" << keypoints << " keypoints, " << 1e-6 * submap_bytes << " MB in memory), "
            << stats.culled_submaps << " redundant submaps culled; map file " << 1e-6 * file_bytes << " MB; max RSS "
            << 1e-3 * usage.ru_maxrss << " MB\n";
}

/// The value at rank floor(q (n - 1) + 0.5) of the sorted `v`; NaN when empty. Kept rather than
/// vims::percentile (std::round of the rank) so that the printed figures stay as they were.
double roundedRankPercentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::min<double>(v.size() - 1, std::floor(q * (v.size() - 1) + 0.5)))];
}

/// One row of optimisations.csv (the stage times summed over the solve's stages).
void writeOptimisationRow(std::ostream& csv, const OptimisationRecord& o) {
  const PoseGraphReport& r = o.report;
  std::string stage_iterations;
  double build = 0.0, ceres_total = 0.0, preprocessor = 0.0, linear = 0.0, jacobian = 0.0;
  for (const PoseGraphStageReport& st : r.stages) {
    stage_iterations += (stage_iterations.empty() ? "" : "+") + std::to_string(st.iterations);
    build += st.build_time_s;
    ceres_total += st.solver_time_s;
    preprocessor += st.preprocessor_time_s;
    linear += st.linear_solver_time_s;
    jacobian += st.jacobian_time_s;
  }
  csv << toString(o.trigger) << "," << std::fixed << std::setprecision(3) << o.t_keyframe << "," << o.solve_ms << ","
      << o.solve_cpu_ms << "," << r.num_nodes << "," << r.num_free_nodes << "," << r.num_loop_edges << ","
      << r.num_yaw_factors << "," << r.iterations << "," << r.stages.size() << "," << stage_iterations << ","
      << 1e3 * build << "," << 1e3 * ceres_total << "," << 1e3 * preprocessor << "," << 1e3 * linear << ","
      << 1e3 * jacobian << "," << std::setprecision(6) << r.initial_cost << "," << r.final_cost << ","
      << std::setprecision(3) << o.max_new_loop_sigmas << "," << (o.local_loop_solve ? 1 : 0) << "\n";
}

/// Cost of the pose-graph optimisation: OUT/optimisations.csv (one row per solve) and a summary
/// line.
void writeOptimisations(const PoseGraphManager& manager, const std::string& out_dir) {
  const PoseGraphTimings timings = manager.timings();
  std::ofstream csv((fs::path(out_dir) / "optimisations.csv").string());
  csv << "trigger,t_keyframe,solve_ms,solve_cpu_ms,nodes,free_nodes,loops,yaw_factors,iterations,stages,stage_"
         "iterations,"
         "build_ms,ceres_ms,preprocessor_ms,linear_solver_ms,jacobian_ms,initial_cost,final_cost,max_new_loop_"
         "sigmas,"
         "local_loop_solve\n";
  std::vector<double> solve_ms, cpu_ms;
  double total_ms = 0.0, total_cpu_ms = 0.0;
  for (const OptimisationRecord& o : timings.solves) {
    writeOptimisationRow(csv, o);
    solve_ms.push_back(o.solve_ms);
    cpu_ms.push_back(o.solve_cpu_ms);
    total_ms += o.solve_ms;
    total_cpu_ms += o.solve_cpu_ms;
  }
  const auto pct = &roundedRankPercentile;
  std::cout << std::fixed << std::setprecision(1) << "pose-graph optimisation: " << solve_ms.size() << " solves, p50 "
            << pct(solve_ms, 0.5) << " ms, p99 " << pct(solve_ms, 0.99) << " ms, max " << pct(solve_ms, 1.0)
            << " ms, total " << std::setprecision(2) << 1e-3 * total_ms << " s (CPU: p50 " << std::setprecision(1)
            << pct(cpu_ms, 0.5) << " ms, p99 " << pct(cpu_ms, 0.99) << " ms, total " << std::setprecision(2)
            << 1e-3 * total_cpu_ms << " s); loop correction (" << timings.loop_correction_ms.size() << " loops): p50 "
            << std::setprecision(1) << pct(timings.loop_correction_ms, 0.5) << " ms, p99 "
            << pct(timings.loop_correction_ms, 0.99) << " ms, max " << pct(timings.loop_correction_ms, 1.0)
            << " ms (CPU: p50 " << pct(timings.loop_correction_cpu_ms, 0.5) << " ms, p99 "
            << pct(timings.loop_correction_cpu_ms, 0.99) << " ms, max " << pct(timings.loop_correction_cpu_ms, 1.0)
            << " ms)\n";
}

/// Depth in camera a of the midpoint triangulation of the normalised observations x_a (camera a)
/// and x_b (camera b), given T_ca_cb; nothing when the two rays are (nearly) parallel.
std::optional<double> midpointDepth(const Eigen::Isometry3d& T_ca_cb, const Eigen::Vector2d& x_a,
                                    const Eigen::Vector2d& x_b) {
  const Eigen::Vector3d ra = x_a.homogeneous().normalized();
  const Eigen::Vector3d rb = T_ca_cb.linear() * x_b.homogeneous().normalized();
  const Eigen::Vector3d cb = T_ca_cb.translation();
  const double c = ra.dot(rb);
  const double den = 1.0 - c * c;
  if (!(den > 1e-4)) return std::nullopt;  // also NaN
  const double l = (ra.dot(cb) - c * rb.dot(cb)) / den;
  return l * ra.z();
}

/// One row of landmark_accuracy.csv: the landmarks of keyframe a against keyframe b.
void writeLandmarkAccuracyRow(std::ostream& acc, const RecordedKeyframe& a, const RecordedKeyframe& b,
                              const CameraModel& camera_model, const Eigen::Isometry3d& T_b_c) {
  std::map<uint64_t, Eigen::Vector2d> pix_b, norm_b;
  for (const KeyframeLandmark& f : b.data.features) {
    pix_b[f.id] = f.pixel;
    norm_b[f.id] = f.normalized;
  }
  std::vector<double> ratio;  // VIO depth / depth triangulated with the ground-truth poses
  const Eigen::Isometry3d T_ca_odom = (a.data.T_odom_b * T_b_c).inverse();
  const Eigen::Isometry3d T_cb_ca = (b.T_w_b_gt * T_b_c).inverse() * (a.T_w_b_gt * T_b_c);
  const Eigen::Isometry3d T_ca_cb = T_cb_ca.inverse();
  std::vector<double> err, depth;
  for (const KeyframeLandmark& f : a.data.features) {
    const auto it = pix_b.find(f.id);
    if (it == pix_b.end()) continue;
    const Eigen::Vector3d p_ca = T_ca_odom * f.p_odom;
    depth.push_back(p_ca.z());
    // Midpoint triangulation of the two observations with the ground-truth relative pose.
    const std::optional<double> z = midpointDepth(T_ca_cb, f.normalized, norm_b[f.id]);
    if (z && *z > 0.1) ratio.push_back(p_ca.z() / *z);
    const std::optional<Eigen::Vector2d> uv = camera_model.project(T_cb_ca * p_ca);
    if (!uv) continue;
    err.push_back((*uv - it->second).norm());
  }
  std::vector<double> sorted = err;
  std::sort(sorted.begin(), sorted.end());
  acc << std::fixed << std::setprecision(3) << a.data.t << "," << a.data.features.size() << "," << err.size() << ","
      << percentile(err, 0.5) << "," << (sorted.empty() ? std::nan("") : sorted[sorted.size() * 9 / 10]) << ","
      << (b.T_w_b_gt.translation() - a.T_w_b_gt.translation()).norm() << "," << percentile(depth, 0.5) << ",";
  const double mr = percentile(ratio, 0.5);
  std::vector<double> dev;
  for (double r : ratio) dev.push_back(std::abs(r - mr));
  acc << mr << "," << percentile(dev, 0.5) << "\n";
}

/// OUT/landmark_accuracy.csv. Landmark accuracy: each landmark of keyframe k, placed in k's camera
/// by the VIO, projected with the ground-truth relative pose into a later keyframe that tracks the
/// same feature id.
void writeLandmarkAccuracy(const std::vector<RecordedKeyframe>& keyframes, const CameraModel& camera_model,
                           const Eigen::Isometry3d& T_b_c, const std::string& out_dir) {
  std::ofstream acc((fs::path(out_dir) / "landmark_accuracy.csv").string());
  acc << "t,landmarks,compared,median_px,p90_px,baseline_m,median_depth_m,median_depth_ratio,mad_depth_ratio\n";
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const RecordedKeyframe& a = keyframes[k];
    if (!a.has_gt) continue;
    // The keyframe ~3 keyframes later: a baseline that makes depth errors visible.
    const size_t j = k + 3;
    if (j >= keyframes.size() || !keyframes[j].has_gt || keyframes[j].data.session != a.data.session) continue;
    writeLandmarkAccuracyRow(acc, a, keyframes[j], camera_model, T_b_c);
  }
}

/// Point-to-line distance of pixel `uv` in image 2 from the epipolar line of the undistorted
/// normalised point x1 of image 1, given T_c2_c1; in normalised units.
double epipolarDistance(const Eigen::Isometry3d& T_c2_c1, const Eigen::Vector2d& x1, const Eigen::Vector2d& x2) {
  const Eigen::Vector3d t = T_c2_c1.translation();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  const Eigen::Vector3d line = tx * T_c2_c1.linear() * x1.homogeneous();
  const double n = line.head<2>().norm();
  if (n < 1e-12) return 0.0;
  return std::abs(line.dot(x2.homogeneous())) / n;
}

/// What the loop diagnosis uses besides the map and the keyframes.
struct LoopDiagnosisContext {
  const LoopDetectorOptions& loop;
  const CameraCalibration& camera;
  const CameraModel& camera_model;
  KeyframeDescriber* describer;  ///< not const: describing uses its detector objects
  const LoopVerifier& verifier;
  double revisit_radius;  ///< horizontal ground-truth distance of a revisit [m]
};

/// The keyframe horizontally nearest to keyframe q under ground truth, within `revisit_radius`
/// and old enough to be a loop candidate (exclusions as the detector); keyframes.size() when
/// there is none. *distance: its distance (revisit_radius when there is none).
size_t nearestOldKeyframe(const std::vector<RecordedKeyframe>& keyframes, size_t q, const LoopDetectorOptions& loop,
                          double revisit_radius, double* distance) {
  const RecordedKeyframe& kq = keyframes[q];
  size_t best = keyframes.size();
  double best_d = revisit_radius;
  for (size_t c = 0; c + static_cast<size_t>(loop.exclude_recent_keyframes) <= q; ++c) {
    const RecordedKeyframe& kc = keyframes[c];
    if (!kc.has_gt || kq.data.t - kc.data.t < loop.exclude_recent_s) continue;
    const double d = (kc.T_w_b_gt.translation() - kq.T_w_b_gt.translation()).head<2>().norm();
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  *distance = best_d;
  return best;
}

/// The loop query of keyframe q (map node `node`) as the manager builds it.
LoopQuery buildLoopQuery(const std::vector<RecordedKeyframe>& keyframes, size_t q, PoseGraphNodeId node,
                         const MultiScaleMap& map, const LoopDiagnosisContext& context) {
  const RecordedKeyframe& kq = keyframes[q];
  const LoopDetectorOptions& loop = context.loop;
  KeyframeDescriber& describer = *context.describer;
  LoopQuery query;
  query.node = node;
  query.t = kq.data.t;
  query.T_odom_b = kq.data.T_odom_b;
  const VisualSubmap qsub =
      describer.describeKeyframe(kq.data.image, kq.data.features, map.vocabulary().get(), &query.points);
  query.bow = qsub.bow;
  // The local map, as the manager builds it: the preceding keyframes of the same session.
  for (int back = 1; back <= loop.query_local_map_keyframes && static_cast<int>(q) - back >= 0; ++back) {
    const RecordedKeyframe& kp = keyframes[q - static_cast<size_t>(back)];
    if (kp.data.session != kq.data.session) break;
    mergeDescribedPoints(&query.points, describer.describePoints(kp.data.image, kp.data.features));
  }
  // The query's own seabed corners, as the manager gives them (the verifier decides when).
  if (loop.query_seabed_corners > 0) {
    const DescribedPoints own = describer.describePoints(kq.data.image, kq.data.features);
    query.seabed_points = describer.describeSeabedCorners(kq.data.image, own, kq.data.T_odom_b * context.camera.T_b_c,
                                                          loop.query_seabed_corners, loop.submap_corner_min_distance_px,
                                                          loop.submap_corner_max_level);
  }
  return query;
}

/// Of the query points the ground truth projects into the candidate image (visible): those with
/// a candidate submap keypoint within 3 px (repeatable; split by the keypoint's angle into ORB,
/// non-negative, and tracked, negative), and those with a Shi-Tomasi corner of the candidate
/// image within 3 px and 6 px (dense, dense6).
struct RepeatabilityCounts {
  int visible = 0, repeatable = 0;
  int orb = 0, tracked = 0, dense = 0, dense6 = 0;
};

/// Whether pixel `a` is within `r` pixels of pixel `b`.
bool withinRadius(const cv::Point2f& a, const Eigen::Vector2d& b, double r) {
  return std::hypot(a.x - b.x(), a.y - b.y()) <= r;
}

/// RepeatabilityCounts of the query's `points` in the candidate keyframe (image, visual submap).
RepeatabilityCounts countRepeatable(const DescribedPoints& points, const VisualSubmap& sub,
                                    const cv::Mat& candidate_image, const Eigen::Isometry3d& T_cc_cq,
                                    const Eigen::Isometry3d& T_cq_odom, const LoopDiagnosisContext& context) {
  const CameraCalibration& cam = context.camera;
  RepeatabilityCounts counts;
  std::vector<cv::Point2f> dense;
  cv::goodFeaturesToTrack(candidate_image, dense, 1000, 0.001, 4.0);
  for (size_t p = 0; p < points.numPoints(); ++p) {
    const std::optional<Eigen::Vector2d> projected =
        context.camera_model.project(T_cc_cq * (T_cq_odom * points.p_odom[p]));
    if (!projected) continue;
    const Eigen::Vector2d& uv = *projected;
    if (uv.x() < 0 || uv.y() < 0 || uv.x() >= cam.width || uv.y() >= cam.height) continue;
    ++counts.visible;
    bool any = false, orb = false, tracked = false;
    for (const cv::KeyPoint& kp : sub.keypoints)
      if (withinRadius(kp.pt, uv, 3.0)) {
        any = true;
        (kp.angle < 0 ? tracked : orb) = true;
      }
    counts.repeatable += any;
    counts.orb += orb;
    counts.tracked += tracked;
    bool d3 = false, d6 = false;
    for (const cv::Point2f& c : dense) {
      d3 = d3 || withinRadius(c, uv, 3.0);
      d6 = d6 || withinRadius(c, uv, 6.0);
    }
    counts.dense += d3;
    counts.dense6 += d6;
  }
  return counts;
}

/// The matches checked against ground truth: within 2 px of their epipolar line (epipolar_ok,
/// with their reprojection errors), and reprojected within max_reprojection_px (reprojection_ok).
struct MatchStatistics {
  int epipolar_ok = 0;
  int reprojection_ok = 0;
  std::vector<double> reprojection_px_epipolar_ok;
};

/// MatchStatistics of `matches` (query `points` to candidate submap `sub`); focal: pixels per
/// normalised unit.
MatchStatistics matchStatistics(const std::vector<PointMatch>& matches, const DescribedPoints& points,
                                const VisualSubmap& sub, const Eigen::Isometry3d& T_cc_cq,
                                const Eigen::Isometry3d& T_cq_odom, double focal, double max_reprojection_px) {
  MatchStatistics stats;
  for (const PointMatch& m : matches) {
    const Eigen::Vector3d p_cq = T_cq_odom * points.p_odom[m.point];
    const Eigen::Vector2d x1 = p_cq.head<2>() / p_cq.z();
    const double epi = epipolarDistance(T_cc_cq, x1, sub.normalized[m.keypoint]) * focal;
    const Eigen::Vector3d p_cc = T_cc_cq * p_cq;
    const double reproj = (p_cc.head<2>() / p_cc.z() - sub.normalized[m.keypoint]).norm() * focal;
    if (epi <= 2.0) {
      ++stats.epipolar_ok;
      stats.reprojection_px_epipolar_ok.push_back(reproj);
    }
    if (reproj <= max_reprojection_px) ++stats.reprojection_ok;
  }
  return stats;
}

/// Rank (-1: not ranked) and score of map node `candidate` in a BoW query over every keyframe of
/// the map.
struct BowRank {
  int rank = -1;
  double score = 0.0;
};

BowRank bowRankOf(const MultiScaleMap& map, const BowVector& bow, PoseGraphNodeId candidate) {
  BowRank result;
  if (map.bowDatabase() != nullptr && map.node(candidate).bow_image >= 0) {
    const auto scores = map.bowDatabase()->query(bow, map.numNodes());
    for (size_t r = 0; r < scores.size(); ++r)
      if (static_cast<int64_t>(scores[r].image) == map.node(candidate).bow_image) {
        result.rank = static_cast<int>(r);
        result.score = scores[r].score;
        break;
      }
  }
  return result;
}

/// The row of loop_diagnosis.csv of query keyframe q: its verification against the keyframe
/// nearest under ground truth. No row when q has no ground truth or no such neighbour, or either
/// is not a map node, or the neighbour has no visual submap.
void writeQueryDiagnosis(std::ostream& diag, const std::vector<RecordedKeyframe>& keyframes, size_t q,
                         const MultiScaleMap& map, const std::map<double, PoseGraphNodeId>& node_of_t,
                         const LoopDiagnosisContext& context) {
  const RecordedKeyframe& kq = keyframes[q];
  if (!kq.has_gt) return;
  const auto qn = node_of_t.find(kq.data.t);
  if (qn == node_of_t.end()) return;
  double best_d = 0.0;
  const size_t best = nearestOldKeyframe(keyframes, q, context.loop, context.revisit_radius, &best_d);
  if (best == keyframes.size()) return;
  const RecordedKeyframe& kc = keyframes[best];
  const auto cn = node_of_t.find(kc.data.t);
  if (cn == node_of_t.end() || !map.node(cn->second).hasVisualSubmap()) return;
  const std::shared_ptr<const VisualSubmap> candidate_submap = map.visualSubmap(cn->second);
  const VisualSubmap& sub = *candidate_submap;
  const LoopQuery query = buildLoopQuery(keyframes, q, qn->second, map, context);

  // Ground truth: query camera -> candidate camera; the query's points in its camera (VIO).
  const Eigen::Isometry3d& T_b_c = context.camera.T_b_c;
  const Eigen::Isometry3d T_cc_cq = (kc.T_w_b_gt * T_b_c).inverse() * (kq.T_w_b_gt * T_b_c);
  const Eigen::Isometry3d T_cq_odom = (kq.data.T_odom_b * T_b_c).inverse();
  const RepeatabilityCounts rep = countRepeatable(query.points, sub, kc.data.image, T_cc_cq, T_cq_odom, context);
  const LoopDetectorOptions& loop = context.loop;
  const std::vector<PointMatch> matches =
      matchPointsToKeypoints(query.points, sub, loop.match_ratio, loop.match_max_distance,
                             loop.match_duplicate_radius_px, context.verifier.levelWindow(query, map, cn->second));
  const double focal = 0.5 * (context.camera.fx + context.camera.fy);
  const MatchStatistics ms =
      matchStatistics(matches, query.points, sub, T_cc_cq, T_cq_odom, focal, loop.pnp_reprojection_px);
  const VerificationResult v = context.verifier.verify(query, map, cn->second);
  // Rank of the ground-truth candidate in a BoW query over every keyframe of the map.
  const BowRank bow = bowRankOf(map, query.bow, cn->second);
  const double dyaw = std::remainder(yawPitchRollFromRotation(kq.T_w_b_gt.linear()).yaw -
                                         yawPitchRollFromRotation(kc.T_w_b_gt.linear()).yaw,
                                     2.0 * M_PI) *
                      180.0 / M_PI;
  diag << std::fixed << std::setprecision(3) << kq.data.t << "," << kc.data.t << "," << best_d << "," << dyaw << ","
       << kq.T_w_b_gt.translation().z() << "," << kq.data.features.size() << "," << query.points.numPoints() << ","
       << query.points.descriptors.size() << "," << sub.keypoints.size() << "," << rep.visible << "," << rep.repeatable
       << "," << matches.size() << "," << ms.epipolar_ok << "," << ms.reprojection_ok << ","
       << percentile(ms.reprojection_px_epipolar_ok, 0.5) << "," << toString(v.stage) << ","
       << (v.stage == LoopStage::kMatching ? v.num_matches : v.num_inliers) << "," << bow.rank << "," << bow.score
       << "," << rep.orb << "," << rep.tracked << "," << rep.dense << "," << rep.dense6 << "\n";
}

/// OUT/loop_diagnosis.csv: per query keyframe with an old ground-truth neighbour, verification
/// against the nearest one.
void writeLoopDiagnosis(const std::vector<RecordedKeyframe>& keyframes, const PoseGraphManager& manager,
                        const LoopDiagnosisContext& context, const std::string& out_dir) {
  std::ofstream diag((fs::path(out_dir) / "loop_diagnosis.csv").string());
  diag << "t_query,t_cand,gt_dist_m,gt_dyaw_deg,altitude_q_m,landmarks,points,descriptors,cand_keypoints,"
          "visible_gt,repeatable_gt,matches,matches_epipolar_ok,matches_reproj_ok,median_reproj_px_epi_ok,"
          "stage,inliers,bow_rank,bow_score,rep_orb,rep_tracked,rep_dense,rep_dense6\n";
  manager.inspectMap([&](const MultiScaleMap& map) {
    std::map<double, PoseGraphNodeId> node_of_t;
    for (PoseGraphNodeId n = 0; n < map.numNodes(); ++n) node_of_t[map.node(n).pose.t] = n;
    for (size_t q = 0; q < keyframes.size(); ++q) writeQueryDiagnosis(diag, keyframes, q, map, node_of_t, context);
  });
}

/// --diagnose: OUT/landmark_accuracy.csv and OUT/loop_diagnosis.csv.
void writeDiagnosis(const std::vector<RecordedKeyframe>& keyframes, const PoseGraphManager& manager,
                    const PoseGraphManagerOptions& options, const CameraCalibration& cam, double revisit_radius,
                    const std::string& out_dir) {
  const CameraModel camera_model(cam);
  KeyframeDescriber describer(options.featureOptions(), options.loop.harris_threshold, cam,
                              options.loop.submap_include_tracked_corners);
  describer.setDenseCorners(options.loop.submap_dense_corners, options.loop.submap_corner_min_distance_px,
                            options.loop.submap_corner_max_level);
  describer.setDenseCornersPerLevel(options.loop.submap_dense_corners_per_level);
  const LoopVerifier verifier(options.loop, cam, options.featureOptions());

  writeLandmarkAccuracy(keyframes, camera_model, cam.T_b_c, out_dir);
  const LoopDiagnosisContext context{options.loop, cam, camera_model, &describer, verifier, revisit_radius};
  writeLoopDiagnosis(keyframes, manager, context, out_dir);
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<ReplayArguments> parsed = parseArguments(argc, argv);
  if (!parsed) return 2;
  const ReplayArguments& args = *parsed;
  try {
    const SequencePaths paths = SequencePaths::resolve(args.sequence_dir);
    const SequenceConfig sequence = SequenceConfig::load(paths.yaml);
    const std::string options_file = args.options_file.empty()
                                         ? (fs::path(args.package_root) / "config" / "pose_graph.yaml").string()
                                         : args.options_file;
    SystemConfig config = SystemConfig::load({options_file}, sequence);
    if (!args.mode.empty()) config.applyMode(args.mode);
    PoseGraphManagerOptions& options = config.pose_graph;
    options.synchronous = true;
    options.record_inputs_path.clear();
    fs::create_directories(args.out_dir);
    LoggerPtr logger = args.quiet ? Logger::nullLogger() : Logger::stderrLogger(LogLevel::kInfo);
    PoseGraphManager manager(options, sequence, PoseGraphManager::loadVocabulary(options, args.package_root), logger);
    LoopCsvWriter loops((fs::path(args.out_dir) / "loops.csv").string());

    std::vector<StampedPose> gt;
    if (args.diagnose) {
      if (paths.gt.empty()) throw std::runtime_error("--diagnose needs the sequence's ground truth");
      gt = readTumFile(paths.gt);
    }
    const ReplayResult replay = replayInputs(args.inputs, args.diagnose, gt, &manager, &loops);
    writeGlobalTrajectory(manager, args.out_dir);
    const PoseGraphManagerStats stats = manager.stats();
    std::cout << "replayed " << replay.num_keyframes << " keyframes, " << replay.num_signatures << " signatures, "
              << replay.num_geomagnetic << " geomagnetic samples; mode " << toString(options.mode) << ": "
              << stats.loop_queries << " queries, " << stats.loop_attempts << " attempts, " << stats.loops_accepted
              << " loops accepted\n";
    printMapSize(manager, options, stats);
    writeOptimisations(manager, args.out_dir);
    if (!args.diagnose) return 0;

    writeDiagnosis(replay.keyframes, manager, options, sequence.camera, args.revisit_radius, args.out_dir);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "vims_pose_graph_replay: " << e.what() << "\n";
    return 1;
  }
}
