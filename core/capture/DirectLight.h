#pragma once
// Light arriving at a point straight from delta lights (punctual lights and the sun): no ray
// ever hits them, so both the probe capture (Full mode) and the evaluation's reference add it
// analytically.
#include <optional>

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

/// True when nothing blocks the segment from p towards the light (shadow ray offset by the
/// tracer's epsilon at the start).
bool deltaLightVisible(const Tracer& tracer, Vec3 p, const DeltaLightArrival& a);

}  // namespace ps
