#include "vims_sim/terrain.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "vims_sim/random.h"

namespace vims {
namespace sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
enum : uint64_t { kStreamRelief = 0x7e11, kStreamRoughness = 0x7e12, kStreamRocks = 0x7e13 };
constexpr double kInverseRockCell = 1.0 / SeabedTerrain::kRockCell;  // (a dome never reaches its cell's edge)
/// Steepest slope of a dome H (1 - rho^2/R^2)^2 is 8 H / (3 sqrt(3) R); with R >= 2.5 H:
constexpr double kRockSlopeBound = 8.0 / (3.0 * 1.7320508075688772 * 2.5);
/// A ray closer than this above a crest counts as touching it [m] (the robust march's end).
constexpr double kGrazingTolerance = 1e-4;
/// Newton steps shorter than this along the ray [m] end the iteration: the remaining error is
/// about curvature * step^2, below 1e-7 m, and the normal (taken one step before) is within
/// curvature * step, below 3e-4 rad, of the hit's.
constexpr double kStepTolerance = 1e-4;

/// sin and cos of n phases at once, exact to ~2e-16 (Cody-Waite reduction by pi/2 and the
/// fdlibm kernel polynomials). Branch-free and without integer conversions, so the compiler
/// vectorises it across the waves: about three times faster than n calls of sincos, which
/// matters because the renderer evaluates the terrain for every pixel.
template <int n>
__attribute__((always_inline)) inline void sinCosBatch(const double* x, double* s, double* c) {
  constexpr double kTwoOverPi = 0.63661977236758134308;
  constexpr double kPio2Hi = 1.57079632673412561417e+00;
  constexpr double kPio2Mid = 6.07710050650619224932e-11;
  constexpr double kPio2Lo = 2.02226624879595063154e-21;
  constexpr double kRoundingShift = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
  for (int i = 0; i < n; ++i) {
    const double q = (x[i] * kTwoOverPi + kRoundingShift) - kRoundingShift;  // nearest integer
    const double r = ((x[i] - q * kPio2Hi) - q * kPio2Mid) - q * kPio2Lo;    // |r| <= pi/4
    const double r2 = r * r;
    const double sin_r =
        r + r * r2 *
                (-1.66666666666666324348e-01 +
                 r2 * (8.33333333332248946124e-03 +
                       r2 * (-1.98412698298579493134e-04 +
                             r2 * (2.75573137070700676789e-06 +
                                   r2 * (-2.50507602534068634195e-08 + r2 * 1.58969099521155010221e-10)))));
    const double cos_r =
        1.0 - 0.5 * r2 +
        r2 * r2 *
            (4.16666666666666019037e-02 +
             r2 * (-1.38888888888741095749e-03 +
                   r2 * (2.48015872894767294178e-05 +
                         r2 * (-2.75573143513906633035e-07 +
                               r2 * (2.08757232129817482790e-09 + r2 * -1.13596475577881948265e-11)))));
    // x = r + q pi/2: rotate (cos r, sin r) by q quarter turns.
    // cos and sin of q pi/2 in double arithmetic (no branches or integer conversions: the loop
    // vectorises): j = q mod 4 and odd = j mod 2 by the same rounding shift.
    const double j = q - 4.0 * (((q * 0.25 - 0.375) + kRoundingShift) - kRoundingShift);
    const double odd = j - 2.0 * (((j * 0.5 - 0.25) + kRoundingShift) - kRoundingShift);
    const double cos_q = (1.0 - odd) * (1.0 - j);  // 1, 0, -1, 0
    const double sin_q = odd * (2.0 - j);          // 0, 1, 0, -1
    s[i] = sin_r * cos_q + cos_r * sin_q;
    c[i] = cos_r * cos_q - sin_r * sin_q;
  }
}

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument("SeabedTerrain: " + message);
}

TerrainWave makeWave(double amplitude, double wavelength, double direction_deg, double phase) {
  TerrainWave w;
  w.amplitude = amplitude;
  w.wavelength = wavelength;
  w.direction_deg = std::fmod(direction_deg, 360.0);
  if (w.direction_deg < 0.0) w.direction_deg += 360.0;
  w.phase = phase;
  return w;
}

}  // namespace

bool TerrainParams::isFlat() const {
  return slope_deg == 0.0 && relief_m == 0.0 && roughness_m == 0.0 && (rock_height_m == 0.0 || rock_density == 0.0);
}

SeabedTerrain::SeabedTerrain(const TerrainParams& params) : params_(params), flat_(params.isFlat()) {
  const TerrainParams& p = params_;
  require(std::isfinite(p.slope_deg) && p.slope_deg >= 0.0 && p.slope_deg < 45.0, "slope must be in [0, 45) deg");
  require(std::isfinite(p.slope_azimuth_deg), "slope azimuth must be finite");
  require(std::isfinite(p.relief_m) && p.relief_m >= 0.0, "relief amplitude must be >= 0");
  require(std::isfinite(p.relief_wavelength_m) && p.relief_wavelength_m > 0.0, "relief wavelength must be > 0");
  require(std::isfinite(p.roughness_m) && p.roughness_m >= 0.0, "roughness must be >= 0");
  // The widest rock (radius 3.5 H) must fit in its grid cell.
  require(std::isfinite(p.rock_height_m) && p.rock_height_m >= 0.0 && 7.0 * p.rock_height_m <= kRockCell,
          "rock height must be in [0, " + std::to_string(kRockCell / 7.0) + "] m");
  require(std::isfinite(p.rock_density) && p.rock_density >= 0.0 && p.rock_density * kRockCell * kRockCell <= 1.0,
          "rock density must be in [0, " + std::to_string(1.0 / (kRockCell * kRockCell)) + "] per m^2");
  if (flat_) return;

  const double slope = std::tan(p.slope_deg * kDeg);
  plane_gx_ = -slope * std::sin(p.slope_azimuth_deg * kDeg);
  plane_gy_ = -slope * std::cos(p.slope_azimuth_deg * kDeg);

  // Every random number is drawn whatever the amplitudes, so one term's parameters never
  // shift another's.
  Rng relief_rng(deriveSeed(p.seed, kStreamRelief));
  const double relief_base = relief_rng.uniform(0.0, 360.0);
  const double relief_direction[3] = {relief_base, relief_base + relief_rng.uniform(50.0, 70.0),
                                      relief_base + relief_rng.uniform(110.0, 130.0)};
  const double relief_length[3] = {1.0, 0.71 * relief_rng.uniform(0.92, 1.08), 0.53 * relief_rng.uniform(0.92, 1.08)};
  const double relief_weight[3] = {0.5, 0.3, 0.2};
  for (int i = 0; i < 3; ++i) {
    const double phase = relief_rng.uniform(0.0, 2.0 * M_PI);
    if (p.relief_m > 0.0) {
      relief_.push_back(makeWave(relief_weight[i] * p.relief_m, relief_length[i] * p.relief_wavelength_m,
                                 relief_direction[i], phase));
    }
  }

  Rng rough_rng(deriveSeed(p.seed, kStreamRoughness));
  const double rough_base = rough_rng.uniform(0.0, 360.0);
  constexpr int kRoughWaves = 5;
  double rough_length[kRoughWaves], rough_direction[kRoughWaves], rough_phase[kRoughWaves];
  double sum_sq = 0.0;
  for (int i = 0; i < kRoughWaves; ++i) {
    rough_length[i] = 5.0 * std::pow(0.2, i / 4.0) * rough_rng.uniform(0.93, 1.07);  // 5 m ... 1 m
    rough_direction[i] = rough_base + 137.5 * i + rough_rng.uniform(-15.0, 15.0);    // golden-angle spread
    rough_phase[i] = rough_rng.uniform(0.0, 2.0 * M_PI);
    sum_sq += rough_length[i] * rough_length[i];
  }
  for (int i = 0; i < kRoughWaves && p.roughness_m > 0.0; ++i) {
    // Amplitudes proportional to the wavelength, scaled so the rms of the sum is roughness_m.
    const double amplitude = p.roughness_m * std::sqrt(2.0) * rough_length[i] / std::sqrt(sum_sq);
    roughness_.push_back(makeWave(amplitude, rough_length[i], rough_direction[i], rough_phase[i]));
  }

  static_assert(3 + kRoughWaves <= kMaxWaves, "every wave has its slot");
  double wave_amplitude_sum = 0.0, wave_slope_sum = 0.0;
  int slot = 0;
  for (const auto* waves : {&relief_, &roughness_}) {
    for (const TerrainWave& w : *waves) {
      const double k = 2.0 * M_PI / w.wavelength;
      wave_kx_[slot] = k * std::sin(w.direction_deg * kDeg);
      wave_ky_[slot] = k * std::cos(w.direction_deg * kDeg);
      wave_phase_[slot] = w.phase;
      wave_amplitude_[slot] = w.amplitude;
      large_scale_amplitude_[slot] = waves == &relief_ ? w.amplitude : 0.0;
      wave_amplitude_sum += w.amplitude;
      wave_slope_sum += w.amplitude * k;
      ++slot;
    }
  }
  const bool rocks = p.rock_height_m > 0.0 && p.rock_density > 0.0;
  rock_probability_ = rocks ? p.rock_density * kRockCell * kRockCell : 0.0;
  rock_seed_ = deriveSeed(p.seed, kStreamRocks);
  // The bounds get a relative margin for rounding; they only steer the ray search.
  smooth_slope_bound_ = (slope + wave_slope_sum) * (1.0 + 1e-9) + 1e-12;
  slope_bound_ = (slope + wave_slope_sum + (rocks ? kRockSlopeBound : 0.0)) * (1.0 + 1e-9) + 1e-12;
  below_plane_ = -wave_amplitude_sum * (1.0 + 1e-9) - 1e-12;
  above_plane_ = (wave_amplitude_sum + (rocks ? p.rock_height_m : 0.0)) * (1.0 + 1e-9) + 1e-12;
}

std::optional<TerrainRock> SeabedTerrain::rockInCell(int64_t i, int64_t j) const {
  if (rock_probability_ <= 0.0) return std::nullopt;
  uint64_t h = hashCoords(rock_seed_, i, j);
  if (hashToUnit(h) >= rock_probability_) return std::nullopt;
  auto next = [&h] {
    h = mix64(h);
    return hashToUnit(h);
  };
  TerrainRock rock;
  rock.height = params_.rock_height_m * (0.5 + 0.5 * next());
  rock.radius = rock.height * (2.5 + next());
  const double free = kRockCell - 2.0 * rock.radius;  // the dome stays inside its cell
  rock.centre.x() = static_cast<double>(i) * kRockCell + rock.radius + free * next();
  rock.centre.y() = static_cast<double>(j) * kRockCell + rock.radius + free * next();
  return rock;
}

bool SeabedTerrain::segmentMeetsRock(double x0, double y0, double x1, double y1, TerrainCursor* cursor) const {
  const auto i0 = static_cast<int64_t>(std::floor(std::min(x0, x1) * kInverseRockCell));
  const auto i1 = static_cast<int64_t>(std::floor(std::max(x0, x1) * kInverseRockCell));
  const auto j0 = static_cast<int64_t>(std::floor(std::min(y0, y1) * kInverseRockCell));
  const auto j1 = static_cast<int64_t>(std::floor(std::max(y0, y1) * kInverseRockCell));
  if ((i1 - i0 + 1) * (j1 - j0 + 1) > 16) return true;  // a long segment: assume the worst
  const Eigen::Vector2d a(x0, y0), ab(x1 - x0, y1 - y0);
  const double length2 = ab.squaredNorm();
  for (int64_t i = i0; i <= i1; ++i) {
    for (int64_t j = j0; j <= j1; ++j) {
      const auto& rock = cachedRock(i, j, cursor);
      if (!rock) continue;
      const double f = length2 > 0.0 ? std::clamp((rock->centre - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
      if ((a + f * ab - rock->centre).norm() < rock->radius) return true;
    }
  }
  return false;
}

const std::optional<TerrainRock>& SeabedTerrain::cachedRock(int64_t i, int64_t j, TerrainCursor* cursor) const {
  TerrainCursor::Cell& cell = cursor->cells[(i & 1) | ((j & 1) << 1)];
  if (!cell.valid || cell.i != i || cell.j != j) {
    cell.rock = rockInCell(i, j);
    cell.i = i;
    cell.j = j;
    cell.valid = true;
  }
  return cell.rock;
}

double SeabedTerrain::rockHeight(double x, double y, TerrainCursor* cursor, double* gx, double* gy) const {
  const auto& cached = cachedRock(static_cast<int64_t>(std::floor(x * kInverseRockCell)),
                                  static_cast<int64_t>(std::floor(y * kInverseRockCell)), cursor);
  if (!cached) return 0.0;
  const TerrainRock& rock = *cached;
  const double dx = x - rock.centre.x(), dy = y - rock.centre.y();
  const double inv_r2 = 1.0 / (rock.radius * rock.radius);
  const double s = (dx * dx + dy * dy) * inv_r2;
  if (s >= 1.0) return 0.0;
  const double w = 1.0 - s;
  *gx += -4.0 * rock.height * w * dx * inv_r2;
  *gy += -4.0 * rock.height * w * dy * inv_r2;
  return rock.height * w * w;
}

// Compiled twice, for AVX2 and for plain SSE2, chosen at load time: the fixed-length wave loops
// run about twice as fast with AVX2's wider vectors. The results are bit-identical (the same IEEE
// operations in the same order: the sums are not reassociated and AVX2 brings no fused
// multiply-add), so a sequence does not depend on the machine that made it.
__attribute__((target_clones("avx2", "default"))) double SeabedTerrain::evaluate(double x, double y,
                                                                                 bool with_small_scale,
                                                                                 TerrainCursor* cursor, double* gx,
                                                                                 double* gy) const {
  double h = plane_gx_ * x + plane_gy_ * y;
  double hx = plane_gx_, hy = plane_gy_;
  // Every slot is evaluated (unused ones have zero amplitude): fixed-length loops vectorise.
  const std::array<double, kMaxWaves>& amplitude = with_small_scale ? wave_amplitude_ : large_scale_amplitude_;
  double phase[kMaxWaves], s[kMaxWaves], c[kMaxWaves];
  for (int i = 0; i < kMaxWaves; ++i) phase[i] = wave_kx_[i] * x + wave_ky_[i] * y + wave_phase_[i];
  sinCosBatch<kMaxWaves>(phase, s, c);
  for (int i = 0; i < kMaxWaves; ++i) {
    h += amplitude[i] * s[i];
    const double slope = amplitude[i] * c[i];
    hx += slope * wave_kx_[i];
    hy += slope * wave_ky_[i];
  }
  if (with_small_scale && rock_probability_ > 0.0) h += rockHeight(x, y, cursor, &hx, &hy);
  *gx = hx;
  *gy = hy;
  return h;
}

double SeabedTerrain::height(double x, double y, Eigen::Vector2d* gradient) const {
  if (flat_) {
    if (gradient) gradient->setZero();
    return 0.0;
  }
  double gx, gy;
  TerrainCursor cursor;
  const double h = evaluate(x, y, true, &cursor, &gx, &gy);
  if (gradient) *gradient = Eigen::Vector2d(gx, gy);
  return h;
}

double SeabedTerrain::largeScale(double x, double y, Eigen::Vector2d* gradient) const {
  if (flat_) {
    if (gradient) gradient->setZero();
    return 0.0;
  }
  double gx, gy;
  const double h = evaluate(x, y, false, nullptr, &gx, &gy);
  if (gradient) *gradient = Eigen::Vector2d(gx, gy);
  return h;
}

Eigen::Vector3d SeabedTerrain::normal(double x, double y) const {
  Eigen::Vector2d g;
  height(x, y, &g);
  return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

bool SeabedTerrain::intersectRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_max,
                                 TerrainHit* hit, double t_guess, TerrainCursor* cursor) const {
  if (cursor) return firstCrossing(origin, direction, t_max, t_guess, cursor, hit);
  TerrainCursor own_cursor;
  return firstCrossing(origin, direction, t_max, t_guess, &own_cursor, hit);
}

bool SeabedTerrain::firstCrossing(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_max,
                                  double t_guess, TerrainCursor* cursor, TerrainHit* hit) const {
  const double ox = origin.x(), oy = origin.y(), oz = origin.z();
  const double dx = direction.x(), dy = direction.y(), dz = direction.z();
  const double length2 = direction.squaredNorm();
  if (!(length2 > 0.0) || !(t_max > 0.0)) return false;
  // Step tolerances in the ray parameter (squared): the renderer calls this once per pixel, so
  // square roots and divisions are kept off the common path.
  const double step_tolerance2 = kStepTolerance * kStepTolerance / length2;
  int evaluations = 0;
  double gx = 0.0, gy = 0.0;
  // g(t): height of the ray point above the seabed; its slope g'(t) = dz - grad h . d_xy.
  auto g = [&](double t) {
    ++evaluations;
    return oz + t * dz - evaluate(ox + t * dx, oy + t * dy, true, cursor, &gx, &gy);
  };
  auto finish = [&](double t) {
    if (t > t_max) return false;
    hit->t = t;
    hit->point = origin + t * direction;
    hit->gradient = Eigen::Vector2d(gx, gy);
    hit->evaluations = evaluations;
    return true;
  };
  if (flat_) {
    if (oz <= 0.0 || dz >= 0.0) return false;
    const double t = -oz / dz;
    if (!finish(t)) return false;
    hit->point.z() = 0.0;
    return true;
  }
  const double lateral2 = dx * dx + dy * dy;
  // g decreases strictly along the whole ray (one crossing at most) when dz + bound * |d_xy| < 0.
  auto monotone = [&](double bound) { return dz < 0.0 && bound * bound * lateral2 < dz * dz; };

  // The common case of a run of pixels: a guess within the step tolerance, on a ray from above
  // every crest that can cross the surface only once. One Newton step that moves less than the
  // tolerance is the crossing (no bracket needed). Otherwise the full search below.
  if (t_guess > 0.0 && t_guess <= t_max && oz - planeHeight(ox, oy) > above_plane_ && monotone(slope_bound_)) {
    const double value = g(t_guess);
    const double step = -value / (dz - (gx * dx + gy * dy));
    if (step * step < step_tolerance2 && t_guess + step > 0.0) return finish(t_guess + step);
    t_guess += step;  // the search below starts from the better guess (it keeps it only inside the bracket)
  }

  // The surface lies between the planes P + below and P + above: they bracket the first hit.
  const double height_above_plane = oz - planeHeight(ox, oy);
  const double descent = dz - (plane_gx_ * dx + plane_gy_ * dy);  // d/dt of the height above the plane
  if (height_above_plane <= below_plane_) return false;           // under the seabed
  double t_lo = 0.0, t_hi = t_max, plane_hit = -1.0;
  if (descent < 0.0) {
    const double inverse_rate = -1.0 / descent;
    t_lo = std::max(0.0, (height_above_plane - above_plane_) * inverse_rate);
    t_hi = std::min(t_max, (height_above_plane - below_plane_) * inverse_rate);
    plane_hit = height_above_plane * inverse_rate;
  } else if (height_above_plane >= above_plane_) {
    return false;  // above every crest and not descending
  }
  if (t_lo > t_max) return false;
  if (t_lo == 0.0 && g(0.0) <= 0.0) return false;  // the origin is among the crests, but under the seabed
  // Where the segment [t_lo, t_hi] passes no rock, the bound of the smooth terms holds there.
  double slope_bound = slope_bound_;
  if (!monotone(slope_bound) && rock_probability_ > 0.0 &&
      !segmentMeetsRock(ox + t_lo * dx, oy + t_lo * dy, ox + t_hi * dx, oy + t_hi * dy, cursor)) {
    slope_bound = smooth_slope_bound_;
  }

  double a = t_lo, t = t_lo, value;
  if (monotone(slope_bound)) {
    // One crossing at most, inside [t_lo, t_hi]: safeguarded Newton from the guess.
    double b = t_hi;
    if (t_hi == t_max && g(t_max) > 0.0) return false;  // the crossing is beyond t_max
    t = t_guess > a && t_guess < b ? t_guess : std::clamp(plane_hit, a, b);
    for (int iteration = 0; iteration < 100; ++iteration) {
      value = g(t);
      if (value == 0.0) return finish(t);
      if (value > 0.0) {
        a = t;
      } else {
        b = t;
      }
      const double step = -value / (dz - (gx * dx + gy * dy));
      const double next = t + step;
      if (next > a && next < b) {
        if (step * step < step_tolerance2) return finish(next);
        t = next;
      } else {
        t = 0.5 * (a + b);  // Newton left the bracket: bisect
        if ((b - a) * (b - a) * length2 < 1e-24) return finish(t);
      }
    }
    return finish(t);
  }

  // The ray may cross the surface more than once: march with steps g / (fastest descent),
  // which cannot pass the first crossing, until within the grazing tolerance.
  const double fastest_descent = -dz + slope_bound * std::sqrt(lateral2);  // g decreases at most this fast
  if (!(fastest_descent > 0.0)) return false;                              // the ray can never come down to the seabed
  value = g(t);
  if (value <= 0.0) return t == 0.0 ? false : finish(t);
  for (int step = 0; value > kGrazingTolerance; ++step) {
    t += value / fastest_descent;
    if (t > t_hi || step > 100000) return false;
    value = g(t);
  }
  // Newton from the marched point (forward only: there is no crossing before it). A ray that
  // only grazes a crest (g' >= 0 or a step far beyond the safe one) touches it here.
  a = t;
  const double touch_gx = gx, touch_gy = gy;
  for (int iteration = 0; iteration < 10; ++iteration) {
    const double slope = dz - (gx * dx + gy * dy);
    if (!(slope < 0.0)) break;
    const double step = -value / slope;
    if (t + step < a || step * fastest_descent > 100.0 * kGrazingTolerance) break;
    if (step * step < step_tolerance2) return finish(t + step);
    t += step;
    value = g(t);
  }
  gx = touch_gx;
  gy = touch_gy;
  return finish(a);
}

}  // namespace sim
}  // namespace vims
