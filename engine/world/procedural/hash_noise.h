// World-space hashing and value noise for the procedural prior: splitmix64
// mixing of integer lattice coordinates with the seed and a per-use salt,
// mapped to uniform doubles in [0, 1), and smooth 2D/3D value noise built on
// it. Everything is integer arithmetic plus a few double multiplies, so the
// same inputs give the same bits on every standard library (no std::
// distributions, whose algorithms are implementation-defined).
#pragma once

#include <cmath>
#include <cstdint>

namespace icube::world::procedural {

inline uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Order-sensitive combination of a running hash with one more value.
inline uint64_t hash_mix(uint64_t h, uint64_t v) { return splitmix64(h ^ splitmix64(v + 0x632BE59BD9B4E019ull)); }

// Base hash of a (seed, salt) pair; lattice_hash then costs one splitmix64 per call.
inline uint64_t hash_base(uint64_t seed, uint64_t salt) { return hash_mix(splitmix64(seed), salt); }

// Odd multipliers spread each coordinate over all 64 bits before the final mix.
inline uint64_t lattice_hash(uint64_t base, int64_t a, int64_t b = 0, int64_t c = 0) {
  return splitmix64(base ^ (static_cast<uint64_t>(a) * 0x9E3779B97F4A7C15ull) ^
                    (static_cast<uint64_t>(b) * 0xC2B2AE3D27D4EB4Full) ^
                    (static_cast<uint64_t>(c) * 0x165667B19E3779F9ull));
}

inline uint64_t hash_of(uint64_t seed, uint64_t salt, int64_t a, int64_t b = 0, int64_t c = 0) {
  return lattice_hash(hash_base(seed, salt), a, b, c);
}

// The top 53 bits as a double in [0, 1).
inline double to_unit(uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }

inline double hash_u01(uint64_t seed, uint64_t salt, int64_t a, int64_t b = 0, int64_t c = 0) {
  return to_unit(hash_of(seed, salt, a, b, c));
}

// Deterministic stream of uniforms for one object (a parcel, a tree): draw k gives hash(base, k).
class HashStream {
 public:
  explicit HashStream(uint64_t base) : base_(base) {}
  double next() { return to_unit(hash_mix(base_, counter_++)); }
  double range(double lo, double hi) { return lo + (hi - lo) * next(); }

 private:
  uint64_t base_;
  uint64_t counter_ = 0;
};

inline double smooth01(double t) { return t * t * (3.0 - 2.0 * t); }

// Value noise in [0, 1): uniform values on an integer lattice of spacing
// `wavelength` metres, smoothstep-interpolated. Continuous in x, y.
inline double value_noise2(uint64_t seed, uint64_t salt, double x, double y, double wavelength) {
  const double fx = x / wavelength, fy = y / wavelength;
  const double gx = std::floor(fx), gy = std::floor(fy);
  const auto ix = static_cast<int64_t>(gx), iy = static_cast<int64_t>(gy);
  const double tx = smooth01(fx - gx), ty = smooth01(fy - gy);
  const uint64_t h = hash_base(seed, salt);
  const double v00 = to_unit(lattice_hash(h, ix, iy)), v10 = to_unit(lattice_hash(h, ix + 1, iy));
  const double v01 = to_unit(lattice_hash(h, ix, iy + 1)), v11 = to_unit(lattice_hash(h, ix + 1, iy + 1));
  const double a = v00 + (v10 - v00) * tx, b = v01 + (v11 - v01) * tx;
  return a + (b - a) * ty;
}

inline double value_noise3(uint64_t seed, uint64_t salt, double x, double y, double z, double wavelength) {
  const double f[3] = {x / wavelength, y / wavelength, z / wavelength};
  double g[3], t[3];
  int64_t i[3];
  for (int k = 0; k < 3; ++k) {
    g[k] = std::floor(f[k]);
    i[k] = static_cast<int64_t>(g[k]);
    t[k] = smooth01(f[k] - g[k]);
  }
  const uint64_t h = hash_base(seed, salt);
  double acc = 0.0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double w = (dx ? t[0] : 1.0 - t[0]) * (dy ? t[1] : 1.0 - t[1]) * (dz ? t[2] : 1.0 - t[2]);
    acc += w * to_unit(lattice_hash(h, i[0] + dx, i[1] + dy, i[2] + dz));
  }
  return acc;
}

}  // namespace icube::world::procedural
