// Textures (core/scene/Texture.h) and their use: wrap modes and filters against the glTF spec
// (3.8.4), sRGB decoding, base colour / emissive / specular-glossiness diffuse textures from a
// file, a buffer view and a data URI, alphaMode MASK as a cut-out the tracer sees through, and
// a textured white furnace whose irradiance is the closed form pi Le / (1 - rho).
#include <gtest/gtest.h>
#include <unistd.h>

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/io/SceneHash.h"
#include "core/scene/Scene.h"
#include "core/scene/Texture.h"
#include "core/trace/Tracer.h"
#include "tests/core/TestFiles.h"

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace ps {
namespace {

const fs::path& tempDir() {
  return ps::test::programTempDir("ps_test_texture_");
}

std::vector<uint8_t> readBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// A PNG of w x h texels with `channels` 8-bit channels (row 0 at the top), written by
/// OpenImageIO; returns its bytes.
std::vector<uint8_t> pngBytes(int w, int h, int channels, const std::vector<uint8_t>& texels,
                              const std::string& name) {
  const fs::path path = tempDir() / name;
  auto out = OIIO::ImageOutput::create(path.string());
  EXPECT_TRUE(out);
  OIIO::ImageSpec spec(w, h, channels, OIIO::TypeDesc::UINT8);
  spec.attribute("oiio:UnassociatedAlpha", 1);
  EXPECT_TRUE(out->open(path.string(), spec));
  EXPECT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, texels.data()));
  out->close();
  return readBytes(path);
}

/// The 2x2 RGBA test texture: four distinct texels, top-left, top-right, bottom-left,
/// bottom-right.
const std::vector<uint8_t> kTexels = {255, 0,   0,   255,   // (0, 0) red
                                      0,   255, 0,   255,   // (1, 0) green
                                      0,   0,   255, 255,   // (0, 1) blue
                                      255, 255, 255, 128};  // (1, 1) white, half alpha

Rgb linearTexel(int x, int y) {
  const uint8_t* t = &kTexels[size_t(y * 2 + x) * 4];
  return {srgbToLinear(t[0] / 255.0), srgbToLinear(t[1] / 255.0), srgbToLinear(t[2] / 255.0)};
}

/// One quad in the y = 0 plane over x, z in [0, 1], facing +y, with TEXCOORD_0 = a * (x, z) + b
/// and material 0 (given); `images`, `textures`, `samplers` as given. `imageBytes`, when not
/// empty, is appended to the buffer and exposed as bufferView 3.
struct QuadGltf {
  json material = json::object();
  json images = json::array();
  json textures = json::array();
  json samplers = json::array();
  std::vector<uint8_t> imageBytes;
  double uvScale = 1, uvOffset = 0;
  double height = 0;           ///< the quad's y (a node translation)
  int uvComponentType = 5126;  ///< float; 5121 / 5123: normalized unsigned byte / short

  fs::path write(const std::string& name) const {
    std::vector<uint8_t> bin;
    auto put = [&](const void* p, size_t n) {
      const auto* b = static_cast<const uint8_t*>(p);
      bin.insert(bin.end(), b, b + n);
    };
    const float pos[12] = {0, 0, 0, 0, 0, 1, 1, 0, 1, 1, 0, 0};
    float uv[8];
    for (int i = 0; i < 4; ++i) {
      uv[2 * i] = float(uvScale * pos[3 * i] + uvOffset);
      uv[2 * i + 1] = float(uvScale * pos[3 * i + 2] + uvOffset);
    }
    const uint16_t up[6] = {0, 1, 2, 0, 2, 3};
    put(pos, sizeof pos);
    // TEXCOORD_0 in 32 bytes whatever its type (unsigned byte and short are padded: spec
    // 3.6.2.4 aligns each element to 4 bytes).
    uint8_t uvBytes[32] = {};
    for (int i = 0; i < 8; ++i) {
      if (uvComponentType == 5126) {
        std::memcpy(uvBytes + 4 * i, &uv[i], 4);
      } else if (uvComponentType == 5123) {
        const auto v = uint16_t(std::lround(std::clamp(uv[i], 0.0f, 1.0f) * 65535));
        std::memcpy(uvBytes + 8 * (i / 2) + 2 * (i % 2), &v, 2);
      } else {
        uvBytes[4 * (i / 2) + i % 2] = uint8_t(std::lround(std::clamp(uv[i], 0.0f, 1.0f) * 255));
      }
    }
    put(uvBytes, sizeof uvBytes);
    put(up, 12);
    const int uvStride = uvComponentType == 5126 ? 8 : (uvComponentType == 5123 ? 8 : 4);
    json uvView = {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 32}};
    if (uvComponentType != 5126) uvView["byteStride"] = uvStride;
    json views = json::array({{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
                              uvView,
                              {{"buffer", 0}, {"byteOffset", 80}, {"byteLength", 12}}});
    if (!imageBytes.empty()) {
      views.push_back(
          {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", imageBytes.size()}});
      put(imageBytes.data(), imageBytes.size());
    }
    json doc = {{"asset", {{"version", "2.0"}}},
                {"scene", 0},
                {"scenes", {{{"nodes", {0}}}}},
                {"nodes", {{{"mesh", 0}, {"translation", {0, height, 0}}}}},
                {"meshes",
                 {{{"primitives",
                    {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}},
                      {"indices", 2},
                      {"material", 0}}}}}}},
                {"accessors",
                 {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
                  {{"bufferView", 1},
                   {"componentType", uvComponentType},
                   {"normalized", uvComponentType != 5126},
                   {"count", 4},
                   {"type", "VEC2"}},
                  {{"bufferView", 2}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}},
                {"bufferViews", views},
                {"buffers",
                 {{{"byteLength", bin.size()},
                   {"uri", "data:application/octet-stream;base64," + ps::test::base64(bin)}}}},
                {"materials", {material}}};
    if (!images.empty()) doc["images"] = images;
    if (!textures.empty()) doc["textures"] = textures;
    if (!samplers.empty()) doc["samplers"] = samplers;
    const fs::path path = tempDir() / name;
    std::ofstream(path) << doc.dump(1);
    return path;
  }
};

/// The material's albedo where a vertical ray at (x, z) hits the quad.
Rgb albedoUnder(const Scene& scene, const Tracer& tracer, double x, double z) {
  const auto hit = tracer.intersect(Ray{{x, 5, z}, {0, -1, 0}});
  EXPECT_TRUE(hit.has_value()) << "no hit at " << x << ", " << z;
  if (!hit) return {};
  return scene.albedoAt(hit->triangle, hit->u, hit->v);
}

void expectRgbNear(Rgb got, Rgb want, double tol, const std::string& what) {
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], tol) << what << " channel " << c;
}

json nearestSampler(int wrap = 10497) {
  return {{"magFilter", 9728}, {"minFilter", 9728}, {"wrapS", wrap}, {"wrapT", wrap}};
}

// ---- Sampling ------------------------------------------------------------------------------

Image testImage() {
  Image img;
  img.width = 2;
  img.height = 2;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) {
      const Rgb c = linearTexel(x, y);
      img.rgba.insert(img.rgba.end(), {float(c.r), float(c.g), float(c.b),
                                       kTexels[size_t(y * 2 + x) * 4 + 3] / 255.0f});
    }
  return img;
}

TEST(TextureSampling, SrgbDecodingMatchesIec61966) {
  EXPECT_EQ(srgbToLinear(0.0), 0.0);
  EXPECT_NEAR(srgbToLinear(1.0), 1.0, 1e-15);
  EXPECT_NEAR(srgbToLinear(0.04045), 0.04045 / 12.92, 1e-15);
  EXPECT_NEAR(srgbToLinear(0.5), 0.214041140, 1e-8);
  EXPECT_NEAR(srgbToLinear(188.0 / 255.0), 0.50289, 1e-5);
  // Monotone and continuous at the segment joint.
  EXPECT_NEAR(srgbToLinear(0.04045 - 1e-9), srgbToLinear(0.04045 + 1e-9), 1e-8);
}

TEST(TextureSampling, WrapModesFollowTheGltfSpec) {
  using W = TextureWrap;
  EXPECT_DOUBLE_EQ(wrapCoordinate(1.25, W::Repeat), 0.25);
  EXPECT_DOUBLE_EQ(wrapCoordinate(-0.25, W::Repeat), 0.75);
  EXPECT_DOUBLE_EQ(wrapCoordinate(1.25, W::MirroredRepeat), 0.75);
  EXPECT_DOUBLE_EQ(wrapCoordinate(-0.25, W::MirroredRepeat), 0.25);
  EXPECT_DOUBLE_EQ(wrapCoordinate(2.25, W::MirroredRepeat), 0.25);
  EXPECT_DOUBLE_EQ(wrapCoordinate(-1.25, W::MirroredRepeat), 0.75);
  EXPECT_DOUBLE_EQ(wrapCoordinate(-0.25, W::ClampToEdge), 0.0);
  EXPECT_LT(wrapCoordinate(1.25, W::ClampToEdge), 1.0);
  EXPECT_GT(wrapCoordinate(1.25, W::ClampToEdge), 0.999);
  EXPECT_EQ(wrapCoordinate(std::nan(""), W::Repeat), 0.0);
}

TEST(TextureSampling, NearestReturnsTheTexelUnderTheCoordinate) {
  const Image img = testImage();
  struct Case {
    double s, t;
    TextureWrap wrap;
    int x, y;
  };
  const Case cases[] = {
      {0.25, 0.25, TextureWrap::Repeat, 0, 0},
      {0.75, 0.25, TextureWrap::Repeat, 1, 0},
      {0.25, 0.75, TextureWrap::Repeat, 0, 1},
      {1.25, 0.25, TextureWrap::Repeat, 0, 0},
      {-0.25, 0.25, TextureWrap::Repeat, 1, 0},
      {1.25, 0.25, TextureWrap::ClampToEdge, 1, 0},
      {-0.25, -3, TextureWrap::ClampToEdge, 0, 0},
      {1.25, 0.25, TextureWrap::MirroredRepeat, 1, 0},
      {-0.25, 0.25, TextureWrap::MirroredRepeat, 0, 0},
      {0.25, 1.75, TextureWrap::MirroredRepeat, 0, 0},
  };
  for (const Case& c : cases) {
    TextureRef ref;
    ref.image = 0;
    ref.wrapS = ref.wrapT = c.wrap;
    ref.nearest = true;
    float out[4];
    sampleImage(img, ref, c.s, c.t, out);
    const float* want = img.texel(c.x, c.y);
    for (int k = 0; k < 4; ++k)
      EXPECT_EQ(out[k], want[k]) << "s " << c.s << " t " << c.t << " wrap " << int(c.wrap);
  }
}

TEST(TextureSampling, BilinearIsExactAtTexelCentresAndAveragesBetween) {
  const Image img = testImage();
  TextureRef ref;
  ref.image = 0;
  float out[4];
  sampleImage(img, ref, 0.25, 0.25, out);  // the centre of texel (0, 0)
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(out[k], img.texel(0, 0)[k], 1e-6);
  sampleImage(img, ref, 0.5, 0.5, out);  // the middle of all four
  for (int k = 0; k < 4; ++k) {
    const double mean =
        (img.texel(0, 0)[k] + img.texel(1, 0)[k] + img.texel(0, 1)[k] + img.texel(1, 1)[k]) / 4.0;
    EXPECT_NEAR(out[k], mean, 1e-6);
  }
  // At the left edge, between the centres of texel 0 and its neighbour to the left: Repeat
  // averages texels 1 and 0; ClampToEdge and MirroredRepeat give texel 0 itself.
  sampleImage(img, ref, 0.0, 0.25, out);
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(out[k], (img.texel(0, 0)[k] + img.texel(1, 0)[k]) / 2, 1e-6);
  for (TextureWrap w : {TextureWrap::ClampToEdge, TextureWrap::MirroredRepeat}) {
    ref.wrapS = w;
    sampleImage(img, ref, 0.0, 0.25, out);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(out[k], img.texel(0, 0)[k], 1e-6);
  }
  // Huge and non-finite coordinates stay finite.
  ref.wrapS = TextureWrap::Repeat;
  sampleImage(img, ref, 1e12, -1e15, out);
  for (float v : out) EXPECT_TRUE(std::isfinite(v));
  sampleImage(img, ref, std::nan(""), INFINITY, out);
  for (float v : out) EXPECT_TRUE(std::isfinite(v));
}

TEST(TextureDecoding, GarbageBytesGiveAReasonNotACrash) {
  const std::vector<uint8_t> junk = {0x89, 'P', 'N', 'G', 1, 2, 3, 4, 5, 6, 7};
  std::string why;
  EXPECT_FALSE(decodeImage(junk.data(), junk.size(), "image/png", true, why).has_value());
  EXPECT_FALSE(why.empty());
  why.clear();
  EXPECT_FALSE(decodeImage(nullptr, 0, "", true, why).has_value());
  EXPECT_FALSE(why.empty());
}

// ---- glTF textures -------------------------------------------------------------------------

TEST(GltfTextures, BaseColorFromFileBufferViewAndDataUriAreTheSameTexels) {
  const std::vector<uint8_t> png = pngBytes(2, 2, 4, kTexels, "base.png");
  const Rgb factor{0.5, 0.8, 1.0};
  QuadGltf q;
  q.material = {{"pbrMetallicRoughness",
                 {{"baseColorFactor", {factor.r, factor.g, factor.b, 1.0}},
                  {"baseColorTexture", {{"index", 0}}}}}};
  q.textures = {{{"source", 0}, {"sampler", 0}}};
  q.samplers = {nearestSampler()};
  QuadGltf fromFile = q, fromView = q, fromUri = q;
  fromFile.images = {{{"uri", "base.png"}}};
  fromView.images = {{{"bufferView", 3}, {"mimeType", "image/png"}}};
  fromView.imageBytes = png;
  fromUri.images = {{{"uri", "data:image/png;base64," + ps::test::base64(png)}}};
  for (const auto& [name, g] : {std::pair{"file.gltf", fromFile}, std::pair{"view.gltf", fromView},
                                std::pair{"uri.gltf", fromUri}}) {
    const Scene scene = loadScene(g.write(name));
    EXPECT_TRUE(scene.warnings.empty()) << name << ": " << scene.warnings.front();
    ASSERT_EQ(scene.images.size(), 1u) << name;
    const Tracer tracer(scene);
    // UV = (x, z): texel (0, 0) covers x, z < 0.5.
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x)
        expectRgbNear(albedoUnder(scene, tracer, 0.25 + 0.5 * x, 0.25 + 0.5 * y),
                      factor * linearTexel(x, y), 1e-6, std::string(name) + " texel");
  }
}

TEST(GltfTextures, NormalizedIntegerTexcoordsSampleTheSameTexels) {
  const std::vector<uint8_t> png = pngBytes(2, 2, 4, kTexels, "int.png");
  for (int type : {5121, 5123}) {
    QuadGltf q;
    q.uvComponentType = type;
    q.material = {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}};
    q.textures = {{{"source", 0}, {"sampler", 0}}};
    q.samplers = {nearestSampler()};
    q.images = {{{"uri", "int.png"}}};
    const Scene scene = loadScene(q.write("int" + std::to_string(type) + ".gltf"));
    const Tracer tracer(scene);
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x)
        expectRgbNear(albedoUnder(scene, tracer, 0.25 + 0.5 * x, 0.25 + 0.5 * y), linearTexel(x, y),
                      1e-6, "componentType " + std::to_string(type));
  }
}

TEST(GltfTextures, SamplerWrapModesApplyOutsideZeroOne) {
  const std::vector<uint8_t> png = pngBytes(2, 2, 4, kTexels, "wrap.png");
  // UV = 2 (x, z) - 0.5 spans [-0.5, 1.5]: x = 0.125 is s = -0.25, x = 0.875 is s = 1.25.
  struct Case {
    int wrap;
    int texelAtMinus, texelAtPlus;  // the column seen at s = -0.25 and at s = 1.25
  };
  for (const Case c : {Case{10497, 1, 0}, Case{33071, 0, 1}, Case{33648, 0, 1}}) {
    QuadGltf q;
    q.uvScale = 2;
    q.uvOffset = -0.5;
    q.material = {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}};
    q.textures = {{{"source", 0}, {"sampler", 0}}};
    q.samplers = {nearestSampler(c.wrap)};
    q.images = {{{"uri", "wrap.png"}}};
    const Scene scene = loadScene(q.write("wrap" + std::to_string(c.wrap) + ".gltf"));
    const Tracer tracer(scene);
    // z = 0.375 is t = 0.25: row 0.
    expectRgbNear(albedoUnder(scene, tracer, 0.125, 0.375), linearTexel(c.texelAtMinus, 0), 1e-6,
                  "s = -0.25, wrap " + std::to_string(c.wrap));
    expectRgbNear(albedoUnder(scene, tracer, 0.875, 0.375), linearTexel(c.texelAtPlus, 0), 1e-6,
                  "s = 1.25, wrap " + std::to_string(c.wrap));
  }
}

TEST(GltfTextures, SpecularGlossinessDiffuseAndEmissiveStrength) {
  const std::vector<uint8_t> png = pngBytes(2, 2, 4, kTexels, "sg.png");
  QuadGltf q;
  q.material = {{"pbrMetallicRoughness", {{"baseColorFactor", {0.1, 0.1, 0.1, 1.0}}}},
                {"emissiveFactor", {1.0, 0.5, 0.25}},
                {"emissiveTexture", {{"index", 0}}},
                {"extensions",
                 {{"KHR_materials_pbrSpecularGlossiness",
                   {{"diffuseFactor", {0.2, 0.4, 0.6, 1.0}}, {"diffuseTexture", {{"index", 0}}}}},
                  {"KHR_materials_emissive_strength", {{"emissiveStrength", 4.0}}}}}};
  q.textures = {{{"source", 0}, {"sampler", 0}}};
  q.samplers = {nearestSampler()};
  q.images = {{{"uri", "sg.png"}}};
  const Scene scene = loadScene(q.write("sg.gltf"));
  ASSERT_EQ(scene.images.size(), 1u);  // one image, decoded once for both uses
  const Tracer tracer(scene);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) {
      const auto hit = tracer.intersect(Ray{{0.25 + 0.5 * x, 5, 0.25 + 0.5 * y}, {0, -1, 0}});
      ASSERT_TRUE(hit);
      expectRgbNear(scene.albedoAt(hit->triangle, hit->u, hit->v),
                    Rgb(0.2, 0.4, 0.6) * linearTexel(x, y), 1e-6, "diffuse");
      expectRgbNear(scene.emissionAt(hit->triangle, hit->u, hit->v),
                    Rgb(4.0, 2.0, 1.0) * linearTexel(x, y), 1e-6, "emission");
    }
}

TEST(GltfTextures, UnreadableTextureWarnsAndFallsBackToTheFactor) {
  QuadGltf q;
  q.material = {
      {"pbrMetallicRoughness",
       {{"baseColorFactor", {0.3, 0.6, 0.9, 1.0}}, {"baseColorTexture", {{"index", 0}}}}}};
  q.textures = {{{"source", 0}}};
  q.images = {{{"uri", "missing-texture.png"}}};
  const fs::path missing = q.write("missing.gltf");
  const Scene a = loadScene(missing);
  ASSERT_EQ(a.warnings.size(), 1u);
  EXPECT_NE(a.warnings[0].find(missing.string()), std::string::npos) << a.warnings[0];
  EXPECT_NE(a.warnings[0].find("images[0]"), std::string::npos) << a.warnings[0];
  EXPECT_NE(a.warnings[0].find("missing-texture.png"), std::string::npos) << a.warnings[0];
  EXPECT_NE(a.warnings[0].find("materials[0].pbrMetallicRoughness.baseColorTexture"),
            std::string::npos)
      << a.warnings[0];
  const Tracer ta(a);
  expectRgbNear(albedoUnder(a, ta, 0.3, 0.3), {0.3, 0.6, 0.9}, 1e-12, "fallback");

  // Bytes that are not an image.
  q.images = {
      {{"uri", "data:image/png;base64," + ps::test::base64({0x89, 'P', 'N', 'G', 0, 0, 0, 0})}}};
  const Scene b = loadScene(q.write("corrupt.gltf"));
  ASSERT_EQ(b.warnings.size(), 1u);
  EXPECT_NE(b.warnings[0].find("images[0]"), std::string::npos) << b.warnings[0];
  const Tracer tb(b);
  expectRgbNear(albedoUnder(b, tb, 0.3, 0.3), {0.3, 0.6, 0.9}, 1e-12, "fallback");
}

TEST(GltfTextures, MissingTextureIsHashedNotAnError) {
  // place and bake hash the scene's files: a missing texture must stay a warning there too,
  // and the hash changes when the file appears.
  QuadGltf q;
  q.material = {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}};
  q.textures = {{{"source", 0}}};
  q.images = {{{"uri", "late.png"}}};
  const fs::path file = q.write("late.gltf");
  fs::remove(tempDir() / "late.png");
  const uint64_t before = sceneContentHash(file);
  EXPECT_EQ(loadScene(file).warnings.size(), 1u);
  pngBytes(2, 2, 4, kTexels, "late.png");
  const uint64_t after = sceneContentHash(file);
  EXPECT_NE(before, after);
  EXPECT_TRUE(loadScene(file).warnings.empty());
}

TEST(GltfTextures, MalformedMaterialFieldsNameTheGltfPath) {
  auto expectError = [](const QuadGltf& q, const std::string& name, const std::string& field) {
    try {
      loadScene(q.write(name));
      ADD_FAILURE() << name << ": expected a FileError at " << field;
    } catch (const FileError& e) {
      EXPECT_EQ(e.field(), field) << e.what();
    }
  };
  QuadGltf q;
  q.material = {{"alphaMode", "CUTOUT"}};
  expectError(q, "bad-alpha.gltf", "materials[0].alphaMode");
  q.material = {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 3}}}}}};
  expectError(q, "bad-texture.gltf", "materials[0].pbrMetallicRoughness.baseColorTexture.index");
  q.material = {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}};
  q.textures = {{{"source", 5}}};
  expectError(q, "bad-source.gltf", "textures[0].source");
  q.textures = {{{"source", 0}, {"sampler", 2}}};
  q.images = {{{"uri", "x.png"}}};
  expectError(q, "bad-sampler.gltf", "textures[0].sampler");
  q = QuadGltf{};
  q.material = {
      {"extensions", {{"KHR_materials_pbrSpecularGlossiness", {{"diffuseFactor", {1, 2}}}}}}};
  expectError(q, "bad-diffuse.gltf",
              "materials[0].extensions.KHR_materials_pbrSpecularGlossiness.diffuseFactor");
}

// ---- Cut-outs ------------------------------------------------------------------------------

/// A black floor of half-size 1000 at y = 0 appended to `s` (single-sided, facing up).
void addBlackFloor(Scene& s) {
  Material m;
  m.albedo = {0, 0, 0};
  m.name = "floor";
  s.materials.push_back(m);
  const auto mat = uint32_t(s.materials.size() - 1);
  const auto base = uint32_t(s.vertexCount());
  const double h = 1000;
  for (Vec3 p : {Vec3{-h, 0, -h}, Vec3{-h, 0, h}, Vec3{h, 0, h}, Vec3{h, 0, -h}}) {
    s.positions.insert(s.positions.end(), {float(p.x), float(p.y), float(p.z)});
    s.normals.insert(s.normals.end(), {0.0f, 1.0f, 0.0f});
    s.texcoords.insert(s.texcoords.end(), {0.0f, 0.0f});
    s.bounds.extend(p);
  }
  s.indices.insert(s.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  s.triangleMaterial.insert(s.triangleMaterial.end(), {mat, mat});
}

/// A black MASK quad at y = 2 over a black floor, a probe at (0.5, 1, 0.5) between them and a
/// sun straight overhead of irradiance 3: returns the probe's capture.
ProbeCapture captureUnderMask(const QuadGltf& quad, const std::string& name) {
  Scene scene = loadScene(quad.write(name));
  addBlackFloor(scene);
  const Tracer tracer(scene);
  LightingRig rig;
  Light sun;
  sun.type = LightType::Directional;
  sun.direction = {0, -1, 0};
  sun.intensity = {3, 3, 3};
  rig.lights.push_back(sun);
  CaptureSettings cs;
  cs.samplesPerProbe = 256;
  const std::vector<Vec3> at = {{0.5, 1, 0.5}};
  return captureProbes(tracer, rig, at, cs)[0];
}

TEST(GltfAlphaMask, TheSunShinesThroughATransparentCutOut) {
  // A fully transparent 2x2 texture (alpha 0) on a MASK quad that faces the probe.
  std::vector<uint8_t> clear = kTexels;
  for (size_t i = 3; i < clear.size(); i += 4) clear[i] = 0;
  std::vector<uint8_t> opaque = kTexels;
  for (size_t i = 3; i < opaque.size(); i += 4) opaque[i] = 255;
  QuadGltf q;
  q.height = 2;
  q.material = {
      {"alphaMode", "MASK"},
      {"pbrMetallicRoughness",
       {{"baseColorFactor", {0.0, 0.0, 0.0, 1.0}}, {"baseColorTexture", {{"index", 0}}}}}};
  q.textures = {{{"source", 0}, {"sampler", 0}}};
  q.samplers = {nearestSampler()};

  // The sun's direct term projects to c_i = E Y_i(+y); its L2 irradiance for the normal +y is
  // E (pi/(4 pi) + (2 pi/3) 3/(4 pi) + (pi/4) 5/(4 pi)) = E (1/4 + 1/2 + 5/16). The quad faces
  // up, so the probe under it sees its back face where it is not cut out.
  const double e = 3;
  const double wantUp = e * (0.25 + 0.5 + (5.0 / 16.0));
  q.images = {
      {{"uri", "data:image/png;base64," + ps::test::base64(pngBytes(2, 2, 4, clear, "c.png"))}}};
  const ProbeCapture through = captureUnderMask(q, "mask-clear.gltf");
  EXPECT_NEAR(through.sh.irradiance({0, 1, 0}).g, wantUp, 1e-9);
  EXPECT_EQ(through.backfaceFraction, 0.0);  // rays pass through the cut-out: nothing seen

  // The same quad with an opaque texture casts its shadow.
  q.images = {
      {{"uri", "data:image/png;base64," + ps::test::base64(pngBytes(2, 2, 4, opaque, "o.png"))}}};
  const ProbeCapture blocked = captureUnderMask(q, "mask-opaque.gltf");
  EXPECT_NEAR(blocked.sh.irradiance({0, 1, 0}).g, 0.0, 1e-9);
  EXPECT_GT(blocked.backfaceFraction, 0.05);

  // OPAQUE ignores alpha; MASK with the factor's alpha under the cutoff passes light.
  q.material["alphaMode"] = "OPAQUE";
  q.images = {
      {{"uri", "data:image/png;base64," + ps::test::base64(pngBytes(2, 2, 4, clear, "c2.png"))}}};
  EXPECT_NEAR(captureUnderMask(q, "opaque-clear.gltf").sh.irradiance({0, 1, 0}).g, 0.0, 1e-9);
  q.material = {{"alphaMode", "MASK"},
                {"alphaCutoff", 0.5},
                {"pbrMetallicRoughness", {{"baseColorFactor", {0.0, 0.0, 0.0, 0.4}}}}};
  q.textures = json::array();
  q.samplers = json::array();
  q.images = json::array();
  EXPECT_NEAR(captureUnderMask(q, "mask-factor.gltf").sh.irradiance({0, 1, 0}).g, wantUp, 1e-9);
  q.material["alphaCutoff"] = 0.3;
  EXPECT_NEAR(captureUnderMask(q, "mask-factor-kept.gltf").sh.irradiance({0, 1, 0}).g, 0.0, 1e-9);
}

TEST(GltfAlphaMask, CutOutFollowsTheTexelsAlpha) {
  // kTexels: texel (1, 1) has alpha 128/255 (just over 0.5): cut out with cutoff 0.6, kept
  // with 0.4; the other texels are opaque.
  QuadGltf q;
  q.material = {{"alphaMode", "MASK"},
                {"alphaCutoff", 0.6},
                {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}};
  q.textures = {{{"source", 0}, {"sampler", 0}}};
  q.samplers = {nearestSampler()};
  q.images = {
      {{"uri", "data:image/png;base64," + ps::test::base64(pngBytes(2, 2, 4, kTexels, "a.png"))}}};
  for (double cutoff : {0.6, 0.4}) {
    q.material["alphaCutoff"] = cutoff;
    const Scene scene = loadScene(q.write("cut.gltf"));
    const Tracer tracer(scene);
    EXPECT_EQ(tracer.intersect(Ray{{0.75, 5, 0.75}, {0, -1, 0}}).has_value(), cutoff < 0.5)
        << cutoff;
    EXPECT_EQ(tracer.occluded(Ray{{0.75, 5, 0.75}, {0, -1, 0}}), cutoff < 0.5) << cutoff;
    EXPECT_TRUE(tracer.intersect(Ray{{0.25, 5, 0.25}, {0, -1, 0}}).has_value());
    EXPECT_TRUE(tracer.occluded(Ray{{0.25, 5, 0.75}, {0, -1, 0}}));
  }
}

// ---- Capture with textures -----------------------------------------------------------------

/// A closed box (inward faces) whose material has the given factors and a uniform 2x2 texture
/// of linear value `texel` as albedo and emission texture.
Scene texturedFurnace(Rgb albedoFactor, Rgb emissionFactor, Rgb texel) {
  Scene s;
  Material m;
  m.albedo = albedoFactor;
  m.emission = emissionFactor;
  Image img;
  img.width = img.height = 2;
  for (int i = 0; i < 4; ++i)
    img.rgba.insert(img.rgba.end(), {float(texel.r), float(texel.g), float(texel.b), 1.0f});
  s.images.push_back(img);
  m.albedoTexture.image = 0;
  m.emissionTexture.image = 0;
  s.materials.push_back(m);
  const Vec3 lo{-1, -1, -1}, hi{1, 1, 1};
  const Vec3 d = hi - lo;
  const Vec3 x{d.x, 0, 0}, y{0, d.y, 0}, z{0, 0, d.z};
  struct Face {
    Vec3 corner, e1, e2;
  };
  const Face faces[] = {{lo, z, x}, {{lo.x, hi.y, lo.z}, x, z},
                        {lo, y, z}, {{hi.x, lo.y, lo.z}, z, y},
                        {lo, x, y}, {{lo.x, lo.y, hi.z}, y, x}};
  for (const Face& f : faces) {
    const auto base = uint32_t(s.vertexCount());
    const Vec3 n = normalize(cross(f.e1, f.e2));
    const Vec3 ps[4] = {f.corner, f.corner + f.e1, f.corner + f.e1 + f.e2, f.corner + f.e2};
    const float uv[8] = {0, 0, 3, 0, 3, 3, 0, 3};  // repeats: every texel is used
    for (int k = 0; k < 4; ++k) {
      s.positions.insert(s.positions.end(), {float(ps[k].x), float(ps[k].y), float(ps[k].z)});
      s.normals.insert(s.normals.end(), {float(n.x), float(n.y), float(n.z)});
      s.texcoords.insert(s.texcoords.end(), {uv[2 * k], uv[2 * k + 1]});
      s.bounds.extend(ps[k]);
    }
    s.indices.insert(s.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    s.triangleMaterial.insert(s.triangleMaterial.end(), {0, 0});
  }
  return s;
}

TEST(CaptureTextures, TexturedFurnaceGivesPiLeOverOneMinusRho) {
  // rho = factor * texel, Le = emission factor * texel, per channel.
  const Rgb albedoFactor{1, 0.8, 0.5}, emissionFactor{2, 2, 2}, texel{0.6, 0.5, 0.4};
  const Scene s = texturedFurnace(albedoFactor, emissionFactor, texel);
  const Tracer tracer(s);
  CaptureSettings cs;
#if defined(__SANITIZE_ADDRESS__)
  cs.samplesPerProbe = 4096;
  const double tol = 0.03;
#else
  cs.samplesPerProbe = 32768;
  const double tol = 0.01;
#endif
  const std::vector<Vec3> at = {{0.2, -0.3, 0.1}};
  const ProbeCapture c = captureProbes(tracer, LightingRig{}, at, cs)[0];
  for (Vec3 n : {Vec3{1, 0, 0}, Vec3{0, -1, 0}, Vec3{0, 0, 1}}) {
    const Rgb e = c.sh.irradiance(n);
    for (int ch = 0; ch < 3; ++ch) {
      const double rho = albedoFactor[ch] * texel[ch];
      const double le = emissionFactor[ch] * texel[ch];
      EXPECT_NEAR(e[ch], kPi * le / (1 - rho), tol * kPi * le / (1 - rho)) << "channel " << ch;
    }
  }
}

// ---- Shared real scenes --------------------------------------------------------------------

const fs::path kShared = fs::path(PS_SHARED_SCENES_DIR);

TEST(SharedScenes, CornellBoxTexturesDecodeWithoutWarnings) {
  const fs::path file = kShared / "cornell-box" / "cornellBox-2.80-Eevee-gltf.gltf";
  if (!fs::exists(file)) GTEST_SKIP() << "shared scene not found: " << file;
  const Scene s = loadScene(file);
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  ASSERT_EQ(s.images.size(), 2u);
  // checkerBJS.png is 1024 x 1024, checker-meter.png 256 x 256 (as oiiotool --info says).
  EXPECT_EQ(s.images[0].width, 1024);
  EXPECT_EQ(s.images[1].width, 256);
  for (const Image& img : s.images)
    EXPECT_EQ(img.rgba.size(), size_t(img.width) * size_t(img.height) * 4) << img.name;
  EXPECT_EQ(s.texcoords.size(), 2 * s.vertexCount());
}

TEST(SharedScenes, GardenSpecularGlossinessDiffuseIsTheAlbedo) {
  const fs::path file = kShared / "japanese-bridge-garden" / "japanese-bridge-garden.glb";
  if (!fs::exists(file)) GTEST_SKIP() << "shared scene not found: " << file;
  const Scene s = loadScene(file);
  // The JSON chunk of the .glb, read here independently of the loader.
  const std::vector<uint8_t> bytes = readBytes(file);
  ASSERT_GT(bytes.size(), 20u);
  uint32_t jsonLength;
  std::memcpy(&jsonLength, &bytes[12], 4);
  const json doc = json::parse(bytes.begin() + 20, bytes.begin() + 20 + jsonLength);
  int checked = 0;
  for (size_t i = 0; i < doc["materials"].size(); ++i) {
    const json& m = doc["materials"][i];
    if (!m.contains("extensions") ||
        !m["extensions"].contains("KHR_materials_pbrSpecularGlossiness"))
      continue;
    const json& sg = m["extensions"]["KHR_materials_pbrSpecularGlossiness"];
    const json f = sg.value("diffuseFactor", json::array({1.0, 1.0, 1.0, 1.0}));
    expectRgbNear(s.materials[i].albedo, Rgb(f[0], f[1], f[2]), 1e-12,
                  "materials[" + std::to_string(i) + "]");
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

}  // namespace
}  // namespace ps
