#pragma once
/// @file seabed_texture.h
/// @brief The albedo of the flat seabed (z = 0), a deterministic function of the world seed.
///
/// The texture is defined on the whole infinite plane by world-coordinate hash noise and by
/// objects placed on a hash grid, so any region can be generated on its own and always looks
/// the same (a sequence and a later one with the same world seed see the same seabed). It is
/// generated lazily in square tiles (2.56 m at 5 mm per texel by default) with a mip pyramid
/// (2x2 box filter per level), and tiles live in a bounded LRU cache, so memory stays bounded
/// on large areas. The cache is thread-safe; concurrent requests for a tile generate it once.
///
/// Content: sand with low-contrast fBm and wave ripples, rocks (irregular domes with shading
/// and contact shadows), shells (small bright ribbed ellipses), pebbles and weed patches. A
/// low-frequency density field makes sparse sandy stretches with few objects.

#include <condition_variable>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <unordered_map>
#include <vector>

namespace vims {
namespace sim {

struct SeabedTextureParams {
  double texel_size = 0.005;  ///< [m] level-0 texel edge
  int tile_texels = 512;      ///< level-0 texels per tile edge (must be divisible by 2^(levels-1))
  int levels = 6;             ///< mip levels (level L has texel edge texel_size * 2^L)
  /// LRU capacity (a 512-texel tile with its pyramid is ~350 kB); raised by reserveTiles to
  /// what a frame reads.
  size_t cache_tiles = 160;
  /// The seabed changed since the world was surveyed (a repeat mission): this fraction of the
  /// area, in patches about 2 m across placed by change_seed, carries another seabed's sand and
  /// objects (sediment moved, objects came and went). 0: the world seed's seabed everywhere.
  double change_fraction = 0.0;
  uint64_t change_seed = 0;
};

/// One tile: the mip pyramid of the albedo (CV_8UC1, 255 = albedo 1). Row r, column c of level
/// L covers world x in [x0 + c s, x0 + (c+1) s), y in [y0 + r s, y0 + (r+1) s), s = texel edge.
struct SeabedTile {
  int64_t tile_x = 0;
  int64_t tile_y = 0;
  std::vector<cv::Mat> levels;
};

class SeabedTexture {
 public:
  explicit SeabedTexture(uint64_t world_seed, SeabedTextureParams params = SeabedTextureParams());

  const SeabedTextureParams& params() const { return params_; }
  uint64_t worldSeed() const { return seed_; }
  int levels() const { return params_.levels; }
  /// Texel edge of a level [m].
  double texelSize(int level) const { return params_.texel_size * static_cast<double>(1 << level); }
  double tileSize() const { return params_.texel_size * params_.tile_texels; }

  /// Fills `patch` (CV_8UC1, its current size) with the texels of `level` whose global texel
  /// indices start at (gx0, gy0): patch(r, c) is global texel (gx0 + c, gy0 + r), i.e. world
  /// x in [(gx0 + c) s, (gx0 + c + 1) s) and y in [(gy0 + r) s, (gy0 + r + 1) s).
  void fillPatch(int level, int64_t gx0, int64_t gy0, cv::Mat& patch) const;

  /// The tile with indices (tile_x, tile_y), covering world x in [tile_x T, (tile_x + 1) T).
  std::shared_ptr<const SeabedTile> tile(int64_t tile_x, int64_t tile_y) const;

  /// Feature density in [0, 1] at a world point (low: sparse sandy stretch).
  double featureDensity(double x, double y) const;
  /// How much of the changed seabed shows at a world point: 0 (the world's own) to 1.
  double changeWeight(double x, double y) const;

  /// Tiles a fillPatch of `level` at (gx0, gy0) of `cols` x `rows` texels reads.
  size_t tilesSpanned(int level, int64_t gx0, int64_t gy0, int cols, int rows) const;
  /// Keeps at least `tiles` tiles cached from now on. A renderer reserves twice the tiles one
  /// frame reads: a wide lens at a grazing angle reads a large region (its far field on coarse
  /// levels, but a tile is generated with its whole pyramid), and a cache smaller than that
  /// would evict, frame after frame, the tiles the next frame reads again (a fisheye rendered
  /// 60 s of tank in 20 min instead of 15 s).
  void reserveTiles(size_t tiles) const;

  /// Number of tiles generated so far (cache misses) and currently cached.
  size_t tilesGenerated() const;
  size_t tilesCached() const;

 private:
  std::shared_ptr<const SeabedTile> generateTile(int64_t tile_x, int64_t tile_y) const;
  /// Level-0 albedo (CV_32FC1) of one tile of the seabed of `seed`.
  cv::Mat drawAlbedo(uint64_t seed, int64_t tile_x, int64_t tile_y) const;
  static double featureDensityOf(uint64_t seed, double x, double y);
  /// The patch-noise level above which params.change_fraction of the area lies.
  static double changeThreshold(const SeabedTextureParams& params);
  /// changeWeight for a value of the patch noise.
  double changeWeightOfNoise(double noise) const;

  struct CacheEntry {
    std::shared_ptr<const SeabedTile> tile;  ///< null while being generated
    std::list<uint64_t>::iterator lru_position;
  };

  uint64_t seed_;
  SeabedTextureParams params_;
  double change_threshold_;
  mutable std::mutex mutex_;
  mutable std::condition_variable_any generated_;
  mutable std::unordered_map<uint64_t, CacheEntry> cache_;
  mutable std::list<uint64_t> lru_;  ///< most recently used first
  mutable size_t tiles_generated_ = 0;
  mutable size_t capacity_;  ///< params_.cache_tiles, or more after reserveTiles
};

}  // namespace sim
}  // namespace vims
