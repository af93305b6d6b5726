#pragma once
// A scene flattened to world-space triangle arrays: what the tracer and every stage read.
// Conventions (README "Conventions"): glTF +Y up, metres; Lambertian materials whose albedo is
// baseColor and whose emitted radiance is emissive.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/math/Vec3.h"

namespace ps {

struct Material {
  std::string name;
  Rgb albedo{1, 1, 1};       ///< baseColorFactor (linear), the Lambertian reflectance
  Rgb emission{0, 0, 0};     ///< emitted radiance, W/(m^2 sr) per channel
  bool doubleSided = false;  ///< glTF doubleSided: back faces are surfaces too (never "inside")
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
  std::vector<uint32_t> indices;           ///< 3 per triangle, counter-clockwise front faces
  std::vector<uint32_t> triangleMaterial;  ///< 1 per triangle, index into materials
  std::vector<Material> materials;         ///< never empty once loaded (a default is added)
  std::vector<Light> lights;               ///< lights the scene brings (KHR_lights_punctual)
  Bounds3 bounds;                          ///< of all vertices

  size_t vertexCount() const { return positions.size() / 3; }
  size_t triangleCount() const { return indices.size() / 3; }
  Vec3 vertex(uint32_t i) const {
    return {positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]};
  }
  /// True when some triangle emits light (an emissive material is in use).
  bool hasEmissiveSurfaces() const;
};

/// Loads a .gltf or .glb file and flattens its default scene (or every root node when the file
/// names none) to world space. Node TRS and matrix transforms are applied; normals are
/// transformed by the inverse transpose (or computed from faces when absent).
/// Throws ps::FileError naming the file and the glTF path (e.g. `meshes[3].primitives[0]`) for
/// a missing or malformed file, an accessor out of range, an index out of range, NaN or
/// infinite vertices, or a scene with no triangles.
Scene loadScene(const std::filesystem::path& path);

}  // namespace ps
