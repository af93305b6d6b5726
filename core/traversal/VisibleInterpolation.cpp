// The visibility-aware interpolant (contract and formulas in VisibleInterpolation.h; DDGI,
// Majercik et al. 2019, sec. 5.2). Every step is in double from the stored floats, in the order
// the runtime reader repeats.
#include "core/traversal/VisibleInterpolation.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/common/Check.h"
#include "core/math/Octahedral.h"

namespace ps {

namespace {

/// Bilinear lookup of a map of R x R texels (layout in core/capture/Capture.h) in unit direction
/// d: mean and mean square.
void lookupMoments(const float* map, int R, Vec3 d, double& mu, double& mu2) {
  const OctUv o = octEncode(d);
  // Texel centres at integer coordinates.
  const double x = (o.u + 1.0) * 0.5 * R - 0.5;
  const double y = (o.v + 1.0) * 0.5 * R - 0.5;
  const double fx0 = std::floor(x), fy0 = std::floor(y);
  const int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
  const double ax = x - fx0, ay = y - fy0;
  const int t00 = octWrappedTexel(x0, y0, R), t10 = octWrappedTexel(x0 + 1, y0, R);
  const int t01 = octWrappedTexel(x0, y0 + 1, R), t11 = octWrappedTexel(x0 + 1, y0 + 1, R);
  const double w00 = (1 - ax) * (1 - ay), w10 = ax * (1 - ay), w01 = (1 - ax) * ay, w11 = ax * ay;
  mu = w00 * map[2 * t00] + w10 * map[2 * t10] + w01 * map[2 * t01] + w11 * map[2 * t11];
  mu2 = w00 * map[2 * t00 + 1] + w10 * map[2 * t10 + 1] + w01 * map[2 * t01 + 1] +
        w11 * map[2 * t11 + 1];
}

/// The map of probe `probe` of `v` (which has maps).
const float* probeMap(const ProbeVolume& v, int32_t probe) {
  const int R = v.visibilityMapSize;
  return v.visibility.data() + size_t(probe) * size_t(2 * R * R);
}

/// The factor f of probe `probe` of `v` (which has maps) for p.
double probeFactor(const ProbeVolume& v, int32_t probe, Vec3 p, const std::optional<Vec3>& n) {
  return visibilityFactor(probeMap(v, probe), v.visibilityMapSize,
                          v.probeInside[size_t(probe)] != 0, v.position(probe), p, n);
}

/// The neighbour search (fallback 2 of VisibleInterpolation.h): the tets within
/// kNeighbourSearchDepth face steps of `tet`, breadth first through the stored face neighbours
/// (Sukys 3.2.1: per tet, 4 neighbour ids), each neighbour list in local order; their vertices
/// not in `tet`, in that order, without repeats, at most kMaxNeighbourProbes. Sets w.count and
/// w.probes to them. Reads at most 1 + 4 + 12 tets.
void neighbourCandidates(const ProbeVolume& v, int32_t tet, VisibleWeights& w) {
  constexpr int kMaxTets = 1 + 4 + 12;
  static_assert(kNeighbourSearchDepth == 2, "kMaxTets counts two face steps");
  int32_t tets[kMaxTets];
  int nt = 0, begin = 0;
  tets[nt++] = tet;
  for (int depth = 0; depth < kNeighbourSearchDepth; ++depth) {
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
  w.count = 0;
  for (int i = 1; i < nt && w.count < kMaxNeighbourProbes; ++i)
    for (int k = 0; k < 4 && w.count < kMaxNeighbourProbes; ++k) {
      const int32_t q = v.tets[size_t(tets[i])][k];
      if (std::find(own.begin(), own.end(), q) != own.end() ||
          std::find(w.probes.begin(), w.probes.begin() + w.count, q) != w.probes.begin() + w.count)
        continue;
      w.probes[size_t(w.count++)] = q;
    }
}

}  // namespace

double mapVisibility(const float* map, int mapSize, Vec3 x, Vec3 p) {
  if (map == nullptr) return 1.0;
  const Vec3 d = p - x;
  const double r = length(d);
  if (!(r > 1e-6)) return 1.0;
  double mu = 0, mu2 = 0;
  lookupMoments(map, mapSize, d / r, mu, mu2);
  if (r <= mu) return 1.0;
  const double bias = kVisibilityVarianceBias * mu;
  const double var = std::max(0.0, mu2 - mu * mu) + bias * bias;
  const double c = var / (var + (r - mu) * (r - mu));
  return c * c * c;
}

double visibilityFactor(const float* map, int mapSize, bool inside, Vec3 x, Vec3 p,
                        const std::optional<Vec3>& n) {
  if (inside) return 0.0;
  const Vec3 d = p - x;
  const double r = length(d);
  if (!(r > 1e-6)) return 1.0;
  const Vec3 dir = d / r;
  double f = mapVisibility(map, mapSize, x, p);
  if (n) {
    const double s = (dot(-dir, *n) + 1.0) * 0.5;
    f *= s * s + 0.2;
  }
  if (f < 0.2) f = f * f * f / 0.04;
  return f < kVisibilityMinFactor ? 0.0 : f;
}

VisibleFallback combineVisibleWeights(const std::array<double, 4>& barycentric,
                                      const std::array<double, 4>& factors,
                                      std::array<double, 4>& weights) {
  double sum = 0, factorSum = 0;
  std::array<double, 4> raw{};
  for (int i = 0; i < 4; ++i) {
    raw[i] = barycentric[i] * factors[i];
    sum += raw[i];
    factorSum += factors[i];
  }
  if (sum > 0) {
    for (int i = 0; i < 4; ++i) weights[i] = raw[i] / sum;
    return VisibleFallback::None;
  }
  if (factorSum > 0) {
    for (int i = 0; i < 4; ++i) weights[i] = factors[i] / factorSum;
    return VisibleFallback::Visibility;
  }
  weights = barycentric;
  return VisibleFallback::Barycentric;
}

double probeVisibility(const ProbeVolume& v, int32_t probe, Vec3 p) {
  if (!v.hasVisibility()) return 1.0;
  PS_CHECK(probe >= 0 && size_t(probe) < v.probeCount());
  return mapVisibility(probeMap(v, probe), v.visibilityMapSize, v.position(probe), p);
}

VisibleWeights visibleWeights(const ProbeVolume& v, const VolumeLocation& loc, Vec3 p,
                              const std::optional<Vec3>& normal) {
  VisibleWeights w;
  w.tet = loc.tet;
  w.outside = loc.outside;
  if (loc.tet < 0) return w;
  const auto& tet = v.tets[size_t(loc.tet)];
  w.count = 4;
  for (int i = 0; i < 4; ++i) {
    w.probes[size_t(i)] = tet[i];
    w.weights[size_t(i)] = loc.weights[i];
    w.factors[size_t(i)] = 1.0;
  }
  if (!v.hasVisibility()) return w;
  PS_CHECK_EQ(v.visibility.size(),
              v.probeCount() * size_t(2 * v.visibilityMapSize * v.visibilityMapSize));
  PS_CHECK_EQ(v.probeInside.size(), v.probeCount());
  std::array<double, 4> barycentric{}, factors{}, weights{};
  for (int i = 0; i < 4; ++i) {
    barycentric[i] = double(loc.weights[i]);
    factors[i] = probeFactor(v, tet[i], p, normal);
  }
  w.fallback = combineVisibleWeights(barycentric, factors, weights);
  std::copy(factors.begin(), factors.end(), w.factors.begin());
  std::copy(weights.begin(), weights.end(), w.weights.begin());
  if (w.fallback != VisibleFallback::Barycentric) return w;
  // No probe of p's tet sees p: the neighbour search (fallback 2), each candidate that sees p
  // weighed by f_j / d_j^2. When none does, the barycentric weights stand.
  VisibleWeights n;
  n.tet = w.tet;
  n.outside = w.outside;
  neighbourCandidates(v, loc.tet, n);
  double sum = 0;
  for (int j = 0; j < n.count; ++j) {
    const int32_t q = n.probes[size_t(j)];
    const double f = probeFactor(v, q, p, normal);
    const Vec3 d = p - v.position(q);
    n.factors[size_t(j)] = f;
    n.weights[size_t(j)] = f > 0 ? f / std::max(dot(d, d), std::numeric_limits<double>::min()) : 0;
    sum += n.weights[size_t(j)];
  }
  if (!(sum > 0)) return w;
  for (int j = 0; j < n.count; ++j) n.weights[size_t(j)] /= sum;
  n.fallback = VisibleFallback::Neighbours;
  return n;
}

VisibleWeights visibleWeights(const ProbeVolume& v, Vec3 p, const std::optional<Vec3>& normal,
                              int32_t hintTet) {
  return visibleWeights(v, locate(v, p, hintTet), p, normal);
}

ShRgb interpolate(const ProbeVolume& v, const VisibleWeights& w) {
  ShRgb out;
  if (w.tet < 0) return out;
  for (int i = 0; i < w.count; ++i) {
    const float* s = v.sh.data() + size_t(27) * size_t(w.probes[i]);
    const double wi = w.weights[i];
    for (int k = 0; k < kShCoeffCount; ++k)
      for (int ch = 0; ch < 3; ++ch) out.c[k][ch] += wi * s[3 * k + ch];
  }
  return out;
}

ShRgb interpolateVisible(const ProbeVolume& v, Vec3 p, const std::optional<Vec3>& normal,
                         int32_t hintTet) {
  return interpolate(v, visibleWeights(v, p, normal, hintTet));
}

}  // namespace ps
