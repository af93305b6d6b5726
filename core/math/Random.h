#pragma once
// Small deterministic random numbers: SplitMix64 streams, seeded per item (probe, query) so
// that results never depend on the thread count.
#include <cmath>
#include <cstdint>

#include "core/math/Vec3.h"

namespace ps {

/// SplitMix64 step (Steele et al. 2014): advances `state` and returns 64 random bits.
inline uint64_t splitMix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/// A stream state for item `index` of a run seeded with `seed`.
inline uint64_t streamSeed(uint64_t seed, uint64_t index) {
  uint64_t s = seed ^ (index * 0xD1B54A32D192ED03ull);
  splitMix64(s);
  return s;
}

/// Uniform double in [0, 1).
inline double uniform01(uint64_t& state) {
  return (splitMix64(state) >> 11) * 0x1.0p-53;
}

/// Uniform direction on the unit sphere from two uniforms in [0, 1).
inline Vec3 uniformSphere(double u1, double u2) {
  const double z = 1.0 - 2.0 * u1;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * kPi * u2;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

/// Cosine-weighted direction around +Z (pdf cos(theta) / pi).
inline Vec3 cosineHemisphere(double u1, double u2) {
  const double r = std::sqrt(u1);
  const double phi = 2.0 * kPi * u2;
  return {r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1.0 - u1))};
}

}  // namespace ps
