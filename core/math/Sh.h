#pragma once
// Real, orthonormal spherical harmonics of order 2 (9 coefficients), ordered l = 0..2,
// m = -l..l (index l*(l+1)+m), in the +Y-up world frame with (x, y, z) a unit direction:
//   Y00 = 0.282095
//   Y1-1 = 0.488603 y   Y10 = 0.488603 z   Y11 = 0.488603 x
//   Y2-2 = 1.092548 xy  Y2-1 = 1.092548 yz  Y20 = 0.315392 (3z^2 - 1)
//   Y21 = 1.092548 xz   Y22 = 0.546274 (x^2 - y^2)
// A probe stores incident radiance L(w) = sum c_lm Y_lm(w) per RGB channel. Irradiance for a
// normal n is E(n) = sum A_l c_lm Y_lm(n), A = (pi, 2pi/3, pi/4) (Ramamoorthi & Hanrahan 2001).
#include <array>

#include "core/math/Vec3.h"

namespace ps {

inline constexpr int kShCoeffCount = 9;

/// The 9 basis functions evaluated at the unit direction d.
std::array<double, kShCoeffCount> shBasis(Vec3 d);

/// Ramamoorthi–Hanrahan cosine-lobe convolution factor A_l for band l of coefficient i.
double shCosineLobe(int coeffIndex);

/// RGB SH L2 coefficients of incident radiance.
struct ShRgb {
  std::array<Rgb, kShCoeffCount> c{};

  ShRgb& operator+=(const ShRgb& o) {
    for (int i = 0; i < kShCoeffCount; ++i) c[i] += o.c[i];
    return *this;
  }
  ShRgb operator*(double s) const {
    ShRgb r = *this;
    for (auto& x : r.c) x *= s;
    return r;
  }
  bool operator==(const ShRgb&) const = default;

  /// Adds the radiance sample `radiance` arriving from direction d, weighted by `weight`
  /// (for Monte Carlo projection: weight = 1 / (pdf * N)).
  void addSample(Vec3 d, Rgb radiance, double weight);
  /// Radiance reconstructed in direction d (band-limited).
  Rgb radiance(Vec3 d) const;
  /// Irradiance E(n) on a surface with unit normal n (Ramamoorthi & Hanrahan eq. 7-8).
  Rgb irradiance(Vec3 n) const;
};

/// f = integral over the sphere of w * lum(L(w)) dw for the band-limited radiance of `sh`
/// (Chajdas sec. 2.1, eq. 1, as an integral instead of a sum over cube-map texels). Only the
/// l = 1 band contributes: with Y1-1 = k y, Y10 = k z, Y11 = k x (k = 0.488603) and the basis
/// orthonormal, the integral of x * L is c11 / k, and so on.
inline Vec3 luminanceDirection(const ShRgb& sh) {
  constexpr double k = 0.488602511902919921;
  return Vec3{luminance(sh.c[3]), luminance(sh.c[1]), luminance(sh.c[2])} * (1.0 / k);
}

}  // namespace ps
