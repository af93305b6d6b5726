// The visibility-aware interpolant (contract and formulas in VisibleInterpolation.h; DDGI,
// Majercik et al. 2019, sec. 5.2). Every step is in double from the stored floats, in the order
// the runtime reader repeats.
#include "core/traversal/VisibleInterpolation.h"

#include <cmath>

#include "core/common/Check.h"
#include "core/math/Octahedral.h"

namespace ps {

namespace {

/// Bilinear lookup of probe `probe`'s moments in unit direction d: mean and mean square.
void lookupMoments(const ProbeVolume& v, int32_t probe, Vec3 d, double& mu, double& mu2) {
  const int R = v.visibilityMapSize;
  const float* map = v.visibility.data() + size_t(probe) * size_t(2 * R * R);
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

/// The factor f of the header (normal term, crush and floor included) for probe `probe`.
double probeFactor(const ProbeVolume& v, int32_t probe, Vec3 p, const std::optional<Vec3>& n) {
  if (v.probeInside[size_t(probe)]) return 0.0;
  const Vec3 d = p - v.position(probe);
  const double r = length(d);
  if (!(r > 1e-6)) return 1.0;
  const Vec3 dir = d / r;
  double f = probeVisibility(v, probe, p);
  if (n) {
    const double s = (dot(-dir, *n) + 1.0) * 0.5;
    f *= s * s + 0.2;
  }
  if (f < 0.2) f = f * f * f / 0.04;
  return f < kVisibilityMinFactor ? 0.0 : f;
}

}  // namespace

double probeVisibility(const ProbeVolume& v, int32_t probe, Vec3 p) {
  if (!v.hasVisibility()) return 1.0;
  PS_CHECK(probe >= 0 && size_t(probe) < v.probeCount());
  const Vec3 d = p - v.position(probe);
  const double r = length(d);
  if (!(r > 1e-6)) return 1.0;
  double mu = 0, mu2 = 0;
  lookupMoments(v, probe, d / r, mu, mu2);
  if (r <= mu) return 1.0;
  const double bias = kVisibilityVarianceBias * mu;
  const double var = std::max(0.0, mu2 - mu * mu) + bias * bias;
  const double c = var / (var + (r - mu) * (r - mu));
  return c * c * c;
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
  double sum = 0, factorSum = 0;
  std::array<double, 4> raw{};
  for (int i = 0; i < 4; ++i) {
    w.factors[i] = probeFactor(v, tet[i], p, normal);
    raw[i] = double(loc.weights[i]) * w.factors[i];
    sum += raw[i];
    factorSum += w.factors[i];
  }
  if (sum > 0) {
    for (int i = 0; i < 4; ++i) w.weights[i] = raw[i] / sum;
  } else if (factorSum > 0) {
    w.fallback = VisibleFallback::Visibility;
    for (int i = 0; i < 4; ++i) w.weights[i] = w.factors[i] / factorSum;
  } else {
    w.fallback = VisibleFallback::Barycentric;  // the barycentric weights, as set above
  }
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
