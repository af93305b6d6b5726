#include "core/math/Sh.h"

namespace ps {

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
