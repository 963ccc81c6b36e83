/// vims_pose_graph_replay: re-runs the pose graph and hierarchical loop closing on the inputs a
/// run recorded (PoseGraphManagerOptions::record_inputs_path), without the front end and the
/// VIO, and optionally diagnoses loop verification against ground truth: for every keyframe with
/// a ground-truth revisit, what each stage produced against the ground-truth nearest keyframe.
/// docs/pose_graph.md, "Replaying recorded inputs".

#include <sys/resource.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <opencv2/imgproc.hpp>
#include <string>
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

}  // namespace

int main(int argc, char** argv) {
  std::string sequence_dir, inputs, out_dir, options_file, mode, package_root = ".";
  bool diagnose = false, quiet = false;
  double revisit_radius = 1.5;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](std::string* v) {
      if (i + 1 >= argc) return false;
      *v = argv[++i];
      return true;
    };
    std::string v;
    if (arg == "--sequence" && value(&sequence_dir)) continue;
    if (arg == "--inputs" && value(&inputs)) continue;
    if (arg == "--out" && value(&out_dir)) continue;
    if (arg == "--options" && value(&options_file)) continue;
    if (arg == "--mode" && value(&mode)) continue;
    if (arg == "--package-root" && value(&package_root)) continue;
    if (arg == "--revisit-radius" && value(&v)) {
      revisit_radius = std::stod(v);
      continue;
    }
    if (arg == "--diagnose") {
      diagnose = true;
      continue;
    }
    if (arg == "--quiet") {
      quiet = true;
      continue;
    }
    std::cerr << "bad argument '" << arg << "'\n" << kUsage;
    return 2;
  }
  if (sequence_dir.empty() || inputs.empty() || out_dir.empty()) {
    std::cerr << kUsage;
    return 2;
  }
  try {
    const SequencePaths paths = SequencePaths::resolve(sequence_dir);
    const SequenceConfig sequence = SequenceConfig::load(paths.yaml);
    if (options_file.empty()) options_file = (fs::path(package_root) / "config" / "pose_graph.yaml").string();
    SystemConfig config = SystemConfig::load({options_file}, sequence);
    if (!mode.empty()) config.applyMode(mode);
    PoseGraphManagerOptions& options = config.pose_graph;
    options.synchronous = true;
    options.record_inputs_path.clear();
    fs::create_directories(out_dir);
    LoggerPtr logger = quiet ? Logger::nullLogger() : Logger::stderrLogger(LogLevel::kInfo);
    PoseGraphManager manager(options, sequence, PoseGraphManager::loadVocabulary(options, package_root), logger);
    LoopCsvWriter loops((fs::path(out_dir) / "loops.csv").string());

    std::vector<StampedPose> gt;
    if (diagnose) {
      if (paths.gt.empty()) throw std::runtime_error("--diagnose needs the sequence's ground truth");
      gt = readTumFile(paths.gt);
    }
    std::vector<RecordedKeyframe> keyframes;
    InputReader reader(inputs);
    RecordedInput input;
    size_t n_kf = 0, n_sig = 0, n_geo = 0;
    while (reader.next(&input)) {
      if (auto* kf = std::get_if<KeyframeData>(&input)) {
        manager.feedKeyframe(*kf);
        ++n_kf;
        if (diagnose) {
          RecordedKeyframe r;
          r.data = std::move(*kf);
          r.has_gt = gtPoseAt(gt, r.data.t, &r.T_w_b_gt);
          keyframes.push_back(std::move(r));
        }
      } else if (auto* w = std::get_if<SignatureWindow>(&input)) {
        manager.feedSignature(*w);
        ++n_sig;
      } else if (auto* g = std::get_if<RecordedGeomagnetic>(&input)) {
        manager.feedGeomagnetic(g->t, g->field_body);
        ++n_geo;
      }
      for (const LoopAttempt& a : manager.takeNewLoopAttempts()) loops.write(a);
    }
    manager.finish();
    for (const LoopAttempt& a : manager.takeNewLoopAttempts()) loops.write(a);
    loops.flush();
    {
      TumWriter global((fs::path(out_dir) / "global.tum").string());
      for (const KeyframePose& p : manager.keyframePoses())
        global.write(p.t, p.T_w_b.translation(), Eigen::Quaterniond(p.T_w_b.linear()));
      global.flush();
    }
    const PoseGraphManagerStats s = manager.stats();
    std::cout << "replayed " << n_kf << " keyframes, " << n_sig << " signatures, " << n_geo
              << " geomagnetic samples; mode " << toString(options.mode) << ": " << s.loop_queries << " queries, "
              << s.loop_attempts << " attempts, " << s.loops_accepted << " loops accepted\n";
    {
      // Size of the map: the visual submaps held in memory (vector capacities) and the map file.
      rusage usage{};
      getrusage(RUSAGE_SELF, &usage);  // before serialising (the bytes below are a second copy of the map)
      size_t submaps = 0, keypoints = 0, submap_bytes = 0, file_bytes = 0;
      manager.inspectMap([&](const MultiScaleMap& map) {
        for (const MapNode& n : map.nodes()) {
          if (n.visual.empty()) continue;
          ++submaps;
          keypoints += n.visual.keypoints.size();
          submap_bytes += visualSubmapMemoryBytes(n.visual);
        }
        file_bytes = map.serialize(options.vocabularyPath()).size();
      });
      std::cout << std::fixed << std::setprecision(2) << "map: " << s.keyframes << " keyframes, " << submaps
                << " visual submaps (" << keypoints << " keypoints, " << 1e-6 * submap_bytes << " MB in memory), "
                << s.culled_submaps << " redundant submaps culled; map file " << 1e-6 * file_bytes << " MB; max RSS "
                << 1e-3 * usage.ru_maxrss << " MB\n";
    }
    {
      // Cost of the pose-graph optimisation: one row per solve, and a summary line.
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
        csv << toString(o.trigger) << "," << std::fixed << std::setprecision(3) << o.t_keyframe << "," << o.solve_ms
            << "," << o.solve_cpu_ms << "," << r.num_nodes << "," << r.num_free_nodes << "," << r.num_loop_edges << ","
            << r.num_yaw_factors << "," << r.iterations << "," << r.stages.size() << "," << stage_iterations << ","
            << 1e3 * build << "," << 1e3 * ceres_total << "," << 1e3 * preprocessor << "," << 1e3 * linear << ","
            << 1e3 * jacobian << "," << std::setprecision(6) << r.initial_cost << "," << r.final_cost << ","
            << std::setprecision(3) << o.max_new_loop_sigmas << "," << (o.local_loop_solve ? 1 : 0) << "\n";
        solve_ms.push_back(o.solve_ms);
        cpu_ms.push_back(o.solve_cpu_ms);
        total_ms += o.solve_ms;
        total_cpu_ms += o.solve_cpu_ms;
      }
      auto pct = [](std::vector<double> v, double q) {
        if (v.empty()) return std::nan("");
        std::sort(v.begin(), v.end());
        return v[static_cast<size_t>(std::min<double>(v.size() - 1, std::floor(q * (v.size() - 1) + 0.5)))];
      };
      std::cout << std::fixed << std::setprecision(1) << "pose-graph optimisation: " << solve_ms.size()
                << " solves, p50 " << pct(solve_ms, 0.5) << " ms, p99 " << pct(solve_ms, 0.99) << " ms, max "
                << pct(solve_ms, 1.0) << " ms, total " << std::setprecision(2) << 1e-3 * total_ms << " s (CPU: p50 "
                << std::setprecision(1) << pct(cpu_ms, 0.5) << " ms, p99 " << pct(cpu_ms, 0.99) << " ms, total "
                << std::setprecision(2) << 1e-3 * total_cpu_ms << " s); loop correction ("
                << timings.loop_correction_ms.size() << " loops): p50 " << std::setprecision(1)
                << pct(timings.loop_correction_ms, 0.5) << " ms, p99 " << pct(timings.loop_correction_ms, 0.99)
                << " ms, max " << pct(timings.loop_correction_ms, 1.0) << " ms (CPU: p50 "
                << pct(timings.loop_correction_cpu_ms, 0.5) << " ms, p99 " << pct(timings.loop_correction_cpu_ms, 0.99)
                << " ms, max " << pct(timings.loop_correction_cpu_ms, 1.0) << " ms)\n";
    }
    if (!diagnose) return 0;

    // ---- diagnosis
    const CameraCalibration& cam = sequence.camera;
    const CameraModel camera_model(cam);
    const Eigen::Isometry3d T_b_c = cam.T_b_c;
    const double focal = 0.5 * (cam.fx + cam.fy);
    KeyframeDescriber describer(options.featureOptions(), options.loop.harris_threshold, cam,
                                options.loop.submap_include_tracked_corners);
    describer.setDenseCorners(options.loop.submap_dense_corners, options.loop.submap_corner_min_distance_px,
                              options.loop.submap_corner_max_level);
    describer.setDenseCornersPerLevel(options.loop.submap_dense_corners_per_level);
    LoopVerifier verifier(options.loop, cam, options.featureOptions());

    // Landmark accuracy: each landmark of keyframe k, placed in k's camera by the VIO, projected
    // with the ground-truth relative pose into a later keyframe that tracks the same feature id.
    {
      std::ofstream acc((fs::path(out_dir) / "landmark_accuracy.csv").string());
      acc << "t,landmarks,compared,median_px,p90_px,baseline_m,median_depth_m,median_depth_ratio,mad_depth_ratio\n";
      for (size_t k = 0; k < keyframes.size(); ++k) {
        const RecordedKeyframe& a = keyframes[k];
        if (!a.has_gt) continue;
        // The keyframe ~3 keyframes later: a baseline that makes depth errors visible.
        const size_t j = k + 3;
        if (j >= keyframes.size() || !keyframes[j].has_gt || keyframes[j].data.session != a.data.session) continue;
        const RecordedKeyframe& b = keyframes[j];
        std::map<uint64_t, Eigen::Vector2d> pix_b, norm_b;
        for (const KeyframeLandmark& f : b.data.features) {
          pix_b[f.id] = f.pixel;
          norm_b[f.id] = f.normalized;
        }
        std::vector<double> ratio;  // VIO depth / depth triangulated with the ground-truth poses
        const Eigen::Isometry3d T_ca_odom = (a.data.T_odom_b * T_b_c).inverse();
        const Eigen::Isometry3d T_cb_ca = (b.T_w_b_gt * T_b_c).inverse() * (a.T_w_b_gt * T_b_c);
        std::vector<double> err, depth;
        for (const KeyframeLandmark& f : a.data.features) {
          const auto it = pix_b.find(f.id);
          if (it == pix_b.end()) continue;
          const Eigen::Vector3d p_ca = T_ca_odom * f.p_odom;
          depth.push_back(p_ca.z());
          {
            // Midpoint triangulation of the two observations with the ground-truth relative pose.
            const Eigen::Isometry3d T_ca_cb = T_cb_ca.inverse();
            const Eigen::Vector3d ra = f.normalized.homogeneous().normalized();
            const Eigen::Vector3d rb = T_ca_cb.linear() * norm_b[f.id].homogeneous().normalized();
            const Eigen::Vector3d cb = T_ca_cb.translation();
            const double c = ra.dot(rb);
            const double den = 1.0 - c * c;
            if (den > 1e-4) {
              const double l = (ra.dot(cb) - c * rb.dot(cb)) / den;
              const double z = l * ra.z();
              if (z > 0.1) ratio.push_back(p_ca.z() / z);
            }
          }
          const std::optional<Eigen::Vector2d> uv = camera_model.project(T_cb_ca * p_ca);
          if (!uv) continue;
          err.push_back((*uv - it->second).norm());
        }
        std::vector<double> sorted = err;
        std::sort(sorted.begin(), sorted.end());
        acc << std::fixed << std::setprecision(3) << a.data.t << "," << a.data.features.size() << "," << err.size()
            << "," << percentile(err, 0.5) << "," << (sorted.empty() ? std::nan("") : sorted[sorted.size() * 9 / 10])
            << "," << (b.T_w_b_gt.translation() - a.T_w_b_gt.translation()).norm() << "," << percentile(depth, 0.5)
            << ",";
        const double mr = percentile(ratio, 0.5);
        std::vector<double> dev;
        for (double r : ratio) dev.push_back(std::abs(r - mr));
        acc << mr << "," << percentile(dev, 0.5) << "\n";
      }
    }

    // Per query keyframe with an old ground-truth neighbour: verification against the nearest one.
    std::ofstream diag((fs::path(out_dir) / "loop_diagnosis.csv").string());
    diag << "t_query,t_cand,gt_dist_m,gt_dyaw_deg,altitude_q_m,landmarks,points,descriptors,cand_keypoints,"
            "visible_gt,repeatable_gt,matches,matches_epipolar_ok,matches_reproj_ok,median_reproj_px_epi_ok,"
            "stage,inliers,bow_rank,bow_score,rep_orb,rep_tracked,rep_dense,rep_dense6\n";
    manager.inspectMap([&](const MultiScaleMap& map) {
      std::map<double, PoseGraphNodeId> node_of_t;
      for (PoseGraphNodeId n = 0; n < map.numNodes(); ++n) node_of_t[map.node(n).pose.t] = n;
      for (size_t q = 0; q < keyframes.size(); ++q) {
        const RecordedKeyframe& kq = keyframes[q];
        if (!kq.has_gt) continue;
        const auto qn = node_of_t.find(kq.data.t);
        if (qn == node_of_t.end()) continue;
        // Ground-truth nearest keyframe old enough to be a loop candidate (exclusions as the detector).
        size_t best = keyframes.size();
        double best_d = revisit_radius;
        for (size_t c = 0; c + static_cast<size_t>(options.loop.exclude_recent_keyframes) <= q; ++c) {
          const RecordedKeyframe& kc = keyframes[c];
          if (!kc.has_gt || kq.data.t - kc.data.t < options.loop.exclude_recent_s) continue;
          const double d = (kc.T_w_b_gt.translation() - kq.T_w_b_gt.translation()).head<2>().norm();
          if (d < best_d) {
            best_d = d;
            best = c;
          }
        }
        if (best == keyframes.size()) continue;
        const RecordedKeyframe& kc = keyframes[best];
        const auto cn = node_of_t.find(kc.data.t);
        if (cn == node_of_t.end() || map.node(cn->second).visual.empty()) continue;
        const VisualSubmap& sub = map.node(cn->second).visual;

        LoopQuery query;
        query.node = qn->second;
        query.t = kq.data.t;
        query.T_odom_b = kq.data.T_odom_b;
        VisualSubmap qsub =
            describer.describeKeyframe(kq.data.image, kq.data.features, map.vocabulary().get(), &query.points);
        query.bow = qsub.bow;
        // The local map, as the manager builds it: the preceding keyframes of the same session.
        for (int back = 1; back <= options.loop.query_local_map_keyframes && static_cast<int>(q) - back >= 0; ++back) {
          const RecordedKeyframe& kp = keyframes[q - static_cast<size_t>(back)];
          if (kp.data.session != kq.data.session) break;
          mergeDescribedPoints(&query.points, describer.describePoints(kp.data.image, kp.data.features));
        }
        // The query's own seabed corners, as the manager gives them (the verifier decides when).
        if (options.loop.query_seabed_corners > 0) {
          DescribedPoints own = describer.describePoints(kq.data.image, kq.data.features);
          query.seabed_points = describer.describeSeabedCorners(
              kq.data.image, own, kq.data.T_odom_b * T_b_c, options.loop.query_seabed_corners,
              options.loop.submap_corner_min_distance_px, options.loop.submap_corner_max_level);
        }

        // Ground truth: query camera -> candidate camera; the query's points in its camera (VIO).
        const Eigen::Isometry3d T_cc_cq = (kc.T_w_b_gt * T_b_c).inverse() * (kq.T_w_b_gt * T_b_c);
        const Eigen::Isometry3d T_cq_odom = (kq.data.T_odom_b * T_b_c).inverse();
        int visible = 0, repeatable = 0;
        int rep_orb = 0, rep_tracked = 0, rep_dense = 0, rep_dense6 = 0;
        std::vector<cv::Point2f> dense;
        cv::goodFeaturesToTrack(kc.data.image, dense, 1000, 0.001, 4.0);
        auto within = [](const cv::Point2f& a, const Eigen::Vector2d& b, double r) {
          return std::hypot(a.x - b.x(), a.y - b.y()) <= r;
        };
        for (size_t p = 0; p < query.points.numPoints(); ++p) {
          const std::optional<Eigen::Vector2d> projected =
              camera_model.project(T_cc_cq * (T_cq_odom * query.points.p_odom[p]));
          if (!projected) continue;
          const Eigen::Vector2d& uv = *projected;
          if (uv.x() < 0 || uv.y() < 0 || uv.x() >= cam.width || uv.y() >= cam.height) continue;
          ++visible;
          bool any = false, orb = false, tracked = false;
          for (const cv::KeyPoint& kp : sub.keypoints)
            if (within(kp.pt, uv, 3.0)) {
              any = true;
              (kp.angle < 0 ? tracked : orb) = true;
            }
          repeatable += any;
          rep_orb += orb;
          rep_tracked += tracked;
          bool d3 = false, d6 = false;
          for (const cv::Point2f& c : dense) {
            d3 = d3 || within(c, uv, 3.0);
            d6 = d6 || within(c, uv, 6.0);
          }
          rep_dense += d3;
          rep_dense6 += d6;
        }
        const std::vector<PointMatch> matches = matchPointsToKeypoints(
            query.points, sub, options.loop.match_ratio, options.loop.match_max_distance,
            options.loop.match_duplicate_radius_px, verifier.levelWindow(query, map, cn->second));
        int epi_ok = 0, reproj_ok = 0;
        std::vector<double> reproj_epi_ok;
        for (const PointMatch& m : matches) {
          const Eigen::Vector3d p_cq = T_cq_odom * query.points.p_odom[m.point];
          const Eigen::Vector2d x1 = p_cq.head<2>() / p_cq.z();
          const double epi = epipolarDistance(T_cc_cq, x1, sub.normalized[m.keypoint]) * focal;
          const Eigen::Vector3d p_cc = T_cc_cq * p_cq;
          const double reproj = (p_cc.head<2>() / p_cc.z() - sub.normalized[m.keypoint]).norm() * focal;
          if (epi <= 2.0) {
            ++epi_ok;
            reproj_epi_ok.push_back(reproj);
          }
          if (reproj <= options.loop.pnp_reprojection_px) ++reproj_ok;
        }
        const VerificationResult v = verifier.verify(query, map, cn->second);
        // Rank of the ground-truth candidate in a BoW query over every keyframe of the map.
        int rank = -1;
        double score = 0.0;
        if (map.bowDatabase() != nullptr && map.node(cn->second).bow_image >= 0) {
          const auto scores = map.bowDatabase()->query(query.bow, map.numNodes());
          for (size_t r = 0; r < scores.size(); ++r)
            if (static_cast<int64_t>(scores[r].image) == map.node(cn->second).bow_image) {
              rank = static_cast<int>(r);
              score = scores[r].score;
              break;
            }
        }
        const double dyaw = std::remainder(yawPitchRollFromRotation(kq.T_w_b_gt.linear()).yaw -
                                               yawPitchRollFromRotation(kc.T_w_b_gt.linear()).yaw,
                                           2.0 * M_PI) *
                            180.0 / M_PI;
        diag << std::fixed << std::setprecision(3) << kq.data.t << "," << kc.data.t << "," << best_d << "," << dyaw
             << "," << kq.T_w_b_gt.translation().z() << "," << kq.data.features.size() << ","
             << query.points.numPoints() << "," << query.points.descriptors.size() << "," << sub.keypoints.size() << ","
             << visible << "," << repeatable << "," << matches.size() << "," << epi_ok << "," << reproj_ok << ","
             << percentile(reproj_epi_ok, 0.5) << "," << toString(v.stage) << ","
             << (v.stage == LoopStage::kMatching ? v.num_matches : v.num_inliers) << "," << rank << "," << score << ","
             << rep_orb << "," << rep_tracked << "," << rep_dense << "," << rep_dense6 << "\n";
      }
    });
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "vims_pose_graph_replay: " << e.what() << "\n";
    return 1;
  }
}
