#include "ui/SurfacePlacement.h"

namespace ps::ui {

std::optional<SurfacePlacement> placeOnSurface(const Tracer& tracer, Vec3 origin, Vec3 direction,
                                               double offsetMeters) {
  const auto hit = tracer.intersect(Ray{origin, direction});
  if (!hit) return std::nullopt;
  SurfacePlacement out;
  out.hitPoint = origin + direction * hit->t;
  out.normal = hit->geometricNormal;
  if (dot(out.normal, direction) > 0) out.normal = -out.normal;  // towards the viewer
  double offset = offsetMeters;
  const auto across =
      tracer.intersect(Ray{out.hitPoint, out.normal, tracer.rayEpsilon(), 2.0 * offsetMeters});
  if (across) offset = 0.5 * across->t;
  out.position = out.hitPoint + out.normal * offset;
  return out;
}

}  // namespace ps::ui
