#include "core/math/Sh.h"

namespace ps {

std::array<double, kShCoeffCount> shBasis(Vec3 d) {
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

double shCosineLobe(int coeffIndex) {
  // Ramamoorthi & Hanrahan 2001, eq. 8: A0 = pi, A1 = 2pi/3, A2 = pi/4.
  if (coeffIndex == 0) return kPi;
  if (coeffIndex < 4) return 2.0 * kPi / 3.0;
  return kPi / 4.0;
}

void ShRgb::addSample(Vec3 d, Rgb radiance, double weight) {
  const auto y = shBasis(d);
  for (int i = 0; i < kShCoeffCount; ++i) c[i] += radiance * (y[i] * weight);
}

Rgb ShRgb::radiance(Vec3 d) const {
  const auto y = shBasis(d);
  Rgb r;
  for (int i = 0; i < kShCoeffCount; ++i) r += c[i] * y[i];
  return r;
}

Rgb ShRgb::irradiance(Vec3 n) const {
  const auto y = shBasis(n);
  Rgb e;
  for (int i = 0; i < kShCoeffCount; ++i) e += c[i] * (shCosineLobe(i) * y[i]);
  return e;
}

}  // namespace ps
