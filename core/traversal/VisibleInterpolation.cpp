// The visibility-aware interpolant (contract and formulas in VisibleInterpolation.h; DDGI,
// Majercik et al. 2019, sec. 5.2). Every step is in double from the stored floats, in the order
// the runtime reader repeats.
#include "core/traversal/VisibleInterpolation.h"

#include <cmath>

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
  for (int i = 0; i < 4; ++i) {
    w.probes[i] = tet[i];
    w.weights[i] = loc.weights[i];
    w.factors[i] = 1.0;
  }
  if (!v.hasVisibility()) return w;
  PS_CHECK_EQ(v.visibility.size(),
              v.probeCount() * size_t(2 * v.visibilityMapSize * v.visibilityMapSize));
  PS_CHECK_EQ(v.probeInside.size(), v.probeCount());
  std::array<double, 4> barycentric{};
  for (int i = 0; i < 4; ++i) {
    barycentric[i] = double(loc.weights[i]);
    w.factors[i] =
        visibilityFactor(probeMap(v, tet[i]), v.visibilityMapSize,
                         v.probeInside[size_t(tet[i])] != 0, v.position(tet[i]), p, normal);
  }
  w.fallback = combineVisibleWeights(barycentric, w.factors, w.weights);
  return w;
}

VisibleWeights visibleWeights(const ProbeVolume& v, Vec3 p, const std::optional<Vec3>& normal,
                              int32_t hintTet) {
  return visibleWeights(v, locate(v, p, hintTet), p, normal);
}

ShRgb interpolate(const ProbeVolume& v, const VisibleWeights& w) {
  ShRgb out;
  if (w.tet < 0) return out;
  for (int i = 0; i < 4; ++i) {
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
