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

bool Scene::hasDoubleSidedSurfaces() const {
  for (uint32_t m : triangleMaterial)
    if (m < materials.size() && materials[m].doubleSided) return true;
  return false;
}

void Scene::texcoordAt(uint32_t triangle, double u, double v, double& s, double& t) const {
  if (texcoords.size() != 2 * vertexCount()) {
    s = t = 0;
    return;
  }
  const uint32_t* tri = &indices[3 * static_cast<size_t>(triangle)];
  const double w0 = 1 - u - v;
  s = w0 * texcoords[2 * tri[0]] + u * texcoords[2 * tri[1]] + v * texcoords[2 * tri[2]];
  t = w0 * texcoords[2 * tri[0] + 1] + u * texcoords[2 * tri[1] + 1] +
      v * texcoords[2 * tri[2] + 1];
}

namespace {

/// The texture's RGBA at the point, or nothing when the material has no (loaded) texture.
bool sampleAt(const Scene& scene, const TextureRef& ref, uint32_t triangle, double u, double v,
              float out[4]) {
  if (!ref.valid() || static_cast<size_t>(ref.image) >= scene.images.size()) return false;
  const Image& img = scene.images[static_cast<size_t>(ref.image)];
  if (img.width <= 0 || img.height <= 0) return false;
  double s, t;
  scene.texcoordAt(triangle, u, v, s, t);
  sampleImage(img, ref, s, t, out);
  return true;
}

}  // namespace

Rgb Scene::albedoAt(uint32_t triangle, double u, double v) const {
  const Material& m = materials[triangleMaterial[triangle]];
  float texel[4];
  if (!sampleAt(*this, m.albedoTexture, triangle, u, v, texel)) return m.albedo;
  return m.albedo * Rgb(texel[0], texel[1], texel[2]);
}

Rgb Scene::emissionAt(uint32_t triangle, double u, double v) const {
  const Material& m = materials[triangleMaterial[triangle]];
  float texel[4];
  if (m.emission.isBlack() || !sampleAt(*this, m.emissionTexture, triangle, u, v, texel))
    return m.emission;
  return m.emission * Rgb(texel[0], texel[1], texel[2]);
}

double Scene::alphaAt(uint32_t triangle, double u, double v) const {
  const Material& m = materials[triangleMaterial[triangle]];
  float texel[4];
  if (!sampleAt(*this, m.albedoTexture, triangle, u, v, texel)) return m.alpha;
  return m.alpha * texel[3];
}

bool Scene::isCutOutAt(uint32_t triangle, double u, double v) const {
  const Material& m = materials[triangleMaterial[triangle]];
  return m.isCutOut() && alphaAt(triangle, u, v) < m.alphaCutoff;
}

}  // namespace ps
