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

/// The 9 basis functions evaluated at the unit direction d (inline: the capture's inner loop
/// calls it per sample).
inline std::array<double, kShCoeffCount> shBasis(Vec3 d) {
  // The header's constants to full double precision (they are quoted there to 6 digits):
  // 1/2 sqrt(1/pi), sqrt(3/(4pi)), 1/2 sqrt(15/pi), 1/4 sqrt(5/pi), 1/4 sqrt(15/pi).
  constexpr double k0 = 0.28209479177387814347;   // Y00
  constexpr double k1 = 0.48860251190291992159;   // band 1
  constexpr double k2 = 1.09254843059207907054;   // Y2-2, Y2-1, Y21
  constexpr double k20 = 0.31539156525252000603;  // Y20
  constexpr double k22 = 0.54627421529603953527;  // Y22
  const double x = d.x, y = d.y, z = d.z;
  return {
      k0,                         // Y00
      k1 * y,                     // Y1-1
      k1 * z,                     // Y10
      k1 * x,                     // Y11
      k2 * x * y,                 // Y2-2
      k2 * y * z,                 // Y2-1
      k20 * (3.0 * z * z - 1.0),  // Y20
      k2 * x * z,                 // Y21
      k22 * (x * x - y * y),      // Y22
  };
}

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
