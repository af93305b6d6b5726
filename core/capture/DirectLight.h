#pragma once
// Light arriving at a point straight from delta lights (punctual lights and the sun): no ray
// ever hits them, so both the probe capture (Full mode) and the evaluation's reference add it
// analytically.
#include <optional>
#include <span>

#include "core/math/Sh.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace ps {

struct DeltaLightArrival {
  Vec3 directionToLight;  ///< unit
  double distance = 0;    ///< to the light; infinity for directional lights
  Rgb irradiance;         ///< on a surface facing the light, before occlusion (W/m^2)
};

/// Directional: intensity; point: I / d^2; spot: I / d^2 times the smooth cone falloff between
/// inner and outer angle; with a range, glTF's recommended window
/// clamp(1 - (d / range)^4, 0, 1)^2. Nothing when the light contributes nothing at p.
std::optional<DeltaLightArrival> deltaLightArrival(const Light& light, Vec3 p);

/// deltaLightArrival(), and nothing also when its direction or irradiance is not finite (a light
/// at p, a zero direction: never NaN into a probe).
std::optional<DeltaLightArrival> finiteDeltaArrival(const Light& light, Vec3 p);

/// The shadow ray from p towards the light: offset by the tracer's epsilon `rayEpsilon` at the
/// start, ending just short of a point or spot light.
Ray deltaLightShadowRay(double rayEpsilon, Vec3 p, const DeltaLightArrival& a);

/// True when nothing blocks the segment from p towards the light (deltaLightShadowRay).
bool deltaLightVisible(const Tracer& tracer, Vec3 p, const DeltaLightArrival& a);

/// What the delta light delivers at p through an unoccluded segment (p is a probe, a ray origin
/// or a point already offset from its surface), or nothing when it is blocked, dark or
/// degenerate (a zero direction or a light at p: never NaN into a probe).
std::optional<DeltaLightArrival> visibleDeltaArrival(const Tracer& tracer, const Light& light,
                                                     Vec3 p);

/// SH of the radiance arriving at p straight from the delta lights (the visible ones):
/// c_i = sum over the lights of E Y_i(w).
ShRgb directDeltaSh(const Tracer& tracer, std::span<const Light> lights, Vec3 p);

}  // namespace ps
