#pragma once
// Seeded point sets shared by the tessellation and traversal tests and benchmarks
// (tests/bench/bench_tessellation.cpp), so that both measure the same inputs.
#include <cstdint>
#include <vector>

#include "core/math/Random.h"
#include "core/math/Vec3.h"

namespace ps::testing {

/// n points uniform in the cube [lo, lo + size)^3 from stream `seed`.
inline std::vector<Vec3> randomPoints(int n, uint64_t seed, Vec3 lo = {0, 0, 0}, double size = 1) {
  std::vector<Vec3> pts;
  pts.reserve(n);
  uint64_t s = streamSeed(seed, 0);
  for (int i = 0; i < n; ++i) {
    const double x = uniform01(s), y = uniform01(s), z = uniform01(s);
    pts.push_back(lo + Vec3(x, y, z) * size);
  }
  return pts;
}

/// As randomPoints, rounded to float: a volume's float positions are then the exact input.
inline std::vector<Vec3> randomFloatPoints(int n, uint64_t seed, Vec3 lo = {0, 0, 0},
                                           double size = 1) {
  std::vector<Vec3> pts = randomPoints(n, seed, lo, size);
  for (Vec3& p : pts) p = {float(p.x), float(p.y), float(p.z)};
  return pts;
}

/// The n x n x n grid origin + step * (x, y, z), x fastest.
inline std::vector<Vec3> gridPoints(int n, Vec3 origin = {0, 0, 0}, double step = 1) {
  std::vector<Vec3> pts;
  pts.reserve(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) pts.push_back(origin + Vec3(x, y, z) * step);
  return pts;
}

}  // namespace ps::testing
