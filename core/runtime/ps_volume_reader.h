// SPDX-License-Identifier: MIT
// This one file is under the MIT licence (the rest of ProbeStudio is GPL-3.0-or-later), so that
// an engine can copy it:
//
// Copyright (c) 2026 The ProbeStudio authors
//
// Permission is hereby granted, free of charge, to any person obtaining a copy of this software
// and associated documentation files (the "Software"), to deal in the Software without
// restriction, including without limitation the rights to use, copy, modify, merge, publish,
// distribute, sublicense, and/or sell copies of the Software, and to permit persons to whom the
// Software is furnished to do so, subject to the following conditions:
//
// The above copyright notice and this permission notice shall be included in all copies or
// substantial portions of the Software.
//
// THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR IMPLIED, INCLUDING
// BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY, FITNESS FOR A PARTICULAR PURPOSE AND
// NONINFRINGEMENT. IN NO EVENT SHALL THE AUTHORS OR COPYRIGHT HOLDERS BE LIABLE FOR ANY CLAIM,
// DAMAGES OR OTHER LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM,
// OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE SOFTWARE.
//
// ps_volume_reader.h: a dependency-free, header-only C++17 reader for ProbeStudio probe volumes
// (.psv, format versions 1 to 4, docs/formats.md "Probe volume"). Copy this one file into an
// engine.
//
//   ps_runtime::Volume vol;
//   std::string error;
//   if (!ps_runtime::loadVolumeFile("level.psv", vol, &error)) { log(error); return; }
//   ps_runtime::Location loc = ps_runtime::locate(vol, x, y, z, lastTet);
//   float sh[27];  // 9 coefficients x RGB, coefficient-major
//   ps_runtime::interpolate(vol, loc, sh);
//   lastTet = loc.tet;  // coherent queries then walk a few steps
//
// A version 4 volume carries a visibility map per probe; query it with a surface normal (or
// nullptr for a point in the air) for the visibility-aware weights:
//
//   const double n[3] = {nx, ny, nz};
//   ps_runtime::Weights w = ps_runtime::visibleWeights(vol, loc, x, y, z, n);
//   ps_runtime::interpolate(vol, w, sh);
//
// Queries follow Sukys 2014, sec. 3.2.1 ("Interpolation with barycentric coordinates",
// "Traversal", "Drawbacks"), as ProbeStudio's core does (core/traversal/ProbeVolume.cpp): walk
// from a start tetrahedron towards the most negative barycentric coordinate using the stored
// float matrices (double orientations in thin tetrahedra), and clamp a point outside the hull to
// the nearest point of the hull surface. A query clearly inside its hint tetrahedron is answered
// from that tetrahedron's double-precision matrix without a walk. The answers equal the core's
// (tests/runtime). With visibility maps (version 4), visibleWeights() multiplies each probe's
// barycentric weight by DDGI's visibility and normal terms (Majercik et al. 2019, "Dynamic Diffuse
// Global Illumination with Ray-Traced Irradiance Probes", JCGT 8(2), sec. 5.2), as
// core/traversal/VisibleInterpolation.h states and computes; where no probe of the query's
// tetrahedron sees it, the probes of the tetrahedra around it that do (the neighbour search,
// from the stored face neighbours alone).
//
// Loading validates everything before allocating: the header's counts must match the file's
// size exactly, the CRC-32 must match, and every index must be in range; a bad file gives
// false and a one-line reason, never a crash. A version 2 or 3 file with leak cut planes is
// refused (its lighting was made to be read through the cuts, which this reader does not
// apply): re-bake it. Needs a little-endian host.
#ifndef PS_VOLUME_READER_H
#define PS_VOLUME_READER_H

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace ps_runtime {

struct Volume {
  std::vector<float> positions;                   // 3 per probe
  std::vector<float> sh;                          // 27 per probe
  std::vector<std::array<int32_t, 4>> tets;       // 4 probe indices
  std::vector<std::array<int32_t, 4>> neighbors;  // opposite vertex i; -1 on the hull
  std::vector<std::array<float, 9>> matrices;     // (w0, w1, w2) = M (p - v3)
  std::vector<std::array<int32_t, 2>> hullFaces;  // (tet, local vertex opposite the face)
  // Visibility maps (version 4; 0 and empty otherwise): visibilityMapSize texels per side of an
  // octahedral map per probe, each texel the mean and mean square of the distance (m, m^2) from
  // the probe to the first surface in its directions (2 R^2 floats per probe, texel i + R j at
  // octahedral (u, v) in [-1 + 2 i / R, -1 + 2 (i + 1) / R] x ...); probeFlags bit 0: the probe
  // is inside geometry (it gets no visibility weight).
  int32_t visibilityMapSize = 0;
  std::vector<uint8_t> probeFlags;
  std::vector<float> visibility;
  std::string metadataJson;
  // Derived at load: thin tets (walk with double orientations), per tet the double-precision
  // barycentric matrix with its origin v3 (the fast path of locate(); NaN for thin tets) and a
  // cold-start grid.
  std::vector<uint8_t> thin;
  struct alignas(32) Frame {
    double m[9];       // (w0, w1, w2) = m (p - origin), w3 = 1 - sum
    double origin[3];  // v3
  };
  std::vector<Frame> frames;
  std::vector<int32_t> grid;
  float gridLo[3] = {0, 0, 0}, gridCell[3] = {1, 1, 1};
  int32_t gridDims[3] = {0, 0, 0};

  size_t probeCount() const { return positions.size() / 3; }
};

struct Location {
  int32_t tet = -1;
  float weights[4] = {0, 0, 0, 0};  // barycentric, in [0, 1], sum 1
  bool outside = false;             // clamped to the hull
};

namespace detail {

constexpr double kBarycentricSlack = double(1e-5f);
constexpr double kThinRelativeVolume = 1e-2;
constexpr double kFlatRelativeVolume = 1e-12;
constexpr double kFastPathMargin = kBarycentricSlack;

struct V3 {
  double x, y, z;
  double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};
inline V3 operator-(V3 a, V3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline V3 operator+(V3 a, V3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline V3 operator*(V3 a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
inline double dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline V3 cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double orient(V3 a, V3 b, V3 c, V3 d) {
  return dot(b - a, cross(c - a, d - a));
}

inline V3 pos(const Volume& v, int32_t i) {
  return {v.positions[3 * size_t(i)], v.positions[3 * size_t(i) + 1],
          v.positions[3 * size_t(i) + 2]};
}

inline uint32_t crc32(const uint8_t* p, size_t n) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) c = table[(c ^ p[i]) & 0xFF] ^ (c >> 8);
  return ~c;
}

inline bool fail(std::string* error, const std::string& msg) {
  if (error) *error = msg;
  return false;
}

inline bool isFlat(const std::array<float, 9>& m) {
  for (float x : m)
    if (x != 0.0f) return false;
  return true;
}

inline std::array<double, 4> matrixWeights(const Volume& v, int32_t t, V3 p) {
  const auto& m = v.matrices[size_t(t)];
  const V3 d = p - pos(v, v.tets[size_t(t)][3]);
  std::array<double, 4> w;
  w[0] = double(m[0]) * d.x + double(m[1]) * d.y + double(m[2]) * d.z;
  w[1] = double(m[3]) * d.x + double(m[4]) * d.y + double(m[5]) * d.z;
  w[2] = double(m[6]) * d.x + double(m[7]) * d.y + double(m[8]) * d.z;
  w[3] = 1.0 - w[0] - w[1] - w[2];
  return w;
}

inline std::array<double, 4> orientWeights(const Volume& v, int32_t t, V3 p, bool& flat) {
  V3 q[4];
  for (int i = 0; i < 4; ++i) q[i] = pos(v, v.tets[size_t(t)][i]);
  std::array<double, 4> o;
  o[0] = orient(p, q[1], q[2], q[3]);
  o[1] = orient(q[0], p, q[2], q[3]);
  o[2] = orient(q[0], q[1], p, q[3]);
  o[3] = orient(q[0], q[1], q[2], p);
  flat = isFlat(v.matrices[size_t(t)]);
  if (!flat) {
    const double vol = orient(q[0], q[1], q[2], q[3]);
    for (double& x : o) x /= vol;
    return o;
  }
  for (int i = 0; i < 4; ++i) {
    const V3 a = q[(i + 1) & 3], b = q[(i + 2) & 3], c = q[(i + 3) & 3];
    const double n = std::sqrt(dot(cross(b - a, c - a), cross(b - a, c - a)));
    o[i] = n > 0 ? o[i] / n : 0.0;
  }
  return o;
}

// Fast path (Sukys 3.2.1 "Drawbacks": the precomputed matrix, here in double): the weights from
// tet t's double frame when all four are >= kFastPathMargin (p is clearly inside t, so the walk
// would stop there); false near a face, edge or vertex, in a thin tet, or for a non-finite p.
// Rounded to float they are within 1e-7 of the exact barycentrics and sum to 1 within 1e-7.
inline bool frameWeights(const Volume& v, int32_t t, V3 p, float out[4]) {
  if (v.frames.size() != v.tets.size()) return false;
  const Volume::Frame& f = v.frames[size_t(t)];
  const double dx = p.x - f.origin[0], dy = p.y - f.origin[1], dz = p.z - f.origin[2];
  const double w0 = f.m[0] * dx + f.m[1] * dy + f.m[2] * dz;
  const double w1 = f.m[3] * dx + f.m[4] * dy + f.m[5] * dz;
  const double w2 = f.m[6] * dx + f.m[7] * dy + f.m[8] * dz;
  const double w3 = 1.0 - w0 - w1 - w2;
  const double e = kFastPathMargin;
  if (!((w0 >= e) & (w1 >= e) & (w2 >= e) & (w3 >= e))) return false;
  out[0] = static_cast<float>(w0);
  out[1] = static_cast<float>(w1);
  out[2] = static_cast<float>(w2);
  out[3] = static_cast<float>(w3);
  return true;
}

inline int argMin(const std::array<double, 4>& w) {
  int k = 0;
  for (int i = 1; i < 4; ++i)
    if (w[i] < w[k]) k = i;
  return k;
}

inline void cleanWeights(const std::array<double, 4>& w, float out[4]) {
  double c[4], sum = 0;
  for (int i = 0; i < 4; ++i) {
    c[i] = std::isfinite(w[i]) ? std::min(std::max(w[i], 0.0), 1.0) : 0.0;
    sum += c[i];
  }
  for (int i = 0; i < 4; ++i) out[i] = sum > 0 ? static_cast<float>(c[i] / sum) : 0.25f;
}

enum class WalkKind { Inside, Outside, Failed };
struct Walk {
  WalkKind kind = WalkKind::Failed;
  int32_t tet = -1;
  std::array<double, 4> w{};
};

// Sukys 3.2.1 "Traversal", with Brent's cycle detection and a step cap.
inline Walk walk(const Volume& v, V3 p, int32_t start) {
  const bool haveThin = v.thin.size() == v.tets.size();
  const size_t cap = 4 * v.tets.size() + 100;
  int32_t t = start, tortoise = start;
  size_t power = 1, lambda = 0;
  for (size_t step = 0; step < cap; ++step) {
    std::array<double, 4> w;
    bool flat = false;
    if (haveThin && v.thin[size_t(t)]) {
      w = orientWeights(v, t, p, flat);
    } else {
      w = matrixWeights(v, t, p);
      if (w[3] == 1.0 && w[0] == 0.0 && w[1] == 0.0 && w[2] == 0.0 && isFlat(v.matrices[size_t(t)]))
        w = orientWeights(v, t, p, flat);
    }
    const int k = argMin(w);
    if (!flat && w[k] >= -kBarycentricSlack) return {WalkKind::Inside, t, w};
    const int32_t n = v.neighbors[size_t(t)][k];
    if (n < 0) return {WalkKind::Outside, t, w};
    t = n;
    if (t == tortoise) return {WalkKind::Failed, t, w};
    if (++lambda == power) {
      tortoise = t;
      power *= 2;
      lambda = 0;
    }
  }
  return {WalkKind::Failed, t, {}};
}

// Closest point on triangle abc (Ericson, Real-Time Collision Detection, 5.1.5).
inline V3 closestOnTriangle(V3 p, V3 a, V3 b, V3 c, double bary[3]) {
  const V3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  auto set = [&](double x, double y, double z) { bary[0] = x, bary[1] = y, bary[2] = z; };
  if (d1 <= 0 && d2 <= 0) return set(1, 0, 0), a;
  const V3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return set(0, 1, 0), b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double s = d1 / (d1 - d3);
    set(1 - s, s, 0);
    return a + ab * s;
  }
  const V3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return set(0, 0, 1), c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double s = d2 / (d2 - d6);
    set(1 - s, 0, s);
    return a + ac * s;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    set(0, 1 - s, s);
    return b + (c - b) * s;
  }
  const double denom = va + vb + vc;
  if (!(denom > 0)) return set(1, 0, 0), a;
  const double sv = vb / denom, sw = vc / denom;
  set(1 - sv - sw, sv, sw);
  return a + ab * sv + ac * sw;
}

// Sukys 3.2.1 "Drawbacks": outside the hull, clamp to the nearest point of the hull surface.
inline Location clampToHull(const Volume& v, V3 p) {
  Location best;
  best.outside = true;
  double bestD2 = std::numeric_limits<double>::infinity();
  for (const auto& hf : v.hullFaces) {
    const int32_t t = hf[0];
    const int opp = hf[1];
    const int i0 = (opp + 1) & 3, i1 = (opp + 2) & 3, i2 = (opp + 3) & 3;
    const auto& tet = v.tets[size_t(t)];
    double bary[3];
    const V3 q = closestOnTriangle(p, pos(v, tet[i0]), pos(v, tet[i1]), pos(v, tet[i2]), bary);
    const double d2 = dot(q - p, q - p);
    if (d2 < bestD2) {
      bestD2 = d2;
      best.tet = t;
      std::array<double, 4> w{};
      w[i0] = bary[0];
      w[i1] = bary[1];
      w[i2] = bary[2];
      cleanWeights(w, best.weights);
    }
  }
  return best;
}

inline Location bruteForce(const Volume& v, V3 p) {
  int32_t bestTet = -1;
  double bestMin = -std::numeric_limits<double>::infinity();
  std::array<double, 4> bestW{};
  for (int32_t t = 0; t < static_cast<int32_t>(v.tets.size()); ++t) {
    bool flat = false;
    const auto w = orientWeights(v, t, p, flat);
    if (flat) continue;
    const double m = *std::min_element(w.begin(), w.end());
    if (m > bestMin) {
      bestMin = m;
      bestTet = t;
      bestW = w;
    }
  }
  if (bestTet < 0 || bestMin < -kBarycentricSlack) return clampToHull(v, p);
  Location loc;
  loc.tet = bestTet;
  cleanWeights(bestW, loc.weights);
  return loc;
}

inline int32_t coldStart(const Volume& v, V3 p) {
  if (v.grid.empty()) return 0;
  int32_t c[3];
  for (int a = 0; a < 3; ++a) {
    const double x = (p[a] - v.gridLo[a]) / v.gridCell[a];
    const double clamped = std::min(std::max(std::isfinite(x) ? x : 0.0, 0.0), v.gridDims[a] - 1.0);
    c[a] = static_cast<int32_t>(clamped);
  }
  return v
      .grid[size_t(c[0]) + size_t(v.gridDims[0]) * (size_t(c[1]) + size_t(v.gridDims[1]) * c[2])];
}

// The same derived data as the core's buildLocator(): thin tets and a cold-start grid of about
// one cell per probe whose cells hold the tet found at their centre.
inline void buildLocator(Volume& v) {
  v.thin.assign(v.tets.size(), 0);
  v.frames.assign(v.tets.size(), Volume::Frame{});
  v.grid.clear();
  for (int a = 0; a < 3; ++a) v.gridDims[a] = 0;
  if (v.tets.empty()) return;
  for (size_t k = 0; k < v.tets.size(); ++k) {
    V3 q[4];
    for (int i = 0; i < 4; ++i) q[i] = pos(v, v.tets[k][i]);
    double l2 = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) l2 = std::max(l2, dot(q[i] - q[j], q[i] - q[j]));
    const double l = std::sqrt(l2);
    const double rel = std::abs(orient(q[0], q[1], q[2], q[3])) / (l * l * l);
    const bool thin = !(rel >= kThinRelativeVolume);
    v.thin[k] = thin;
    // Frame: [v0 - v3, v1 - v3, v2 - v3]^-1 in double, origin v3.
    Volume::Frame& f = v.frames[k];
    const V3 a = q[0] - q[3], b = q[1] - q[3], c = q[2] - q[3];
    const V3 rows[3] = {cross(b, c), cross(c, a), cross(a, b)};
    const double det = dot(a, rows[0]);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j)
        f.m[3 * i + j] = thin ? std::numeric_limits<double>::quiet_NaN() : rows[i][j] / det;
      f.origin[i] = q[3][i];
    }
  }
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<double>::infinity();
    hi[a] = -std::numeric_limits<double>::infinity();
  }
  for (size_t i = 0; i < v.probeCount(); ++i)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(v.positions[3 * i + a]));
      hi[a] = std::max(hi[a], double(v.positions[3 * i + a]));
    }
  const double target = std::min(std::max(double(v.probeCount()), 1.0), double(1 << 20));
  const double e[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  const double maxE = std::max(e[0], std::max(e[1], e[2]));
  double volume = 1;
  for (int a = 0; a < 3; ++a) volume *= std::max(e[a], 1e-3 * maxE);
  const double cell = std::cbrt(volume / target);
  size_t cells = 1;
  for (int a = 0; a < 3; ++a) {
    const int32_t n = static_cast<int32_t>(std::min(std::max(std::ceil(e[a] / cell), 1.0), 1024.0));
    v.gridDims[a] = n;
    v.gridLo[a] = static_cast<float>(lo[a]);
    v.gridCell[a] = static_cast<float>(std::max(e[a] / n, 1e-30));
    cells *= size_t(n);
  }
  v.grid.assign(cells, 0);
  int32_t t = 0;
  for (int32_t z = 0; z < v.gridDims[2]; ++z)
    for (int32_t y = 0; y < v.gridDims[1]; ++y)
      for (int32_t x = 0; x < v.gridDims[0]; ++x) {
        const V3 centre = {v.gridLo[0] + (x + 0.5) * double(v.gridCell[0]),
                           v.gridLo[1] + (y + 0.5) * double(v.gridCell[1]),
                           v.gridLo[2] + (z + 0.5) * double(v.gridCell[2])};
        const Walk r = walk(v, centre, t);
        if (r.kind != WalkKind::Failed) t = r.tet;
        v.grid[size_t(x) + size_t(v.gridDims[0]) * (size_t(y) + size_t(v.gridDims[1]) * z)] = t;
      }
}

template <typename T>
inline void readArray(const uint8_t*& p, std::vector<T>& out, size_t count) {
  out.resize(count);
  if (count) std::memcpy(out.data(), p, count * sizeof(T));
  p += count * sizeof(T);
}

}  // namespace detail

/// Loads a volume from `size` bytes. On failure returns false and sets *error (when given) to
/// a one-line reason; `out` is then unspecified.
inline bool loadVolumeMemory(const void* data, size_t size, Volume& out,
                             std::string* error = nullptr) {
  using detail::fail;
  static_assert(sizeof(float) == 4, "IEEE-754 binary32 floats required");
  const uint32_t probe = 1;
  uint8_t first;
  std::memcpy(&first, &probe, 1);
  if (first != 1) return fail(error, "big-endian hosts are not supported");
  const auto* b = static_cast<const uint8_t*>(data);
  if (size < 8 + 6 * 4 + 4) return fail(error, "truncated: " + std::to_string(size) + " bytes");
  if (std::memcmp(b, "PSVOLUM1", 8) != 0) return fail(error, "not a ProbeStudio volume");
  uint32_t h[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  std::memcpy(h, b + 8, 6 * 4);
  if (h[0] < 1 || h[0] > 4) return fail(error, "unsupported version " + std::to_string(h[0]));
  // Version 4: a visibility map size, then the probe flags and maps after the hull. Versions 2
  // and 3 (read, never written): a leak-cut plane count C, then the cut starts and planes after
  // the hull; version 3 also the map size and the maps after the cuts.
  const bool cuts = h[0] == 2 || h[0] == 3, maps = h[0] >= 3;
  const size_t kHeader = 8 + (6 + (cuts ? 1 : 0) + (maps ? 1 : 0)) * 4;
  if (size < kHeader + 4) return fail(error, "truncated: " + std::to_string(size) + " bytes");
  if (cuts) std::memcpy(h + 6, b + 8 + 6 * 4, 4);
  if (maps) std::memcpy(h + 7, b + kHeader - 4, 4);
  if (h[1] != 2) return fail(error, "unsupported SH order " + std::to_string(h[1]));
  const uint64_t P = h[2], T = h[3], H = h[4], M = h[5], C = h[6], R = h[7];
  if (maps && (R < 1 || R > 64))
    return fail(error, "visibility map size " + std::to_string(R) + ": expected 1 to 64");
  const uint64_t need = kHeader + P * 30 * 4 + T * 17 * 4 + H * 8 +
                        (cuts ? (T + 1) * 4 + C * 20 : 0) + (maps ? P * (1 + 8 * R * R) : 0) + M +
                        4;
  if (need != size)
    return fail(error, "header counts need " + std::to_string(need) + " bytes, file has " +
                           std::to_string(size));
  uint32_t crc;
  std::memcpy(&crc, b + size - 4, 4);
  if (detail::crc32(b, size - 4) != crc) return fail(error, "CRC-32 mismatch: corrupted file");
  if (P < 4 || T < 1) return fail(error, "a volume needs at least 4 probes and 1 tetrahedron");
  if (C > 0)
    return fail(error, "cut_plane_count: " + std::to_string(C) +
                           " leak cut planes, which this reader does not apply (the visibility "
                           "maps and their neighbour search replace them): re-bake the volume");
  const uint8_t* p = b + kHeader;
  detail::readArray(p, out.positions, size_t(P) * 3);
  detail::readArray(p, out.sh, size_t(P) * 27);
  detail::readArray(p, out.tets, size_t(T));
  detail::readArray(p, out.neighbors, size_t(T));
  detail::readArray(p, out.matrices, size_t(T));
  detail::readArray(p, out.hullFaces, size_t(H));
  if (cuts) {  // C = 0: T + 1 cut starts, each 0
    std::vector<uint32_t> cutStart;
    detail::readArray(p, cutStart, size_t(T) + 1);
    for (size_t t = 0; t <= T; ++t)
      if (cutStart[t] != 0) return fail(error, "cut_start[" + std::to_string(t) + "]: expected 0");
  }
  out.visibilityMapSize = int32_t(R);
  out.probeFlags.clear();
  out.visibility.clear();
  if (maps) {
    detail::readArray(p, out.probeFlags, size_t(P));
    detail::readArray(p, out.visibility, size_t(P * 2 * R * R));
  }
  out.metadataJson.assign(reinterpret_cast<const char*>(p), size_t(M));
  for (float x : out.positions)
    if (!std::isfinite(x)) return fail(error, "NaN or infinite probe position");
  for (float x : out.sh)
    if (!std::isfinite(x)) return fail(error, "NaN or infinite SH coefficient");
  for (size_t t = 0; t < T; ++t) {
    for (int k = 0; k < 4; ++k) {
      if (out.tets[t][k] < 0 || uint64_t(out.tets[t][k]) >= P)
        return fail(error, "tets[" + std::to_string(t) + "]: probe index out of range");
      if (out.neighbors[t][k] < -1 || int64_t(out.neighbors[t][k]) >= int64_t(T))
        return fail(error, "neighbors[" + std::to_string(t) + "]: index out of range");
    }
    for (float m : out.matrices[t])
      if (!std::isfinite(m)) return fail(error, "matrices[" + std::to_string(t) + "]: NaN");
  }
  for (size_t k = 0; k < H; ++k)
    if (out.hullFaces[k][0] < 0 || uint64_t(out.hullFaces[k][0]) >= T || out.hullFaces[k][1] < 0 ||
        out.hullFaces[k][1] > 3)
      return fail(error, "hull_faces[" + std::to_string(k) + "]: index out of range");
  for (size_t i = 0; i < out.probeFlags.size(); ++i)
    if (out.probeFlags[i] > 1)
      return fail(error, "probe flag " + std::to_string(i) + ": expected 0 or 1");
  for (size_t k = 0; k < out.visibility.size(); k += 2) {
    const float mu = out.visibility[k], mu2 = out.visibility[k + 1];
    if (!std::isfinite(mu) || !std::isfinite(mu2) || mu < 0 || mu2 < 0)
      return fail(error, "visibility of probe " + std::to_string(k / size_t(2 * R * R)) +
                             ": NaN, infinite or negative distance moment");
    if (double(mu) * mu > double(mu2) * (1 + 1e-5))
      return fail(error, "visibility of probe " + std::to_string(k / size_t(2 * R * R)) +
                             ": negative variance (mean squared exceeds mean square)");
  }
  detail::buildLocator(out);
  return true;
}

/// Loads a .psv file. On failure returns false with a reason naming the file.
inline bool loadVolumeFile(const char* path, Volume& out, std::string* error = nullptr) {
  std::FILE* f = std::fopen(path, "rb");
  if (!f) return detail::fail(error, std::string(path) + ": cannot open");
  std::vector<uint8_t> bytes;
  uint8_t buf[65536];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) bytes.insert(bytes.end(), buf, buf + n);
  const bool readError = std::ferror(f) != 0;
  std::fclose(f);
  if (readError) return detail::fail(error, std::string(path) + ": read error");
  std::string why;
  if (!loadVolumeMemory(bytes.data(), bytes.size(), out, &why))
    return detail::fail(error, std::string(path) + ": " + why);
  return true;
}

namespace detail {
inline Location locateBarycentric(const Volume& v, double x, double y, double z, int32_t hintTet) {
  if (v.tets.empty()) return {};
  const V3 p = {x, y, z};
  const int32_t n = static_cast<int32_t>(v.tets.size());
  const bool hinted = hintTet >= 0 && hintTet < n;
  if (hinted) {  // clearly inside the hint tet: no walk (rejects a non-finite p)
    Location loc;
    if (frameWeights(v, hintTet, p, loc.weights)) {
      loc.tet = hintTet;
      return loc;
    }
  }
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
    Location loc;
    loc.tet = 0;
    for (float& w : loc.weights) w = 0.25f;
    loc.outside = true;
    return loc;
  }
  const int32_t start = hinted ? hintTet : coldStart(v, p);
  const Walk r = walk(v, p, start);
  if (r.kind == WalkKind::Inside) {
    Location loc;
    loc.tet = r.tet;
    if (hinted && frameWeights(v, r.tet, p, loc.weights)) return loc;  // as the core does
    bool flat = false;
    const auto w = orientWeights(v, r.tet, p, flat);
    cleanWeights(flat ? r.w : w, loc.weights);
    return loc;
  }
  if (r.kind == WalkKind::Outside) return clampToHull(v, p);
  return bruteForce(v, p);
}

}  // namespace detail

/// The tetrahedron containing (x, y, z) and its barycentric weights, walking from `hintTet` (the
/// previous query's tet, or -1). Outside the hull: the nearest hull point (outside = true).
inline Location locate(const Volume& v, double x, double y, double z, int32_t hintTet = -1) {
  return detail::locateBarycentric(v, x, y, z, hintTet);
}

/// The SH (27 floats: 9 coefficients x RGB) blended with the location's weights.
inline void interpolate(const Volume& v, const Location& loc, float out[27]) {
  double acc[27] = {};
  if (loc.tet >= 0)
    for (int i = 0; i < 4; ++i) {
      const float* s = v.sh.data() + size_t(27) * size_t(v.tets[size_t(loc.tet)][i]);
      for (int k = 0; k < 27; ++k) acc[k] += double(loc.weights[i]) * s[k];
    }
  for (int k = 0; k < 27; ++k) out[k] = static_cast<float>(acc[k]);
}

/// The most probes one query's visibility-aware weights blend (the neighbour search's).
constexpr int kMaxWeightedProbes = 16;

/// The probes of a query and their visibility-aware weights (visibleWeights): the four of its
/// tetrahedron, or those of the neighbour search that see it (fallback 3).
struct Weights {
  int32_t tet = -1;   // the query's tetrahedron
  int32_t count = 0;  // entries in use: 4, or 1 to kMaxWeightedProbes with fallback 3
  int32_t probes[kMaxWeightedProbes] = {};
  double weights[kMaxWeightedProbes] = {};  // non-negative, sum 1
  bool outside = false;                     // clamped to the hull
  // 0: barycentric x visibility; 1: visibility alone; 2: barycentric alone; 3: the neighbour
  // search
  int fallback = 0;
};

namespace detail {

// Asks the cache for the line holding p (no effect on results).
inline void prefetch(const void* p) {
#if defined(__GNUC__) || defined(__clang__)
  __builtin_prefetch(p);
#else
  (void)p;
#endif
}

// Texel i + R j, i and j in [-1, R], a step beyond an edge mirrored across the seam.
inline int octWrappedTexel(int i, int j, int R) {
  if (i < 0) {
    i = 0;
    j = R - 1 - j;
  } else if (i >= R) {
    i = R - 1;
    j = R - 1 - j;
  }
  if (j < 0) {
    j = 0;
    i = R - 1 - i;
  } else if (j >= R) {
    j = R - 1;
    i = R - 1 - i;
  }
  return i + R * j;
}

constexpr double kVisibilityVarianceBias = 0.05;
constexpr double kVisibilityMinFactor = 1e-3;

// The visibility steps, as the core's (core/traversal/VisibleInterpolation.cpp), operation for
// operation: the same IEEE results.

// Texel coordinates of direction (dx, dy, dz) (any length > 0) in an R x R map, half = R / 2,
// offset = R / 2 - 1/2: the octahedral encoding (Cigolle et al. 2014) of d / |d|_1 (that of
// d / |d|), the lower hemisphere folded onto the corners, then (u + 1) R / 2 - 1/2.
inline void texelCoords(double dx, double dy, double dz, double half, double offset, double& x,
                        double& y) {
  const double is = 1.0 / (std::abs(dx) + std::abs(dy) + std::abs(dz));
  const double u0 = dx * is, v0 = dy * is;
  const double fu = (1.0 - std::abs(v0)) * std::copysign(1.0, u0 + 0.0);
  const double fv = (1.0 - std::abs(u0)) * std::copysign(1.0, v0 + 0.0);
  const bool lower = dz < 0;
  const double u = std::min(1.0, std::max(-1.0, lower ? fu : u0));
  const double v = std::min(1.0, std::max(-1.0, lower ? fv : v0));
  x = u * half + offset;
  y = v * half + offset;
}

// The bilinear tap at texel coordinates (x, y) >= -1/2: four texels (seams wrapped) and their
// weights; floor(x) as the truncation of x + 1, as the core takes it.
struct MapTap {
  int t00, t10, t01, t11;
  double w00, w10, w01, w11;
};
inline MapTap tapAt(double x, double y, int R) {
  const int x0 = static_cast<int>(x + 1.0) - 1, y0 = static_cast<int>(y + 1.0) - 1;
  const double ax = x - x0, ay = y - y0;
  MapTap t;
  if (x0 >= 0 && y0 >= 0 && x0 < R - 1 && y0 < R - 1) {
    t.t00 = x0 + R * y0;
    t.t10 = t.t00 + 1;
    t.t01 = t.t00 + R;
    t.t11 = t.t01 + 1;
  } else {
    t.t00 = octWrappedTexel(x0, y0, R);
    t.t10 = octWrappedTexel(x0 + 1, y0, R);
    t.t01 = octWrappedTexel(x0, y0 + 1, R);
    t.t11 = octWrappedTexel(x0 + 1, y0 + 1, R);
  }
  t.w00 = (1 - ax) * (1 - ay);
  t.w10 = ax * (1 - ay);
  t.w01 = (1 - ax) * ay;
  t.w11 = ax * ay;
  return t;
}

inline void tapMoments(const float* map, const MapTap& t, double& mu, double& mu2) {
  mu = t.w00 * map[2 * t.t00] + t.w10 * map[2 * t.t10] + t.w01 * map[2 * t.t01] +
       t.w11 * map[2 * t.t11];
  mu2 = t.w00 * map[2 * t.t00 + 1] + t.w10 * map[2 * t.t10 + 1] + t.w01 * map[2 * t.t01 + 1] +
        t.w11 * map[2 * t.t11 + 1];
}

// DDGI's Chebyshev visibility (sec. 5.2), cubed; both sides computed, one selected.
inline double chebyshev(double mu, double mu2, double r) {
  const double bias = kVisibilityVarianceBias * mu;
  const double var = std::max(0.0, mu2 - mu * mu) + bias * bias;
  const double c = var / (var + (r - mu) * (r - mu));
  return r <= mu ? 1.0 : c * c * c;
}

// The smooth-backface normal term (dn = dot(p - probe, n)), the crush (f^3 / 0.04 below 0.2)
// and the floor.
inline double finish(double f, bool hasNormal, double dn, double r) {
  if (hasNormal) {
    const double s = (-dn / r + 1.0) * 0.5;
    f *= s * s + 0.2;
  }
  const double crushed = f * f * f * 25.0;
  f = f < 0.2 ? crushed : f;
  return f < kVisibilityMinFactor ? 0.0 : f;
}

inline const float* probeMap(const Volume& v, int32_t probe) {
  const int R = v.visibilityMapSize;
  return v.visibility.data() + size_t(probe) * size_t(2 * R * R);
}

// One probe's factor for p (n: the unit normal, or nullptr).
inline double probeFactor(const Volume& v, int32_t probe, V3 p, const double* n) {
  if (v.probeFlags[size_t(probe)] & 1) return 0.0;
  const V3 d = p - pos(v, probe);
  const double r = std::sqrt(dot(d, d));
  if (!(r > 1e-6)) return 1.0;
  const int R = v.visibilityMapSize;
  double x, y, mu, mu2;
  texelCoords(d.x, d.y, d.z, 0.5 * R, 0.5 * R - 0.5, x, y);
  tapMoments(probeMap(v, probe), tapAt(x, y, R), mu, mu2);
  return finish(chebyshev(mu, mu2, r), n != nullptr, n ? d.x * n[0] + d.y * n[1] + d.z * n[2] : 0.0,
                r);
}

// The four factors of a tetrahedron's probes q for p, side by side, each probe's lines asked
// for before any is read (as the core's tetFactors).
inline void tetFactors(const Volume& v, const std::array<int32_t, 4>& q, V3 p, const double* n,
                       double f[4]) {
  const int R = v.visibilityMapSize;
  const double half = 0.5 * R, offset = 0.5 * R - 0.5;
  double dx[4], dy[4], dz[4], r[4], x[4], y[4], dn[4], mu[4], mu2[4];
  for (int i = 0; i < 4; ++i) {
    const size_t qi = size_t(q[size_t(i)]);
    prefetch(&v.probeFlags[qi]);
    for (size_t k = 0; k < 27; k += 13) prefetch(v.sh.data() + 27 * qi + k);
    const float* xi = v.positions.data() + 3 * qi;
    dx[i] = p.x - double(xi[0]);
    dy[i] = p.y - double(xi[1]);
    dz[i] = p.z - double(xi[2]);
  }
  for (int i = 0; i < 4; ++i) r[i] = std::sqrt(dx[i] * dx[i] + dy[i] * dy[i] + dz[i] * dz[i]);
  for (int i = 0; i < 4; ++i) texelCoords(dx[i], dy[i], dz[i], half, offset, x[i], y[i]);
  for (int i = 0; i < 4; ++i) dn[i] = n ? dx[i] * n[0] + dy[i] * n[1] + dz[i] * n[2] : 0.0;
  MapTap taps[4];
  const float* maps[4];
  for (int i = 0; i < 4; ++i) {
    maps[i] = probeMap(v, q[size_t(i)]);
    if (!(r[i] > 1e-6)) continue;
    taps[i] = tapAt(x[i], y[i], R);
    prefetch(maps[i] + 2 * taps[i].t00);
    prefetch(maps[i] + 2 * taps[i].t10 + 1);
    prefetch(maps[i] + 2 * taps[i].t01);
    prefetch(maps[i] + 2 * taps[i].t11 + 1);
  }
  for (int i = 0; i < 4; ++i) {
    mu[i] = mu2[i] = 0;
    if (r[i] > 1e-6) tapMoments(maps[i], taps[i], mu[i], mu2[i]);
  }
  for (int i = 0; i < 4; ++i) {
    const double fi = finish(chebyshev(mu[i], mu2[i], r[i]), n != nullptr, dn[i], r[i]);
    f[i] = (v.probeFlags[size_t(q[size_t(i)])] & 1) ? 0.0 : !(r[i] > 1e-6) ? 1.0 : fi;
  }
}

// The neighbour search's candidates (as the core's neighbourCandidates): the tetrahedra within
// two face steps of `tet`, breadth first through `neighbors` (each in local order), and their
// vertices not in `tet`, in that order, without repeats, at most kMaxWeightedProbes.
inline int neighbourCandidates(const Volume& v, int32_t tet, int32_t out[kMaxWeightedProbes]) {
  int32_t tets[1 + 4 + 12];
  int nt = 0, begin = 0;
  tets[nt++] = tet;
  for (int depth = 0; depth < 2; ++depth) {
    const int end = nt;
    for (int i = begin; i < end; ++i)
      for (int k = 0; k < 4; ++k) {
        const int32_t n = v.neighbors[size_t(tets[i])][k];
        if (n < 0 || std::find(tets, tets + nt, n) != tets + nt) continue;
        tets[nt++] = n;
      }
    begin = end;
  }
  const auto& own = v.tets[size_t(tet)];
  int count = 0;
  for (int i = 1; i < nt && count < kMaxWeightedProbes; ++i)
    for (int k = 0; k < 4 && count < kMaxWeightedProbes; ++k) {
      const int32_t q = v.tets[size_t(tets[i])][k];
      if (std::find(own.begin(), own.end(), q) != own.end() ||
          std::find(out, out + count, q) != out + count)
        continue;
      out[count++] = q;
    }
  return count;
}

// The tetrahedra around vertex c (its star), from tet t, which holds it (as the core's
// starTets): breadth first through the faces holding c, each in local order, at most 128.
inline int starTets(const Volume& v, int32_t t, int32_t c, int32_t out[128]) {
  int n = 0;
  out[n++] = t;
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 4; ++k) {
      if (v.tets[size_t(out[i])][k] == c) continue;
      const int32_t nb = v.neighbors[size_t(out[i])][k];
      if (nb < 0 || std::find(out, out + n, nb) != out + n) continue;
      if (n == 128) return n;
      out[n++] = nb;
    }
  return n;
}

// The walk's candidates (as the core's walkCandidates): from the vertex of `tet` nearest p, to
// the nearest vertex of its star while that is strictly nearer, at most 64 steps; then the last
// star's vertices not in `tet`, nearest first (lower index first on a tie), at most
// kMaxWeightedProbes.
inline int walkCandidates(const Volume& v, int32_t tet, V3 p, int32_t out[kMaxWeightedProbes]) {
  const auto d2 = [&](int32_t q) {
    const V3 d = p - pos(v, q);
    return dot(d, d);
  };
  const auto& own = v.tets[size_t(tet)];
  int32_t c = own[0], ct = tet;
  double cd = d2(c);
  for (int k = 1; k < 4; ++k)
    if (d2(own[k]) < cd) {
      c = own[k];
      cd = d2(c);
    }
  int32_t star[128];
  int ns = starTets(v, ct, c, star);
  for (int step = 0; step < 64; ++step) {
    int32_t best = c, bestTet = ct;
    double bd = cd;
    for (int i = 0; i < ns; ++i)
      for (int k = 0; k < 4; ++k) {
        const int32_t q = v.tets[size_t(star[i])][k];
        const double dq = d2(q);
        if (dq < bd) {
          best = q;
          bestTet = star[i];
          bd = dq;
        }
      }
    if (best == c) break;
    c = best;
    ct = bestTet;
    cd = bd;
    ns = starTets(v, ct, c, star);
  }
  double od[kMaxWeightedProbes];
  int count = 0;
  for (int i = 0; i < ns; ++i)
    for (int k = 0; k < 4; ++k) {
      const int32_t q = v.tets[size_t(star[i])][k];
      if (std::find(own.begin(), own.end(), q) != own.end() ||
          std::find(out, out + count, q) != out + count)
        continue;
      const double dq = d2(q);
      int at = count;
      while (at > 0 && (od[at - 1] > dq || (od[at - 1] == dq && out[at - 1] > q))) --at;
      if (at == kMaxWeightedProbes) continue;
      for (int j = std::min(count, kMaxWeightedProbes - 1); j > at; --j) {
        out[j] = out[j - 1];
        od[j] = od[j - 1];
      }
      out[at] = q;
      od[at] = dq;
      count = std::min(count + 1, kMaxWeightedProbes);
    }
  return count;
}

}  // namespace detail

/// The visibility-aware weights at (x, y, z) for `loc` (locate() of that point), with `normal`
/// the unit surface normal there (3 doubles) or nullptr. Per probe i: w_i = b_i f_i with f_i
/// DDGI's chebyshev visibility (variance bias 0.05 mean, cubed) times the smooth-backface term
/// ((dot(dir to probe, n) + 1) / 2)^2 + 0.2, crushed below 0.2 to f^3 / 0.04 and 0 below 1e-3
/// (0 for a probe inside geometry), renormalised. When every w_i is 0: f_i alone, renormalised.
/// When every f_i is 0 too (no probe of the tetrahedron sees the point): the neighbour search,
/// the vertices of the tetrahedra within two face steps (breadth first, each tetrahedron's
/// neighbours in local order) that are not the tetrahedron's, the first 16, each with f_j > 0
/// weighing f_j / d_j^2 (d_j its distance to the point), renormalised (fallback 3); when none of
/// them sees the point either, the walk: from the tetrahedron's vertex nearest the point to the
/// nearest probe (stepping to the nearest vertex of the tetrahedra around the current one while
/// that is nearer), whose surrounding tetrahedra give their vertices not in the point's, nearest
/// first, the first 16, weighed as before; when none of those sees it either: the barycentric
/// weights. Without maps: the barycentric weights.
inline Weights visibleWeights(const Volume& v, const Location& loc, double x, double y, double z,
                              const double* normal) {
  Weights w;
  w.tet = loc.tet;
  w.outside = loc.outside;
  if (loc.tet < 0) return w;
  w.count = 4;
  for (int i = 0; i < 4; ++i) {
    w.probes[i] = v.tets[size_t(loc.tet)][i];
    w.weights[i] = loc.weights[i];
  }
  if (v.visibilityMapSize <= 0) return w;
  const detail::V3 p = {x, y, z};
  double f[4], raw[4], sum = 0, factorSum = 0;
  detail::tetFactors(v, v.tets[size_t(loc.tet)], p, normal, f);
  for (int i = 0; i < 4; ++i) {
    raw[i] = double(loc.weights[i]) * f[i];
    sum += raw[i];
    factorSum += f[i];
  }
  if (sum > 0) {
    const double inv = 1.0 / sum;
    for (int i = 0; i < 4; ++i) w.weights[i] = raw[i] * inv;
  } else if (factorSum > 0) {
    w.fallback = 1;
    const double inv = 1.0 / factorSum;
    for (int i = 0; i < 4; ++i) w.weights[i] = f[i] * inv;
  } else {
    w.fallback = 2;
  }
  if (w.fallback != 2) return w;
  Weights n;
  n.tet = w.tet;
  n.outside = w.outside;
  double nsum = 0;
  const auto weigh = [&] {
    nsum = 0;
    for (int j = 0; j < n.count; ++j) {
      const double fj = detail::probeFactor(v, n.probes[j], p, normal);
      const detail::V3 d = p - detail::pos(v, n.probes[j]);
      n.weights[j] =
          fj > 0 ? fj / std::max(detail::dot(d, d), std::numeric_limits<double>::min()) : 0;
      nsum += n.weights[j];
    }
  };
  n.count = detail::neighbourCandidates(v, loc.tet, n.probes);
  weigh();
  if (!(nsum > 0)) {
    n.count = detail::walkCandidates(v, loc.tet, p, n.probes);
    weigh();
  }
  if (!(nsum > 0)) return w;
  const double inv = 1.0 / nsum;
  for (int j = 0; j < n.count; ++j) n.weights[j] *= inv;
  n.fallback = 3;
  return n;
}

/// The SH (27 floats) blended with visibility-aware weights.
inline void interpolate(const Volume& v, const Weights& w, float out[27]) {
  double acc[27] = {};
  if (w.tet >= 0)
    for (int i = 0; i < w.count; ++i) {
      const float* s = v.sh.data() + size_t(27) * size_t(w.probes[i]);
      for (int k = 0; k < 27; ++k) acc[k] += w.weights[i] * s[k];
    }
  for (int k = 0; k < 27; ++k) out[k] = static_cast<float>(acc[k]);
}

}  // namespace ps_runtime

#endif  // PS_VOLUME_READER_H
