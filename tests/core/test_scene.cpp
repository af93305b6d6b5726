// Tests of ps::loadScene (core/scene/GltfLoader.cpp) and the bundled default scenes written by
// scripts/make_scenes.py. Small glTF files are built here in a temp dir; malformed inputs live in
// tests/data/gltf/.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "core/common/Error.h"
#include "core/scene/Scene.h"
#include "tests/core/TestFiles.h"

namespace fs = std::filesystem;
using json = nlohmann::json;
using ps::Vec3;

namespace {

const fs::path kScenes = fs::path(PS_SOURCE_DIR) / "resources" / "scenes";
const fs::path kData = fs::path(PS_SOURCE_DIR) / "tests" / "data" / "gltf";
const fs::path kShared = fs::path(PS_SHARED_SCENES_DIR);

const fs::path& tempDir() {
  return ps::test::programTempDir("ps_test_scene_");
}

/// Builds small glTF documents: one buffer, one bufferView per accessor.
struct Gltf {
  json doc = {{"asset", {{"version", "2.0"}}}, {"scenes", json::array()},
              {"nodes", json::array()},        {"meshes", json::array()},
              {"accessors", json::array()},    {"bufferViews", json::array()}};
  std::vector<uint8_t> bin;

  template <typename T>
  int accessor(const std::vector<T>& values, int componentType, const char* type, int count) {
    while (bin.size() % 4) bin.push_back(0);
    const size_t offset = bin.size();
    bin.resize(offset + values.size() * sizeof(T));
    std::memcpy(bin.data() + offset, values.data(), values.size() * sizeof(T));
    doc["bufferViews"].push_back(
        {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", values.size() * sizeof(T)}});
    doc["accessors"].push_back({{"bufferView", doc["bufferViews"].size() - 1},
                                {"componentType", componentType},
                                {"count", count},
                                {"type", type}});
    return int(doc["accessors"].size() - 1);
  }
  int positions(const std::vector<float>& p) {
    return accessor(p, 5126, "VEC3", int(p.size() / 3));
  }
  /// A mesh with one primitive; returns its index.
  int mesh(int position, std::optional<int> normal, std::optional<int> indices, int mode = 4) {
    json prim = {{"attributes", {{"POSITION", position}}}, {"mode", mode}};
    if (normal) prim["attributes"]["NORMAL"] = *normal;
    if (indices) prim["indices"] = *indices;
    doc["meshes"].push_back({{"primitives", json::array({prim})}});
    return int(doc["meshes"].size() - 1);
  }
  int node(json n) {
    doc["nodes"].push_back(std::move(n));
    return int(doc["nodes"].size() - 1);
  }
  void scene(std::vector<int> roots) {
    doc["scenes"].push_back({{"nodes", roots}});
    doc["scene"] = 0;
  }
  fs::path writeGltf(const std::string& name) {
    json d = doc;
    d["buffers"] = {{{"byteLength", bin.size()},
                     {"uri", "data:application/octet-stream;base64," + ps::test::base64(bin)}}};
    const fs::path path = tempDir() / name;
    std::ofstream(path) << d.dump();
    return path;
  }
  std::vector<uint8_t> glbBytes() {
    json d = doc;
    d["buffers"] = {{{"byteLength", bin.size()}}};
    std::string text = d.dump();
    while (text.size() % 4) text += ' ';
    std::vector<uint8_t> b = bin;
    while (b.size() % 4) b.push_back(0);
    std::vector<uint8_t> out;
    auto u32 = [&](uint32_t v) {
      for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
    };
    u32(0x46546C67u);  // "glTF"
    u32(2);
    u32(uint32_t(12 + 8 + text.size() + 8 + b.size()));
    u32(uint32_t(text.size()));
    u32(0x4E4F534Au);
    out.insert(out.end(), text.begin(), text.end());
    u32(uint32_t(b.size()));
    u32(0x004E4942u);
    out.insert(out.end(), b.begin(), b.end());
    return out;
  }
};

fs::path writeBytes(const std::string& name, const std::vector<uint8_t>& bytes) {
  const fs::path path = tempDir() / name;
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  return path;
}

Vec3 normalAt(const ps::Scene& s, uint32_t v) {
  return {s.normals[3 * v], s.normals[3 * v + 1], s.normals[3 * v + 2]};
}
std::array<Vec3, 3> triangle(const ps::Scene& s, size_t t) {
  return {s.vertex(s.indices[3 * t]), s.vertex(s.indices[3 * t + 1]),
          s.vertex(s.indices[3 * t + 2])};
}
Vec3 windingNormal(const std::array<Vec3, 3>& t) {
  return ps::normalize(ps::cross(t[1] - t[0], t[2] - t[0]));
}
void expectNear(Vec3 a, Vec3 b, double eps) {
  EXPECT_NEAR(a.x, b.x, eps) << a << " vs " << b;
  EXPECT_NEAR(a.y, b.y, eps) << a << " vs " << b;
  EXPECT_NEAR(a.z, b.z, eps) << a << " vs " << b;
}

/// Invariants every loaded scene satisfies.
void expectWellFormed(const ps::Scene& s) {
  ASSERT_EQ(s.positions.size(), s.normals.size());
  ASSERT_EQ(s.indices.size() % 3, 0u);
  ASSERT_EQ(s.triangleMaterial.size(), s.triangleCount());
  ASSERT_FALSE(s.materials.empty());
  size_t bad = 0;
  for (uint32_t i : s.indices) bad += i >= s.vertexCount();
  for (uint32_t m : s.triangleMaterial) bad += m >= s.materials.size();
  EXPECT_EQ(bad, 0u) << "indices or material ids out of range";
  size_t notUnit = 0, outside = 0;
  for (uint32_t v = 0; v < s.vertexCount(); ++v) {
    notUnit += std::abs(ps::length(normalAt(s, v)) - 1.0) > 1e-5;
    outside += !s.bounds.contains(s.vertex(v));
  }
  EXPECT_EQ(notUnit, 0u) << "normals must be unit length";
  EXPECT_EQ(outside, 0u) << "bounds must contain every vertex";
}

/// Every triangle's shading normals agree with its winding (true of the bundled box scenes).
void expectNormalsFollowWinding(const ps::Scene& s) {
  size_t disagree = 0;
  for (size_t t = 0; t < s.triangleCount(); ++t) {
    const Vec3 g = windingNormal(triangle(s, t));
    for (int k = 0; k < 3; ++k) disagree += ps::dot(g, normalAt(s, s.indices[3 * t + k])) < 0.9999;
  }
  EXPECT_EQ(disagree, 0u);
}

/// Möller–Trumbore, brute force over every triangle: the oracle for visibility checks.
bool segmentBlocked(const ps::Scene& s, Vec3 from, Vec3 to) {
  const Vec3 d = to - from;
  for (size_t t = 0; t < s.triangleCount(); ++t) {
    const auto [a, b, c] = triangle(s, t);
    const Vec3 e1 = b - a, e2 = c - a, p = ps::cross(d, e2);
    const double det = ps::dot(e1, p);
    if (std::abs(det) < 1e-12) continue;
    const Vec3 tv = from - a;
    const double u = ps::dot(tv, p) / det;
    const Vec3 q = ps::cross(tv, e1);
    const double v = ps::dot(d, q) / det;
    const double h = ps::dot(e2, q) / det;
    if (u >= 0 && v >= 0 && u + v <= 1 && h > 1e-9 && h < 1 - 1e-9) return true;
  }
  return false;
}

template <typename F>
std::string errorOf(F&& load) {
  try {
    load();
  } catch (const ps::FileError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected ps::FileError";
  return {};
}
std::string loadError(const fs::path& p) {
  return errorOf([&] { ps::loadScene(p); });
}

}  // namespace

// ---------------------------------------------------------------------------- bundled scenes

TEST(BundledScenes, CornellCountsBoundsAndLight) {
  const ps::Scene s = ps::loadScene(kScenes / "cornell.gltf");
  expectWellFormed(s);
  expectNormalsFollowWinding(s);
  EXPECT_EQ(s.triangleCount(), 8u * 12u);  // 8 boxes
  EXPECT_EQ(s.materials.size(), 4u);
  EXPECT_TRUE(s.lights.empty());
  EXPECT_TRUE(s.hasEmissiveSurfaces());
  expectNear(s.bounds.lo, {-2.85, -0.1, -2.85}, 1e-6);
  expectNear(s.bounds.hi, {2.85, 5.6, 2.75}, 1e-6);
  // The one emissive material: radiance 16 (factor 1 x strength 16), and its lower face is the
  // only emissive face looking down into the room, 2 cm below the ceiling.
  int emissive = -1;
  for (size_t m = 0; m < s.materials.size(); ++m)
    if (!s.materials[m].emission.isBlack()) {
      EXPECT_EQ(emissive, -1);
      emissive = int(m);
    }
  ASSERT_GE(emissive, 0);
  EXPECT_EQ(s.materials[size_t(emissive)].emission, ps::Rgb(16, 16, 16));
  double downArea = 0;
  for (size_t t = 0; t < s.triangleCount(); ++t) {
    if (s.triangleMaterial[t] != uint32_t(emissive)) continue;
    const auto tri = triangle(s, t);
    if (windingNormal(tri).y > 0.999) continue;
    if (windingNormal(tri).y < -0.999) {
      EXPECT_NEAR(tri[0].y, 5.48, 1e-6);
      downArea += 0.5 * ps::length(ps::cross(tri[1] - tri[0], tri[2] - tri[0]));
    }
  }
  EXPECT_NEAR(downArea, 1.3 * 1.05, 1e-5);
  // Red on the left (-x), green on the right (+x).
  for (size_t t = 0; t < s.triangleCount(); ++t) {
    const ps::Rgb a = s.materials[s.triangleMaterial[t]].albedo;
    const double x = triangle(s, t)[0].x;
    if (a.r > 0.5 && a.g < 0.1) {
      EXPECT_LE(x, -2.75 + 1e-6);
    }
    if (a.g > 0.4 && a.r < 0.2) {
      EXPECT_GE(x, 2.75 - 1e-6);
    }
  }
}

TEST(BundledScenes, PillarRoomPillarShadowsPartOfTheRoom) {
  const ps::Scene s = ps::loadScene(kScenes / "pillar-room.gltf");
  expectWellFormed(s);
  expectNormalsFollowWinding(s);
  EXPECT_EQ(s.triangleCount(), 7u * 12u);
  EXPECT_EQ(s.materials.size(), 3u);
  EXPECT_FALSE(s.hasEmissiveSurfaces());
  expectNear(s.bounds.lo, {-4.2, -0.2, -4.2}, 1e-6);
  expectNear(s.bounds.hi, {4.2, 3.2, 4.2}, 1e-6);
  ASSERT_EQ(s.lights.size(), 1u);
  const ps::Light& l = s.lights[0];
  EXPECT_EQ(l.type, ps::LightType::Point);
  expectNear(l.position, {2.0, 2.7, 1.5}, 1e-6);
  // Floor irradiance straight below, I / r^2, is O(1-10) W/m^2.
  const double below = l.intensity.maxComponent() / (2.7 * 2.7);
  EXPECT_GT(below, 1.0);
  EXPECT_LT(below, 10.0);
  // The floor point diametrically behind the pillar is in shadow; one beside the light is lit.
  EXPECT_TRUE(segmentBlocked(s, {-2.0, 1e-3, -1.5}, l.position));
  EXPECT_FALSE(segmentBlocked(s, {2.0, 1e-3, -2.0}, l.position));
}

TEST(BundledScenes, TwoRoomsDoorwayAndSunPatch) {
  const ps::Scene s = ps::loadScene(kScenes / "two-rooms.gltf");
  expectWellFormed(s);
  expectNormalsFollowWinding(s);
  EXPECT_EQ(s.triangleCount(), 16u * 12u);
  EXPECT_EQ(s.materials.size(), 4u);
  EXPECT_FALSE(s.hasEmissiveSurfaces());
  expectNear(s.bounds.lo, {-6.25, -0.2, -3.2}, 1e-6);
  expectNear(s.bounds.hi, {6.25, 3.2, 3.2}, 1e-6);
  ASSERT_EQ(s.lights.size(), 2u);
  const ps::Light& lamp = s.lights[0];
  const ps::Light& sun = s.lights[1];
  EXPECT_EQ(lamp.type, ps::LightType::Point);
  EXPECT_LT(lamp.position.x, 0.0);                // room A
  EXPECT_GT(lamp.intensity.r, lamp.intensity.b);  // warm
  EXPECT_EQ(sun.type, ps::LightType::Directional);
  expectNear(sun.direction, ps::normalize(Vec3(-1, -0.8, 0.25)), 1e-6);
  EXPECT_GE(sun.intensity.maxComponent(), 3.0);
  EXPECT_LE(sun.intensity.maxComponent(), 5.0);
  // The sun reaches B's floor through the window, and nowhere in room A.
  const Vec3 toSun = -sun.direction * 100.0;
  EXPECT_FALSE(segmentBlocked(s, Vec3(4.0, 1e-3, 0.5), Vec3(4.0, 1e-3, 0.5) + toSun));
  EXPECT_TRUE(segmentBlocked(s, Vec3(2.0, 1e-3, 0.5), Vec3(2.0, 1e-3, 0.5) + toSun));
  for (double x = -5.5; x < 0; x += 0.5)
    EXPECT_TRUE(segmentBlocked(s, Vec3(x, 1e-3, 0.3), Vec3(x, 1e-3, 0.3) + toSun)) << x;
  // The doorway connects the rooms; the shared wall blocks elsewhere.
  EXPECT_FALSE(segmentBlocked(s, {-1.0, 1.0, 0.0}, {1.0, 1.0, 0.0}));
  EXPECT_TRUE(segmentBlocked(s, {-1.0, 1.0, 2.0}, {1.0, 1.0, 2.0}));
  EXPECT_TRUE(segmentBlocked(s, {-1.0, 2.5, 0.0}, {1.0, 2.5, 0.0}));
  // Closed exterior except the window: no horizontal escape at y = 0.5.
  for (Vec3 d : {Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(0, 1, 0)})
    EXPECT_TRUE(segmentBlocked(s, {3.0, 0.5, 0.0}, Vec3(3.0, 0.5, 0.0) + d * 50.0)) << d;
}

TEST(BundledScenes, GeneratorIsDeterministicAndFilesAreCurrent) {
  const fs::path script = fs::path(PS_SOURCE_DIR) / "scripts" / "make_scenes.py";
  if (std::system("python3 --version > /dev/null 2>&1") != 0) GTEST_SKIP() << "no python3";
  const fs::path out = tempDir() / "regen";
  const std::string cmd = "python3 '" + script.string() + "' '" + out.string() + "' > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  for (const char* name : {"cornell.gltf", "pillar-room.gltf", "two-rooms.gltf"})
    EXPECT_TRUE(slurp(out / name) == slurp(kScenes / name))
        << name << " differs from scripts/make_scenes.py output: regenerate it";
}

// The centimetre and millimetre copies of two-rooms (make_scenes.py --unit-copies), loaded in
// their unit, are the metre scene: positions and light positions scaled, intensities as written.
TEST(BundledScenes, UnitCopiesLoadedInTheirUnitAreTheMetreScene) {
  const fs::path script = fs::path(PS_SOURCE_DIR) / "scripts" / "make_scenes.py";
  if (std::system("python3 --version > /dev/null 2>&1") != 0) GTEST_SKIP() << "no python3";
  const fs::path out = tempDir() / "units";
  const std::string cmd =
      "python3 '" + script.string() + "' --unit-copies '" + out.string() + "' > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const ps::Scene m = ps::loadScene(kScenes / "two-rooms.gltf");
  for (const auto& [name, unit] :
       {std::pair{"two-rooms-cm.gltf", 0.01}, {"two-rooms-mm.gltf", 0.001}}) {
    SCOPED_TRACE(name);
    const ps::Scene s = ps::loadScene(out / name, unit);
    ASSERT_EQ(s.positions.size(), m.positions.size());
    for (size_t i = 0; i < s.positions.size(); ++i)
      ASSERT_NEAR(s.positions[i], m.positions[i], 1e-6 * 12.5) << i;
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(s.bounds.lo[a], m.bounds.lo[a], 1e-5);
      EXPECT_NEAR(s.bounds.hi[a], m.bounds.hi[a], 1e-5);
    }
    ASSERT_EQ(s.lights.size(), m.lights.size());
    for (size_t k = 0; k < s.lights.size(); ++k) {
      EXPECT_NEAR(length(s.lights[k].position - m.lights[k].position), 0, 1e-5);
      EXPECT_EQ(s.lights[k].intensity, m.lights[k].intensity);
      EXPECT_NEAR(length(s.lights[k].direction - m.lights[k].direction), 0, 1e-9);
    }
    // Read as metres, the copy is 1 / unit times larger.
    const ps::Scene raw = ps::loadScene(out / name);
    EXPECT_NEAR(raw.bounds.extent().y, m.bounds.extent().y / unit, 1e-3 / unit);
  }
}

// ---------------------------------------------------------------------------- small glTFs

TEST(GltfLoader, TrsParentWithMatrixChildLandsWhereExpected) {
  Gltf g;
  const int pos = g.positions({0, 0, 0, 1, 0, 0, 0, 0, -1});
  const int mesh = g.mesh(pos, std::nullopt, std::nullopt);
  // Child: matrix = translate(0, 1, 0), column-major.
  const int child =
      g.node({{"mesh", mesh}, {"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 1}}});
  // Parent: T(10, 0, 0) * R_y(90 deg) * S(2).
  const double h = std::sqrt(0.5);
  const int parent = g.node({{"children", {child}},
                             {"translation", {10, 0, 0}},
                             {"rotation", {0, h, 0, h}},
                             {"scale", {2, 2, 2}}});
  g.scene({parent});
  const ps::Scene s = ps::loadScene(g.writeGltf("hierarchy.gltf"));
  expectWellFormed(s);
  ASSERT_EQ(s.triangleCount(), 1u);
  // p -> p + (0,1,0) -> 2p -> R_y(90): (x, y, z) -> (z, y, -x) -> + (10, 0, 0)
  const auto t = triangle(s, 0);
  expectNear(t[0], {10, 2, 0}, 1e-6);
  expectNear(t[1], {10, 2, -2}, 1e-6);
  expectNear(t[2], {8, 2, 0}, 1e-6);
  expectNear(s.bounds.lo, {8, 2, -2}, 1e-6);
  expectNear(s.bounds.hi, {10, 2, 0}, 1e-6);
  // Flat normal facing the winding.
  for (int k = 0; k < 3; ++k) expectNear(normalAt(s, s.indices[k]), windingNormal(t), 1e-6);
  EXPECT_EQ(s.materials.size(), 1u);  // the default white material
  EXPECT_EQ(s.materials[0].albedo, ps::Rgb(1, 1, 1));
}

TEST(GltfLoader, NonUniformScaleTransformsNormalsByInverseTranspose) {
  Gltf g;
  // Triangle in the plane x + y = 1 with its normal (1, 1, 0)/sqrt2 given per vertex.
  const int pos = g.positions({1, 0, 0, 0, 1, 0, 1, 0, 1});
  const float c = float(std::sqrt(0.5));
  const int nor = g.accessor(std::vector<float>{c, c, 0, c, c, 0, c, c, 0}, 5126, "VEC3", 3);
  g.node({{"mesh", g.mesh(pos, nor, std::nullopt)}, {"scale", {4, 1, 1}}});
  g.scene({0});
  const ps::Scene s = ps::loadScene(g.writeGltf("scaled.gltf"));
  const auto t = triangle(s, 0);
  const Vec3 n = normalAt(s, s.indices[0]);
  expectNear(n, ps::normalize(Vec3(0.25, 1, 0)), 1e-6);
  EXPECT_NEAR(ps::dot(n, t[1] - t[0]), 0.0, 1e-6);
  EXPECT_NEAR(ps::dot(n, t[2] - t[0]), 0.0, 1e-6);
}

TEST(GltfLoader, NegativeDeterminantFlipsWinding) {
  for (bool withNormals : {true, false}) {
    Gltf g;
    const int pos = g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});  // CCW seen from +z
    std::optional<int> nor;
    if (withNormals)
      nor = g.accessor(std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1}, 5126, "VEC3", 3);
    g.node({{"mesh", g.mesh(pos, nor, std::nullopt)}, {"scale", {-1, 1, 1}}});
    g.scene({0});
    const ps::Scene s = ps::loadScene(g.writeGltf("mirror.gltf"));
    // Mirroring x keeps the front face towards +z: the winding must be reversed to match.
    expectNear(windingNormal(triangle(s, 0)), {0, 0, 1}, 1e-6);
    expectNear(normalAt(s, s.indices[0]), {0, 0, 1}, 1e-6);
  }
}

TEST(GltfLoader, StripsAndFansFollowTheSpecVertexOrder) {
  // Strip v0..v4 zig-zag in z = 0: p_i = {v_i, v_{i+1+i%2}, v_{i+2-i%2}} (glTF 3.7.2.1).
  const std::vector<float> strip = {0, 0, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0, 2, 0, 0};
  // Fan around v0, v1..v4 counter-clockwise: p_i = {v_{i+1}, v_{i+2}, v_0}.
  const std::vector<float> fan = {0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0};
  Gltf g;
  g.node({{"mesh", g.mesh(g.positions(strip), std::nullopt, std::nullopt, 5)}});
  g.node({{"mesh", g.mesh(g.positions(fan), std::nullopt, std::nullopt, 6)},
          {"translation", {0, 0, 5}}});
  g.scene({0, 1});
  const ps::Scene s = ps::loadScene(g.writeGltf("strip-fan.gltf"));
  expectWellFormed(s);
  ASSERT_EQ(s.triangleCount(), 6u);
  auto v = [](const std::vector<float>& a, int i, double dz = 0) {
    return Vec3(a[3 * i], a[3 * i + 1], a[3 * i + 2] + dz);
  };
  const int stripOrder[3][3] = {{0, 1, 2}, {1, 3, 2}, {2, 3, 4}};
  for (int t = 0; t < 3; ++t)
    for (int k = 0; k < 3; ++k) expectNear(triangle(s, t)[k], v(strip, stripOrder[t][k]), 1e-6);
  const int fanOrder[3][3] = {{1, 2, 0}, {2, 3, 0}, {3, 4, 0}};
  for (int t = 0; t < 3; ++t)
    for (int k = 0; k < 3; ++k) expectNear(triangle(s, 3 + t)[k], v(fan, fanOrder[t][k], 5), 1e-6);
  // Consistent orientation: every strip triangle faces -z, every fan triangle +z.
  for (int t = 0; t < 3; ++t) expectNear(windingNormal(triangle(s, t)), {0, 0, -1}, 1e-6);
  for (int t = 3; t < 6; ++t) expectNear(windingNormal(triangle(s, t)), {0, 0, 1}, 1e-6);
}

TEST(GltfLoader, IndexComponentTypesU8U16U32GiveTheSameTriangles) {
  const std::vector<float> quad = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  Gltf g;
  const int pos = g.positions(quad);
  const std::vector<uint32_t> idx = {0, 1, 2, 0, 2, 3};
  const int i8 = g.accessor(std::vector<uint8_t>(idx.begin(), idx.end()), 5121, "SCALAR", 6);
  const int i16 = g.accessor(std::vector<uint16_t>(idx.begin(), idx.end()), 5123, "SCALAR", 6);
  const int i32 = g.accessor(idx, 5125, "SCALAR", 6);
  // Indexed strip (u8) and fan (u16) over the same quad as well.
  const int s8 = g.accessor(std::vector<uint8_t>{1, 2, 0, 3}, 5121, "SCALAR", 4);
  const int f16 = g.accessor(std::vector<uint16_t>{0, 1, 2, 3}, 5123, "SCALAR", 4);
  for (int acc : {i8, i16, i32}) g.node({{"mesh", g.mesh(pos, std::nullopt, acc)}});
  g.node({{"mesh", g.mesh(pos, std::nullopt, s8, 5)}});
  g.node({{"mesh", g.mesh(pos, std::nullopt, f16, 6)}});
  g.scene({0, 1, 2, 3, 4});
  const ps::Scene s = ps::loadScene(g.writeGltf("index-types.gltf"));
  expectWellFormed(s);
  ASSERT_EQ(s.triangleCount(), 10u);
  for (size_t t = 0; t < s.triangleCount(); ++t) {
    const auto tri = triangle(s, t);
    expectNear(windingNormal(tri), {0, 0, 1}, 1e-6);
    EXPECT_NEAR(0.5 * ps::length(ps::cross(tri[1] - tri[0], tri[2] - tri[0])), 0.5, 1e-6);
  }
  for (size_t m = 1; m < 3; ++m)
    for (size_t k = 0; k < 6; ++k)
      expectNear(triangle(s, 2 * m + k / 3)[k % 3], triangle(s, k / 3)[k % 3], 0);
}

TEST(GltfLoader, MissingNormalsAreFlatUnitAndFaceTheWinding) {
  // A tetrahedron, CCW seen from outside, without normals.
  Gltf g;
  const int pos = g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1});
  const int idx =
      g.accessor(std::vector<uint16_t>{0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}, 5123, "SCALAR", 12);
  g.node({{"mesh", g.mesh(pos, std::nullopt, idx)}});
  g.scene({0});
  const ps::Scene s = ps::loadScene(g.writeGltf("tetra.gltf"));
  expectWellFormed(s);
  ASSERT_EQ(s.triangleCount(), 4u);
  EXPECT_EQ(s.vertexCount(), 12u);  // flat: three vertices per triangle
  const Vec3 centroid(0.25, 0.25, 0.25);
  for (size_t t = 0; t < 4; ++t) {
    const auto tri = triangle(s, t);
    for (int k = 0; k < 3; ++k) {
      const Vec3 n = normalAt(s, s.indices[3 * t + size_t(k)]);
      expectNear(n, windingNormal(tri), 1e-6);
      EXPECT_GT(ps::dot(n, tri[0] - centroid), 0.0) << "normal must point out of the solid";
    }
  }
}

TEST(GltfLoader, GlbAndGltfGiveTheSameScene) {
  Gltf g;
  g.node({{"mesh", g.mesh(g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0}), std::nullopt, std::nullopt)},
          {"translation", {1, 2, 3}}});
  g.scene({0});
  const ps::Scene a = ps::loadScene(g.writeGltf("same.gltf"));
  const ps::Scene b = ps::loadScene(writeBytes("same.glb", g.glbBytes()));
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.indices, b.indices);
}

TEST(GltfLoader, MaterialsAndPunctualLights) {
  Gltf g;
  const int pos = g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
  g.doc["materials"] = {
      {{"name", "glow"},
       {"doubleSided", true},
       {"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.25, 0.125, 1}}}},
       {"emissiveFactor", {1, 0.5, 0}},
       {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 4}}}}}}};
  json prim = {{"attributes", {{"POSITION", pos}}}, {"material", 0}};
  g.doc["meshes"].push_back({{"primitives", json::array({prim})}});
  g.node({{"mesh", 0}});
  g.doc["extensions"] = {{"KHR_lights_punctual",
                          {{"lights",
                            {{{"type", "spot"},
                              {"color", {1, 0.5, 0.25}},
                              {"intensity", 8},
                              {"range", 12},
                              {"spot", {{"innerConeAngle", 0.2}, {"outerConeAngle", 0.5}}}},
                             {{"type", "directional"}, {"intensity", 3}}}}}}};
  const double h = std::sqrt(0.5);
  // Spot at (0, 4, 0) pointing down: R_x(-90 deg) turns local -Z into -Y.
  g.node({{"translation", {0, 4, 0}},
          {"rotation", {-h, 0, 0, h}},
          {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
  // Directional light under a parent rotated about Y by 90 deg: -Z becomes -X.
  const int sun = g.node({{"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}});
  g.node({{"children", {sun}}, {"rotation", {0, h, 0, h}}});
  g.scene({0, 1, 3});
  const ps::Scene s = ps::loadScene(g.writeGltf("lights.gltf"));
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].albedo, ps::Rgb(0.5, 0.25, 0.125));
  EXPECT_EQ(s.materials[0].emission, ps::Rgb(4, 2, 0));
  EXPECT_TRUE(s.materials[0].doubleSided);
  EXPECT_TRUE(s.hasEmissiveSurfaces());
  ASSERT_EQ(s.lights.size(), 2u);
  EXPECT_EQ(s.lights[0].type, ps::LightType::Spot);
  expectNear(s.lights[0].position, {0, 4, 0}, 1e-9);
  expectNear(s.lights[0].direction, {0, -1, 0}, 1e-9);
  EXPECT_EQ(s.lights[0].intensity, ps::Rgb(8, 4, 2));
  EXPECT_EQ(s.lights[0].rangeMeters, 12.0);
  EXPECT_EQ(s.lights[0].innerConeRad, 0.2);
  EXPECT_EQ(s.lights[0].outerConeRad, 0.5);
  EXPECT_EQ(s.lights[1].type, ps::LightType::Directional);
  expectNear(s.lights[1].direction, {-1, 0, 0}, 1e-9);
  EXPECT_EQ(s.lights[1].intensity, ps::Rgb(3, 3, 3));
}

TEST(GltfLoader, WithoutADefaultSceneEveryRootNodeIsFlattened) {
  Gltf g;
  const int mesh = g.mesh(g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0}), std::nullopt, std::nullopt);
  const int child = g.node({{"mesh", mesh}});
  g.node({{"mesh", mesh}, {"children", {child}}, {"translation", {0, 0, 1}}});
  g.node({{"mesh", mesh}, {"translation", {0, 0, 2}}});
  g.doc.erase("scenes");
  // Roots are nodes 1 and 2; node 0 is reached through node 1 only.
  const ps::Scene s = ps::loadScene(g.writeGltf("no-scene.gltf"));
  EXPECT_EQ(s.triangleCount(), 3u);
  EXPECT_EQ(s.hasEmissiveSurfaces(), false);
}

// ---------------------------------------------------------------------------- shared scenes

namespace {
void expectSharedScene(const fs::path& rel, size_t triangles, bool timeIt = false) {
  const fs::path p = kShared / rel;
  if (!fs::exists(p)) GTEST_SKIP() << p << " not found: shared test scenes are absent";
  const auto t0 = std::chrono::steady_clock::now();
  const ps::Scene s = ps::loadScene(p);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (timeIt) std::cout << "load time of " << rel.string() << ": " << ms << " ms\n";
  expectWellFormed(s);
  EXPECT_EQ(s.triangleCount(), triangles);
  EXPECT_FALSE(s.bounds.empty());
}
}  // namespace

TEST(SharedScenes, CornellBoxGltf) {
  expectSharedScene("cornell-box/cornellBox-2.80-Eevee-gltf.gltf", 4410);
}
TEST(SharedScenes, DreamApartmentGlb) {
  expectSharedScene("dream-apartment/dream-apartment.glb", 177934, true);
}
TEST(SharedScenes, JapaneseBridgeGardenGlb) {
  expectSharedScene("japanese-bridge-garden/japanese-bridge-garden.glb", 21883);
}
TEST(SharedScenes, CornellBoxHasAnEmissiveCeilingLight) {
  const fs::path p = kShared / "cornell-box/cornellBox-2.80-Eevee-gltf.gltf";
  if (!fs::exists(p)) GTEST_SKIP() << p << " not found: shared test scenes are absent";
  EXPECT_TRUE(ps::loadScene(p).hasEmissiveSurfaces());
}

// ---------------------------------------------------------------------------- malformed input

TEST(GltfErrors, MissingFile) {
  const fs::path p = tempDir() / "does-not-exist.gltf";
  const std::string e = loadError(p);
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  EXPECT_NE(e.find("not found"), std::string::npos) << e;
}

TEST(GltfErrors, RandomBytesAreNotGltf) {
  std::mt19937 rng(7);
  std::vector<uint8_t> noise(4096);
  for (auto& b : noise) b = uint8_t(rng());
  const fs::path p = writeBytes("noise.gltf", noise);
  const std::string e = loadError(p);
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  EXPECT_NE(e.find("not a valid glTF"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << "one line: " << e;
}

TEST(GltfErrors, TruncatedGlb) {
  Gltf g;
  g.node({{"mesh", g.mesh(g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0}), std::nullopt, std::nullopt)}});
  g.scene({0});
  const std::vector<uint8_t> full = g.glbBytes();
  for (size_t keep : {size_t(10), size_t(24), full.size() / 2, full.size() - 4}) {
    const fs::path p = writeBytes("truncated.glb", {full.begin(), full.begin() + long(keep)});
    const std::string e = loadError(p);
    EXPECT_NE(e.find(p.string()), std::string::npos) << e;
    EXPECT_NE(e.find("truncated .glb"), std::string::npos) << keep << ": " << e;
  }
}

TEST(GltfErrors, AccessorLongerThanItsBuffer) {
  const std::string e = loadError(kData / "short-buffer.gltf");
  EXPECT_NE(e.find("short-buffer.gltf: accessors[0]: "), std::string::npos) << e;
  EXPECT_NE(e.find("exceed bufferViews[0].byteLength 36"), std::string::npos) << e;
}

TEST(GltfErrors, BufferViewOutsideItsBuffer) {
  const std::string e = loadError(kData / "view-out-of-buffer.gltf");
  EXPECT_NE(e.find("view-out-of-buffer.gltf"), std::string::npos) << e;
  EXPECT_NE(e.find("bufferViews[0]"), std::string::npos) << e;
}

TEST(GltfErrors, IndexOutOfRangeNamesThePrimitive) {
  const std::string e = loadError(kData / "index-out-of-range.gltf");
  EXPECT_NE(e.find("index-out-of-range.gltf: meshes[0].primitives[0]: index 7 out of range "
                   "(vertex count 3)"),
            std::string::npos)
      << e;
}

TEST(GltfErrors, MissingExternalBuffer) {
  const std::string e = loadError(kData / "missing-buffer.gltf");
  EXPECT_NE(e.find("missing-buffer.gltf"), std::string::npos) << e;
  EXPECT_NE(e.find("missing-buffer.bin"), std::string::npos) << e;
}

TEST(GltfErrors, NanVertex) {
  const std::string e = loadError(kData / "nan-vertex.gltf");
  EXPECT_NE(e.find("nan-vertex.gltf: meshes[0].primitives[0]: vertex 1 is not finite"),
            std::string::npos)
      << e;
}

TEST(GltfErrors, NonFloatPositions) {
  const std::string e = loadError(kData / "non-float-position.gltf");
  EXPECT_NE(e.find("meshes[0].primitives[0]: POSITION"), std::string::npos) << e;
  EXPECT_NE(e.find("5123"), std::string::npos) << e;
}

TEST(GltfErrors, EmptyScene) {
  const std::string e = loadError(kData / "empty-scene.gltf");
  EXPECT_NE(e.find("empty-scene.gltf"), std::string::npos) << e;
  EXPECT_NE(e.find("no triangles"), std::string::npos) << e;
}

TEST(GltfErrors, NodeCycleAndBadReferences) {
  Gltf g;
  const int mesh = g.mesh(g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0}), std::nullopt, std::nullopt);
  g.node({{"mesh", mesh}, {"children", {1}}});
  g.node({{"children", {0}}});
  g.scene({0});
  EXPECT_NE(loadError(g.writeGltf("cycle.gltf")).find("cycle"), std::string::npos);
  Gltf h;
  h.mesh(h.positions({0, 0, 0, 1, 0, 0, 0, 1, 0}), std::nullopt, std::nullopt);
  h.node({{"mesh", 5}});
  h.scene({0});
  const std::string e = loadError(h.writeGltf("bad-mesh.gltf"));
  EXPECT_NE(e.find("nodes[0]: mesh 5 does not exist"), std::string::npos) << e;
}

TEST(GltfErrors, NodeWithTwoParentsIsRejected) {
  Gltf g;
  const int mesh = g.mesh(g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0}), std::nullopt, std::nullopt);
  g.node({{"mesh", mesh}});
  g.node({{"children", {0}}});
  g.node({{"children", {0}}});
  g.scene({1, 2});
  const std::string e = loadError(g.writeGltf("two-parents.gltf"));
  EXPECT_NE(e.find("nodes[2].children[0]: node 0 has more than one parent"), std::string::npos)
      << e;
}

// A very deep (but valid) hierarchy must not overflow the stack.
TEST(GltfLoader, DeepHierarchyLoads) {
  constexpr int kDepth = 100000;  // deep enough to overflow an 8 MiB stack by recursion
  Gltf g;
  const int mesh = g.mesh(g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0}), std::nullopt, std::nullopt);
  for (int i = 0; i < kDepth; ++i) {
    json n = {{"translation", {1, 0, 0}}};
    if (i + 1 < kDepth)
      n["children"] = {i + 1};
    else
      n["mesh"] = mesh;
    g.node(std::move(n));
  }
  g.scene({0});
  const ps::Scene s = ps::loadScene(g.writeGltf("deep.gltf"));
  ASSERT_EQ(s.triangleCount(), 1u);
  expectNear(s.vertex(s.indices[0]), {kDepth, 0, 0}, 1e-9);
}

// Never crash: every single-byte corruption of a small .glb either loads or throws FileError.
TEST(GltfErrors, CorruptedGlbNeverCrashes) {
  Gltf g;
  const int pos = g.positions({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0});
  const int idx = g.accessor(std::vector<uint16_t>{0, 1, 2, 2, 1, 3}, 5123, "SCALAR", 6);
  g.node({{"mesh", g.mesh(pos, std::nullopt, idx)}, {"scale", {1, 2, 1}}});
  g.scene({0});
  const std::vector<uint8_t> good = g.glbBytes();
  std::mt19937 rng(1234);
  int loaded = 0, rejected = 0;
  for (int trial = 0; trial < 400; ++trial) {
    std::vector<uint8_t> bad = good;
    const int flips = 1 + int(rng() % 3);
    for (int f = 0; f < flips; ++f) bad[rng() % bad.size()] = uint8_t(rng());
    const fs::path p = writeBytes("corrupt.glb", bad);
    try {
      const ps::Scene s = ps::loadScene(p);
      expectWellFormed(s);
      ++loaded;
    } catch (const ps::FileError& e) {
      EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
      ++rejected;
    }
  }
  EXPECT_GT(rejected, 0);
  EXPECT_GT(loaded, 0);
}
