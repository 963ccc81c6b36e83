#pragma once
/// @file sim_options.h
/// @brief Options of one simulated sequence, and the `vims_sim` command line that sets them.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vims_sim/sim_truth.h"
#include "vims_sim/trajectory.h"

namespace vims {
namespace sim {

/// The seabed's shape: a preset and per-term overrides (unset: the preset's value).
struct TerrainOptions {
  std::string preset = "flat";  ///< see terrainPresetNames()
  std::optional<double> slope_deg;
  std::optional<double> slope_azimuth_deg;  ///< unset: seeded from the world seed
  std::optional<double> relief_m;
  std::optional<double> relief_wavelength_m;
  std::optional<double> roughness_m;
  std::optional<double> rock_height_m;
  std::optional<double> rock_density;  ///< per m^2
};

/// "flat", "slope4", "rough", "hills".
const std::vector<std::string>& terrainPresetNames();
/// The preset's terrain (slope azimuth 0 and seed 0: the set-up seeds them). Throws
/// std::invalid_argument for an unknown name.
TerrainParams terrainPreset(const std::string& name);
/// The preset with the overrides applied; azimuth and seed still to be set.
TerrainParams terrainFromOptions(const TerrainOptions& options);

struct PressureOptions {
  bool enabled = false;  ///< --pressure: a depth sensor on /pressure
  double rate_hz = 10.0;
  double atmospheric_error_pa = 0.0;  ///< the YAML's atmospheric_pa is off by this from the truth
  double spike_fraction = 0.0;        ///< fraction of samples with a large spike
};

struct SimOptions {
  Scenario scenario = Scenario::kTank;
  double duration = 0.0;               ///< [s]
  uint64_t seed = 0;                   ///< trajectory seed: path, all noise (and the rig, unless rig_seed)
  std::optional<uint64_t> world_seed;  ///< seabed, coil position, site field; default = seed
  /// The vehicle's rig: camera, sonar, magnetometer and pressure calibration, the thrusters' and
  /// the hull's magnetic make-up; default = seed. A repeat mission of the same vehicle gives the
  /// teach run's seed here.
  std::optional<uint64_t> rig_seed;
  std::string out_dir;
  std::string name;           ///< default: basename of out_dir
  double static_start = 3.0;  ///< [s]
  double camera_delay = 0.0;  ///< [s] image stamp = exposure time + delay
  /// Imperfect calibration: the sequence YAML's T_b_c is the true one turned by this angle about
  /// a seeded axis and moved by this distance in a seeded direction (the truth file keeps both).
  double camera_extrinsic_error_deg = 0.0;
  double camera_extrinsic_error_m = 0.0;
  DropoutSpans spans;
  double start_time = 1700000000.0;  ///< bag-clock time of the sequence start [s]
  bool lz4 = false;                  ///< lz4-compressed bag chunks
  /// "raw" (sensor_msgs/Image mono8), "png" or "jpeg" (sensor_msgs/CompressedImage on
  /// <image topic>/compressed, as image_transport's compressed transport publishes).
  std::string image_format = "raw";
  /// The camera's lens: "radtan" (a mildly distorted pinhole, 60 deg across) or "equidistant"
  /// (a fisheye behind a dome port, Kannala-Brandt, about 110 deg across).
  std::string distortion_model = "radtan";
  /// The image size [px]. The focal length scales with the width, so the lens's field of view
  /// across the width stays; the height sets the aspect.
  int image_width = 640;
  int image_height = 480;
  /// The camera's mounting: its optical axis turned from straight down towards the bow by
  /// camera_tilt_deg (negative: towards the stern), and the camera turned about its optical axis
  /// by camera_roll_deg (0: the image's "up" towards the bow).
  double camera_tilt_deg = 0.0;
  double camera_roll_deg = 0.0;
  double coil_frequency_hz = 11.0;      ///< the (first) seabed coil's frequency
  bool coil_frequency_unknown = false;  ///< the sequence YAML leaves the coil frequency open (null)
  /// Further coils (--coil-frequencies F1,F2,...: coil_frequency_hz = F1, this = {F2, ...}); each
  /// has the first coil's hardware and its own free-running phase. Empty: one coil.
  std::vector<double> other_coil_frequencies_hz;
  /// [m] --coil-spacing: the further coils lie on the base lap this far (horizontally) from the
  /// first, and at least this far from each other when the lap allows it.
  double coil_spacing_m = 30.0;
  /// [Hz] every coil's frequency drifts linearly by this over the sequence (the YAML states the start's)
  double coil_frequency_drift_hz = 0.0;
  /// A geomagnetic anomaly under the mid-mission position: its peak field at the vehicle [uT]
  /// (0: none) and its width [m] (the buried dipole's depth below the vehicle is half of it).
  double magnetic_anomaly_ut = 0.0;
  /// --thrusters: the vehicle's two thrusters disturb the magnetometer (thruster_interference.h);
  /// the knobs give their size at the reference thrust (0.5 m/s).
  struct Thrusters {
    bool enabled = false;
    double line_hz = 45.0;       ///< electrical line frequency at the reference thrust
    double line_nt = 200.0;      ///< peak line amplitude [nT]
    double hard_iron_ut = 3.0;   ///< static offset [uT]
    double broadband_nt = 15.0;  ///< extra white noise per axis [nT]
  } thrusters;
  double magnetic_anomaly_width_m = 10.0;
  /// The magnetometer is not calibrated (the contract expects it to be; a real vehicle's may not
  /// be): --mag-hard-iron-ut [uT] and --mag-soft-iron-pct [%] of the vehicle's iron
  /// (thruster_interference.h, MagnetometerIron). 0: none.
  double mag_hard_iron_ut = 0.0;
  double mag_soft_iron_pct = 0.0;
  int render_threads = 0;              ///< 0: one per hardware thread
  TerrainOptions terrain;              ///< default: the flat seabed z = 0
  std::optional<double> depth_hold_z;  ///< [m] constant body z; unset: altitude hold
  bool hold_plane_only = false;        ///< --hold-plane-only: altitude hold ignores the rolling relief
  PressureOptions pressure;
  MissionConditions mission;  ///< a repeat mission's differences from the teach run (default: none)
  /// [m] the sonar's range limit (the YAML's max_range); a seabed beyond it gives no echo (+inf),
  /// as over a drop-off or when the vehicle climbs off the bottom. Unset: the default sonar's.
  std::optional<double> sonar_max_range;
  /// Sensor rates [Hz], within the contract's ranges; the sequence YAML states them, and the IMU's
  /// per-sample noise follows its rate (the noise densities stay those of the default IMU).
  struct Rates {
    double camera = 10.0;
    double imu = 200.0;
    double sonar = 10.0;
    double magnetometer = 1000.0;
  } rates;

  uint64_t worldSeed() const { return world_seed ? *world_seed : seed; }
  uint64_t rigSeed() const { return rig_seed ? *rig_seed : seed; }
  /// `name`, or the basename of out_dir when empty.
  std::string sequenceName() const;
  /// Throws std::invalid_argument naming the offending option (as its command-line flag).
  void validate() const;
};

/// Parses the vims_sim arguments (without the program name). Returns std::nullopt for --help.
/// Throws std::invalid_argument with a message that names the offending argument.
std::optional<SimOptions> parseSimCommandLine(const std::vector<std::string>& args);

/// The --help text.
std::string simUsage();

}  // namespace sim
}  // namespace vims
