// Equirectangular environment maps (core/scene/EnvironmentMap.h) in the capture: a constant map
// is the constant sky, a bright patch lights the probe from its direction with the SH its
// integral gives, bad files are named, non-finite texels are sanitized, and the probe set
// stores the map's path relative to the set.
#include <gtest/gtest.h>
#include <unistd.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"
#include "core/math/Random.h"
#include "core/scene/EnvironmentMap.h"
#include "core/scene/LightingRig.h"
#include "tests/core/TestFiles.h"

namespace fs = std::filesystem;

namespace ps {
namespace {

const fs::path& tempDir() {
  return ps::test::programTempDir("ps_test_envmap_");
}

/// Writes a w x h float RGB map (row 0 at the top) with OpenImageIO; the extension picks the
/// format (.hdr, .exr).
fs::path writeMap(const std::string& name, int w, int h, const std::vector<float>& rgb) {
  const fs::path path = tempDir() / name;
  auto out = OIIO::ImageOutput::create(path.string());
  EXPECT_TRUE(out) << OIIO::geterror();
  const OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::FLOAT);
  EXPECT_TRUE(out->open(path.string(), spec)) << out->geterror();
  EXPECT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, rgb.data())) << out->geterror();
  out->close();
  return path;
}

/// A black, single-sided, up-facing floor of half-size 1000 at y = 0.
Scene blackFloor() {
  Scene s;
  Material m;
  m.albedo = {0, 0, 0};
  s.materials.push_back(m);
  const double h = 1000;
  for (Vec3 p : {Vec3{-h, 0, -h}, Vec3{-h, 0, h}, Vec3{h, 0, h}, Vec3{h, 0, -h}}) {
    s.positions.insert(s.positions.end(), {float(p.x), float(p.y), float(p.z)});
    s.normals.insert(s.normals.end(), {0.0f, 1.0f, 0.0f});
    s.bounds.extend(p);
  }
  s.indices = {0, 1, 2, 0, 2, 3};
  s.triangleMaterial = {0, 0};
  return s;
}

TEST(EnvironmentMap, DirectionConventionRoundTrips) {
  EnvironmentMap m;
  m.width = 64;
  m.height = 32;
  m.rgb.assign(64 * 32 * 3, 0.0f);
  int c, r;
  m.texelOf({0, 0, -1}, c, r);  // -Z: the centre column, the middle rows
  EXPECT_EQ(c, 32);
  EXPECT_TRUE(r == 15 || r == 16);
  m.texelOf({1, 0, 0}, c, r);  // +X: three quarters across
  EXPECT_EQ(c, 48);
  m.texelOf({0, 1, 0}, c, r);  // up: the top row
  EXPECT_EQ(r, 0);
  m.texelOf({0, -1, 0}, c, r);  // down: the bottom row
  EXPECT_EQ(r, 31);
  // Every texel centre maps back to its own texel, and the solid angles add up to 4 pi.
  double total = 0;
  for (int row = 0; row < m.height; ++row) {
    total += m.width * m.texelSolidAngle(row);
    for (int col = 0; col < m.width; ++col) {
      m.texelOf(m.directionOf(col, row), c, r);
      EXPECT_EQ(c, col);
      EXPECT_EQ(r, row);
    }
  }
  EXPECT_NEAR(total, 4 * kPi, 1e-12);
}

TEST(EnvironmentMap, ConstantMapGivesTheSameShAsTheConstantSky) {
  const Scene scene = blackFloor();
  const Tracer tracer(scene);
  const Rgb sky{0.5, 1.0, 2.0};  // exact in RGBE and in float
  const int w = 16, h = 8;
  std::vector<float> rgb;
  for (int i = 0; i < w * h; ++i) rgb.insert(rgb.end(), {float(sky.r), float(sky.g), float(sky.b)});
  CaptureSettings cs;
  cs.samplesPerProbe = 2048;
  const std::vector<Vec3> at = {{0.3, 1, -0.2}, {5, 2, 7}};
  LightingRig constant;
  constant.skyRadiance = sky;
  const auto want = captureProbes(tracer, constant, at, cs);
  for (const char* name : {"constant.hdr", "constant.exr"}) {
    LightingRig rig;
    rig.envMapPath = writeMap(name, w, h, rgb).string();
    rig.envMap = loadEnvironmentMap(rig.envMapPath);
    EXPECT_TRUE(rig.envMap->warnings.empty());
    const auto got = captureProbes(tracer, rig, at, cs);
    for (size_t p = 0; p < at.size(); ++p)
      for (int i = 0; i < kShCoeffCount; ++i)
        for (int ch = 0; ch < 3; ++ch) {
          // Same rays, same radiance: equal up to rounding, far inside the standard error.
          EXPECT_NEAR(got[p].sh.c[i][ch], want[p].sh.c[i][ch],
                      1e-12 + 0.01 * want[p].shStdError.c[i][ch])
              << name << " probe " << p << " coefficient " << i;
        }
    // Above a black floor, the sky's irradiance for +y is pi L (L2: within 1 %).
    const Rgb up = got[0].sh.irradiance({0, 1, 0});
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(up[ch], kPi * sky[ch], 0.01 * kPi * sky[ch]);
  }
}

TEST(EnvironmentMap, BrightPatchLightsFromItsDirectionWithItsIntegral) {
  // A black 64 x 32 map with one bright patch: rows 6-10 (theta 34-62 degrees from +Y),
  // columns 43-52 (phi 62-118 degrees: around +X). Its SH is the integral of L Y over the
  // patch, computed here on 8 x 8 equal-area subcells per texel.
  const int w = 64, h = 32;
  const Rgb bright{40, 20, 10};
  std::vector<float> rgb(size_t(w * h * 3), 0.0f);
  EnvironmentMap ref;
  ref.width = w;
  ref.height = h;
  ShRgb want;
  for (int row = 6; row <= 10; ++row)
    for (int col = 43; col <= 52; ++col) {
      float* t = &rgb[size_t(row * w + col) * 3];
      t[0] = float(bright.r), t[1] = float(bright.g), t[2] = float(bright.b);
      const double cos0 = std::cos(kPi * row / h), cos1 = std::cos(kPi * (row + 1) / h);
      const double sub = ref.texelSolidAngle(row) / 64;
      for (int a = 0; a < 8; ++a)
        for (int b = 0; b < 8; ++b) {
          const double z = cos0 + (cos1 - cos0) * (a + 0.5) / 8;  // equal area in cos theta
          const double theta = std::acos(z);
          const double phi = 2 * kPi * ((col + (b + 0.5) / 8) / w - 0.5);
          const Vec3 d{std::sin(theta) * std::sin(phi), std::cos(theta),
                       -std::sin(theta) * std::cos(phi)};
          want.addSample(d, bright, sub);
        }
    }
  LightingRig rig;
  rig.envMapPath = writeMap("patch.exr", w, h, rgb).string();
  const Scene scene = blackFloor();
  const Tracer tracer(scene);
  CaptureSettings cs;
#if defined(__SANITIZE_ADDRESS__)
  cs.samplesPerProbe = 8192;
#else
  cs.samplesPerProbe = 32768;
#endif
  const std::vector<Vec3> at = {{0, 1, 0}};
  const ProbeCapture c = captureProbes(tracer, rig, at, cs)[0];  // map loaded from the path
  // The light comes from the patch: the l = 1 band (y, z, x order) points at its centre.
  const Vec3 centre = normalize(Vec3{std::sin(kPi * 8.5 / 32), std::cos(kPi * 8.5 / 32), 0});
  const Vec3 band1 = normalize(Vec3{c.sh.c[3].r, c.sh.c[1].r, c.sh.c[2].r});
  EXPECT_GT(dot(band1, centre), 0.97) << band1;
  EXPECT_GT(c.sh.irradiance({1, 0, 0}).r, 10 * std::abs(c.sh.irradiance({-1, 0, 0}).r));
  // Every coefficient within 4.5 standard errors of the integral.
  for (int i = 0; i < kShCoeffCount; ++i)
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_NEAR(c.sh.c[i][ch], want.c[i][ch], 4.5 * c.shStdError.c[i][ch] + 1e-9)
          << "coefficient " << i << " channel " << ch;
}

TEST(EnvironmentMap, ImportanceSamplingPdfMatchesTheSampledDirections) {
  // The pdf sample() reports is the one pdf() gives for the direction, it integrates to 1 over
  // the texels, and samples land in bright texels only.
  const int w = 16, h = 8;
  std::vector<float> rgb(size_t(w * h * 3), 0.0f);
  for (int c = 3; c < 7; ++c)
    for (int k = 0; k < 3; ++k) rgb[size_t(2 * w + c) * 3 + size_t(k)] = float(c);
  rgb[size_t(6 * w + 12) * 3 + 1] = 50.0f;
  const auto map = loadEnvironmentMap(writeMap("sampling.exr", w, h, rgb));
  ASSERT_TRUE(map->canSample());
  double total = 0;
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) total += map->pdf(map->directionOf(c, r)) * map->texelSolidAngle(r);
  EXPECT_NEAR(total, 1.0, 1e-12);
  uint64_t state = 7;
  for (int i = 0; i < 2000; ++i) {
    double pdf = 0;
    const Vec3 d = map->sample(uniform01(state), uniform01(state), pdf);
    EXPECT_NEAR(length(d), 1.0, 1e-12);
    EXPECT_GT(pdf, 0.0);
    EXPECT_NEAR(map->pdf(d), pdf, 1e-9 * pdf);
    EXPECT_GT(luminance(map->radiance(d)), 0.0);
  }
}

TEST(EnvironmentMap, BrightPatchOverAWhiteFloorMatchesTheClosedForm) {
  // An infinite Lambertian floor of albedo rho under the patch receives E = sum L cos(theta)
  // d(omega) over the patch and reflects the uniform radiance rho E / pi; the probe 1 m above
  // it sees the patch above and that radiance over the whole lower hemisphere. The floor's light
  // comes from next-event estimation to the map, weighted against the bounce (MIS).
  const int w = 64, h = 32;
  const Rgb bright{40, 20, 10};
  std::vector<float> rgb(size_t(w * h * 3), 0.0f);
  EnvironmentMap ref;
  ref.width = w;
  ref.height = h;
  ShRgb want;
  Rgb floorE;
  for (int row = 6; row <= 10; ++row)
    for (int col = 43; col <= 52; ++col) {
      float* t = &rgb[size_t(row * w + col) * 3];
      t[0] = float(bright.r), t[1] = float(bright.g), t[2] = float(bright.b);
      const double cos0 = std::cos(kPi * row / h), cos1 = std::cos(kPi * (row + 1) / h);
      // Integral of cos(theta) over the texel: (2 pi / w) (cos0^2 - cos1^2) / 2.
      floorE += bright * ((2 * kPi / w) * (cos0 * cos0 - cos1 * cos1) / 2);
      const double sub = ref.texelSolidAngle(row) / 64;
      for (int a = 0; a < 8; ++a)
        for (int b = 0; b < 8; ++b) {
          const double z = cos0 + (cos1 - cos0) * (a + 0.5) / 8;
          const double theta = std::acos(z);
          const double phi = 2 * kPi * ((col + (b + 0.5) / 8) / w - 0.5);
          const Vec3 d{std::sin(theta) * std::sin(phi), std::cos(theta),
                       -std::sin(theta) * std::cos(phi)};
          want.addSample(d, bright, sub);
        }
    }
  const double rho = 0.5;
  const Rgb floorL = floorE * (rho / kPi);
  // A constant radiance over the lower hemisphere: c00 = L 2 pi Y00, c1,-1 = L 0.488603 (-pi).
  want.c[0] += floorL * (2 * kPi * 0.282095);
  want.c[1] += floorL * (-kPi * 0.488603);
  Scene scene = blackFloor();
  scene.materials[0].albedo = {rho, rho, rho};
  const Tracer tracer(scene);
  LightingRig rig;
  rig.envMap = loadEnvironmentMap(writeMap("patch-floor.exr", w, h, rgb));
  CaptureSettings cs;
#if defined(__SANITIZE_ADDRESS__)
  cs.samplesPerProbe = 8192;
#else
  cs.samplesPerProbe = 32768;
#endif
  const std::vector<Vec3> at = {{0, 1, 0}};
  const ProbeCapture c = captureProbes(tracer, rig, at, cs)[0];
  for (int i = 0; i < kShCoeffCount; ++i)
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_NEAR(c.sh.c[i][ch], want.c[i][ch],
                  4.5 * c.shStdError.c[i][ch] + 0.005 * std::abs(want.c[0][ch]))
          << "coefficient " << i << " channel " << ch;
}

TEST(EnvironmentMap, BadFilesAreNamed) {
  const fs::path missing = tempDir() / "no-such-sky.hdr";
  try {
    loadEnvironmentMap(missing);
    ADD_FAILURE() << "expected a FileError";
  } catch (const FileError& e) {
    EXPECT_EQ(e.file(), missing.string());
  }
  const fs::path junk = tempDir() / "junk.exr";
  std::ofstream(junk) << "this is not an image";
  try {
    loadEnvironmentMap(junk);
    ADD_FAILURE() << "expected a FileError";
  } catch (const FileError& e) {
    EXPECT_EQ(e.file(), junk.string());
    EXPECT_NE(std::string(e.what()).find("environment map"), std::string::npos) << e.what();
  }
  // A rig read from JSON names a missing map when the capture first needs it.
  LightingRig rig;
  rig.envMapPath = missing.string();
  const Scene scene = blackFloor();
  const Tracer tracer(scene);
  const std::vector<Vec3> at = {{0, 1, 0}};
  EXPECT_THROW(captureProbes(tracer, rig, at, CaptureSettings{}), FileError);
}

TEST(EnvironmentMap, NonFiniteTexelsAreSanitizedWithAWarning) {
  const int w = 8, h = 4;
  std::vector<float> rgb(size_t(w * h * 3), 1.0f);
  rgb[0] = std::nanf("");
  rgb[5] = INFINITY;
  rgb[7] = -3.0f;
  const auto map = loadEnvironmentMap(writeMap("nan.exr", w, h, rgb));
  ASSERT_EQ(map->warnings.size(), 2u);
  EXPECT_NE(map->warnings[0].find("2 NaN or infinite"), std::string::npos) << map->warnings[0];
  EXPECT_NE(map->warnings[1].find("1 negative"), std::string::npos) << map->warnings[1];
  for (float v : map->rgb) EXPECT_TRUE(std::isfinite(v) && v >= 0);
  LightingRig rig;
  rig.envMap = map;
  const Scene scene = blackFloor();
  const Tracer tracer(scene);
  CaptureSettings cs;
  cs.samplesPerProbe = 512;
  const std::vector<Vec3> at = {{0, 1, 0}};
  const ProbeCapture c = captureProbes(tracer, rig, at, cs)[0];
  for (int i = 0; i < kShCoeffCount; ++i)
    for (int ch = 0; ch < 3; ++ch) EXPECT_TRUE(std::isfinite(c.sh.c[i][ch]));
}

TEST(EnvironmentMap, BlackMapAloneIsNoLight) {
  LightingRig rig;
  rig.envMap = loadEnvironmentMap(writeMap("black.exr", 4, 2, std::vector<float>(24, 0.0f)));
  const Scene scene = blackFloor();
  const Tracer tracer(scene);
  const std::vector<Vec3> at = {{0, 1, 0}};
  EXPECT_THROW(captureProbes(tracer, rig, at, CaptureSettings{}), ParameterError);
}

TEST(EnvironmentMap, ProbeSetStoresThePathRelativeToTheSet) {
  const fs::path map = writeMap("sky.hdr", 4, 2, std::vector<float>(24, 1.0f));
  fs::create_directories(tempDir() / "sets");
  ProbeSet set;
  set.rig.envMapPath = map.string();
  const fs::path file = tempDir() / "sets" / "a.probes.json";
  saveProbeSet(set, file);
  std::ifstream in(file);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"env_map\": \"../sky.hdr\""), std::string::npos) << text;
  const ProbeSet back = loadProbeSet(file);
  EXPECT_EQ(fs::path(back.rig.envMapPath), map.lexically_normal());
  EXPECT_FALSE(back.rig.envMap);  // loaded when a capture needs it
  EXPECT_FALSE(back.rig.empty());
  // A rig without a map writes no env_map field.
  ProbeSet plain;
  plain.rig.skyRadiance = {1, 1, 1};
  saveProbeSet(plain, file);
  std::ifstream in2(file);
  const std::string text2((std::istreambuf_iterator<char>(in2)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text2.find("env_map"), std::string::npos);
  EXPECT_TRUE(loadProbeSet(file).rig.envMapPath.empty());
}

}  // namespace
}  // namespace ps
