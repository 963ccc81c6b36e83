#include "frontend_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>

#include "vims_common/magnetic_signature.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/timing.h"
#include "vims_common/trajectory_io.h"
#include "vims_magnetometer/magnetic_front_end.h"
#include "vims_magnetometer/signature_csv_writer.h"
#include "vims_ros/sequence_bag_reader.h"
#include "vims_sim/sensor_models.h"
#include "vims_sim/sim_truth.h"
#include "vims_sonar/sonar_altitude_filter.h"
#include "vims_sonar/sonar_csv_writer.h"

namespace vims {
namespace frontend_eval {
namespace {

constexpr const char* kComponent = "frontend_eval";
/// Windows whose true field is at least this share horizontal have a meaningful azimuth.
constexpr double kMinHorizontalShare = 0.3;
/// Ground truth is written at 50 Hz or faster; a longer hole is not interpolated across.
constexpr double kMaxTruthGap = 0.1;
/// The evaluation's outlier threshold in units of range_noise_std (issue 3's definition).
constexpr double kOutlierSigma = 5.0;

/// T_w_b at time t: linear position, slerp rotation between the two neighbouring poses.
std::optional<Eigen::Isometry3d> truthAt(const std::vector<StampedPose>& gt, double t) {
  if (gt.empty() || t < gt.front().t || t > gt.back().t) return std::nullopt;
  auto upper = std::lower_bound(gt.begin(), gt.end(), t, [](const StampedPose& p, double v) { return p.t < v; });
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (upper->t == t) {
    T.linear() = upper->q.toRotationMatrix();
    T.translation() = upper->p;
    return T;
  }
  const StampedPose& b = *upper;
  const StampedPose& a = *(upper - 1);
  if (b.t - a.t > kMaxTruthGap) return std::nullopt;
  const double alpha = (t - a.t) / (b.t - a.t);
  T.linear() = a.q.slerp(alpha, b.q).toRotationMatrix();
  T.translation() = (1.0 - alpha) * a.p + alpha * b.p;
  return T;
}

std::string fmt(double v, int decimals = 3) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

struct Sequence {
  SequencePaths paths;
  SequenceConfig config;
  std::vector<StampedPose> gt;
};

Sequence loadSequence(const std::string& dir, LoggerPtr logger) {
  Sequence s;
  s.paths = SequencePaths::resolve(dir);
  std::vector<std::string> unknown;
  s.config = SequenceConfig::load(s.paths.yaml, &unknown);
  for (const auto& key : unknown) logger->warn(kComponent, s.paths.yaml + ": key '" + key + "' is not in the contract");
  if (s.paths.gt.empty()) throw std::runtime_error("sequence '" + dir + "' has no ground truth (<seq>_gt.tum)");
  s.gt = readTumFile(s.paths.gt);
  return s;
}

}  // namespace

std::string SonarEvaluation::summaryLine() const {
  return "VIMS_SONAR samples=" + std::to_string(samples) + " dropouts=" + std::to_string(dropouts) +
         " outliers=" + std::to_string(outliers) + " rejected=" + std::to_string(outliers_rejected) +
         " rejected_pct=" + fmt(rejectedPct(), 2) + " good=" + std::to_string(good) +
         " lost=" + std::to_string(good_lost) + " lost_pct=" + fmt(lostPct(), 2) + " resets=" + std::to_string(resets) +
         " filtered_rmse_m=" + fmt(filtered_rmse_m, 4);
}

std::string MagEvaluation::summaryLine() const {
  return "VIMS_MAG windows=" + std::to_string(windows) + " valid=" + std::to_string(valid_windows) +
         " scored=" + std::to_string(scored) + " median_rel_err_pct=" + fmt(median_rel_err_pct, 2) +
         " p90_rel_err_pct=" + fmt(p90_rel_err_pct, 2) + " heading_pairs=" + std::to_string(heading_pairs) +
         " heading_median_rel_diff_pct=" + fmt(heading_median_rel_diff_pct, 2) +
         " heading_median_raw_diff_pct=" + fmt(heading_median_raw_diff_pct, 2) + " median_snr=" + fmt(median_snr, 1) +
         " median_magnitude_err_pct=" + fmt(median_magnitude_err_pct, 2) +
         " median_azimuth_err_deg=" + fmt(median_azimuth_err_deg, 2) +
         " mean_azimuth_err_deg=" + fmt(mean_azimuth_err_deg, 2);
}

std::string MagCoilEvaluation::summaryLine() const {
  return "VIMS_MAG_COIL coil=" + std::to_string(coil) + " frequency_hz=" + fmt(frequency_hz, 3) +
         " scored=" + std::to_string(scored) + " median_rel_err_pct=" + fmt(median_rel_err_pct, 2) +
         " p90_rel_err_pct=" + fmt(p90_rel_err_pct, 2);
}

SonarEvaluation evaluateSonar(const std::string& sequence_dir, const SonarFilterOptions& options, LoggerPtr logger,
                              const std::string& csv_path) {
  if (!logger) logger = Logger::nullLogger();
  const Sequence seq = loadSequence(sequence_dir, logger);
  // The true slant range is to the seabed the simulator drew (its terrain, from <seq>_truth.yaml),
  // or to the flat z = 0 for a sequence without a truth file.
  const sim::SeabedTerrain seabed =
      seq.paths.truth.empty() ? sim::SeabedTerrain() : sim::terrainFromTruth(sim::SimTruth::load(seq.paths.truth));
  SonarAltitudeFilter filter(options, seq.config.sonar, logger);
  std::vector<SonarFilterResult> results;
  SequenceBagReader reader(seq.paths.bag, seq.config);
  SequenceBagReader::Handlers handlers;
  handlers.sonar = [&](const SonarRange& s) { filter.feed(s, &results); };
  reader.run(handlers);
  filter.flush(&results);

  std::optional<SonarCsvWriter> csv;
  if (!csv_path.empty()) csv.emplace(csv_path);
  SonarEvaluation ev;
  const double sigma = seq.config.sonar.range_noise_std;
  double sq_err = 0.0;
  long n_accepted_scored = 0;
  for (const SonarFilterResult& r : results) {
    if (csv) csv->write(r);
    ++ev.samples;
    const bool in_range =
        std::isfinite(r.raw) && r.raw >= seq.config.sonar.min_range && r.raw <= seq.config.sonar.max_range;
    if (!in_range) {
      ++ev.dropouts;
      continue;
    }
    const auto T_w_b = truthAt(seq.gt, r.t);
    if (!T_w_b) {
      ++ev.no_truth;
      continue;
    }
    const double truth =
        sim::SonarSimulator::trueRange(*T_w_b, seq.config.sonar.T_b_s, seabed, seq.config.sonar.max_range);
    if (std::abs(r.raw - truth) > kOutlierSigma * sigma) {
      ++ev.outliers;
      if (!r.accepted) ++ev.outliers_rejected;
    } else {
      ++ev.good;
      if (!r.accepted) ++ev.good_lost;
    }
    if (r.accepted) {
      sq_err += (r.filtered - truth) * (r.filtered - truth);
      ++n_accepted_scored;
    }
  }
  ev.resets = filter.stats().resets;
  ev.filtered_rmse_m = n_accepted_scored > 0 ? std::sqrt(sq_err / n_accepted_scored) : 0.0;
  return ev;
}

MagEvaluation evaluateMagnetometer(const std::string& sequence_dir, const MagnetometerOptions& options,
                                   const MagEvaluationOptions& eval_options, LoggerPtr logger,
                                   const std::string& csv_path) {
  if (!logger) logger = Logger::nullLogger();
  const Sequence seq = loadSequence(sequence_dir, logger);
  if (seq.paths.truth.empty()) {
    throw std::runtime_error("sequence '" + sequence_dir +
                             "' has no <seq>_truth.yaml: the coil position is needed to score signatures");
  }
  const sim::SimTruth truth = sim::SimTruth::load(seq.paths.truth);
  MagneticFrontEnd extractor(options, seq.config.magnetometer, seq.config.imu.gravity, logger);
  std::vector<SignatureWindow> signatures;
  SequenceBagReader reader(seq.paths.bag, seq.config);
  SequenceBagReader::Handlers handlers;
  handlers.imu = [&](const ImuSample& s) { extractor.feedImu(s); };
  handlers.mag = [&](const MagSample& s) { extractor.feedMag(s, &signatures, nullptr); };
  reader.run(handlers);

  std::optional<SignatureCsvWriter> csv;
  if (!csv_path.empty()) csv.emplace(csv_path);
  struct Scored {
    double t;
    int coil;
    Eigen::Vector3d p_w_m;
    double heading;
    Eigen::Vector3d measured;
    Eigen::Vector3d truth;
  };
  std::vector<Scored> scored;
  std::vector<double> rel_errors, snrs, magnitude_errors, azimuth_errors;
  // Per coil of the truth: index = SignatureWindow::coil.
  std::vector<std::vector<double>> coil_rel_errors(static_cast<size_t>(truth.coilCount()));
  MagEvaluation ev;
  for (const SignatureWindow& sig : signatures) {
    if (csv) csv->write(sig);
    ++ev.windows;
    if (!sig.valid) continue;
    ++ev.valid_windows;
    snrs.push_back(sig.snr);
    const sim::CoilDipole* coil = truth.coilAt(sig.coil);
    if (!coil) {
      if (ev.unknown_coil++ == 0) {
        logger->warn(kComponent, "signature windows of coil " + std::to_string(sig.coil) + ", but the truth has " +
                                     std::to_string(truth.coilCount()) + " coil(s): not scored");
      }
      continue;
    }
    const auto T_w_b = truthAt(seq.gt, sig.t);
    if (!T_w_b) continue;
    const Eigen::Vector3d p_w_m = (*T_w_b * seq.config.magnetometer.T_b_m).translation();
    const Eigen::Vector3d g = canonicalSignature(coil->peakField(p_w_m));
    if (g.norm() < eval_options.min_amplitude_t) continue;
    const Eigen::Vector3d x_w = T_w_b->linear().col(0);
    scored.push_back({sig.t, sig.coil, p_w_m, std::atan2(x_w.y(), x_w.x()), sig.amplitude_enu, g});
    rel_errors.push_back((sig.amplitude_enu - g).norm() / g.norm());
    coil_rel_errors[static_cast<size_t>(sig.coil)].push_back(rel_errors.back());
    magnitude_errors.push_back(std::abs(sig.amplitude_enu.norm() - g.norm()) / g.norm());
    if (g.head<2>().norm() >= kMinHorizontalShare * g.norm()) {
      const Eigen::Vector3d s = alignedSignature(sig.amplitude_enu, g);
      const double d = std::atan2(s.y(), s.x()) - std::atan2(g.y(), g.x());
      azimuth_errors.push_back(std::atan2(std::sin(d), std::cos(d)) * 180.0 / M_PI);
    }
  }
  ev.scored = static_cast<long>(scored.size());
  ev.median_rel_err_pct = 100.0 * percentile(rel_errors, 0.5);
  ev.p90_rel_err_pct = 100.0 * percentile(rel_errors, 0.9);
  ev.median_snr = percentile(snrs, 0.5);
  ev.median_magnitude_err_pct = 100.0 * percentile(magnitude_errors, 0.5);
  std::vector<double> azimuth_sizes;
  double azimuth_sum = 0.0;
  for (const double a : azimuth_errors) {
    azimuth_sizes.push_back(std::abs(a));
    azimuth_sum += a;
  }
  ev.median_azimuth_err_deg = percentile(azimuth_sizes, 0.5);
  ev.mean_azimuth_err_deg = azimuth_errors.empty() ? 0.0 : azimuth_sum / static_cast<double>(azimuth_errors.size());
  for (int i = 0; i < truth.coilCount(); ++i) {
    MagCoilEvaluation coil;
    coil.coil = i;
    coil.frequency_hz = truth.coilAt(i)->frequency;
    const std::vector<double>& errors = coil_rel_errors[static_cast<size_t>(i)];
    coil.scored = static_cast<long>(errors.size());
    coil.median_rel_err_pct = 100.0 * percentile(errors, 0.5);
    coil.p90_rel_err_pct = 100.0 * percentile(errors, 0.9);
    ev.coils.push_back(coil);
  }

  std::vector<double> compensated, raw;
  const double min_heading = eval_options.pair_min_heading_deg * M_PI / 180.0;
  for (std::size_t i = 0; i < scored.size(); ++i) {
    for (std::size_t j = i + 1; j < scored.size(); ++j) {
      const Scored& a = scored[i];
      const Scored& b = scored[j];
      if (a.coil != b.coil) continue;              // different coils' signatures are never compared
      if (b.t - a.t < options.window_s) continue;  // overlapping windows share data
      if ((a.p_w_m - b.p_w_m).norm() > eval_options.pair_radius_m) continue;
      const double dh = std::abs(std::atan2(std::sin(a.heading - b.heading), std::cos(a.heading - b.heading)));
      if (dh <= min_heading) continue;
      const double scale = 0.5 * (a.truth.norm() + b.truth.norm());
      compensated.push_back(((a.measured - b.measured) - (a.truth - b.truth)).norm() / scale);
      raw.push_back((a.measured - b.measured).norm() / scale);
    }
  }
  ev.heading_pairs = static_cast<long>(compensated.size());
  ev.heading_median_rel_diff_pct = 100.0 * percentile(compensated, 0.5);
  ev.heading_median_raw_diff_pct = 100.0 * percentile(raw, 0.5);
  return ev;
}

}  // namespace frontend_eval
}  // namespace vims
