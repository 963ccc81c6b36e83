#pragma once
/// @file sim_setup.h
/// @brief Everything a sequence is made of, derived deterministically from its options:
/// the rig (camera intrinsics, extrinsics, noise figures) from the trajectory seed, the site
/// (seabed texture and shape, coil position, geomagnetic field, water depth) from the world seed.

#include <memory>

#include "vims_common/sequence_config.h"
#include "vims_sim/magnetic_field.h"
#include "vims_sim/seabed_renderer.h"
#include "vims_sim/seabed_texture.h"
#include "vims_sim/sensor_models.h"
#include "vims_sim/sim_options.h"
#include "vims_sim/sim_truth.h"
#include "vims_sim/terrain.h"
#include "vims_sim/trajectory.h"

namespace vims {
namespace sim {

/// The site of a world seed: identical for every trajectory seed (map save/load tests rely on it).
struct SiteModel {
  CoilDipole coil;  ///< position, turns, current, diameter, frequency; phase 0 (set per sequence)
  GeomagneticField geomagnetic;
};

/// Coil at a seeded point within 2.5 m of the scenario's survey pattern (so its signature is
/// measurable: its field falls off with distance^3), on the seabed; about 49 uT at 46 deg
/// inclination with a seeded declination of 2-6 deg east or west.
SiteModel makeSite(Scenario scenario, uint64_t world_seed);

/// Horizontal positions of `count` further coils (vims_sim --coil-frequencies): points on the
/// scenario's base lap (scenarioLapWaypoints, closed) whose distance from `first` is as close as
/// possible to `spacing_m`, among the points at least `spacing_m` from every coil placed before
/// (when the lap has none, the point farthest from them: the nearest of them as far as possible;
/// with a spacing beyond the lap's reach, the lap's farthest point from `first`); inside the area like the first
/// coil. Equally good points (e.g. the lap's several crossings of the circle round the first
/// coil) are chosen between by the world seed's own stream; coil n does not depend on `count`.
std::vector<Eigen::Vector2d> placeOtherCoils(Scenario scenario, const Eigen::Vector2d& first, int count,
                                             double spacing_m, uint64_t world_seed);

struct SimSetup {
  SimOptions options;
  SequenceConfig config;  ///< -> <seq>.yaml (the estimator's calibration)
  SimTruth truth;         ///< -> <seq>_truth.yaml
  Trajectory trajectory;
  ImuNoiseParams imu;
  SonarParams sonar;
  MagnetometerParams magnetometer;
  SeabedTextureParams texture;
  UnderwaterOptics optics;
  std::shared_ptr<const SeabedTerrain> terrain;  ///< the seabed's shape (never null; flat by default)
  PressureParams pressure;                       ///< used when config.pressure is set
};

/// The seabed of the options: the preset with its overrides, the slope azimuth (unless given)
/// and the shape's seed from the world seed.
TerrainParams resolveTerrain(const TerrainOptions& options, uint64_t world_seed);

/// Validates the options (std::invalid_argument naming the flag) and derives the setup. Also
/// an error: a designed trajectory that comes closer than 1 m to the seabed, or a pressure
/// port that leaves the water.
SimSetup buildSimSetup(const SimOptions& options);

}  // namespace sim
}  // namespace vims
