#pragma once
/// @file geomagnetic_gate.h
/// @brief Rejects geomagnetic yaw measurements taken in a disturbed field (docs/pose_graph.md,
/// "Geomagnetic yaw gate").
///
/// The yaw factor trusts the horizontal direction of the low-passed field. Near steel (a wreck, a
/// pipe, the coil's frame, magnetised rock) the local field is bent: its heading is off by up to
/// the disturbance over the horizontal field (2 uT over 34 uT: ~3 deg). The heading itself cannot
/// be checked (it is what is measured), but the two invariants of the field can: its magnitude and
/// its inclination below the horizon (from the field levelled with the VIO's pitch and roll). A
/// clean site has one value of each over the few hundred metres of a mission; a disturbance moves
/// them together with the heading. The site's values are the medians of every measurement seen
/// (robust to a disturbed minority). A disturbance across the horizontal field bends the heading
/// and leaves both invariants almost as they are; it shows instead against the VIO, whose yaw
/// drifts slowly: in a clean field the field's azimuth in the VIO's frame stays put (or follows
/// a grossly drifting VIO's line), near steel it swings. A measurement is accepted when its
/// magnitude and inclination lie within the gate's bounds of the site's and its azimuth in the
/// VIO frame within a bound of the median of the recent ones of the same VIO session.

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

namespace vims {

template <typename Options>
class OptionTable;

struct GeomagneticGateOptions {
  /// false: every measurement becomes a yaw factor (the site is still estimated and logged).
  bool enabled = true;
  /// Accepted when | |B| - site | <= this fraction of the site's magnitude. 0.015 (0.75 uT of a
  /// 50 uT field): a disturbance that bends the heading by a degree (0.6 uT across a 34 uT
  /// horizontal field) changes the magnitude by about as much when it is not purely horizontal;
  /// the noise of a low-passed sample is a few nT.
  double magnitude_fraction = 0.015;
  /// Accepted when |inclination - site| <= this [rad] (key inclination_deg). The inclination's own
  /// error is the VIO's pitch and roll error (< 0.1 deg); 0.75 deg is what the heading would be bent
  /// by a disturbance of the same size in the horizontal.
  double inclination_rad = 0.75 * M_PI / 180.0;
  /// Accepted when the field's azimuth in the VIO frame is within this [rad] (key heading_deg) of
  /// the median of the session's measurements that passed the invariants within heading_window_s
  /// (a gross VIO drift taken out; 0: no heading check). A low-passed sample's heading noise is
  /// ~0.01 deg and VIMS's VIO drifts ~0.1 deg over a window; a disturbance of this size moves
  /// the heading by 1/6 of the yaw factor's sigma, where it stops mattering against hundreds of
  /// clean samples.
  double heading_rad = 0.5 * M_PI / 180.0;
  /// [s] Half-width of the window of the heading reference. Short enough that the VIO's yaw
  /// drift inside it stays well below heading_deg, long enough that a disturbed region (20 m of
  /// track at 0.3 m/s is ~70 s) is less than half of it.
  double heading_window_s = 120.0;
  /// Measurements are held until the site's medians rest on this many (and at the end of the
  /// run on what there is, at least 3; with fewer every held measurement is accepted).
  int min_samples = 20;

  static const OptionTable<GeomagneticGateOptions>& optionTable();
};

/// A levelled geomagnetic measurement waiting for its verdict.
struct GeomagneticCandidate {
  uint32_t node = 0;                                  ///< pose-graph node it belongs to
  uint32_t session = 0;                               ///< the VIO session (odometry frame) of the node
  double t = 0.0;                                     ///< [s]
  Eigen::Vector3d field_b = Eigen::Vector3d::Zero();  ///< [T] body frame, as measured
  double magnitude_tesla = 0.0;
  double inclination_rad = 0.0;   ///< below the horizon positive (the northern hemisphere's sign)
  double azimuth_odom_rad = 0.0;  ///< direction of the horizontal field in the VIO's odometry frame
};

struct GeomagneticVerdict {
  GeomagneticCandidate candidate;
  bool accepted = true;
  double magnitude_error_fraction = 0.0;  ///< (|B| - site) / site
  double inclination_error_rad = 0.0;     ///< inclination - site
  double heading_error_rad = 0.0;         ///< azimuth - the recent median (0 when not checked)
};

class GeomagneticGate {
 public:
  explicit GeomagneticGate(const GeomagneticGateOptions& options);

  /// The candidate of a body-frame field measured at a node whose VIO attitude is R_odom_b.
  static GeomagneticCandidate levelled(uint32_t node, uint32_t session, double t, const Eigen::Vector3d& field_b,
                                       const Eigen::Matrix3d& R_odom_b);

  /// Adds a finite candidate to the site's estimate and returns the verdicts now due, in
  /// measurement order: none while warming up, then the held candidates and this one. Disabled,
  /// the gate accepts each at once.
  std::vector<GeomagneticVerdict> add(const GeomagneticCandidate& candidate);
  /// Verdicts for the candidates still held (end of the run).
  std::vector<GeomagneticVerdict> flush();
  /// Replaces the site's estimate and the heading reference by those of `history` (every
  /// candidate added so far, re-measured: the vehicle's field taken out with a newer fit), so
  /// the samples measured before cannot hold the medians where the uncorrected field was.
  /// Held candidates and the counts stay.
  void restartSite(const std::vector<GeomagneticCandidate>& history);

  /// The site's values: medians of every candidate added (NaN before the first).
  double siteMagnitude() const;
  double siteInclination() const;
  size_t numSamples() const { return magnitudes_.size(); }
  size_t numRejected() const { return rejected_; }
  size_t numJudged() const { return judged_; }

 private:
  struct Azimuth {
    uint32_t session;
    double t;
    double azimuth;
  };
  bool invariantsAgree(const GeomagneticCandidate& candidate, GeomagneticVerdict* verdict) const;
  /// The candidate's azimuth minus the median of the accepted-by-invariants azimuths of its
  /// session within the window (a gross drift taken out); nullopt with too few of them to tell.
  std::optional<double> headingError(const GeomagneticCandidate& candidate) const;

  GeomagneticGateOptions options_;
  std::vector<double> magnitudes_;    ///< sorted
  std::vector<double> inclinations_;  ///< sorted
  std::vector<GeomagneticCandidate> held_;
  std::deque<Azimuth> azimuths_;  ///< of the candidates that passed the invariants, in time order
  size_t judged_ = 0;
  size_t rejected_ = 0;
};

}  // namespace vims
