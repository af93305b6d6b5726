// Compiled as C++17 with no ProbeStudio library: proves core/runtime/ps_volume_reader.h is a
// self-contained C++17 header, and checks its answers against the core's.
// Usage: runtime_reader_cpp17 VOLUME.psv EXPECTED.txt
// EXPECTED.txt (written by tests/core/test_runtime_reader.cpp from the core's answers), one
// query a line, hex floats: x y z hint tet w0 w1 w2 w3 outside sh0 .. sh26.
// Exit 0 when every answer is identical, 1 with the first difference otherwise. A point on a
// face or edge two tetrahedra share may be located in either by builds that round differently
// (one contracting to FMA): then the same probes with the same weights, and the same SH to
// 1e-6, count as identical (a tie; at most one, and one query in 1000 beyond it).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/runtime/ps_volume_reader.h"

namespace {
// True when tets a and b of `vol` give their probes the same weights (those above 0).
bool sameBlend(const ps_runtime::Volume& vol, int a, const float* wa, int b, const float* wb) {
  if (a < 0 || b < 0 || size_t(a) >= vol.tets.size() || size_t(b) >= vol.tets.size()) return false;
  for (int pass = 0; pass < 2; ++pass)
    for (int i = 0; i < 4; ++i) {
      const int probe = vol.tets[size_t(pass ? b : a)][size_t(i)];
      const float w = pass ? wb[i] : wa[i];
      if (!(w > 0)) continue;
      bool found = false;
      for (int j = 0; j < 4; ++j)
        found = found ||
                (vol.tets[size_t(pass ? a : b)][size_t(j)] == probe && (pass ? wa[j] : wb[j]) == w);
      if (!found) return false;
    }
  return true;
}
}  // namespace

#if __cplusplus != 201703L
#error "this test must be compiled as C++17"
#endif

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s VOLUME.psv EXPECTED.txt\n", argv[0]);
    return 2;
  }
  ps_runtime::Volume vol;
  std::string error;
  if (!ps_runtime::loadVolumeFile(argv[1], vol, &error)) {
    std::fprintf(stderr, "load failed: %s\n", error.c_str());
    return 1;
  }
  std::FILE* f = std::fopen(argv[2], "r");
  if (!f) {
    std::fprintf(stderr, "cannot open %s\n", argv[2]);
    return 2;
  }
  int queries = 0, ties = 0;
  char line[4096];
  while (std::fgets(line, sizeof line, f)) {
    char* s = line;
    auto num = [&s] { return std::strtod(s, &s); };
    const double x = num(), y = num(), z = num();
    const int hint = static_cast<int>(num());
    const int tet = static_cast<int>(num());
    float w[4];
    for (float& v : w) v = static_cast<float>(num());
    const bool outside = num() != 0;
    float sh[27];
    for (float& v : sh) v = static_cast<float>(num());
    const ps_runtime::Location loc = ps_runtime::locate(vol, x, y, z, hint);
    float got[27];
    ps_runtime::interpolate(vol, loc, got);
    bool same = loc.tet == tet && loc.outside == outside;
    for (int i = 0; i < 4; ++i) same = same && loc.weights[i] == w[i];
    for (int k = 0; k < 27; ++k) same = same && got[k] == sh[k];
    if (!same && loc.tet != tet && loc.outside == outside &&
        sameBlend(vol, tet, w, loc.tet, loc.weights)) {
      same = true;
      for (int k = 0; k < 27; ++k)
        same = same && std::abs(got[k] - sh[k]) <= 1e-6f * std::max(1.0f, std::abs(sh[k]));
      ties += same;
    }
    if (!same) {
      std::fprintf(stderr,
                   "query %d at (%g, %g, %g) hint %d: core tet %d outside %d w (%g %g %g %g) sh0 "
                   "%g; reader tet %d outside %d w (%g %g %g %g) sh0 %g\n",
                   queries, x, y, z, hint, tet, outside, w[0], w[1], w[2], w[3], sh[0], loc.tet,
                   loc.outside, loc.weights[0], loc.weights[1], loc.weights[2], loc.weights[3],
                   got[0]);
      std::fclose(f);
      return 1;
    }
    ++queries;
  }
  std::fclose(f);
  std::printf("%d queries, all identical to the core's (%d ties)\n", queries, ties);
  return queries > 0 && ties <= 1 + queries / 1000 ? 0 : 1;
}
