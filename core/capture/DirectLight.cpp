#include "core/capture/DirectLight.h"

#include <algorithm>
#include <cmath>

namespace ps {

std::optional<DeltaLightArrival> deltaLightArrival(const Light& light, Vec3 p) {
  DeltaLightArrival a;
  if (light.type == LightType::Directional) {
    a.directionToLight = -normalize(light.direction);
    a.distance = std::numeric_limits<double>::infinity();
    a.irradiance = light.intensity;
    return a;
  }
  const Vec3 toLight = light.position - p;
  const double d2 = dot(toLight, toLight);
  if (d2 <= 0) return std::nullopt;
  a.distance = std::sqrt(d2);
  a.directionToLight = toLight / a.distance;
  double scale = 1.0 / d2;
  if (light.rangeMeters > 0) {
    // KHR_lights_punctual's recommended range window.
    const double r = a.distance / light.rangeMeters;
    const double w = std::clamp(1.0 - r * r * r * r, 0.0, 1.0);
    scale *= w * w;
  }
  if (light.type == LightType::Spot) {
    // KHR_lights_punctual's spot falloff: smooth between the outer and inner cone.
    const double cosOuter = std::cos(light.outerConeRad);
    const double cosInner = std::cos(light.innerConeRad);
    const double cd = dot(-a.directionToLight, normalize(light.direction));
    const double t = std::clamp((cd - cosOuter) / std::max(1e-9, cosInner - cosOuter), 0.0, 1.0);
    scale *= t * t;
  }
  if (scale <= 0) return std::nullopt;
  a.irradiance = light.intensity * scale;
  return a;
}

std::optional<DeltaLightArrival> finiteDeltaArrival(const Light& light, Vec3 p) {
  auto a = deltaLightArrival(light, p);
  const auto finite = [](Rgb c) {
    return std::isfinite(c.r) && std::isfinite(c.g) && std::isfinite(c.b);
  };
  if (!a || !isFinite(a->directionToLight) || !finite(a->irradiance)) return std::nullopt;
  return a;
}

Ray deltaLightShadowRay(double rayEpsilon, Vec3 p, const DeltaLightArrival& a) {
  Ray r;
  r.origin = p;
  r.direction = a.directionToLight;
  r.tMin = rayEpsilon;
  r.tMax = std::isfinite(a.distance) ? a.distance * (1.0 - 1e-6)
                                     : std::numeric_limits<double>::infinity();
  return r;
}

bool deltaLightVisible(const Tracer& tracer, Vec3 p, const DeltaLightArrival& a) {
  return !tracer.occluded(deltaLightShadowRay(tracer.rayEpsilon(), p, a));
}

std::optional<DeltaLightArrival> visibleDeltaArrival(const Tracer& tracer, const Light& light,
                                                     Vec3 p) {
  auto a = finiteDeltaArrival(light, p);
  if (!a || !deltaLightVisible(tracer, p, *a)) return std::nullopt;
  return a;
}

ShRgb directDeltaSh(const Tracer& tracer, std::span<const Light> lights, Vec3 p) {
  ShRgb sh;
  for (const Light& light : lights)
    if (const auto a = visibleDeltaArrival(tracer, light, p))
      sh.addSample(a->directionToLight, a->irradiance, 1.0);  // c_i = E Y_i(w)
  return sh;
}

}  // namespace ps
