#include "vims_sim/seabed_texture.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "vims_sim/random.h"

namespace vims {
namespace sim {
namespace {

// Sub-stream identifiers of the world seed (one per texture ingredient).
enum : uint64_t {
  kSeedSand = 101,
  kSeedTone = 102,
  kSeedRippleWarp = 103,
  kSeedRippleWarp2 = 104,
  kSeedRippleStrength = 105,
  kSeedDensity = 106,
  kSeedDensity2 = 107,
  kSeedObjects = 108,
  kSeedRockSurface = 109,
  kSeedRipples = 110,
  kSeedChangedSeabed = 111,  // of the change seed: the seabed laid in the changed patches
  kSeedChangeMask = 112,     // of the change seed: where the patches are
};

constexpr double kChangePatchSpacing = 2.0;  // [m] value-noise lattice of the changed patches
constexpr double kChangeEdge = 0.08;         // noise units over which a patch edge blends

constexpr double kObjectCell = 0.2;        // [m] hash-grid cell; at most one object per cell
constexpr double kMaxObjectExtent = 0.36;  // [m] no object reaches further from its anchor

double quinticFade(double u) { return u * u * u * (u * (u * 6.0 - 15.0) + 10.0); }

double latticeValue(uint64_t seed, int64_t ix, int64_t iy) { return 2.0 * hashToUnit(hashCoords(seed, ix, iy)) - 1.0; }

/// 2-D value noise in [-1, 1] with lattice spacing `spacing` [m].
double valueNoise(uint64_t seed, double spacing, double x, double y) {
  const double fx = x / spacing, fy = y / spacing;
  const double ix = std::floor(fx), iy = std::floor(fy);
  const double u = quinticFade(fx - ix), v = quinticFade(fy - iy);
  const auto i = static_cast<int64_t>(ix), j = static_cast<int64_t>(iy);
  const double a = latticeValue(seed, i, j), b = latticeValue(seed, i + 1, j);
  const double c = latticeValue(seed, i, j + 1), d = latticeValue(seed, i + 1, j + 1);
  return (a + (b - a) * u) * (1.0 - v) + (c + (d - c) * u) * v;
}

/// The same value noise with the lattice values of one region cached (a tile evaluates each
/// octave at 262144 texels but touches only a few hundred lattice points).
class LatticeNoise {
 public:
  LatticeNoise(uint64_t seed, double spacing, double x0, double y0, double x1, double y1) : spacing_(spacing) {
    ix0_ = static_cast<int64_t>(std::floor(x0 / spacing)) - 1;
    iy0_ = static_cast<int64_t>(std::floor(y0 / spacing)) - 1;
    nx_ = static_cast<int>(static_cast<int64_t>(std::floor(x1 / spacing)) - ix0_ + 3);
    ny_ = static_cast<int>(static_cast<int64_t>(std::floor(y1 / spacing)) - iy0_ + 3);
    values_.resize(static_cast<size_t>(nx_) * ny_);
    for (int j = 0; j < ny_; ++j)
      for (int i = 0; i < nx_; ++i) values_[static_cast<size_t>(j) * nx_ + i] = latticeValue(seed, ix0_ + i, iy0_ + j);
  }
  double at(double x, double y) const {
    const double fx = x / spacing_, fy = y / spacing_;
    const double ix = std::floor(fx), iy = std::floor(fy);
    const double u = quinticFade(fx - ix), v = quinticFade(fy - iy);
    const int i = static_cast<int>(static_cast<int64_t>(ix) - ix0_);
    const int j = static_cast<int>(static_cast<int64_t>(iy) - iy0_);
    const double* row0 = &values_[static_cast<size_t>(j) * nx_ + i];
    const double* row1 = row0 + nx_;
    return (row0[0] + (row0[1] - row0[0]) * u) * (1.0 - v) + (row1[0] + (row1[1] - row1[0]) * u) * v;
  }

 private:
  double spacing_;
  int64_t ix0_ = 0, iy0_ = 0;
  int nx_ = 0, ny_ = 0;
  std::vector<double> values_;
};

int64_t floorDiv(int64_t a, int64_t b) {
  int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) != (b < 0))) --q;
  return q;
}

double clamp01(double x) { return std::min(1.0, std::max(0.0, x)); }

/// Writes one object into the level-0 albedo buffer of a tile. The buffer's texel (r, c) has
/// its centre at world (x0 + (c + 0.5) s, y0 + (r + 0.5) s).
class TileCanvas {
 public:
  TileCanvas(cv::Mat& albedo, double x0, double y0, double texel) : albedo_(albedo), x0_(x0), y0_(y0), s_(texel) {}

  /// Calls f(x, y, value&) for every texel whose centre is within the box around (cx, cy).
  template <typename F>
  void forEachTexel(double cx, double cy, double radius, F&& f) {
    const int c0 = std::max(0, static_cast<int>(std::floor((cx - radius - x0_) / s_)));
    const int c1 = std::min(albedo_.cols - 1, static_cast<int>(std::floor((cx + radius - x0_) / s_)));
    const int r0 = std::max(0, static_cast<int>(std::floor((cy - radius - y0_) / s_)));
    const int r1 = std::min(albedo_.rows - 1, static_cast<int>(std::floor((cy + radius - y0_) / s_)));
    for (int r = r0; r <= r1; ++r) {
      float* row = albedo_.ptr<float>(r);
      const double y = y0_ + (r + 0.5) * s_;
      for (int c = c0; c <= c1; ++c) {
        const double x = x0_ + (c + 0.5) * s_;
        double value = row[c];
        f(x, y, value);
        row[c] = static_cast<float>(value);
      }
    }
  }
  double texel() const { return s_; }

 private:
  cv::Mat& albedo_;
  double x0_, y0_, s_;
};

void drawRock(TileCanvas& canvas, Rng& rng, double cx, double cy, uint64_t surface_seed) {
  const double u = rng.uniform();
  const double radius = 0.03 + 0.2 * std::pow(u, 2.5);  // mostly small stones, a few boulders
  double harmonic[3], harmonic_phase[3], bulge = 0.0;
  for (int k = 0; k < 3; ++k) {
    harmonic[k] = rng.uniform(-0.12, 0.12);
    harmonic_phase[k] = rng.uniform(0.0, 2.0 * M_PI);
    bulge += std::abs(harmonic[k]);
  }
  const double rock_albedo = rng.uniform(0.18, 0.75);
  const double surface_scale = rng.uniform(0.008, 0.02);
  const double shadow_depth = rng.uniform(0.2, 0.4);
  const double s = canvas.texel();
  canvas.forEachTexel(cx, cy, 1.3 * radius * (1.0 + bulge), [&](double x, double y, double& value) {
    const double dx = x - cx, dy = y - cy;
    const double rho = std::sqrt(dx * dx + dy * dy);
    const double phi = std::atan2(dy, dx);
    const double edge = radius * (1.0 + harmonic[0] * std::cos(2.0 * phi + harmonic_phase[0]) +
                                  harmonic[1] * std::cos(3.0 * phi + harmonic_phase[1]) +
                                  harmonic[2] * std::cos(4.0 * phi + harmonic_phase[2]));
    const double q = rho / edge;
    if (q >= 1.3) return;
    if (q >= 1.0) {  // contact shadow / scour ring around the stone
      const double w = 1.0 - (q - 1.0) / 0.3;
      value *= 1.0 - shadow_depth * w * w;
      return;
    }
    const double height = std::sqrt(1.0 - q * q);
    const double speckle = 1.0 + 0.18 * valueNoise(surface_seed, surface_scale, x, y);
    const double rock = rock_albedo * (0.5 + 0.5 * height) * speckle;
    const double coverage = clamp01((1.0 - q) * edge / s + 0.5);
    const double shadowed = value * (1.0 - shadow_depth);
    value = shadowed + (rock - shadowed) * coverage;
  });
}

void drawShell(TileCanvas& canvas, Rng& rng, double cx, double cy) {
  const double a = rng.uniform(0.006, 0.018);
  const double b = a * rng.uniform(0.45, 0.75);
  const double angle = rng.uniform(0.0, M_PI);
  const double shell_albedo = rng.uniform(0.78, 0.97);
  const double ca = std::cos(angle), sa = std::sin(angle);
  const double s = canvas.texel();
  canvas.forEachTexel(cx, cy, a + 2.0 * s, [&](double x, double y, double& value) {
    const double dx = x - cx, dy = y - cy;
    const double u = dx * ca + dy * sa, v = -dx * sa + dy * ca;
    const double q = std::sqrt((u / a) * (u / a) + (v / b) * (v / b));
    if (q >= 1.0 + 2.0 * s / b) return;
    const double ribs = 0.85 + 0.15 * std::cos(9.0 * std::atan2(v, u + a));  // ribs fan out from the hinge
    const double coverage = clamp01((1.0 - q) * b / s + 0.5);
    value += (shell_albedo * ribs - value) * coverage;
  });
}

void drawPebble(TileCanvas& canvas, Rng& rng, double cx, double cy) {
  const double radius = rng.uniform(0.005, 0.014);
  const double albedo = rng.uniform() < 0.6 ? rng.uniform(0.12, 0.3) : rng.uniform(0.7, 0.88);
  const double s = canvas.texel();
  canvas.forEachTexel(cx, cy, radius + 2.0 * s, [&](double x, double y, double& value) {
    const double rho = std::hypot(x - cx, y - cy);
    const double q = rho / radius;
    const double coverage = clamp01((1.0 - q) * radius / s + 0.5);
    if (coverage <= 0.0) return;
    const double height = std::sqrt(std::max(0.0, 1.0 - q * q));
    value += (albedo * (0.7 + 0.3 * height) - value) * coverage;
  });
}

void drawWeed(TileCanvas& canvas, Rng& rng, double cx, double cy) {
  const int blades = 5 + static_cast<int>(rng.uniform() * 8.0);
  const double s = canvas.texel();
  for (int i = 0; i < blades; ++i) {
    const double bx = cx + rng.uniform(-0.08, 0.08), by = cy + rng.uniform(-0.08, 0.08);
    const double angle = rng.uniform(0.0, 2.0 * M_PI);
    const double length = rng.uniform(0.03, 0.1);
    const double half_width = 0.5 * rng.uniform(0.003, 0.007);
    const double albedo = rng.uniform(0.12, 0.25);
    const double ux = std::cos(angle), uy = std::sin(angle);
    canvas.forEachTexel(bx + 0.5 * length * ux, by + 0.5 * length * uy, 0.5 * length + half_width + 2.0 * s,
                        [&](double x, double y, double& value) {
                          const double dx = x - bx, dy = y - by;
                          const double along = std::min(length, std::max(0.0, dx * ux + dy * uy));
                          const double distance = std::hypot(dx - along * ux, dy - along * uy);
                          const double width = half_width * (1.0 - 0.6 * along / length);  // tapering blade
                          const double coverage = clamp01((width - distance) / s + 0.5);
                          value += (albedo - value) * coverage;
                        });
  }
}

}  // namespace

SeabedTexture::SeabedTexture(uint64_t world_seed, SeabedTextureParams params)
    : seed_(world_seed), params_(params), change_threshold_(changeThreshold(params)), capacity_(params.cache_tiles) {
  if (!(params_.texel_size > 0.0)) throw std::invalid_argument("SeabedTexture: texel size must be > 0");
  if (params_.levels < 1 || params_.levels > 10)
    throw std::invalid_argument("SeabedTexture: levels must be in [1, 10]");
  if (params_.tile_texels <= 0 || params_.tile_texels % (1 << (params_.levels - 1)) != 0) {
    throw std::invalid_argument("SeabedTexture: tile_texels must be a positive multiple of 2^(levels - 1)");
  }
  if (params_.cache_tiles < 4) throw std::invalid_argument("SeabedTexture: cache must hold at least 4 tiles");
  if (!(params_.change_fraction >= 0.0 && params_.change_fraction <= 1.0))
    throw std::invalid_argument("SeabedTexture: change fraction must be in [0, 1]");
}

double SeabedTexture::featureDensity(double x, double y) const { return featureDensityOf(seed_, x, y); }

double SeabedTexture::featureDensityOf(uint64_t seed, double x, double y) {
  const double n = 0.7 * valueNoise(deriveSeed(seed, kSeedDensity), 9.0, x, y) +
                   0.3 * valueNoise(deriveSeed(seed, kSeedDensity2), 3.5, x, y);
  const double t = clamp01((0.5 + 0.5 * n - 0.3) / 0.4);
  return t * t * (3.0 - 2.0 * t);
}

double SeabedTexture::changeThreshold(const SeabedTextureParams& params) {
  if (!(params.change_fraction > 0.0)) return 2.0;  // above every noise value: nothing changed
  if (params.change_fraction >= 1.0) return -2.0;   // below every one: all changed
  // The patch noise is stationary: its (1 - fraction) quantile over a large sample of the plane
  // is the level above which that fraction of the area lies.
  const uint64_t mask_seed = deriveSeed(params.change_seed, kSeedChangeMask);
  std::vector<double> values;
  constexpr int kSamples = 200;
  constexpr double kStep = 0.37 * kChangePatchSpacing;  // incommensurate with the lattice
  values.reserve(kSamples * kSamples);
  for (int j = 0; j < kSamples; ++j)
    for (int i = 0; i < kSamples; ++i)
      values.push_back(valueNoise(mask_seed, kChangePatchSpacing, i * kStep, j * kStep));
  const auto k = static_cast<size_t>((1.0 - params.change_fraction) * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

double SeabedTexture::changeWeight(double x, double y) const {
  if (params_.change_fraction <= 0.0) return 0.0;
  return changeWeightOfNoise(valueNoise(deriveSeed(params_.change_seed, kSeedChangeMask), kChangePatchSpacing, x, y));
}

double SeabedTexture::changeWeightOfNoise(double noise) const {
  return clamp01((noise - change_threshold_) / kChangeEdge + 0.5);
}

std::shared_ptr<const SeabedTile> SeabedTexture::generateTile(int64_t tile_x, int64_t tile_y) const {
  const int n = params_.tile_texels;
  const double s = params_.texel_size;
  const double x0 = static_cast<double>(tile_x * n) * s;
  const double y0 = static_cast<double>(tile_y * n) * s;
  cv::Mat albedo = drawAlbedo(seed_, tile_x, tile_y);
  if (params_.change_fraction > 0.0) {
    // Re-laid patches: another seabed's sand and objects, blended over a narrow edge (the patch
    // noise as changeWeight's, its lattice cached for the tile).
    const cv::Mat changed = drawAlbedo(deriveSeed(params_.change_seed, kSeedChangedSeabed), tile_x, tile_y);
    const LatticeNoise mask(deriveSeed(params_.change_seed, kSeedChangeMask), kChangePatchSpacing, x0, y0, x0 + n * s,
                            y0 + n * s);
    for (int r = 0; r < n; ++r) {
      float* row = albedo.ptr<float>(r);
      const float* other = changed.ptr<float>(r);
      const double y = y0 + (r + 0.5) * s;
      for (int c = 0; c < n; ++c) {
        const auto w = static_cast<float>(changeWeightOfNoise(mask.at(x0 + (c + 0.5) * s, y)));
        if (w > 0.0f) row[c] += w * (other[c] - row[c]);
      }
    }
  }

  auto tile = std::make_shared<SeabedTile>();
  tile->tile_x = tile_x;
  tile->tile_y = tile_y;
  tile->levels.resize(params_.levels);
  albedo.convertTo(tile->levels[0], CV_8UC1, 255.0);  // saturating, rounded
  for (int level = 1; level < params_.levels; ++level) {
    const cv::Mat& finer = tile->levels[level - 1];
    cv::resize(finer, tile->levels[level], cv::Size(finer.cols / 2, finer.rows / 2), 0, 0, cv::INTER_AREA);
  }
  return tile;
}

cv::Mat SeabedTexture::drawAlbedo(uint64_t seed, int64_t tile_x, int64_t tile_y) const {
  const int n = params_.tile_texels;
  const double s = params_.texel_size;
  const double x0 = static_cast<double>(tile_x * n) * s;
  const double y0 = static_cast<double>(tile_y * n) * s;
  const double x1 = x0 + n * s, y1 = y0 + n * s;

  // World-level parameters (identical for every tile of this world).
  Rng world_rng(deriveSeed(seed, kSeedRipples));
  const double ripple_direction = world_rng.uniform(0.0, M_PI);
  const double ripple_wavelength = world_rng.uniform(0.085, 0.12);
  const double ripple_dx = std::cos(ripple_direction) * 2.0 * M_PI / ripple_wavelength;
  const double ripple_dy = std::sin(ripple_direction) * 2.0 * M_PI / ripple_wavelength;

  // Sand: tone patches, low-contrast fBm from 1.6 m down to 2.5 cm, and wave ripples that come
  // and go in patches and meander (warped phase).
  const double fbm_spacing[] = {1.6, 0.8, 0.4, 0.2, 0.1, 0.05, 0.025};
  const double fbm_weight[] = {1.0, 0.8, 0.65, 0.55, 0.5, 0.45, 0.4};
  std::vector<LatticeNoise> fbm;
  double fbm_norm = 0.0;
  for (int o = 0; o < 7; ++o) {
    fbm.emplace_back(deriveSeed(seed, kSeedSand + 1000 * (o + 1)), fbm_spacing[o], x0, y0, x1, y1);
    fbm_norm += fbm_weight[o];
  }
  const LatticeNoise tone(deriveSeed(seed, kSeedTone), 6.0, x0, y0, x1, y1);
  const LatticeNoise warp(deriveSeed(seed, kSeedRippleWarp), 0.6, x0, y0, x1, y1);
  const LatticeNoise warp2(deriveSeed(seed, kSeedRippleWarp2), 2.0, x0, y0, x1, y1);
  const LatticeNoise strength(deriveSeed(seed, kSeedRippleStrength), 4.0, x0, y0, x1, y1);

  cv::Mat albedo(n, n, CV_32FC1);
  for (int r = 0; r < n; ++r) {
    float* row = albedo.ptr<float>(r);
    const double y = y0 + (r + 0.5) * s;
    for (int c = 0; c < n; ++c) {
      const double x = x0 + (c + 0.5) * s;
      double f = 0.0;
      for (int o = 0; o < 7; ++o) f += fbm_weight[o] * fbm[o].at(x, y);
      f /= fbm_norm;
      const double ripple_gate = clamp01((strength.at(x, y) + 0.2) / 0.8);
      const double phase = x * ripple_dx + y * ripple_dy + 2.5 * warp.at(x, y) + 4.0 * warp2.at(x, y);
      const double ripple = 0.06 * ripple_gate * (std::sin(phase) + 0.35 * std::sin(2.0 * phase + 0.8));
      row[c] = static_cast<float>(0.5 + 0.07 * tone.at(x, y) + 0.16 * f + ripple);
    }
  }

  // Objects on the hash grid, drawn in global cell order so overlaps resolve identically in
  // every tile. Each cell holds at most one object, more likely where the density is high.
  TileCanvas canvas(albedo, x0, y0, s);
  const uint64_t object_seed = deriveSeed(seed, kSeedObjects);
  const uint64_t surface_seed = deriveSeed(seed, kSeedRockSurface);
  const auto cx0 = static_cast<int64_t>(std::floor((x0 - kMaxObjectExtent) / kObjectCell));
  const auto cx1 = static_cast<int64_t>(std::floor((x1 + kMaxObjectExtent) / kObjectCell));
  const auto cy0 = static_cast<int64_t>(std::floor((y0 - kMaxObjectExtent) / kObjectCell));
  const auto cy1 = static_cast<int64_t>(std::floor((y1 + kMaxObjectExtent) / kObjectCell));
  for (int64_t cy = cy0; cy <= cy1; ++cy) {
    for (int64_t cx = cx0; cx <= cx1; ++cx) {
      Rng rng(hashCoords(object_seed, cx, cy));
      const double ax = (static_cast<double>(cx) + rng.uniform()) * kObjectCell;
      const double ay = (static_cast<double>(cy) + rng.uniform()) * kObjectCell;
      const double occupancy = 0.08 + 0.72 * featureDensityOf(seed, ax, ay);
      if (rng.uniform() >= occupancy) continue;
      const double kind = rng.uniform();
      if (kind < 0.30) {
        drawRock(canvas, rng, ax, ay, hashCoords(surface_seed, cx, cy));
      } else if (kind < 0.58) {
        drawShell(canvas, rng, ax, ay);
      } else if (kind < 0.82) {
        drawPebble(canvas, rng, ax, ay);
      } else {
        drawWeed(canvas, rng, ax, ay);
      }
    }
  }

  return albedo;
}

std::shared_ptr<const SeabedTile> SeabedTexture::tile(int64_t tile_x, int64_t tile_y) const {
  const uint64_t key = (static_cast<uint64_t>(static_cast<uint32_t>(tile_x)) << 32) |
                       static_cast<uint64_t>(static_cast<uint32_t>(tile_y));
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    auto it = cache_.find(key);
    if (it == cache_.end()) break;
    if (it->second.tile) {
      lru_.splice(lru_.begin(), lru_, it->second.lru_position);
      return it->second.tile;
    }
    generated_.wait(lock);  // another thread is generating this tile
  }
  lru_.push_front(key);
  cache_[key] = CacheEntry{nullptr, lru_.begin()};
  lock.unlock();

  std::shared_ptr<const SeabedTile> tile;
  try {
    tile = generateTile(tile_x, tile_y);
  } catch (...) {
    lock.lock();
    lru_.erase(cache_[key].lru_position);
    cache_.erase(key);
    generated_.notify_all();
    throw;
  }

  lock.lock();
  cache_[key].tile = tile;
  ++tiles_generated_;
  // Evict least recently used tiles (never one still being generated; users of an evicted
  // tile keep it alive through their shared_ptr).
  auto victim = lru_.end();
  while (cache_.size() > capacity_ && victim != lru_.begin()) {
    --victim;
    auto entry = cache_.find(*victim);
    if (!entry->second.tile) continue;
    cache_.erase(entry);
    victim = lru_.erase(victim);
  }
  generated_.notify_all();
  return tile;
}

void SeabedTexture::fillPatch(int level, int64_t gx0, int64_t gy0, cv::Mat& patch) const {
  if (level < 0 || level >= params_.levels) throw std::out_of_range("SeabedTexture::fillPatch: bad level");
  if (patch.type() != CV_8UC1) throw std::invalid_argument("SeabedTexture::fillPatch: patch must be CV_8UC1");
  const int64_t n = params_.tile_texels >> level;
  const int64_t gx1 = gx0 + patch.cols, gy1 = gy0 + patch.rows;  // exclusive
  for (int64_t ty = floorDiv(gy0, n); ty <= floorDiv(gy1 - 1, n); ++ty) {
    for (int64_t tx = floorDiv(gx0, n); tx <= floorDiv(gx1 - 1, n); ++tx) {
      const auto t = tile(tx, ty);
      const int64_t ax = std::max(gx0, tx * n), bx = std::min(gx1, (tx + 1) * n);
      const int64_t ay = std::max(gy0, ty * n), by = std::min(gy1, (ty + 1) * n);
      const cv::Rect src(static_cast<int>(ax - tx * n), static_cast<int>(ay - ty * n), static_cast<int>(bx - ax),
                         static_cast<int>(by - ay));
      const cv::Rect dst(static_cast<int>(ax - gx0), static_cast<int>(ay - gy0), src.width, src.height);
      t->levels[level](src).copyTo(patch(dst));
    }
  }
}

size_t SeabedTexture::tilesSpanned(int level, int64_t gx0, int64_t gy0, int cols, int rows) const {
  if (level < 0 || level >= params_.levels || cols <= 0 || rows <= 0) return 0;
  const int64_t n = params_.tile_texels >> level;
  const int64_t nx = floorDiv(gx0 + cols - 1, n) - floorDiv(gx0, n) + 1;
  const int64_t ny = floorDiv(gy0 + rows - 1, n) - floorDiv(gy0, n) + 1;
  return static_cast<size_t>(nx * ny);
}

void SeabedTexture::reserveTiles(size_t tiles) const {
  std::lock_guard<std::mutex> lock(mutex_);
  capacity_ = std::max(capacity_, tiles);
}

size_t SeabedTexture::tilesGenerated() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tiles_generated_;
}

size_t SeabedTexture::tilesCached() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cache_.size();
}

}  // namespace sim
}  // namespace vims
