#pragma once
/// @file sequence_run.h
/// @brief The VIO on a generated sequence as vims_offline wires it (bag -> sonar filter ->
/// tracker -> VioEstimator), optionally with the tracker's observations replaced by the exact
/// projections of the tracked seabed points: what the estimator makes of perfect features, and
/// how far the tracker is from them (test_time_offset.cpp, test_fisheye_features.cpp).

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "vims_common/camera_model.h"
#include "vims_common/sequence_config.h"
#include "vims_common/tracked_frame.h"
#include "vims_common/trajectory_io.h"
#include "vims_estimator/estimator_options.h"

namespace vims {
namespace test {

struct SequenceRun {
  std::vector<StampedPose> poses;  ///< body pose at every frame stamp
  double td_final = 0.0;
  int resets = 0;
  bool all_finite = true;
  double ate_pct = 0.0;  ///< VIO ATE (SE3) in % of the distance
  double sim3_scale = 1.0;
};

/// Optional edit of every tracked frame before the estimator sees it.
using FrameEdit = std::function<void(TrackedFrame*)>;

/// Runs the VIO on the sequence in `dir` (its ATE when it gave more than 50 poses).
SequenceRun runSequence(const std::string& dir, const EstimatorOptions& options, const FrameEdit& edit = nullptr);

/// $VIMS_TEST_DATA/name, or empty when VIMS_TEST_DATA is not set.
std::string sequenceDir(const std::string& name);

/// Ground-truth body pose at t (linear / slerp interpolation of the TUM samples).
Eigen::Isometry3d gtPose(const std::vector<StampedPose>& gt, double t);

/// A FrameEdit that measures the tracker against the exact projections of the tracked seabed
/// points and (unless measuring only) replaces each observation by its projection. A track's
/// point is where its first observation's ray meets the simulator's flat seabed (z = 0) at the
/// ground-truth exposure time t_stamp - delay; every later observation is that point projected
/// at its own exposure time. The tracks (which features, how long) stay the tracker's.
class ExactProjections {
 public:
  ExactProjections(const std::string& dir, double delay, bool replace);

  void operator()(TrackedFrame* frame);
  FrameEdit edit() {
    return [this](TrackedFrame* f) { (*this)(f); };
  }

  /// RMS of fx times the normalised-plane error at a track age (ages above 40 count as 40) [px].
  double rmsErrorAtAge(int age) const;

  /// The tracker's error in pixels, split along and across the ray from the principal point,
  /// of observations at least min_radial_age frames into their track, by distance from the
  /// principal point.
  struct RadialBin {
    double r0_px = 0.0, r1_px = 0.0;
    double mean_radial_px = 0.0;  ///< positive: the tracked point lies farther out than the truth
    double rms_px = 0.0;
    int count = 0;
  };
  std::vector<RadialBin> radialErrors() const;
  static constexpr int kMinRadialAge = 8;
  static constexpr double kRadialBinPx = 50.0;

 private:
  SequenceConfig config_;
  CameraModel camera_;
  std::vector<StampedPose> gt_;
  double delay_;
  bool replace_;
  std::map<std::uint64_t, Eigen::Vector3d> seabed_points_;
  std::map<int, std::pair<double, int>> error_by_age_;  ///< sum of squared px, count
  std::map<int, std::array<double, 3>> radial_;         ///< bin -> sum radial, sum squared, count
};

}  // namespace test
}  // namespace vims
