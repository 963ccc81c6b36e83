#pragma once
/// @file random.h
/// @brief Deterministic, platform-independent random numbers and coordinate hashes.
///
/// The standard library's distributions are implementation-defined, so a sequence generated
/// with libstdc++ could differ from one generated with libc++. Everything random in the
/// simulator goes through these few functions instead, which makes a sequence a pure function
/// of (scenario, seed, world seed, options).

#include <cmath>
#include <cstdint>

namespace vims {
namespace sim {

/// SplitMix64 finaliser: a bijective 64-bit mixer with good avalanche.
inline uint64_t mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// Hash of a seed and up to three integer coordinates (lattice points, tile indices, ...).
inline uint64_t hashCoords(uint64_t seed, int64_t a, int64_t b = 0, int64_t c = 0) {
  uint64_t h = mix64(seed);
  h = mix64(h ^ static_cast<uint64_t>(a));
  h = mix64(h ^ (static_cast<uint64_t>(b) * 0xD6E8FEB86659FD93ULL));
  h = mix64(h ^ (static_cast<uint64_t>(c) * 0xCA5A826395121157ULL));
  return h;
}

/// Uniform double in [0, 1) from the top 53 bits of a hash.
inline double hashToUnit(uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

/// Derives an independent seed for a named sub-stream (e.g. "imu noise") of a master seed, so
/// that switching one sensor off or changing its spans never changes another sensor's noise.
inline uint64_t deriveSeed(uint64_t master, uint64_t stream_id) {
  return hashCoords(master, 0x5EED, static_cast<int64_t>(stream_id));
}

/// xoshiro256++ generator with uniform and Gaussian draws.
class Rng {
 public:
  explicit Rng(uint64_t seed) {
    uint64_t x = seed;
    for (auto& s : state_) {
      x = mix64(x);
      s = x;
    }
  }

  uint64_t next() {
    const uint64_t result = rotl(state_[0] + state_[3], 23) + state_[0];
    const uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotl(state_[3], 45);
    return result;
  }

  /// Uniform in [0, 1).
  double uniform() { return hashToUnit(next()); }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal (Box-Muller; the second value of each pair is kept for the next call).
  double gaussian() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = uniform();
    while (u1 <= 0.0) u1 = uniform();
    const double u2 = uniform();
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double angle = 2.0 * M_PI * u2;
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }
  double gaussian(double stddev) { return stddev * gaussian(); }
  /// -1 or +1 with equal probability.
  double sign() { return (next() >> 63) ? 1.0 : -1.0; }

 private:
  static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t state_[4];
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace sim
}  // namespace vims
