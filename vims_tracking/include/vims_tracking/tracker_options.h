#pragma once
/// @file tracker_options.h
/// @brief Parameters of the visual front end (FeatureTracker). Defaults are chosen for the
/// contract camera (640x480 mono8 at 10 Hz, downward-looking over the seabed); the reason for
/// each default is given next to it.

#include <string>

#include "vims_common/config_reader.h"

namespace vims {

template <typename Options>
class OptionTable;

struct TrackerOptions {
  // ---- feature budget and spread ----
  /// Features kept per frame. 150 constrains the sliding window well while KLT stays at a few ms.
  int max_features = 150;
  /// Minimum distance between features [px]. 640x480 / 150 gives ~45 px spacing; 30 px leaves
  /// room to refill gaps while preventing clusters on one rock.
  double min_distance_px = 30.0;
  /// Features closer than this to the image border are dropped [px]. 11 keeps the whole 21 px
  /// KLT window inside the image: a window reaching into the padded border biased tracks by up
  /// to 0.4 px in tests.
  int border_px = 11;
  /// New corners are detected only when at least this many features are missing (or none is
  /// left). A downward camera loses a few tracks a frame, and detecting costs a whole-image
  /// corner response (~40 % of the front end): waiting for 10 % of the budget detects on about
  /// one frame in five and keeps 135-150 features. 1 detects on every frame with a free slot.
  int detect_min_missing = 15;

  // ---- Shi-Tomasi detection ----
  /// Preferred relative quality (fraction of the strongest corner response in the frame).
  double quality_level = 0.01;
  /// Lowest relative quality the adaptive detector may reach on sparse (sandy) frames.
  double min_quality_level = 0.0005;
  /// Each adaptation step multiplies the quality level by this factor.
  double quality_decrease_factor = 0.25;
  /// Absolute floor on the Shi-Tomasi response (minimum eigenvalue on OpenCV's cornerMinEigenVal
  /// scale for 8-bit images, block 3, aperture 3). 1e-5 is below a corner of one grey level per
  /// pixel: it only keeps flat, saturated or quantisation-step areas out, so that weak but real
  /// texture on dark frames still counts. (Blackouts are caught by blank_frame_max_stddev.)
  double min_corner_response = 1e-5;

  // ---- photometric normalisation ----
  /// Illumination flattening of the image KLT tracks on (flattenIllumination): each image is
  /// divided by its local mean, a Gaussian low-pass of this standard deviation [px]; 0 = off
  /// (KLT then tracks on the detection image, see clahe_enabled).
  /// The vehicle's lamp lights the seabed with a beam, a 1/r^2 fall-off and vignetting that are
  /// fixed to the camera, not to the scene, so a seabed point changes grey level as it crosses
  /// the image, and KLT, which assumes constant brightness, drifts along every track. On tank60
  /// the tracker's error against the exact projections of the tracked seabed points at track age
  /// 20 fell from 2.7 px (CLAHE) / 3.5 px (raw) to 0.81 px with 20 px, and the VIO ATE from
  /// 0.12 % to 0.03 % (sigma 10 / 15 / 30 / 60 / 100 px: 0.61 / 0.72 / 0.98 / 1.65 / 2.45 px at
  /// age 20; docs/frontends.md). About the KLT window (21 px): the gain is nearly constant over
  /// a window, while every smoother illumination component is removed.
  double illumination_sigma_px = 20.0;
  /// Mean grey level of the flattened image (the middle of the 8-bit range).
  double illumination_target_mean = 128.0;

  // ---- contrast equalisation ----
  /// CLAHE on the image corners are detected in, so dark low-contrast water keeps corners (and
  /// on the image KLT tracks on when illumination_sigma_px is 0). Its clip limit bounds the gain
  /// on dark, noisy regions, so detection prefers corners that stand out of the noise; its
  /// tiles are fixed to the image, which biases KLT like the lamp does, hence the flattening
  /// for tracking.
  bool clahe_enabled = true;
  /// CLAHE clip limit: 3 lifts faint texture while bounding noise amplification.
  double clahe_clip_limit = 3.0;
  /// CLAHE tiles per image side (4 -> 160x120 px tiles at 640x480). CLAHE's tiles are fixed to
  /// the image while the scene moves, so the mapping a scene point gets changes between frames
  /// and biases KLT: 8x8 tiles gave up to 0.45 px error in tests, 4x4 0.30 px (raw image 0.25 px),
  /// while 4x4 still lifts the dark, vignetted rim for detection.
  int clahe_tiles = 4;
  /// A frame whose intensity standard deviation (grey levels, measured on a 4x area-downsampled
  /// copy so pixel noise averages out) is at or below this is treated as blank (camera blackout):
  /// all tracks end and no corners are detected in it.
  double blank_frame_max_stddev = 1.0;

  /// A gap between accepted frames longer than this [s] ends all tracks (dropped images, camera
  /// driver restart): after 1 s (10 frames) of unknown motion KLT would mostly produce outliers,
  /// and the estimator should not link observations across the gap.
  double max_frame_gap_s = 1.0;

  // ---- pyramidal KLT ----
  /// KLT window side [px].
  int klt_window_px = 21;
  /// Highest pyramid level (OpenCV maxLevel; 3 -> 4 levels, tracks ~100 px motion at 10 Hz).
  int klt_max_level = 3;
  int klt_max_iterations = 30;
  /// KLT convergence threshold (OpenCV compares it with the squared update step [px^2]).
  double klt_epsilon = 0.01;
  /// KLT declares a track lost when its window's normalised minimum eigenvalue is below this
  /// (OpenCV's default 1e-4). Right for CLAHE images; on raw dark images (clahe_enabled false)
  /// it drops nearly every low-contrast track, so lower it there.
  double klt_min_eigen_threshold = 1e-4;
  /// Forward-backward check: tracks whose backward-tracked position misses the start by more
  /// than this [px] are rejected.
  double fb_max_error_px = 1.0;

  // ---- epipolar outlier rejection ----
  bool ransac_enabled = true;
  /// Fundamental-matrix RANSAC inlier threshold, in pixels of a virtual undistorted camera
  /// with the mean focal length [px].
  double ransac_threshold_px = 1.0;
  double ransac_confidence = 0.99;
  int ransac_max_iterations = 1000;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<TrackerOptions>& optionTable();
  /// Reads the options from a mapping (e.g. the `tracker:` section of a vims_offline configuration).
  /// Absent keys keep their defaults; unknown keys and out-of-range values throw ConfigError
  /// naming the key.
  static TrackerOptions fromReader(const ConfigReader& reader);

  /// Throws ConfigError naming the first option out of range (for options built in code).
  void validate() const;

  /// YAML mapping of all options (for logging the effective configuration).
  std::string toYaml() const;
};

}  // namespace vims
