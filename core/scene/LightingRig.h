#pragma once
// Light added by the user on top of the scene's own (most real scenes bring none): a sun, a
// sky and extra lights. Stored in the probe set so that eval and bake see the same light.
#include <memory>
#include <string>
#include <vector>

#include "core/scene/EnvironmentMap.h"
#include "core/scene/Scene.h"

namespace ps {

struct LightingRig {
  /// Extra lights. A sun is a Directional light; `--sun DX,DY,DZ,E` gives the direction from
  /// the scene towards the sun, stored here as the direction the light travels (its negation).
  std::vector<Light> lights;
  /// Constant sky radiance, W/(m^2 sr) per channel, seen by rays that leave the scene.
  Rgb skyRadiance{0, 0, 0};
  /// An equirectangular sky (`--env-map FILE`), added to skyRadiance for rays that leave the
  /// scene. The path is what the probe set stores; `envMap` is the loaded map, or null when
  /// only the path is known (a rig read from JSON): environmentOf() then loads it.
  std::string envMapPath;
  std::shared_ptr<const EnvironmentMap> envMap;

  bool empty() const {
    return lights.empty() && skyRadiance.isBlack() && envMapPath.empty() && !envMap;
  }
};

/// The rig with its point and spot lights' positions multiplied by `factor`: the rig in another
/// length unit (the probe set and the volume store positions in the scene's unit). Directions,
/// intensities and rangeMeters (metres in every unit) are unchanged.
/// Inline, so that the loaders (and their fuzz targets) need no other part of the rig's code.
inline LightingRig scaledRig(LightingRig rig, double factor) {
  for (Light& l : rig.lights)
    if (l.type != LightType::Directional) l.position = l.position * factor;
  return rig;
}

/// The scene's lights followed by the rig's.
std::vector<Light> allLights(const Scene& scene, const LightingRig& rig);

/// Eval's queries (EvalSettings) and greedy's probes keep this fraction of the domain's diagonal
/// away from point and spot lights. A point light's irradiance grows as 1 / r^2, so the squared
/// error of an interpolation next to it grows as 1 / r^4, whose integral over the volume around the
/// light diverges: without a clearance, rel_rmse is the relative error at whichever query lands
/// nearest to the light, and varies strongly with the seed. No real object sits inside a lamp.
inline constexpr double kDefaultLightClearanceRelative = 0.02;

/// The punctual lights (point and spot) of a scene and rig: their positions.
std::vector<Vec3> punctualLightPositions(const Scene& scene, const LightingRig& rig);

/// The rig's environment map: rig.envMap when loaded, else the map at rig.envMapPath read once
/// per process and path (a thread-safe cache), else null. Throws ps::FileError when the file
/// cannot be read.
std::shared_ptr<const EnvironmentMap> environmentOf(const LightingRig& rig);

}  // namespace ps
