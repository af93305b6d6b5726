#include "ui/IrradianceSphere.h"

#include <algorithm>
#include <cmath>

namespace ps::ui {

namespace {
double aces(double x) {  // Narkowicz 2015, as the viewport's shader
  return std::clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}
int toSrgb8(double c) {
  c = std::clamp(c, 0.0, 1.0);
  const double s = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
  return int(std::lround(s * 255.0));
}
}  // namespace

QImage renderIrradianceSphere(const ShRgb& sh, int sizePx, double exposure) {
  sizePx = std::max(sizePx, 8);
  QImage img(sizePx, sizePx, QImage::Format_ARGB32);
  img.fill(Qt::transparent);
  const double r = 0.5 * sizePx;
  for (int py = 0; py < sizePx; ++py)
    for (int px = 0; px < sizePx; ++px) {
      const double x = (px + 0.5 - r) / r, y = (r - py - 0.5) / r;  // +Y up in the image
      const double z2 = 1.0 - x * x - y * y;
      if (z2 < 0) continue;
      const Vec3 n(x, y, std::sqrt(z2));
      const Rgb e = sh.irradiance(n);
      const double k = exposure / kPi;
      img.setPixel(
          px, py,
          qRgba(toSrgb8(aces(std::max(e.r, 0.0) * k)), toSrgb8(aces(std::max(e.g, 0.0) * k)),
                toSrgb8(aces(std::max(e.b, 0.0) * k)), 255));
    }
  return img;
}

double autoExposureFor(const ShRgb& sh) {
  const double mean = std::max(luminance(sh.c[0]) * 0.282095, 0.0) + 1e-4;
  return 0.6 / mean;
}

}  // namespace ps::ui
