#pragma once
// A scene flattened to world-space triangle arrays: what the tracer and every stage read.
// Conventions (README "Conventions"): glTF +Y up, metres (a scene in another unit is scaled to
// metres on load, core/scene/SceneUnits.h); Lambertian materials whose albedo is
// baseColor and whose emitted radiance is emissive.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/math/Vec3.h"
#include "core/scene/Texture.h"

namespace ps {

/// glTF alphaMode (spec 3.9.4). Blend is treated as Opaque (a Lambertian capture has no
/// partial transparency); Mask cuts out where alpha < alphaCutoff.
enum class AlphaMode { Opaque, Mask, Blend };

struct Material {
  std::string name;
  /// The Lambertian reflectance: baseColorFactor (linear), or KHR_materials_pbrSpecularGlossiness
  /// diffuseFactor; multiplied by `albedoTexture` (sRGB decoded) where there is one.
  Rgb albedo{1, 1, 1};
  /// Emitted radiance, W/(m^2 sr) per channel: emissiveFactor times
  /// KHR_materials_emissive_strength; multiplied by `emissionTexture` where there is one.
  Rgb emission{0, 0, 0};
  /// glTF doubleSided: back faces are surfaces too (shaded, and a path goes on from them); its
  /// back faces count half towards "inside" (backfaceFraction).
  bool doubleSided = false;
  double alpha = 1;  ///< baseColorFactor[3] (diffuseFactor[3]), times the texture's alpha
  AlphaMode alphaMode = AlphaMode::Opaque;
  double alphaCutoff = 0.5;  ///< Mask: a point whose alpha is below this is not there
  TextureRef albedoTexture;  ///< baseColorTexture (diffuseTexture); its alpha is coverage
  TextureRef emissionTexture;

  bool isTextured() const { return albedoTexture.valid() || emissionTexture.valid(); }
  bool isCutOut() const { return alphaMode == AlphaMode::Mask; }
};

enum class LightType { Directional, Point, Spot };

/// A punctual light (KHR_lights_punctual) or a rig light, in world space.
struct Light {
  LightType type = LightType::Point;
  std::string name;
  Vec3 position;             ///< Point, Spot: world position
  Vec3 direction{0, -1, 0};  ///< Directional, Spot: unit direction the light travels
  /// Directional: irradiance on a surface facing the light (W/m^2 per channel).
  /// Point, Spot: radiant intensity (W/sr per channel), inverse-square falloff.
  Rgb intensity{1, 1, 1};
  double rangeMeters = 0;   ///< 0 = infinite
  double innerConeRad = 0;  ///< Spot only
  double outerConeRad = kPi / 4;
};

struct Scene {
  std::string sourcePath;                  ///< the file it was loaded from, as given
  std::vector<float> positions;            ///< 3 per vertex, world space
  std::vector<float> normals;              ///< 3 per vertex, world space, unit (same count)
  std::vector<float> texcoords;            ///< 2 per vertex: TEXCOORD_0 (0, 0 when absent)
  std::vector<uint32_t> indices;           ///< 3 per triangle, counter-clockwise front faces
  std::vector<uint32_t> triangleMaterial;  ///< 1 per triangle, index into materials
  std::vector<Material> materials;         ///< never empty once loaded (a default is added)
  std::vector<Light> lights;               ///< lights the scene brings (KHR_lights_punctual)
  std::vector<Image> images;               ///< decoded textures, indexed by TextureRef::image
  /// What was read but not used as written (an unreadable texture falls back to its factor),
  /// one line each naming the file and the glTF path. The CLI prints them to stderr.
  std::vector<std::string> warnings;
  Bounds3 bounds;  ///< of all vertices

  size_t vertexCount() const { return positions.size() / 3; }
  size_t triangleCount() const { return indices.size() / 3; }
  Vec3 vertex(uint32_t i) const {
    return {positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]};
  }
  /// True when some triangle emits light (an emissive material is in use).
  bool hasEmissiveSurfaces() const;
  /// True when some triangle's material is double-sided.
  bool hasDoubleSidedSurfaces() const;

  /// TEXCOORD_0 at barycentrics (u, v) of vertices 1 and 2 of `triangle` (a Hit's u, v).
  void texcoordAt(uint32_t triangle, double u, double v, double& s, double& t) const;
  /// The material's albedo at a point of the triangle: factor times texture.
  Rgb albedoAt(uint32_t triangle, double u, double v) const;
  /// The material's emitted radiance at a point of the triangle: factor times texture.
  Rgb emissionAt(uint32_t triangle, double u, double v) const;
  /// The material's alpha (coverage) at a point of the triangle: factor times texture alpha.
  double alphaAt(uint32_t triangle, double u, double v) const;
  /// True when the triangle's material is alphaMode MASK and the point is cut out
  /// (alpha < alphaCutoff): rays pass through it (glTF 3.9.4).
  bool isCutOutAt(uint32_t triangle, double u, double v) const;
};

/// Loads a .gltf or .glb file and flattens its default scene (or every root node when the file
/// names none) to world space. Node TRS and matrix transforms are applied; normals are
/// transformed by the inverse transpose (or computed from faces when absent).
/// `metresPerUnit` is the file's unit (1: metres, 0.001: millimetres; positive, finite): the
/// result is in metres, scaled by scaleScene() (positions, bounds, light positions and ranges;
/// light intensities and emission are unit-free and stay as written).
/// Throws ps::FileError naming the file and the glTF path (e.g. `meshes[3].primitives[0]`) for
/// a missing or malformed file, an accessor out of range, an index out of range, NaN or
/// infinite vertices, or a scene with no triangles.
Scene loadScene(const std::filesystem::path& path, double metresPerUnit = 1.0);

}  // namespace ps
