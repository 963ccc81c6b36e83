#include "vims_eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vims {
namespace eval {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

void checkEqualLength(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est) {
  if (gt.size() != est.size()) throw std::invalid_argument("metrics: trajectories differ in length");
}

}  // namespace

ErrorStats ErrorStats::compute(const std::vector<double>& errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) return s;
  double sum = 0.0, sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  const double n = static_cast<double>(errors.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  s.min = sorted.front();
  s.max = sorted.back();
  const std::size_t mid = sorted.size() / 2;
  // numpy.median: the mean of the two middle values for an even count.
  s.median = (sorted.size() % 2 == 1) ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return s;
}

double pathLength(const std::vector<StampedPose>& poses) {
  double length = 0.0;
  for (std::size_t i = 1; i < poses.size(); ++i) length += (poses[i].p - poses[i - 1].p).norm();
  return length;
}

double rotationAngleDeg(const Eigen::Quaterniond& q) {
  // 2 atan2(|v|, |w|) is accurate near 0 and 180 deg, unlike acos of the trace.
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w())) * kRadToDeg;
}

std::vector<double> translationErrors(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est) {
  checkEqualLength(gt, est);
  std::vector<double> errors;
  errors.reserve(gt.size());
  for (std::size_t i = 0; i < gt.size(); ++i) errors.push_back((gt[i].p - est[i].p).norm());
  return errors;
}

std::vector<double> rotationErrorsDeg(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est) {
  checkEqualLength(gt, est);
  std::vector<double> errors;
  errors.reserve(gt.size());
  for (std::size_t i = 0; i < gt.size(); ++i) errors.push_back(rotationAngleDeg(gt[i].q.conjugate() * est[i].q));
  return errors;
}

std::vector<std::pair<std::size_t, std::size_t>> pairsByPathLength(const std::vector<StampedPose>& reference,
                                                                   double delta_m) {
  if (!(delta_m > 0.0)) throw std::invalid_argument("RPE: delta must be positive");
  // evo (filters.filter_pairs_by_path, all_pairs=False): the first kept index is the first
  // one delta metres along the path, not index 0; we keep that so numbers compare 1:1.
  std::vector<std::size_t> kept;
  double path_since_kept = 0.0;
  for (std::size_t i = 1; i < reference.size(); ++i) {
    path_since_kept += (reference[i].p - reference[i - 1].p).norm();
    if (path_since_kept >= delta_m) {
      kept.push_back(i);
      path_since_kept = 0.0;
    }
  }
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t k = 1; k < kept.size(); ++k) pairs.emplace_back(kept[k - 1], kept[k]);
  return pairs;
}

RpeResult computeRpe(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est, double delta_m) {
  checkEqualLength(gt, est);
  RpeResult r;
  r.delta_m = delta_m;
  r.pairs = pairsByPathLength(gt, delta_m);
  for (const auto& [i, j] : r.pairs) {
    // Relative motions T_bi_bj of ground truth and estimate, and their difference.
    const Eigen::Quaterniond q_i_j_gt = gt[i].q.conjugate() * gt[j].q;
    const Eigen::Vector3d p_i_j_gt = gt[i].q.conjugate() * (gt[j].p - gt[i].p);
    const Eigen::Quaterniond q_i_j_est = est[i].q.conjugate() * est[j].q;
    const Eigen::Vector3d p_i_j_est = est[i].q.conjugate() * (est[j].p - est[i].p);
    // E = T_gt^-1 T_est: translation R_gt^T (p_est - p_gt), rotation R_gt^T R_est.
    r.trans_errors_m.push_back((q_i_j_gt.conjugate() * (p_i_j_est - p_i_j_gt)).norm());
    r.rot_errors_deg.push_back(rotationAngleDeg(q_i_j_gt.conjugate() * q_i_j_est));
  }
  r.trans = ErrorStats::compute(r.trans_errors_m);
  r.rot = ErrorStats::compute(r.rot_errors_deg);
  return r;
}

std::vector<double> tiltErrorsDeg(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est) {
  checkEqualLength(gt, est);
  std::vector<double> errors;
  errors.reserve(gt.size());
  for (std::size_t i = 0; i < gt.size(); ++i) {
    const Eigen::Vector3d up_gt = gt[i].q.conjugate() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d up_est = est[i].q.conjugate() * Eigen::Vector3d::UnitZ();
    errors.push_back(std::atan2(up_gt.cross(up_est).norm(), up_gt.dot(up_est)) * 180.0 / M_PI);
  }
  return errors;
}

std::vector<double> heightErrors(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est) {
  checkEqualLength(gt, est);
  std::vector<double> errors;
  errors.reserve(gt.size());
  for (std::size_t i = 0; i < gt.size(); ++i) errors.push_back(std::abs(est[i].p.z() - gt[i].p.z()));
  return errors;
}

AlignedErrors evaluateAligned(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                              AlignmentMode mode, double rpe_delta_m) {
  checkEqualLength(gt, est);
  AlignedErrors out;
  out.mode = mode;
  out.S_w_v = computeAlignment(gt, est, mode);
  out.est_aligned = out.S_w_v.transformPoses(est);
  out.trans_errors_m = translationErrors(gt, out.est_aligned);
  out.rot_errors_deg = rotationErrorsDeg(gt, out.est_aligned);
  out.ate = ErrorStats::compute(out.trans_errors_m);
  out.rot = ErrorStats::compute(out.rot_errors_deg);
  out.tilt = ErrorStats::compute(tiltErrorsDeg(gt, out.est_aligned));
  out.height = ErrorStats::compute(heightErrors(gt, out.est_aligned));
  const double distance = pathLength(gt);
  out.ate_rmse_pct = distance > 0.0 ? 100.0 * out.ate.rmse / distance : 0.0;
  out.rpe = computeRpe(gt, out.est_aligned, rpe_delta_m);
  return out;
}

const AlignedErrors* TrajectoryEvaluation::find(AlignmentMode mode) const {
  for (const auto& r : results)
    if (r.mode == mode) return &r;
  return nullptr;
}

TrajectoryEvaluation evaluateTrajectory(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                                        const TrajectoryEvalOptions& options, const std::string& label) {
  if (options.alignments.empty()) throw std::invalid_argument("evaluateTrajectory: no alignment requested");
  TrajectoryEvaluation ev;
  ev.label = label;
  ev.associated = associate(gt, est, options.association);
  ev.gt_distance_m = pathLength(ev.associated.gt);
  ev.duration_s = ev.associated.est.back().t - ev.associated.est.front().t;
  for (AlignmentMode mode : options.alignments)
    ev.results.push_back(evaluateAligned(ev.associated.gt, ev.associated.est, mode, options.rpe_delta_m));
  return ev;
}

}  // namespace eval
}  // namespace vims
