#include "vims_eval/association.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vims {
namespace eval {
namespace {

/// Index of the element of sorted `stamps` nearest to t (stamps non-empty).
std::size_t nearestIndex(const std::vector<double>& stamps, double t) {
  const auto it = std::lower_bound(stamps.begin(), stamps.end(), t);
  if (it == stamps.begin()) return 0;
  if (it == stamps.end()) return stamps.size() - 1;
  const std::size_t hi = static_cast<std::size_t>(it - stamps.begin());
  const std::size_t lo = hi - 1;
  // Ties go to the earlier stamp, like numpy.argmin in evo.
  return (t - stamps[lo] <= stamps[hi] - t) ? lo : hi;
}

std::vector<double> stampsOf(const std::vector<StampedPose>& poses) {
  std::vector<double> stamps;
  stamps.reserve(poses.size());
  for (const auto& p : poses) stamps.push_back(p.t);
  return stamps;
}

std::string spanText(const std::vector<StampedPose>& poses) {
  if (poses.empty()) return "[empty]";
  std::ostringstream os;
  os.precision(15);
  os << "[" << poses.front().t << ", " << poses.back().t << "] (" << poses.size() << " poses)";
  return os.str();
}

void associateNearest(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est, double max_dt,
                      AssociatedTrajectories* out) {
  // Iterate over the shorter list, as evo does, so every pose of the sparser trajectory
  // gets a chance at a partner.
  const bool est_is_short = est.size() <= gt.size();
  const auto& shorter = est_is_short ? est : gt;
  const auto& longer = est_is_short ? gt : est;
  const std::vector<double> long_stamps = stampsOf(longer);

  struct Pair {
    std::size_t i_short;
    std::size_t i_long;
    double abs_dt;
  };
  std::vector<Pair> pairs;
  for (std::size_t i = 0; i < shorter.size(); ++i) {
    const std::size_t j = nearestIndex(long_stamps, shorter[i].t);
    const double abs_dt = std::abs(long_stamps[j] - shorter[i].t);
    if (abs_dt > max_dt) continue;
    // Both lists are sorted, so only the previous pair can already hold partner j.
    if (!pairs.empty() && pairs.back().i_long == j) {
      if (abs_dt < pairs.back().abs_dt) pairs.back() = Pair{i, j, abs_dt};
      continue;
    }
    pairs.push_back(Pair{i, j, abs_dt});
  }
  for (const auto& pr : pairs) {
    out->gt.push_back(est_is_short ? longer[pr.i_long] : shorter[pr.i_short]);
    out->est.push_back(est_is_short ? shorter[pr.i_short] : longer[pr.i_long]);
    out->max_abs_dt_s = std::max(out->max_abs_dt_s, pr.abs_dt);
  }
}

void associateInterpolated(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                           const AssociationOptions& options, AssociatedTrajectories* out) {
  const std::vector<double> gt_stamps = stampsOf(gt);
  for (const auto& pose_est : est) {
    std::optional<StampedPose> pose_gt = interpolatePose(gt, pose_est.t, options.max_gt_gap_s);
    if (!pose_gt) {
      // Just outside the ground truth's span or next to a gap: the nearest sample is as good
      // as nearest-stamp association would be, within the same tolerance.
      const StampedPose& nearest = gt[nearestIndex(gt_stamps, pose_est.t)];
      const double abs_dt = std::abs(nearest.t - pose_est.t);
      if (abs_dt > options.max_dt_s) continue;
      pose_gt = nearest;
      out->max_abs_dt_s = std::max(out->max_abs_dt_s, abs_dt);
    }
    pose_gt->t = pose_est.t;
    out->gt.push_back(*pose_gt);
    out->est.push_back(pose_est);
  }
}

}  // namespace

std::optional<StampedPose> interpolatePose(const std::vector<StampedPose>& traj, double t, double max_gap_s) {
  if (traj.empty()) return std::nullopt;
  constexpr double kSameStamp = 1e-9;
  if (t < traj.front().t - kSameStamp || t > traj.back().t + kSameStamp) return std::nullopt;
  const auto it =
      std::lower_bound(traj.begin(), traj.end(), t, [](const StampedPose& p, double stamp) { return p.t < stamp; });
  if (it != traj.end() && std::abs(it->t - t) <= kSameStamp) return *it;
  if (it == traj.begin()) return traj.front();  // within kSameStamp before the first sample
  if (it == traj.end()) return traj.back();     // within kSameStamp after the last sample
  const StampedPose& before = *(it - 1);
  if (std::abs(before.t - t) <= kSameStamp) return before;
  const StampedPose& after = *it;
  if (after.t - before.t > max_gap_s) return std::nullopt;
  const double alpha = (t - before.t) / (after.t - before.t);
  StampedPose out;
  out.t = t;
  out.p = (1.0 - alpha) * before.p + alpha * after.p;
  out.q = before.q.slerp(alpha, after.q).normalized();
  return out;
}

AssociatedTrajectories associate(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                                 const AssociationOptions& options) {
  if (gt.empty()) throw std::runtime_error("association: the ground truth is empty");
  if (est.empty()) throw std::runtime_error("association: the estimate is empty");
  if (!(options.max_dt_s >= 0.0)) throw std::invalid_argument("association: max_dt_s must be >= 0");
  AssociatedTrajectories out;
  out.gt_total = gt.size();
  out.est_total = est.size();
  if (options.interpolate) {
    associateInterpolated(gt, est, options, &out);
  } else {
    associateNearest(gt, est, options.max_dt_s, &out);
  }
  if (out.empty()) {
    std::ostringstream os;
    os << "association: no estimate stamp matches the ground truth within " << options.max_dt_s << " s"
       << (options.interpolate ? " (interpolating)" : "") << "; ground truth spans " << spanText(gt)
       << ", estimate spans " << spanText(est) << " - wrong files or a clock offset?";
    throw std::runtime_error(os.str());
  }
  return out;
}

}  // namespace eval
}  // namespace vims
