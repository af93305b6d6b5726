#include "core/scene/LightingRig.h"

#include <map>
#include <mutex>

namespace ps {

std::vector<Light> allLights(const Scene& scene, const LightingRig& rig) {
  std::vector<Light> all = scene.lights;
  all.insert(all.end(), rig.lights.begin(), rig.lights.end());
  return all;
}

std::shared_ptr<const EnvironmentMap> environmentOf(const LightingRig& rig) {
  if (rig.envMap || rig.envMapPath.empty()) return rig.envMap;
  // Rigs read from a probe set carry only the path; evaluation builds a path tracer per ray,
  // so the map is read once per path and shared.
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const EnvironmentMap>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = cache.find(rig.envMapPath);
  if (it != cache.end()) return it->second;
  auto map = loadEnvironmentMap(rig.envMapPath);
  cache.emplace(rig.envMapPath, map);
  return map;
}

std::vector<Vec3> punctualLightPositions(const Scene& scene, const LightingRig& rig) {
  std::vector<Vec3> out;
  for (const Light& l : allLights(scene, rig))
    if (l.type != LightType::Directional) out.push_back(l.position);
  return out;
}

}  // namespace ps
