// Visibility per probe (DDGI, Majercik et al. 2019, sec. 4-5): the capture's distance maps, the
// visibility-aware interpolant (core/traversal/VisibleInterpolation.h) and the volume file's
// version 4, which carries the maps.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "core/bake/Bake.h"
#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/eval/Evaluate.h"
#include "core/io/VolumeFile.h"
#include "core/math/Octahedral.h"
#include "core/runtime/ps_volume_reader.h"
#include "core/trace/Tracer.h"
#include "core/traversal/VisibleInterpolation.h"
#include "tests/core/SceneBuilders.h"
#include "tests/core/TestFiles.h"

namespace fs = std::filesystem;
using namespace ps;
using ps::testing::pointLight;

namespace {

/// Two rooms side by side, x in [0, 1.95] (room A, dark) and [2.05, 4] (room B, a point light
/// at (3, 1, 1)), y and z in [0, 2], parted by a solid single-sided wall 0.1 m thick.
Scene twoRooms() {
  return ps::testing::roomsAlongX({4, 2, 2}, {2.0}, pointLight({3, 1, 1}, {5, 5, 5}));
}

struct Captured {
  std::vector<Vec3> points;
  std::vector<ShRgb> sh;
  std::vector<ProbeVisibility> vis;
};

Captured capture(const Tracer& tracer, std::vector<Vec3> points, int spp = 1024) {
  CaptureSettings cs;
  cs.samplesPerProbe = spp;
  cs.visibilityMaps = true;
  const auto caps = captureProbes(tracer, LightingRig{}, points, cs);
  Captured c;
  c.points = std::move(points);
  for (const ProbeCapture& p : caps) {
    c.sh.push_back(p.sh);
    ProbeVisibility v;
    EXPECT_EQ(p.distanceMoments.size(), v.distanceMoments.size());
    std::copy(p.distanceMoments.begin(), p.distanceMoments.end(), v.distanceMoments.begin());
    v.inside = p.backfaceFraction > 0.25;
    c.vis.push_back(v);
  }
  return c;
}

}  // namespace

TEST(Octahedral, EncodeDecodeRoundTripsAndTexelsCoverTheSphere) {
  for (int i = 0; i < 200; ++i) {
    const double z = -1 + 2 * (i + 0.5) / 200, phi = 2.399963 * i;
    const Vec3 d{std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z};
    const OctUv o = octEncode(d);
    EXPECT_NEAR(length(octDecode(o.u, o.v) - d), 0, 1e-12);
  }
  // A texel beyond an edge is the one across the seam: its centre's direction is next to the
  // edge texel's.
  const int R = 8;
  for (int j = 0; j < R; ++j) {
    const int across = octWrappedTexel(-1, j, R);
    EXPECT_EQ(across, 0 + R * (R - 1 - j));
  }
  EXPECT_EQ(octWrappedTexel(-1, -1, R), R - 1 + R * (R - 1));
  EXPECT_EQ(octWrappedTexel(R, R, R), 0);
}

TEST(Visibility, CaptureRecordsTheDistanceToTheWallsPerTexel) {
  const Scene s = twoRooms();
  const Tracer tracer(s);
  const Vec3 p{1, 1, 1};
  const Captured c = capture(tracer, {p});
  const auto& m = c.vis[0].distanceMoments;
  // Per texel, the mean distance lies between the nearest and farthest hit over the texel's
  // directions; at the texel centre, the distance along the centre's ray is inside that range
  // up to the texel's spread. Check the centre's distance within 30 %, and the moments'
  // consistency (mean^2 <= mean square).
  const int R = kVisibilityMapSize;
  for (int j = 0; j < R; ++j)
    for (int i = 0; i < R; ++i) {
      const Vec3 d = octTexelDirection(i, j, R);
      double tMax = std::numeric_limits<double>::infinity();
      for (int a = 0; a < 3; ++a) {
        if (d[a] > 1e-9) tMax = std::min(tMax, ((a == 0 ? 1.95 : 2.0) - p[a]) / d[a]);
        if (d[a] < -1e-9) tMax = std::min(tMax, (0.0 - p[a]) / d[a]);
      }
      const size_t k = size_t(i + R * j);
      EXPECT_NEAR(m[2 * k], tMax, 0.3 * tMax) << "texel " << i << "," << j;
      EXPECT_LE(double(m[2 * k]) * m[2 * k], double(m[2 * k + 1]) * (1 + 1e-6));
    }
  EXPECT_FALSE(c.vis[0].inside);
  // A probe inside the wall is flagged inside.
  EXPECT_TRUE(capture(tracer, {{2, 1, 1}}).vis[0].inside);
  // Without CaptureSettings::visibilityMaps, no map (and the same SH: the same rays).
  CaptureSettings plain;
  plain.samplesPerProbe = 1024;
  const ProbeCapture without = captureProbes(tracer, LightingRig{}, std::vector<Vec3>{p}, plain)[0];
  EXPECT_TRUE(without.distanceMoments.empty());
  EXPECT_EQ(without.sh, c.sh[0]);
}

TEST(Visibility, NoLightCrossesTheWallAndAProbeInsideItGetsNoWeight) {
  const Scene s = twoRooms();
  const Tracer tracer(s);
  // Room A's probes, room B's, one inside the wall.
  const Captured c = capture(tracer, {{0.5, 0.5, 0.5},
                                      {0.5, 1.5, 1.5},
                                      {1.5, 0.5, 1.5},
                                      {1.5, 1.5, 0.5},
                                      {2.5, 0.5, 0.5},
                                      {2.5, 1.5, 1.5},
                                      {3.5, 0.5, 1.5},
                                      {3.5, 1.5, 0.5},
                                      {2, 1, 1}});
  const ProbeVolume plain = volumeFromProbes(c.points, c.sh);
  const ProbeVolume v = volumeFromProbes(c.points, c.sh, c.vis);
  ASSERT_TRUE(v.hasVisibility());
  int32_t wallProbe = -1;
  for (size_t i = 0; i < v.probeCount(); ++i)
    if (length(v.position(int32_t(i)) - Vec3{2, 1, 1}) < 1e-6) wallProbe = int32_t(i);
  ASSERT_GE(wallProbe, 0);
  EXPECT_EQ(v.probeInside[size_t(wallProbe)], 1);
  // Points of room A near the wall: their tets reach room B's probes and the wall's probe.
  int leakingWithout = 0, checked = 0, tried = 0;
  for (int i = 0; i < 200; ++i) {
    const Vec3 p{1.6 + 0.3 * ((i * 37) % 100) / 100.0, 0.2 + 1.6 * ((i * 53) % 100) / 100.0,
                 0.2 + 1.6 * ((i * 71) % 100) / 100.0};
    if (p.x >= 1.94) continue;
    for (const std::optional<Vec3>& n :
         {std::optional<Vec3>{}, std::optional<Vec3>{Vec3{1, 0, 0}}}) {
      const VisibleWeights w = visibleWeights(v, p, n);
      ASSERT_GE(w.tet, 0);
      ++tried;
      checked += w.fallback != VisibleFallback::Barycentric;
      double sum = 0;
      for (int k = 0; k < w.count; ++k) {
        ASSERT_TRUE(std::isfinite(w.weights[k]));
        ASSERT_GE(w.weights[k], 0);
        sum += w.weights[k];
        if (w.probes[k] == wallProbe) {
          EXPECT_EQ(w.weights[k], 0);
        }
        // The test is statistical (a texel's distances spread over its solid angle): a probe
        // across the wall keeps at most a trace of weight.
        if (v.position(w.probes[k]).x > 2 && w.fallback != VisibleFallback::Barycentric) {
          EXPECT_LT(w.weights[k], 0.01)
              << "room B's probe interpolated at " << p.x << "," << p.y << "," << p.z;
        }
      }
      EXPECT_NEAR(sum, 1, 1e-12);
      // Room A is dark: only light that leaked through the wall would light it.
      const double e = luminance(interpolate(v, w).irradiance({-1, 0, 0}));
      if (w.fallback != VisibleFallback::Barycentric) {
        EXPECT_LT(e, 0.05);
      }
    }
    leakingWithout += luminance(interpolate(plain, locate(plain, p)).irradiance({-1, 0, 0})) > 0.05;
  }
  EXPECT_GT(leakingWithout, 20);  // the test can fail: without visibility, light crosses
  // The checks above hold for the points whose weights did not fall back to barycentric: most
  // of them must reach those checks, or the test would pass by skipping them.
  EXPECT_GE(checked, tried * 3 / 4) << checked << " of " << tried << " queries kept visibility";
}

TEST(Visibility, FallbacksAreFiniteNonNegativeAndSumToOne) {
  const Scene s = twoRooms();
  const Tracer tracer(s);
  // Only room B's probes: a query in room A sees none of them.
  const Captured c = capture(
      tracer, {{2.5, 0.5, 0.5}, {2.5, 1.5, 1.5}, {3.5, 0.5, 1.5}, {3.5, 1.5, 0.5}, {3.0, 1.0, 1.8}},
      256);
  const ProbeVolume v = volumeFromProbes(c.points, c.sh, c.vis);
  const VisibleWeights none = visibleWeights(v, Vec3{0.5, 1, 1}, std::nullopt);
  EXPECT_EQ(none.fallback, VisibleFallback::Barycentric);
  const VolumeLocation loc = locate(v, {0.5, 1, 1});
  for (int k = 0; k < 4; ++k) EXPECT_EQ(none.weights[k], loc.weights[k]);
  // A barycentric weight only on a probe the query cannot see: the visibility alone decides.
  const Vec3 q{3.2, 1.1, 1.0};
  VolumeLocation one = locate(v, q);
  ASSERT_GE(one.tet, 0);
  one.weights = {1, 0, 0, 0};
  // Make vertex 0 unseen by flagging it inside geometry.
  ProbeVolume flagged = v;
  flagged.probeInside[size_t(flagged.tets[size_t(one.tet)][0])] = 1;
  const VisibleWeights w = visibleWeights(flagged, one, q, Vec3{0, 1, 0});
  EXPECT_EQ(w.fallback, VisibleFallback::Visibility);
  EXPECT_EQ(w.weights[0], 0);
  double sum = 0;
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(std::isfinite(w.weights[k]));
    EXPECT_GE(w.weights[k], 0);
    sum += w.weights[k];
  }
  EXPECT_NEAR(sum, 1, 1e-12);
  EXPECT_GE(luminance(interpolate(flagged, w).irradiance({0, 1, 0})), 0);
}

// eval reads a volume with maps through the visibility-aware interpolant (unless told not to):
// in the two rooms, fewer queries leak and the error falls.
TEST(Visibility, EvalUsesTheInterpolantAndItLowersLeaks) {
  const Scene s = twoRooms();
  const Tracer tracer(s);
  const Captured c = capture(tracer, {{0.5, 0.5, 0.5},
                                      {0.5, 1.5, 1.5},
                                      {1.5, 0.5, 1.5},
                                      {1.5, 1.5, 0.5},
                                      {2.5, 0.5, 0.5},
                                      {2.5, 1.5, 1.5},
                                      {3.5, 0.5, 1.5},
                                      {3.5, 1.5, 0.5}});
  const ProbeVolume v = volumeFromProbes(c.points, c.sh, c.vis);
  EvalSettings es;
  es.queries = 512;
  es.referenceSpp = 64;
  const EvalResult with = evaluateVolume(tracer, LightingRig{}, v, es);
  es.useVisibility = false;
  const EvalResult without = evaluateVolume(tracer, LightingRig{}, v, es);
  EXPECT_TRUE(with.visibility);
  EXPECT_FALSE(without.visibility);
  std::printf("rel_rmse %.4f -> %.4f, leaking %.4f -> %.4f\n", without.relRmse, with.relRmse,
              without.leakingFraction, with.leakingFraction);
  EXPECT_LT(with.leakingFraction, 0.5 * without.leakingFraction);
  EXPECT_LT(with.relRmse, without.relRmse);
}

// ---- Volume file version 4 ----------------------------------------------------------------

namespace {

/// A small volume with maps, saved as version 4; its bytes.
std::string volumeBytes(const fs::path& path) {
  const Scene s = twoRooms();
  const Tracer tracer(s);
  const Captured c = capture(
      tracer, {{2.5, 0.5, 0.5}, {2.5, 1.5, 1.5}, {3.5, 0.5, 1.5}, {3.5, 1.5, 0.5}, {3.0, 1.0, 1.8}},
      64);
  VolumeFile vf;
  vf.volume = volumeFromProbes(c.points, c.sh, c.vis);
  vf.metadataJson = "{}";
  saveVolume(vf, path);
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

/// The file with its CRC-32 recomputed, so that a loader reaches the field checks.
std::string withCrc(std::string b) {
  const uint32_t c = crc32(b.data(), b.size() - 4);
  std::memcpy(b.data() + b.size() - 4, &c, 4);
  return b;
}

std::string coreError(const std::string& bytes) {
  try {
    parseVolume(bytes, "v.psv");
  } catch (const FileError& e) {
    return e.what();
  }
  return "ok";
}

std::string readerError(const std::string& bytes) {
  ps_runtime::Volume v;
  std::string e;
  return ps_runtime::loadVolumeMemory(bytes.data(), bytes.size(), v, &e) ? "ok" : e;
}

}  // namespace

TEST(VolumeFileV4, RoundTripsTheMaps) {
  const fs::path dir = ps::test::testTempDir("ps_test_visibility_");
  const std::string bytes = volumeBytes(dir / "v.psv");
  uint32_t version;
  std::memcpy(&version, bytes.data() + 8, 4);
  EXPECT_EQ(version, 4u);
  const VolumeFile vf = loadVolume(dir / "v.psv");
  EXPECT_EQ(vf.volume.visibilityMapSize, kVisibilityMapSize);
  EXPECT_EQ(vf.volume.visibility.size(), vf.volume.probeCount() * size_t(kVisibilityFloats));
  // Written again, byte for byte the same.
  saveVolume(vf, dir / "w.psv");
  std::ifstream in(dir / "w.psv", std::ios::binary);
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(in)), {}), bytes);
  EXPECT_EQ(readerError(bytes), "ok");
}

TEST(VolumeFileV4, BadMapsAreRefusedNamingTheField) {
  const fs::path dir = ps::test::testTempDir("ps_test_visibility_");
  const std::string good = volumeBytes(dir / "v.psv");
  const VolumeFile vf = parseVolume(good, "v.psv");
  const size_t P = vf.volume.probeCount();
  const size_t mapBytes = P * 4 * size_t(kVisibilityFloats);
  const size_t mapStart = good.size() - 4 - vf.metadataJson.size() - mapBytes;
  const size_t flagStart = mapStart - P;
  // Truncated by one map: the header's counts no longer match.
  {
    std::string b = good;
    b.erase(mapStart, 4 * size_t(kVisibilityFloats));
    b = withCrc(b);
    EXPECT_NE(coreError(b).find("visibility maps"), std::string::npos) << coreError(b);
    EXPECT_NE(readerError(b), "ok");
  }
  // The wrong map size in the header.
  {
    std::string b = good;
    const uint32_t r = 0;
    std::memcpy(b.data() + 8 + 6 * 4, &r, 4);
    b = withCrc(b);
    EXPECT_NE(coreError(b).find("visibility_map_size"), std::string::npos) << coreError(b);
    EXPECT_NE(readerError(b).find("visibility map size"), std::string::npos) << readerError(b);
    const uint32_t half = kVisibilityMapSize / 2;
    std::memcpy(b.data() + 8 + 6 * 4, &half, 4);
    b = withCrc(b);
    EXPECT_NE(coreError(b).find("need"), std::string::npos) << coreError(b);
    EXPECT_NE(readerError(b), "ok");
  }
  // NaN, negative and inconsistent moments.
  const auto setFloat = [&](size_t index, float value) {
    std::string b = good;
    std::memcpy(b.data() + mapStart + 4 * index, &value, 4);
    return withCrc(b);
  };
  const std::string nan = setFloat(10, std::numeric_limits<float>::quiet_NaN());
  EXPECT_NE(coreError(nan).find("visibility[probe 0, texel 5]"), std::string::npos)
      << coreError(nan);
  EXPECT_NE(readerError(nan).find("visibility"), std::string::npos) << readerError(nan);
  const std::string negative = setFloat(2, -1.0f);
  EXPECT_NE(coreError(negative).find("non-negative"), std::string::npos) << coreError(negative);
  EXPECT_NE(readerError(negative).find("visibility"), std::string::npos);
  // Mean 10 m with a mean square of ~1 m^2: a negative variance.
  const std::string variance = setFloat(0, 10.0f);
  EXPECT_NE(coreError(variance).find("negative variance"), std::string::npos)
      << coreError(variance);
  EXPECT_NE(readerError(variance).find("negative variance"), std::string::npos)
      << readerError(variance);
  // A probe flag other than 0 or 1.
  std::string flag = good;
  flag[flagStart] = 7;
  flag = withCrc(flag);
  EXPECT_NE(coreError(flag).find("probe_flags[0]"), std::string::npos) << coreError(flag);
  EXPECT_NE(readerError(flag).find("probe flag"), std::string::npos) << readerError(flag);
}

// The fuzzer's version 3 seed (tests/fuzz/seeds/volume, no cut planes) is a valid volume for
// both readers.
TEST(VolumeFileV4, TheVersion3FuzzSeedLoads) {
  const fs::path seed = fs::path(PS_SOURCE_DIR) / "tests/fuzz/seeds/volume/one-tet-visibility.psv";
  const VolumeFile vf = loadVolume(seed);
  EXPECT_EQ(vf.volume.visibilityMapSize, 1);
  EXPECT_EQ(vf.volume.probeInside[3], 1);
  std::ifstream in(seed, std::ios::binary);
  EXPECT_EQ(readerError(std::string((std::istreambuf_iterator<char>(in)), {})), "ok");
}

// Volumes of version 1 still load, without maps, and the interpolant answers with their
// barycentric weights, as before. A version 2 volume with cut planes is refused by both readers.
TEST(VolumeFileV4, OlderVersionsLoadAndAnswerAsBefore) {
  {
    const fs::path file = fs::path(PS_SOURCE_DIR) / "tests/fuzz/seeds/volume/one-tet-cut.psv";
    std::ifstream in(file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), {});
    EXPECT_NE(coreError(bytes).find("cut_plane_count"), std::string::npos) << coreError(bytes);
    EXPECT_NE(readerError(bytes).find("re-bake"), std::string::npos) << readerError(bytes);
  }
  for (const char* name : {"one-tet.psv", "two-tets.psv"}) {
    const fs::path file = fs::path(PS_SOURCE_DIR) / "tests/fuzz/seeds/volume" / name;
    const VolumeFile vf = loadVolume(file);
    EXPECT_FALSE(vf.volume.hasVisibility()) << name;
    for (const Vec3 p : {Vec3{0.1, 0.2, 0.3}, Vec3{0.25, 0.25, 0.25}, Vec3{2, -1, 0.5}}) {
      const VolumeLocation loc = locate(vf.volume, p);
      const VisibleWeights w = visibleWeights(vf.volume, loc, p, Vec3{0, 1, 0});
      EXPECT_EQ(w.fallback, VisibleFallback::None);
      for (int k = 0; k < 4; ++k) EXPECT_EQ(w.weights[k], double(loc.weights[k])) << name;
      const ShRgb a = interpolate(vf.volume, loc), b = interpolate(vf.volume, w);
      for (int k = 0; k < kShCoeffCount; ++k) EXPECT_EQ(a.c[k], b.c[k]) << name;
    }
    std::ifstream in(file, std::ios::binary);
    EXPECT_EQ(readerError(std::string((std::istreambuf_iterator<char>(in)), {})), "ok");
  }
}
