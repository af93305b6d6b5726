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

/// Where the bilinear lookup of an R x R map (layout in core/capture/Capture.h) reads: four
/// texels and their weights, texel centres at integer coordinates, a texel beyond an edge
/// wrapped across the octahedral seam.
struct MapTap {
  int t00, t10, t01, t11;
  double w00, w10, w01, w11;
};

// The steps below are written on plain doubles, one probe's values at a time, so that the same
// operations serve one probe (visibilityFactor) and four side by side (visibleWeights, where the
// compiler pairs them in SIMD registers): every path gives the same IEEE results.

/// The texel coordinates (x, y) of direction d = (dx, dy, dz) (any length > 0) in an R x R map
/// (half = R / 2, offset = R / 2 - 1/2): the octahedral encoding (Cigolle et al. 2014) of
/// d / |d|_1, which is that of d / |d| (no square root or normalisation needed), the lower
/// hemisphere folded onto the corners (by selects: half of all directions take the fold, so a
/// branch on it is mispredicted often), then (u + 1) R / 2 - 1/2.
inline void texelCoords(double dx, double dy, double dz, double half, double offset, double& x,
                        double& y) {
  const double is = 1.0 / (std::abs(dx) + std::abs(dy) + std::abs(dz));
  const double u0 = dx * is, v0 = dy * is;
  // Signs as copysign of u0 + 0 (which makes -0 into +0, as u0 >= 0 counts it): no branch.
  const double fu = (1.0 - std::abs(v0)) * std::copysign(1.0, u0 + 0.0);
  const double fv = (1.0 - std::abs(u0)) * std::copysign(1.0, v0 + 0.0);
  const bool lower = dz < 0;
  const double u = std::min(1.0, std::max(-1.0, lower ? fu : u0));
  const double v = std::min(1.0, std::max(-1.0, lower ? fv : v0));
  x = u * half + offset;
  y = v * half + offset;
}

/// The bilinear tap at texel coordinates (x, y), both >= -1/2.
inline MapTap tapAt(double x, double y, int R) {
  // floor(x) for x >= -0.5 as a truncation of x + 1, without floor's long SSE2 sequence. It is
  // exact but where x + 1 rounds up to an integer (x within half an ulp of x + 1 below one):
  // there the weight moves to the texel x all but reaches, by that half ulp (below 1e-15).
  const int x0 = static_cast<int>(x + 1.0) - 1, y0 = static_cast<int>(y + 1.0) - 1;
  const double ax = x - x0, ay = y - y0;
  MapTap t;
  if (x0 >= 0 && y0 >= 0 && x0 < R - 1 && y0 < R - 1) {  // no seam: the common case
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

/// The map's mean and mean square at the tap.
inline void tapMoments(const float* map, const MapTap& t, double& mu, double& mu2) {
  mu = t.w00 * map[2 * t.t00] + t.w10 * map[2 * t.t10] + t.w01 * map[2 * t.t01] +
       t.w11 * map[2 * t.t11];
  mu2 = t.w00 * map[2 * t.t00 + 1] + t.w10 * map[2 * t.t10 + 1] + t.w01 * map[2 * t.t01 + 1] +
        t.w11 * map[2 * t.t11 + 1];
}

/// DDGI sec. 5.2: Chebyshev's bound on the probability that the first surface along the
/// direction lies beyond r, from the mean and mean square there, cubed (v = c^3). Both sides
/// are computed and one selected: whether r <= mu varies from probe to probe, and a mispredicted
/// branch costs more than the division (whose 0 / 0 at r = mu, var = 0 is not the one taken).
inline double chebyshev(double mu, double mu2, double r) {
  const double bias = kVisibilityVarianceBias * mu;
  const double var = std::max(0.0, mu2 - mu * mu) + bias * bias;
  const double c = var / (var + (r - mu) * (r - mu));
  return r <= mu ? 1.0 : c * c * c;
}

/// The factor f from v (the header's steps 3 and 4): with a normal, DDGI's smooth-backface term
/// from dot(-dir, n) = -dn / r (dn = dot(d, n)); then the crush (f^3 / 0.04 below 0.2, selected
/// as above) and the floor.
inline double finish(double f, bool hasNormal, double dn, double r) {
  if (hasNormal) {  // the same for every probe of a query: predicted
    const double s = (-dn / r + 1.0) * 0.5;
    f *= s * s + 0.2;
  }
  const double crushed = f * f * f * 25.0;
  f = f < 0.2 ? crushed : f;
  return f < kVisibilityMinFactor ? 0.0 : f;
}

/// One probe's v at d = p - x, r = |d| > 1e-6.
double tapVisibility(const float* map, int R, Vec3 d, double r) {
  double x, y, mu, mu2;
  texelCoords(d.x, d.y, d.z, 0.5 * R, 0.5 * R - 0.5, x, y);
  tapMoments(map, tapAt(x, y, R), mu, mu2);
  return chebyshev(mu, mu2, r);
}

/// Asks the cache for the line holding `p` (no effect on results).
inline void prefetch(const void* p) {
  __builtin_prefetch(p);
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
/// not in `tet`, in that order, without repeats, at most kMaxNeighbourProbes, into `out`; returns
/// how many. Reads at most 1 + 4 + 12 tets.
int neighbourCandidates(const ProbeVolume& v, int32_t tet,
                        std::array<int32_t, kMaxNeighbourProbes>& out) {
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
  int count = 0;
  for (int i = 1; i < nt && count < kMaxNeighbourProbes; ++i)
    for (int k = 0; k < 4 && count < kMaxNeighbourProbes; ++k) {
      const int32_t q = v.tets[size_t(tets[i])][k];
      if (std::find(own.begin(), own.end(), q) != own.end() ||
          std::find(out.begin(), out.begin() + count, q) != out.begin() + count)
        continue;
      out[size_t(count++)] = q;
    }
  return count;
}

/// The tets around vertex `c` (its star), from `tet`, which holds it: breadth first through the
/// faces that hold c (those opposite the tet's other three vertices), each tet's faces in local
/// order; at most kMaxStarTets, into `out`; returns how many.
int starTets(const ProbeVolume& v, int32_t tet, int32_t c, std::array<int32_t, kMaxStarTets>& out) {
  int n = 0;
  out[size_t(n++)] = tet;
  for (int i = 0; i < n; ++i) {
    const auto& t = v.tets[size_t(out[size_t(i)])];
    for (int k = 0; k < 4; ++k) {
      if (t[k] == c) continue;
      const int32_t nb = v.neighbors[size_t(out[size_t(i)])][k];
      if (nb < 0 || std::find(out.begin(), out.begin() + n, nb) != out.begin() + n) continue;
      if (n == kMaxStarTets) return n;
      out[size_t(n++)] = nb;
    }
  }
  return n;
}

/// The walk's candidates (the second part of fallback 2 of VisibleInterpolation.h): from the
/// vertex of `tet` nearest p (the first in local order on a tie), step to the nearest vertex of
/// its star while that one is strictly nearer p, at most kMaxWalkSteps steps (in a Delaunay
/// tetrahedralization the walk ends at p's nearest probe: a vertex that is not the nearest has a
/// Delaunay neighbour nearer p); then the vertices of the last star that are not `tet`'s, by
/// distance to p (the lower index first on a tie), the first kMaxNeighbourProbes, into `out`;
/// returns how many.
int walkCandidates(const ProbeVolume& v, int32_t tet, Vec3 p,
                   std::array<int32_t, kMaxNeighbourProbes>& out) {
  const auto d2 = [&](int32_t q) {
    const Vec3 d = p - v.position(q);
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
  std::array<int32_t, kMaxStarTets> star;
  int ns = starTets(v, ct, c, star);
  for (int step = 0; step < kMaxWalkSteps; ++step) {
    int32_t best = c, bestTet = ct;
    double bd = cd;
    for (int i = 0; i < ns; ++i)
      for (int k = 0; k < 4; ++k) {
        const int32_t q = v.tets[size_t(star[size_t(i)])][k];
        const double dq = d2(q);
        if (dq < bd) {
          best = q;
          bestTet = star[size_t(i)];
          bd = dq;
        }
      }
    if (best == c) break;
    c = best;
    ct = bestTet;
    cd = bd;
    ns = starTets(v, ct, c, star);
  }
  // The star's vertices not in `tet`, nearest first: an insertion into `out`, kept sorted.
  std::array<double, kMaxNeighbourProbes> od;
  int count = 0;
  for (int i = 0; i < ns; ++i)
    for (int k = 0; k < 4; ++k) {
      const int32_t q = v.tets[size_t(star[size_t(i)])][k];
      if (std::find(own.begin(), own.end(), q) != own.end() ||
          std::find(out.begin(), out.begin() + count, q) != out.begin() + count)
        continue;
      const double dq = d2(q);
      int at = count;
      while (at > 0 &&
             (od[size_t(at - 1)] > dq || (od[size_t(at - 1)] == dq && out[size_t(at - 1)] > q)))
        --at;
      if (at == kMaxNeighbourProbes) continue;
      for (int j = std::min(count, kMaxNeighbourProbes - 1); j > at; --j) {
        out[size_t(j)] = out[size_t(j - 1)];
        od[size_t(j)] = od[size_t(j - 1)];
      }
      out[size_t(at)] = q;
      od[size_t(at)] = dq;
      count = std::min(count + 1, kMaxNeighbourProbes);
    }
  return count;
}

/// visibilityFactor() of each of the four probes `q` of a tet for p, into f: the same
/// operations, run for the four side by side (loops over them that the compiler can pair in
/// SIMD registers), and with the lines each probe's lookup, flag and SH will read asked for
/// before any is used, so that a query whose probes are out of cache waits for memory about
/// once rather than four times over.
void tetFactors(const ProbeVolume& v, const std::array<int32_t, 4>& q, Vec3 p,
                const std::optional<Vec3>& n, std::array<double, 4>& f) {
  const int R = v.visibilityMapSize;
  const double half = 0.5 * R, offset = 0.5 * R - 0.5;
  double dx[4], dy[4], dz[4], r[4], x[4], y[4], dn[4], mu[4], mu2[4];
  for (int i = 0; i < 4; ++i) {
    const size_t qi = size_t(q[size_t(i)]);
    prefetch(&v.probeInside[qi]);
    for (size_t k = 0; k < 27; k += 13) prefetch(v.sh.data() + 27 * qi + k);  // 108 B: 2-3 lines
    const float* xi = v.positions.data() + 3 * qi;
    dx[i] = p.x - double(xi[0]);
    dy[i] = p.y - double(xi[1]);
    dz[i] = p.z - double(xi[2]);
  }
  for (int i = 0; i < 4; ++i) r[i] = std::sqrt(dx[i] * dx[i] + dy[i] * dy[i] + dz[i] * dz[i]);
  for (int i = 0; i < 4; ++i) texelCoords(dx[i], dy[i], dz[i], half, offset, x[i], y[i]);
  const Vec3 nn = n.value_or(Vec3{});
  for (int i = 0; i < 4; ++i) dn[i] = dx[i] * nn.x + dy[i] * nn.y + dz[i] * nn.z;
  MapTap taps[4];
  const float* maps[4];
  for (int i = 0; i < 4; ++i) {
    maps[i] = probeMap(v, q[size_t(i)]);
    if (!(r[i] > 1e-6)) continue;  // p at the probe: no direction (and x, y are NaN)
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
    const double fi = finish(chebyshev(mu[i], mu2[i], r[i]), n.has_value(), dn[i], r[i]);
    f[size_t(i)] = v.probeInside[size_t(q[size_t(i)])] != 0 ? 0.0 : !(r[i] > 1e-6) ? 1.0 : fi;
  }
}

/// combineVisibleWeights(), inlined into visibleWeights().
inline VisibleFallback combineWeights(const std::array<double, 4>& barycentric,
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
    const double inv = 1.0 / sum;
    for (int i = 0; i < 4; ++i) weights[i] = raw[i] * inv;
    return VisibleFallback::None;
  }
  if (factorSum > 0) {
    const double inv = 1.0 / factorSum;
    for (int i = 0; i < 4; ++i) weights[i] = factors[i] * inv;
    return VisibleFallback::Visibility;
  }
  weights = barycentric;
  return VisibleFallback::Barycentric;
}

}  // namespace

double mapVisibility(const float* map, int mapSize, Vec3 x, Vec3 p) {
  if (map == nullptr) return 1.0;
  const Vec3 d = p - x;
  const double r = length(d);
  if (!(r > 1e-6)) return 1.0;
  return tapVisibility(map, mapSize, d, r);
}

double visibilityFactor(const float* map, int mapSize, bool inside, Vec3 x, Vec3 p,
                        const std::optional<Vec3>& n) {
  if (inside) return 0.0;
  const Vec3 d = p - x;
  const double r = length(d);
  if (!(r > 1e-6)) return 1.0;
  return finish(map ? tapVisibility(map, mapSize, d, r) : 1.0, n.has_value(), n ? dot(d, *n) : 0.0,
                r);
}

VisibleFallback combineVisibleWeights(const std::array<double, 4>& barycentric,
                                      const std::array<double, 4>& factors,
                                      std::array<double, 4>& weights) {
  return combineWeights(barycentric, factors, weights);
}

double probeVisibility(const ProbeVolume& v, int32_t probe, Vec3 p) {
  if (!v.hasVisibility()) return 1.0;
  PS_CHECK(probe >= 0 && size_t(probe) < v.probeCount());
  return mapVisibility(probeMap(v, probe), v.visibilityMapSize, v.position(probe), p);
}

VisibleWeights barycentricWeights(const ProbeVolume& v, const VolumeLocation& loc) {
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
  return w;
}

VisibleWeights visibleWeights(const ProbeVolume& v, const VolumeLocation& loc, Vec3 p,
                              const std::optional<Vec3>& normal) {
  VisibleWeights w = barycentricWeights(v, loc);
  if (loc.tet < 0 || !v.hasVisibility()) return w;
  const auto& tet = v.tets[size_t(loc.tet)];
  PS_CHECK_EQ(v.visibility.size(),
              v.probeCount() * size_t(2 * v.visibilityMapSize * v.visibilityMapSize));
  PS_CHECK_EQ(v.probeInside.size(), v.probeCount());
  std::array<double, 4> barycentric{}, factors{}, weights{};
  for (int i = 0; i < 4; ++i) barycentric[i] = double(loc.weights[i]);
  tetFactors(v, tet, p, normal, factors);
  w.fallback = combineWeights(barycentric, factors, weights);
  std::copy(factors.begin(), factors.end(), w.factors.begin());
  std::copy(weights.begin(), weights.end(), w.weights.begin());
  if (w.fallback != VisibleFallback::Barycentric) return w;
  // No probe of p's tet sees p: the neighbour search (fallback 2), each candidate that sees p
  // weighed by f_j / d_j^2. When none does, the barycentric weights stand. (Built aside and
  // copied in, so that `w` is the one object returned.)
  std::array<int32_t, kMaxNeighbourProbes> probes;
  std::array<double, kMaxNeighbourProbes> nf, nw;
  int count = 0;
  double sum = 0;
  const auto weigh = [&] {
    sum = 0;
    for (int j = 0; j < count; ++j) {
      const int32_t q = probes[size_t(j)];
      const double f = probeFactor(v, q, p, normal);
      const Vec3 dq = p - v.position(q);
      nf[size_t(j)] = f;
      nw[size_t(j)] = f > 0 ? f / std::max(dot(dq, dq), std::numeric_limits<double>::min()) : 0;
      sum += nw[size_t(j)];
    }
  };
  count = neighbourCandidates(v, loc.tet, probes);
  weigh();
  if (!(sum > 0)) {
    // None of the face search's probes sees p, as in a sliver of the hull whose probes lie tens
    // of metres away: the probes around p's nearest probe.
    count = walkCandidates(v, loc.tet, p, probes);
    weigh();
  }
  if (!(sum > 0)) return w;
  const double inv = 1.0 / sum;
  w.count = count;
  for (int j = 0; j < count; ++j) {
    w.probes[size_t(j)] = probes[size_t(j)];
    w.factors[size_t(j)] = nf[size_t(j)];
    w.weights[size_t(j)] = nw[size_t(j)] * inv;
  }
  w.fallback = VisibleFallback::Neighbours;
  return w;
}

VisibleWeights visibleWeights(const ProbeVolume& v, Vec3 p, const std::optional<Vec3>& normal,
                              int32_t hintTet) {
  return visibleWeights(v, locate(v, p, hintTet), p, normal);
}

ShRgb interpolate(const ProbeVolume& v, const VisibleWeights& w) {
  ShRgb out;
  if (w.tet < 0) return out;
  // Per stored value (coefficient-major, RGB), the sum over the probes in their order; the
  // tet's four (nearly every query) unrolled.
  const float* s[kMaxVisibleProbes];
  for (int i = 0; i < w.count; ++i) s[i] = v.sh.data() + size_t(27) * size_t(w.probes[size_t(i)]);
  double acc[27];
  if (w.count == 4) {
    const double w0 = w.weights[0], w1 = w.weights[1], w2 = w.weights[2], w3 = w.weights[3];
    for (int k = 0; k < 27; ++k) {
      double a = 0;
      a += w0 * s[0][k];
      a += w1 * s[1][k];
      a += w2 * s[2][k];
      a += w3 * s[3][k];
      acc[k] = a;
    }
  } else {
    for (int k = 0; k < 27; ++k) {
      double a = 0;
      for (int i = 0; i < w.count; ++i) a += w.weights[size_t(i)] * s[i][k];
      acc[k] = a;
    }
  }
  for (int k = 0; k < kShCoeffCount; ++k)
    out.c[k] = Rgb(acc[3 * k], acc[3 * k + 1], acc[3 * k + 2]);
  return out;
}

ShRgb interpolateVisible(const ProbeVolume& v, Vec3 p, const std::optional<Vec3>& normal,
                         int32_t hintTet) {
  return interpolate(v, visibleWeights(v, p, normal, hintTet));
}

}  // namespace ps
