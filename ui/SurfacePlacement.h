#pragma once
// Where a probe goes when the artist clicks a surface: a ray through the cursor, traced by the
// core's Embree tracer.
#include <optional>

#include "core/trace/Tracer.h"

namespace ps::ui {

struct SurfacePlacement {
  Vec3 position;  ///< where the probe goes
  Vec3 hitPoint;  ///< the surface point the ray hit
  Vec3 normal;    ///< unit geometric normal at the hit, turned towards the ray's origin
};

/// The first surface the ray (origin, unit direction) hits, and the point `offsetMeters` from it
/// along the normal turned towards the viewer. When another surface lies along that normal
/// closer than 2 * offsetMeters, the probe goes halfway to it instead, so it never ends up
/// behind (or inside) a nearby wall. Nothing when the ray hits nothing.
std::optional<SurfacePlacement> placeOnSurface(const Tracer& tracer, Vec3 origin, Vec3 direction,
                                               double offsetMeters);

}  // namespace ps::ui
