#pragma once
/// @file frontend_eval.h
/// @brief Evaluation of the sonar filter and the magnetic signature extractor on a simulated
/// sequence against its ground truth. Used by the `vims_frontend_eval` tool and the system test.
///
/// Sonar: the true slant range of each sample is recomputed from the ground-truth pose
/// (interpolated at the sample time), the sonar extrinsic T_b_s and the flat seabed z = 0. A
/// finite, in-range raw range more than 5 sigma (sigma = range_noise_std) from it is an injected
/// outlier; within 5 sigma it is a good sample; +inf and out-of-range values are dropouts.
///
/// Magnetometer: each window is compared with the analytic dipole peak field of the coil (from
/// `<seq>_truth.yaml`) at the magnetometer's true position at the window centre, in the
/// extractor's sign convention (canonicalSignature). Relative error |s - g| / |g| over the valid
/// windows with |g| >= min_amplitude_t. Heading invariance: pairs of such windows whose true
/// positions are within pair_radius_m but whose headings differ by more than
/// pair_min_heading_deg; the figure is |(s_i - s_j) - (g_i - g_j)| / mean(|g_i|, |g_j|), i.e. how
/// much the two measurements differ beyond what the field itself changes between the two
/// (slightly different) positions. The uncompensated |s_i - s_j| / mean(|g|) is reported too.
///
/// Several coils (vims_sim --coil-frequencies): a window is scored against the truth coil whose
/// index is its SignatureWindow::coil (0: the truth's `coil`, i: `other_coils[i - 1]`), pairs are
/// formed between windows of the same coil only, and the median / p90 error is also given per
/// coil. A valid window naming a coil the truth does not have is not scored (`unknown_coil`).

#include <string>
#include <vector>

#include "vims_common/log.h"
#include "vims_magnetometer/magnetometer_options.h"
#include "vims_sonar/sonar_filter_options.h"

namespace vims {
namespace frontend_eval {

struct SonarEvaluation {
  long samples = 0;   ///< sonar samples read
  long no_truth = 0;  ///< outside the ground truth's time span (not scored)
  long dropouts = 0;  ///< +inf / out of range raw values
  long outliers = 0;  ///< injected outliers (> 5 sigma from the true range)
  long outliers_rejected = 0;
  long good = 0;       ///< within 5 sigma of the true range
  long good_lost = 0;  ///< good samples the filter did not accept
  long resets = 0;
  double filtered_rmse_m = 0.0;  ///< filtered range of accepted samples vs truth
  double rejectedPct() const { return outliers > 0 ? 100.0 * outliers_rejected / outliers : 100.0; }
  double lostPct() const { return good > 0 ? 100.0 * good_lost / good : 0.0; }
  /// "VIMS_SONAR samples=.. outliers=.. rejected_pct=.. good=.. lost_pct=.. ..."
  std::string summaryLine() const;
};

struct MagEvaluationOptions {
  double min_amplitude_t = 20e-9;  ///< windows whose true amplitude is below this are not scored
  double pair_radius_m = 0.5;
  double pair_min_heading_deg = 45.0;
};

/// The scores of one coil of a sequence with several.
struct MagCoilEvaluation {
  int coil = 0;               ///< index in the sequence's coil list
  double frequency_hz = 0.0;  ///< the truth's (at the sequence start)
  long scored = 0;
  double median_rel_err_pct = 0.0;
  double p90_rel_err_pct = 0.0;
  /// "VIMS_MAG_COIL coil=.. frequency_hz=.. scored=.. median_rel_err_pct=.. p90_rel_err_pct=.."
  std::string summaryLine() const;
};

struct MagEvaluation {
  long windows = 0;
  long valid_windows = 0;
  long scored = 0;  ///< valid, with truth and |g| >= min_amplitude_t
  double median_rel_err_pct = 0.0;
  double p90_rel_err_pct = 0.0;
  long heading_pairs = 0;
  double heading_median_rel_diff_pct = 0.0;  ///< compensated for the field change (see above)
  double heading_median_raw_diff_pct = 0.0;  ///< |s_i - s_j| / mean |g|
  double median_snr = 0.0;
  /// The error split into what a rotation cannot cause and what a heading error causes:
  /// median of ||s| - |g|| / |g|, and the azimuth of s's horizontal part minus g's [deg]
  /// (median of its size, and its mean: a bias) over windows whose true field is at least 30 %
  /// horizontal. A front end whose attitude is off in heading shows the second, not the first.
  double median_magnitude_err_pct = 0.0;
  double median_azimuth_err_deg = 0.0;
  double mean_azimuth_err_deg = 0.0;
  long unknown_coil = 0;  ///< valid windows whose coil index the truth does not have (not scored)
  /// One per truth coil, in the sequence's order (a single entry for a sequence of one coil).
  std::vector<MagCoilEvaluation> coils;
  /// "VIMS_MAG windows=.. valid=.. scored=.. median_rel_err_pct=.. heading_pairs=.. ..." (all coils)
  std::string summaryLine() const;
};

/// Runs the sonar filter over `<dir>/<seq>.bag`. Writes sonar_filtered.csv rows to csv_path when
/// it is not empty. Throws std::runtime_error (missing files, no ground truth) or ConfigError.
SonarEvaluation evaluateSonar(const std::string& sequence_dir, const SonarFilterOptions& options, LoggerPtr logger,
                              const std::string& csv_path = "");

/// Runs the extractor over the bag (IMU and magnetometer) and scores it. Needs `<seq>_gt.tum` and
/// `<seq>_truth.yaml`. Writes mag_signatures.csv rows to csv_path when it is not empty.
MagEvaluation evaluateMagnetometer(const std::string& sequence_dir, const MagnetometerOptions& options,
                                   const MagEvaluationOptions& eval_options, LoggerPtr logger,
                                   const std::string& csv_path = "");

}  // namespace frontend_eval
}  // namespace vims
