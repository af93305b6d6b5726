// Bake through the capture cache: a re-bake after moving one probe recaptures only that probe,
// and every other probe's SH is bit-identical to the first bake's.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "core/bake/Bake.h"
#include "core/bake/CaptureCache.h"
#include "core/common/Error.h"
#include "core/io/SceneHash.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"
#include "tests/core/TestFiles.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

const fs::path kScenes = fs::path(PS_SOURCE_DIR) / "resources" / "scenes";

fs::path tempDir() {
  return ps::test::testTempDir("ps_test_bake_");
}

// A 3 x 3 x 3 grid of accepted probes inside the Cornell box (x, z in [-2.85, 2.85], y in
// [0, 5.5]).
ProbeSet gridSet() {
  ProbeSet s;
  s.scenePath = (kScenes / "cornell.gltf").string();
  s.rig.skyRadiance = {0.5, 0.5, 0.5};
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y)
      for (int z = 0; z < 3; ++z) {
        Probe p;
        p.position = {-1.5 + 1.5 * x, 1.0 + 1.5 * y, -1.5 + 1.5 * z};
        p.state = ProbeState::Accepted;
        s.add(p);
      }
  return s;
}

// The SH of the volume vertex at `pos`.
ShRgb shAt(const ProbeVolume& v, Vec3 pos) {
  for (size_t i = 0; i < v.probeCount(); ++i)
    if (v.position(static_cast<int32_t>(i)) == Vec3(float(pos.x), float(pos.y), float(pos.z)))
      return v.probeSh(static_cast<int32_t>(i));
  ADD_FAILURE() << "no probe at " << pos.x << "," << pos.y << "," << pos.z;
  return {};
}

}  // namespace

TEST(Bake, ReBakeAfterMovingOneProbeRecapturesOnlyThatProbe) {
  const fs::path dir = tempDir();
  const Scene scene = loadScene(kScenes / "cornell.gltf");
  const Tracer tracer(scene);
  BakeSettings bs;
  bs.capture.samplesPerProbe = 64;
  bs.cacheDir = dir / "cache";
  bs.sceneHash = sceneContentHash(kScenes / "cornell.gltf");

  ProbeSet set = gridSet();
  const BakeResult first = bakeProbeSet(set, tracer, bs);
  EXPECT_EQ(first.captured, 27u);
  EXPECT_EQ(first.cacheHits, 0u);

  set.probes[13].position = {0.25, 2.75, 0.3};  // the centre probe moves
  const BakeResult second = bakeProbeSet(set, tracer, bs);
  EXPECT_EQ(second.captured, 1u);
  EXPECT_EQ(second.cacheHits, 26u);
  for (size_t i = 0; i < set.probes.size(); ++i) {
    if (i == 13) continue;
    EXPECT_EQ(shAt(second.file.volume, set.probes[i].position),
              shAt(first.file.volume, set.probes[i].position));
  }

  // Another rig, sample count or scene hash misses the cache.
  BakeSettings moreSamples = bs;
  moreSamples.capture.samplesPerProbe = 65;
  EXPECT_EQ(bakeProbeSet(set, tracer, moreSamples).captured, 27u);
  ProbeSet brighter = set;
  brighter.rig.skyRadiance = {0.6, 0.5, 0.5};
  EXPECT_EQ(bakeProbeSet(brighter, tracer, bs).captured, 27u);
  BakeSettings otherScene = bs;
  otherScene.sceneHash ^= 1;
  EXPECT_EQ(bakeProbeSet(set, tracer, otherScene).captured, 27u);
  // No cache folder: everything is captured.
  BakeSettings noCache = bs;
  noCache.cacheDir.reset();
  EXPECT_EQ(bakeProbeSet(set, tracer, noCache).captured, 27u);
}

TEST(Bake, DamagedCacheEntriesAreRecaptured) {
  const fs::path dir = tempDir();
  const CaptureCache cache(dir / "cache");
  CaptureCacheEntry entry;
  for (int k = 0; k < kShCoeffCount; ++k) entry.sh.c[k] = {0.1 * k, 0.2 * k, -0.3 * k};
  for (size_t i = 0; i < entry.distanceMoments.size(); ++i) entry.distanceMoments[i] = 0.5f * i;
  entry.inside = true;
  const uint64_t key = CaptureCache::key(7, LightingRig{}, CaptureSettings{}, {1, 2, 3});
  EXPECT_FALSE(cache.find(key).has_value());
  cache.store(key, entry);
  ASSERT_TRUE(cache.find(key).has_value());
  EXPECT_EQ(*cache.find(key), entry);
  EXPECT_NE(key, CaptureCache::key(7, LightingRig{}, CaptureSettings{}, {1, 2, 3.0000001}));
  // Flip one byte of the entry: it no longer counts.
  for (const auto& e : fs::directory_iterator(dir / "cache")) {
    std::fstream f(e.path(), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(40);
    f.put('\x7f');
  }
  EXPECT_FALSE(cache.find(key).has_value());
}
