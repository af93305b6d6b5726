#include "core/scene/Scene.h"

namespace ps {

bool Scene::hasEmissiveSurfaces() const {
  std::vector<bool> emissive(materials.size(), false);
  bool any = false;
  for (size_t i = 0; i < materials.size(); ++i) {
    emissive[i] = !materials[i].emission.isBlack();
    any = any || emissive[i];
  }
  if (!any) return false;
  for (uint32_t m : triangleMaterial)
    if (m < emissive.size() && emissive[m]) return true;
  return false;
}

}  // namespace ps
