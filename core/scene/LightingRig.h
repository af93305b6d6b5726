#pragma once
// Light added by the user on top of the scene's own (most real scenes bring none): a sun, a
// sky and extra lights. Stored in the probe set so that eval and bake see the same light.
#include <string>
#include <vector>

#include "core/scene/Scene.h"

namespace ps {

struct LightingRig {
  /// Extra lights. A sun is a Directional light; `--sun DX,DY,DZ,E` gives the direction from
  /// the scene towards the sun, stored here as the direction the light travels (its negation).
  std::vector<Light> lights;
  /// Constant sky radiance, W/(m^2 sr) per channel, seen by rays that leave the scene.
  Rgb skyRadiance{0, 0, 0};

  bool empty() const { return lights.empty() && skyRadiance.isBlack(); }
};

/// The scene's lights followed by the rig's.
std::vector<Light> allLights(const Scene& scene, const LightingRig& rig);

}  // namespace ps
