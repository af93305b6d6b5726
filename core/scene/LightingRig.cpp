#include "core/scene/LightingRig.h"

namespace ps {

std::vector<Light> allLights(const Scene& scene, const LightingRig& rig) {
  std::vector<Light> all = scene.lights;
  all.insert(all.end(), rig.lights.begin(), rig.lights.end());
  return all;
}

}  // namespace ps
