#pragma once
// Small analytic scenes for the capture tests: quads, boxes (rooms or solids) and an
// "infinite" floor, built straight into a ps::Scene.
#include <cstdint>
#include <initializer_list>

#include "core/scene/Scene.h"

namespace ps::testing {

inline uint32_t addMaterial(Scene& s, Rgb albedo, Rgb emission = {}, bool doubleSided = false) {
  Material m;
  m.albedo = albedo;
  m.emission = emission;
  m.doubleSided = doubleSided;
  s.materials.push_back(m);
  return static_cast<uint32_t>(s.materials.size() - 1);
}

/// A point light at `position` with radiant intensity `intensity` (W/sr).
inline Light pointLight(Vec3 position, Rgb intensity) {
  Light l;
  l.type = LightType::Point;
  l.position = position;
  l.intensity = intensity;
  return l;
}

/// The parallelogram corner, corner + e1, corner + e1 + e2, corner + e2; its front side faces
/// cross(e1, e2).
inline void addQuad(Scene& s, Vec3 corner, Vec3 e1, Vec3 e2, uint32_t material) {
  const auto base = static_cast<uint32_t>(s.vertexCount());
  const Vec3 n = normalize(cross(e1, e2));
  for (Vec3 p : {corner, corner + e1, corner + e1 + e2, corner + e2}) {
    s.positions.insert(s.positions.end(),
                       {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
    s.normals.insert(s.normals.end(),
                     {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
    s.bounds.extend(p);
  }
  s.indices.insert(s.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  s.triangleMaterial.insert(s.triangleMaterial.end(), {material, material});
}

/// An axis-aligned box from lo to hi; front faces inside (a room) or outside (a solid).
inline void addBox(Scene& s, Vec3 lo, Vec3 hi, uint32_t material, bool inward) {
  const Vec3 d = hi - lo;
  const Vec3 x{d.x, 0, 0}, y{0, d.y, 0}, z{0, 0, d.z};
  struct Face {
    Vec3 corner, e1, e2;  // cross(e1, e2) points inwards
  };
  const Face faces[] = {
      {lo, z, x},                  // y = lo: +y
      {{lo.x, hi.y, lo.z}, x, z},  // y = hi: -y
      {lo, y, z},                  // x = lo: +x
      {{hi.x, lo.y, lo.z}, z, y},  // x = hi: -x
      {lo, x, y},                  // z = lo: +z
      {{lo.x, lo.y, hi.z}, y, x},  // z = hi: -z
  };
  for (const Face& f : faces)
    inward ? addQuad(s, f.corner, f.e1, f.e2, material)
           : addQuad(s, f.corner, f.e2, f.e1, material);
}

/// Rooms in a row along x: a grey (albedo 0.5) room box from the origin to `hi`, parted by solid
/// walls 0.1 m thick, full height and depth, centred at each of `wallXs`, lit by one point light.
inline Scene roomsAlongX(Vec3 hi, std::initializer_list<double> wallXs, Light light) {
  Scene s;
  const uint32_t grey = addMaterial(s, {0.5, 0.5, 0.5});
  addBox(s, {0, 0, 0}, hi, grey, /*inward=*/true);
  for (double x : wallXs) addBox(s, {x - 0.05, 0, 0}, {x + 0.05, hi.y, hi.z}, grey, false);
  s.lights.push_back(light);
  return s;
}

/// A black (or given albedo), single-sided, up-facing floor of half-size 1000 at y = 0: an
/// "infinite" ground (probes stand 1 m above it; the horizon gap is under 0.1 % of the sphere).
inline Scene floorScene(Rgb albedo = {0, 0, 0}) {
  Scene s;
  const uint32_t m = addMaterial(s, albedo);
  const double h = 1000;
  addQuad(s, {-h, 0, -h}, {0, 0, 2 * h}, {2 * h, 0, 0}, m);
  return s;
}

/// Two rooms of 5.95 x 3 x 6 m (x in [0, 5.95] and [6.05, 12], y in [0, 3], z in [0, 6])
/// joined by a 1 m wide, 2.1 m high doorway (z in [2.5, 3.5]) in the 0.1 m wall between them;
/// 0.2 m solid walls, floor and roof around them, every box closed and facing out.
inline Scene twoRoomsWithADoor() {
  Scene s;
  const uint32_t m = addMaterial(s, {0.6, 0.6, 0.6});
  addBox(s, {-0.2, -0.2, -0.2}, {12.2, 0, 6.2}, m, false);  // floor
  addBox(s, {-0.2, 3, -0.2}, {12.2, 3.2, 6.2}, m, false);   // roof
  addBox(s, {-0.2, 0, -0.2}, {0, 3, 6.2}, m, false);        // outer walls
  addBox(s, {12, 0, -0.2}, {12.2, 3, 6.2}, m, false);
  addBox(s, {0, 0, -0.2}, {12, 3, 0}, m, false);
  addBox(s, {0, 0, 6}, {12, 3, 6.2}, m, false);
  addBox(s, {5.95, 0, 0}, {6.05, 3, 2.5}, m, false);  // the wall between, its doorway
  addBox(s, {5.95, 0, 3.5}, {6.05, 3, 6}, m, false);
  addBox(s, {5.95, 2.1, 2.5}, {6.05, 3, 3.5}, m, false);
  return s;
}

/// `rooms` rooms of 3.88 x 3 x 6 m in a row along x (room k: x in [4k + 0.06, 4k + 3.94] with
/// walls 0.12 m thick between them), each joined to the next by a 1 m wide, 2.1 m high doorway
/// at z in [2.5, 3.5]; 0.2 m solid walls, floor and roof around them, every box closed and facing
/// out.
inline Scene roomsInARow(int rooms) {
  Scene s;
  const uint32_t m = addMaterial(s, {0.6, 0.6, 0.6});
  const double w = 4.0 * rooms;
  addBox(s, {-0.2, -0.2, -0.2}, {w + 0.2, 0, 6.2}, m, false);  // floor
  addBox(s, {-0.2, 3, -0.2}, {w + 0.2, 3.2, 6.2}, m, false);   // roof
  addBox(s, {-0.2, 0, -0.2}, {0, 3, 6.2}, m, false);           // outer walls
  addBox(s, {w, 0, -0.2}, {w + 0.2, 3, 6.2}, m, false);
  addBox(s, {0, 0, -0.2}, {w, 3, 0}, m, false);
  addBox(s, {0, 0, 6}, {w, 3, 6.2}, m, false);
  for (int k = 1; k < rooms; ++k) {  // the walls between, their doorways
    const double x = 4.0 * k;
    addBox(s, {x - 0.06, 0, 0}, {x + 0.06, 3, 2.5}, m, false);
    addBox(s, {x - 0.06, 0, 3.5}, {x + 0.06, 3, 6}, m, false);
    addBox(s, {x - 0.06, 2.1, 2.5}, {x + 0.06, 3, 3.5}, m, false);
  }
  return s;
}

}  // namespace ps::testing
