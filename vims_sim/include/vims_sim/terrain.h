#pragma once
/// @file terrain.h
/// @brief The shape of the seabed: its height h(x, y) in world ENU (z up), a deterministic
/// function of a few parameters and a seed, with an exact analytic gradient (surface normal).
///
/// h = plane + rolling relief + roughness + rocks:
/// - plane: slope_deg downhill towards slope_azimuth_deg (compass: clockwise from north), 0 at
///   the origin;
/// - relief: three seeded 2-D sinusoids of different directions (about 60 deg apart) and
///   wavelengths (1, 0.71, 0.53 x relief_wavelength_m), amplitudes 0.5 / 0.3 / 0.2 x relief_m,
///   so |relief| <= relief_m and it is not one corrugation;
/// - roughness: five seeded sinusoids with wavelengths from 5 m down to 1 m, amplitude
///   proportional to the wavelength (every octave has the same slope), scaled to an rms height
///   of roughness_m;
/// - rocks: smooth domes H (1 - rho^2 / R^2)^2 (radius R = 2.5-3.5 H, so at most 32 deg steep),
///   H = 0.5-1 x rock_height_m, at most one per cell of a 3 m world grid, present with
///   probability rock_density * cell area; placed by a world-coordinate hash, so the content is
///   infinite and any point can be evaluated on its own.
/// The flat terrain (all amplitudes zero) is exactly h = 0 with normal (0, 0, 1).
///
/// The rays of the camera and the sonar are intersected with the surface by intersectRay():
/// a bracket from the envelope of the surface, then safeguarded Newton steps; a ray that may
/// meet the surface more than once (steeper than the ray can see past) is first marched with
/// steps that provably cannot skip the first hit.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace vims {
namespace sim {

/// Everything that fixes a terrain (also what `<seq>_truth.yaml` records of it).
struct TerrainParams {
  double slope_deg = 0.0;             ///< plane slope [deg]
  double slope_azimuth_deg = 0.0;     ///< downhill direction [deg], clockwise from north (90 = downhill to the east)
  double relief_m = 0.0;              ///< rolling relief: peak amplitude [m] (|relief| <= relief_m)
  double relief_wavelength_m = 30.0;  ///< wavelength of the longest relief wave [m]
  double roughness_m = 0.0;           ///< rms height of the 1-5 m roughness [m]
  double rock_height_m = 0.0;         ///< height of the tallest rocks [m] (rocks are 0.5-1 x this)
  double rock_density = 0.0;          ///< rocks per m^2
  uint64_t seed = 0;                  ///< directions, phases, rock placement

  /// All terms zero: the seabed is the plane z = 0.
  bool isFlat() const;
};

/// One sinusoid of the terrain: amplitude * sin(k (sin(az) x + cos(az) y) + phase), k = 2 pi / wavelength,
/// az = direction_deg (compass, clockwise from north).
struct TerrainWave {
  double amplitude = 0.0;    ///< [m]
  double wavelength = 1.0;   ///< [m]
  double direction_deg = 0;  ///< direction of the wave vector, clockwise from north
  double phase = 0.0;        ///< [rad]
};

/// A rock: the dome height * (1 - rho^2 / radius^2)^2 for rho = |(x, y) - centre| < radius.
struct TerrainRock {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double height = 0.0;
  double radius = 1.0;
};

/// The first crossing of a ray with the seabed.
struct TerrainHit {
  double t = 0.0;                                      ///< ray parameter: point = origin + t * direction
  Eigen::Vector3d point = Eigen::Vector3d::Zero();     ///< world ENU
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();  ///< (dh/dx, dh/dy) at the point
  int evaluations = 0;                                 ///< height evaluations spent (for profiling)
};

/// The rocks of recently visited grid cells, for runs of nearby rays (an image's pixels): saves
/// the hash lookups, changes no result. One per thread.
class TerrainCursor {
 public:
  TerrainCursor() = default;

 private:
  friend class SeabedTerrain;
  struct Cell {
    bool valid = false;
    int64_t i = 0, j = 0;
    std::optional<TerrainRock> rock;
  };
  Cell cells[4];  ///< direct-mapped by the cell indices' parities: neighbouring cells never collide
};

class SeabedTerrain {
 public:
  /// The flat seabed z = 0.
  SeabedTerrain() : SeabedTerrain(TerrainParams()) {}
  /// Throws std::invalid_argument on parameters outside their physical ranges (negative heights,
  /// a density the rock grid cannot hold, ...).
  explicit SeabedTerrain(const TerrainParams& params);

  const TerrainParams& params() const { return params_; }
  bool isFlat() const { return flat_; }

  /// Height h(x, y) [m] and, if asked, its exact gradient.
  double height(double x, double y, Eigen::Vector2d* gradient = nullptr) const;
  /// Unit upward surface normal (-h_x, -h_y, 1) / |.|.
  Eigen::Vector3d normal(double x, double y) const;
  /// The large-scale shape only (plane + rolling relief): what an altitude-holding vehicle follows.
  double largeScale(double x, double y, Eigen::Vector2d* gradient = nullptr) const;

  /// The terms, as built from the seed (zero-amplitude terms are left out).
  const std::vector<TerrainWave>& reliefWaves() const { return relief_; }
  const std::vector<TerrainWave>& roughnessWaves() const { return roughness_; }
  /// Edge of the rock grid [m]; the rock of grid cell (i, j), if there is one (it lies inside
  /// [i c, (i + 1) c) x [j c, (j + 1) c)).
  static constexpr double kRockCell = 3.0;
  std::optional<TerrainRock> rockInCell(int64_t i, int64_t j) const;

  /// Upper bound of |grad h| anywhere.
  double slopeBound() const { return slope_bound_; }
  /// h - plane(x, y) always lies in [belowPlane(), abovePlane()].
  double belowPlane() const { return below_plane_; }
  double abovePlane() const { return above_plane_; }
  /// The plane alone (height and, if asked, its gradient).
  double planeHeight(double x, double y, Eigen::Vector2d* gradient = nullptr) const {
    if (gradient) *gradient = Eigen::Vector2d(plane_gx_, plane_gy_);
    return plane_gx_ * x + plane_gy_ * y;
  }

  /// First crossing of origin + t * direction with the seabed for t in (0, t_max], from above.
  /// `t_guess` (if > 0) starts the Newton iteration, e.g. the neighbouring pixel's hit. Returns
  /// false when the ray meets nothing within t_max or the origin is under the seabed. The hit
  /// is exact to about 1e-7 m (its gradient to 3e-4); a ray passing within 1e-4 m above a crest
  /// counts as touching it.
  /// `cursor` (optional) saves work over runs of neighbouring rays.
  bool intersectRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_max, TerrainHit* hit,
                    double t_guess = -1.0, TerrainCursor* cursor = nullptr) const;

 private:
  /// h and its gradient; `with_small_scale` = false leaves out roughness and rocks (then
  /// `cursor` may be null).
  double evaluate(double x, double y, bool with_small_scale, TerrainCursor* cursor, double* gx, double* gy) const;
  double rockHeight(double x, double y, TerrainCursor* cursor, double* gx, double* gy) const;
  const std::optional<TerrainRock>& cachedRock(int64_t i, int64_t j, TerrainCursor* cursor) const;
  bool firstCrossing(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_max, double t_guess,
                     TerrainCursor* cursor, TerrainHit* hit) const;
  /// Whether the horizontal segment passes over any rock.
  bool segmentMeetsRock(double x0, double y0, double x1, double y1, TerrainCursor* cursor) const;

  TerrainParams params_;
  bool flat_ = true;
  double plane_gx_ = 0.0, plane_gy_ = 0.0;  ///< gradient of the plane
  std::vector<TerrainWave> relief_, roughness_;
  /// All waves, relief first, zero-padded to a fixed count (the evaluation loops then have a
  /// fixed length and vectorise): wave vector components, phase and amplitude; the large-scale
  /// amplitudes have the roughness waves' set to zero.
  static constexpr int kMaxWaves = 8;
  std::array<double, kMaxWaves> wave_kx_{}, wave_ky_{}, wave_phase_{}, wave_amplitude_{}, large_scale_amplitude_{};
  double rock_probability_ = 0.0;  ///< per cell
  uint64_t rock_seed_ = 0;
  double smooth_slope_bound_ = 0.0;  ///< |grad h| without the rocks
  double slope_bound_ = 0.0, below_plane_ = 0.0, above_plane_ = 0.0;
};

}  // namespace sim
}  // namespace vims
