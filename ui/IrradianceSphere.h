#pragma once
// The inspector's picture of a probe: a white Lambertian sphere lit by the probe's SH, seen from
// +Z looking towards -Z with +Y up (world axes), so its top is what a floor-facing-up surface
// would receive.
#include <QImage>

#include "core/math/Sh.h"

namespace ps::ui {

/// Radiance E(n) / pi of the sphere point with normal n (E from ShRgb::irradiance, Ramamoorthi
/// & Hanrahan), times `exposure`, ACES tone mapped and sRGB encoded; outside the disc the image is
/// transparent. `sizePx` >= 8.
QImage renderIrradianceSphere(const ShRgb& sh, int sizePx, double exposure);

/// An exposure that maps the probe's mean radiance (the L00 term) to a mid-tone (0.6), the same
/// key as the viewport's automatic exposure.
double autoExposureFor(const ShRgb& sh);

}  // namespace ps::ui
