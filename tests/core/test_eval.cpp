// eval's reference cache: a second evaluation with the same scene, rig and settings reads the
// reference from disk (flagged cached) and gives bit-identical numbers, for another volume too;
// any change of seed, rig, samples, queries or scene misses; a damaged entry is reported,
// recomputed to the same numbers and replaced.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include "core/bake/Bake.h"
#include "core/common/Error.h"
#include "core/eval/Evaluate.h"
#include "core/eval/ReferenceCache.h"
#include "core/io/SceneHash.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"
#include "tests/core/SceneBuilders.h"
#include "tests/core/TestFiles.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

const fs::path kScenes = fs::path(PS_SOURCE_DIR) / "resources" / "scenes";

struct Fixture {
  Scene scene = loadScene(kScenes / "cornell.gltf");
  Tracer tracer{scene};
  uint64_t sceneHash = sceneContentHash(kScenes / "cornell.gltf");
  LightingRig rig;
  Fixture() { rig.skyRadiance = {0.5, 0.5, 0.5}; }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

// An n x n x n grid of probes inside the Cornell box (x, z in [-2.85, 2.85], y in [0, 5.5]),
// captured cheaply.
ProbeVolume gridVolume(int n) {
  std::vector<Vec3> pts;
  for (int x = 0; x < n; ++x)
    for (int y = 0; y < n; ++y)
      for (int z = 0; z < n; ++z)
        pts.push_back(
            {-2.5 + 5.0 * x / (n - 1), 0.3 + 4.9 * y / (n - 1), -2.5 + 5.0 * z / (n - 1)});
  CaptureSettings cs;
  cs.samplesPerProbe = 32;
  const auto captures = captureProbes(fixture().tracer, fixture().rig, pts, cs);
  std::vector<ShRgb> sh;
  for (const auto& c : captures) sh.push_back(c.sh);
  return volumeFromProbes(pts, sh);
}

EvalSettings cachedSettings(const fs::path& dir) {
  EvalSettings es;
  es.queries = 48;
  es.referenceSpp = 32;
  es.seed = 11;
  es.cacheDir = dir / "cache";
  es.sceneHash = fixture().sceneHash;
  return es;
}

void expectSameNumbers(const EvalResult& a, const EvalResult& b) {
  EXPECT_EQ(a.probes, b.probes);
  EXPECT_EQ(a.queries, b.queries);
  EXPECT_EQ(a.relRmse, b.relRmse);
  EXPECT_EQ(a.p95RelError, b.p95RelError);
  EXPECT_EQ(a.maxRelError, b.maxRelError);
  EXPECT_EQ(a.leakingFraction, b.leakingFraction);
}

std::vector<fs::path> filesIn(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path());
  return files;
}

EvalResult eval(const ProbeVolume& v, const EvalSettings& es, const LightingRig* rig = nullptr) {
  return evaluateVolume(fixture().tracer, rig ? *rig : fixture().rig, v, es);
}

}  // namespace

TEST(EvalReferenceCache, SecondEvalReadsTheCacheWithIdenticalNumbers) {
  const fs::path dir = test::testTempDir("ps_test_eval_");
  const ProbeVolume coarse = gridVolume(2), fine = gridVolume(3);
  const EvalSettings es = cachedSettings(dir);
  EvalSettings noCache = es;
  noCache.cacheDir.reset();

  const EvalResult uncached = eval(coarse, noCache);
  EXPECT_FALSE(uncached.referenceCached);
  const EvalResult first = eval(coarse, es);
  EXPECT_FALSE(first.referenceCached);
  EXPECT_TRUE(first.notes.empty());
  // One entry, no temporary file left beside it.
  const auto files = filesIn(dir / "cache");
  ASSERT_EQ(files.size(), 1u);
  EXPECT_EQ(files[0].extension(), ".psref");
  const EvalResult second = eval(coarse, es);
  EXPECT_TRUE(second.referenceCached);
  EXPECT_TRUE(second.notes.empty());
  expectSameNumbers(first, uncached);
  expectSameNumbers(second, first);
  EXPECT_GT(first.relRmse, 0.0);

  // Another volume (another placement) of the same scene and rig reuses the reference.
  const EvalResult fineCached = eval(fine, es);
  EXPECT_TRUE(fineCached.referenceCached);
  expectSameNumbers(fineCached, eval(fine, noCache));
  EXPECT_NE(fineCached.relRmse, first.relRmse);
  EXPECT_EQ(filesIn(dir / "cache").size(), 1u);
}

TEST(EvalReferenceCache, AnotherSeedRigSampleCountQueryCountOrSceneMisses) {
  const fs::path dir = test::testTempDir("ps_test_eval_");
  const ProbeVolume v = gridVolume(2);
  const EvalSettings es = cachedSettings(dir);
  ASSERT_FALSE(eval(v, es).referenceCached);
  ASSERT_TRUE(eval(v, es).referenceCached);

  EvalSettings seed = es;
  seed.seed += 1;
  EXPECT_FALSE(eval(v, seed).referenceCached);
  EvalSettings spp = es;
  spp.referenceSpp += 1;
  EXPECT_FALSE(eval(v, spp).referenceCached);
  EvalSettings queries = es;
  queries.queries += 1;
  EXPECT_FALSE(eval(v, queries).referenceCached);
  EvalSettings scene = es;
  scene.sceneHash ^= 1;
  EXPECT_FALSE(eval(v, scene).referenceCached);
  LightingRig brighter = fixture().rig;
  brighter.skyRadiance = {0.6, 0.5, 0.5};
  EXPECT_FALSE(eval(v, es, &brighter).referenceCached);
  LightingRig sun = fixture().rig;
  Light l;
  l.type = LightType::Directional;
  sun.lights.push_back(l);
  EXPECT_FALSE(eval(v, es, &sun).referenceCached);
  EXPECT_EQ(filesIn(dir / "cache").size(), 7u);
  // Each of them is cached now, and the first is still there.
  EXPECT_TRUE(eval(v, seed).referenceCached);
  EXPECT_TRUE(eval(v, es, &sun).referenceCached);
  EXPECT_TRUE(eval(v, es).referenceCached);
  // Without a scene hash the cache is not used at all.
  EvalSettings unknownScene = es;
  unknownScene.sceneHash = 0;
  EXPECT_FALSE(eval(v, unknownScene).referenceCached);
}

TEST(EvalReferenceCache, KeyFollowsTheEnvironmentTexelsAndTheDomain) {
  const EvalSettings es;
  Bounds3 box;
  box.extend({0, 0, 0});
  box.extend({1, 2, 3});
  auto map = std::make_shared<EnvironmentMap>();
  map->path = "sky.hdr";
  map->width = 2;
  map->height = 1;
  map->rgb = {1, 1, 1, 2, 2, 2};
  LightingRig rig;
  rig.envMapPath = "sky.hdr";
  rig.envMap = map;
  const uint64_t k = ReferenceCache::key(5, rig, box, es, false);
  EXPECT_EQ(k, ReferenceCache::key(5, rig, box, es, false));
  // The same path with other texels (a map edited in place).
  auto edited = std::make_shared<EnvironmentMap>(*map);
  edited->rgb[4] = 2.5f;
  LightingRig rig2 = rig;
  rig2.envMap = edited;
  EXPECT_NE(k, ReferenceCache::key(5, rig2, box, es, false));
  Bounds3 wider = box;
  wider.extend({1, 2, 3.5});
  EXPECT_NE(k, ReferenceCache::key(5, rig, wider, es, false));
}

TEST(Eval, TheLightClearanceKeysOnlyScenesWithPunctualLights) {
  EvalSettings es;
  const Bounds3 box{{0, 0, 0}, {1, 1, 1}};
  const LightingRig rig;
  EvalSettings none = es;
  none.lightClearanceRelative = 0;
  // Without a point or spot light the clearance changes nothing, so the key stays.
  EXPECT_EQ(ReferenceCache::key(5, rig, box, es, false),
            ReferenceCache::key(5, rig, box, none, false));
  EXPECT_NE(ReferenceCache::key(5, rig, box, es, true),
            ReferenceCache::key(5, rig, box, none, true));
  EXPECT_EQ(ReferenceCache::key(5, rig, box, none, false),
            ReferenceCache::key(5, rig, box, none, true));
}

TEST(Eval, TheDoubleSidedValidityKeysOnlyScenesWithDoubleSidedSurfaces) {
  // Counting double-sided back faces moves queries only in scenes that have such surfaces, so
  // only their keys include the double-sided validity version.
  const EvalSettings es;
  const Bounds3 box{{0, 0, 0}, {1, 1, 1}};
  const LightingRig rig;
  EXPECT_NE(ReferenceCache::key(5, rig, box, es, false, true),
            ReferenceCache::key(5, rig, box, es, false, false));
  Scene scene;
  ps::testing::addBox(scene, {-2, 0, -2}, {2, 2, 2},
                      ps::testing::addMaterial(scene, {0.5, 0.5, 0.5}),
                      /*inward=*/true);
  EXPECT_FALSE(scene.hasDoubleSidedSurfaces());
  ps::testing::addBox(scene, {-1, 0, -1}, {1, 1, 1},
                      ps::testing::addMaterial(scene, {0.5, 0.5, 0.5}, {}, /*doubleSided=*/true),
                      /*inward=*/false);
  EXPECT_TRUE(scene.hasDoubleSidedSurfaces());
}

TEST(Eval, NoQueryInsideAClosedDoubleSidedObject) {
  // A glowing 4 x 2 x 4 m room with a closed double-sided block (clear of the walls) filling a
  // fifth of it. Every asset of the shared real scenes is double-sided: no query may be drawn
  // inside such an object, where the irradiance is zero.
  Scene scene;
  ps::testing::addBox(scene, {-2, 0, -2}, {2, 2, 2},
                      ps::testing::addMaterial(scene, {0.5, 0.5, 0.5}, {1, 1, 1}),
                      /*inward=*/true);
  const Vec3 lo{-1, 0.5, -1}, hi{1.5, 1.5, 1.5};
  ps::testing::addBox(scene, lo, hi,
                      ps::testing::addMaterial(scene, {0.5, 0.5, 0.5}, {}, /*doubleSided=*/true),
                      /*inward=*/false);
  const Tracer tracer(scene);
  EvalSettings es;
  es.queries = 1000;
  es.referenceSpp = 1;
  const EvalReference ref = computeReference(tracer, {}, es);
  ASSERT_EQ(ref.points.size(), 1000u);
  size_t inBlock = 0;
  for (const Vec3& p : ref.points)
    inBlock += p.x > lo.x && p.x < hi.x && p.y > lo.y && p.y < hi.y && p.z > lo.z && p.z < hi.z;
  EXPECT_EQ(inBlock, 0u);
}

TEST(Eval, ReferenceNoiseMatchesItsSpreadAgainstAFinerReference) {
  // The same queries (same seed) traced at 32 and at 2048 samples on the Cornell box, whose
  // area light makes the reference noisy: the 32-sample reference differs from the finer one by
  // what its noise estimate says (an upper bound: the draw is stratified), and the estimate
  // falls as 1 / sqrt(spp).
  EvalSettings es;
  es.queries = 512;
  es.referenceSpp = 32;
  const EvalReference coarse = computeReference(fixture().tracer, fixture().rig, es);
  es.referenceSpp = 2048;
  const EvalReference fine = computeReference(fixture().tracer, fixture().rig, es);
  ASSERT_EQ(coarse.points, fine.points);
  ASSERT_EQ(coarse.variance.size(), 512u);
  double diff = 0, den = 0, varCoarse = 0, varFine = 0;
  for (size_t q = 0; q < 512; ++q) {
    const double a = luminance(coarse.irradiance[q]), b = luminance(fine.irradiance[q]);
    diff += (a - b) * (a - b);
    den += b * b;
    varCoarse += coarse.variance[q];
    varFine += fine.variance[q];
  }
  const double spread = std::sqrt(diff / den);
  const double estimate = std::sqrt((varCoarse + varFine) / den);
  EXPECT_GT(spread, 0.02);  // noisy enough to test anything
  EXPECT_LE(spread, 1.1 * estimate);
  EXPECT_GE(spread, 0.6 * estimate);
  EXPECT_NEAR(std::sqrt(varCoarse / varFine), 8.0, 2.4);
  // evaluateVolume reports it on rel_rmse's scale, and per query.
  es.referenceSpp = 32;
  const EvalResult r = evaluateVolume(fixture().tracer, fixture().rig, gridVolume(3), es);
  double refSq = 0;
  for (const Rgb& e : coarse.irradiance) refSq += luminance(e) * luminance(e);
  EXPECT_NEAR(r.referenceRelNoise, std::sqrt(varCoarse / refSq), 1e-9);
  EXPECT_DOUBLE_EQ(r.perQuery[7].referenceStd, std::sqrt(coarse.variance[7]));
}

TEST(Eval, RelRmseStdErrorPredictsTheSpreadOverQueryDraws) {
  // One volume evaluated with 32 seeds (32 independent draws of 256 queries): the standard
  // deviation of relRmse over the draws is what each draw's relRmseStdError says.
  const ProbeVolume v = gridVolume(3);
  EvalSettings es;
  es.queries = 256;
  es.referenceSpp = 8;
  std::vector<double> rel, se;
  for (uint64_t seed = 1; seed <= 32; ++seed) {
    es.seed = seed;
    const EvalResult r = evaluateVolume(fixture().tracer, fixture().rig, v, es);
    rel.push_back(r.relRmse);
    se.push_back(r.relRmseStdError);
  }
  double mean = 0, meanSe = 0;
  for (size_t i = 0; i < rel.size(); ++i) {
    mean += rel[i] / double(rel.size());
    meanSe += se[i] / double(rel.size());
  }
  double var = 0;
  for (double x : rel) var += (x - mean) * (x - mean) / double(rel.size() - 1);
  const double sd = std::sqrt(var);
  std::printf("relRmse over draws: mean %.4f, sd %.4f; mean std error %.4f\n", mean, sd, meanSe);
  EXPECT_GT(sd, 0.005);
  EXPECT_GT(meanSe, 0.6 * sd);
  EXPECT_LT(meanSe, 1.6 * sd);
  // It falls as 1 / sqrt(queries): 0.25 at 16 times the queries. The relative errors at 8 spp
  // have heavy tails, which 256 queries sample too rarely, so the 256-query figure runs low and
  // the ratio high: over seeds 1 to 16 it ran from 0.29 to 0.38 (0.29 to 0.40 over seeds 1 to 8
  // of a reference traced one ray at a time). The margin takes 0.07 beyond either end.
  es.seed = 1;
  es.queries = 4096;
  const EvalResult many = evaluateVolume(fixture().tracer, fixture().rig, v, es);
  EXPECT_NEAR(many.relRmseStdError / meanSe, 0.345, 0.125);
}

TEST(Eval, QueriesKeepTheClearanceFromPointLights) {
  // A point light in the middle of the Cornell box and a large clearance (a tenth of the
  // diagonal, about 1 m): no query inside it, where without it about 0.8 % of them are.
  LightingRig rig = fixture().rig;
  const Light bulb = ps::testing::pointLight({0, 2.75, 0}, {5, 5, 5});
  rig.lights.push_back(bulb);
  EvalSettings es;
  es.queries = 2000;
  es.referenceSpp = 1;
  es.lightClearanceRelative = 0.1;
  const double clearance = 0.1 * fixture().tracer.scene().bounds.diagonal();
  auto inside = [&](const EvalReference& ref) {
    size_t n = 0;
    for (const Vec3& p : ref.points) n += length(p - bulb.position) < clearance ? 1 : 0;
    return n;
  };
  EXPECT_EQ(inside(computeReference(fixture().tracer, rig, es)), 0u);
  es.lightClearanceRelative = 0;
  EXPECT_GT(inside(computeReference(fixture().tracer, rig, es)), 5u);
  es.lightClearanceRelative = 0.5;
  EXPECT_THROW(computeReference(fixture().tracer, rig, es), ParameterError);
  // Checked before the cache, whose key leaves the clearance out where there is no point light.
  const fs::path dir = fs::temp_directory_path() / "ps-eval-clearance";
  fs::remove_all(dir);
  EvalSettings cached = cachedSettings(dir);
  cached.lightClearanceRelative = 0;
  const ProbeVolume v = gridVolume(3);
  evaluateVolume(fixture().tracer, fixture().rig, v, cached);
  cached.lightClearanceRelative = -1;
  EXPECT_THROW(evaluateVolume(fixture().tracer, fixture().rig, v, cached), ParameterError);
  fs::remove_all(dir);
}

TEST(Eval, QueriesAreUniformOverTheImportanceVolumes) {
  // Two overlapping boxes high in the Cornell box (above the blocks): their union is
  // x in [-2, 1], and the overlap x in [-1, 0] holds a third of it, so a third of the queries
  // (not half, as drawing a box and then a point in it would give).
  EvalSettings es;
  es.queries = 600;
  es.referenceSpp = 1;
  Bounds3 a, b;
  a.extend({-2, 4, -1});
  a.extend({0, 5, 1});
  b.extend({-1, 4, -1});
  b.extend({1, 5, 1});
  es.domain = {a, b};
  const EvalReference ref = computeReference(fixture().tracer, fixture().rig, es);
  int overlap = 0;
  for (Vec3 p : ref.points) {
    EXPECT_TRUE(a.contains(p) || b.contains(p)) << p;
    overlap += a.contains(p) && b.contains(p) ? 1 : 0;
  }
  EXPECT_NEAR(overlap, 200, 5 * std::sqrt(600 * (1.0 / 3) * (2.0 / 3)));  // 5 sigma: +-58
  // Another domain is another cache key; a flat one is an error.
  EXPECT_NE(ReferenceCache::key(1, fixture().rig, es.domain, es, false),
            ReferenceCache::key(1, fixture().rig, std::vector<Bounds3>{a}, es, false));
  Bounds3 flat;
  flat.extend({0, 4, 0});
  flat.extend({1, 4, 1});
  es.domain = {flat};
  EXPECT_THROW(computeReference(fixture().tracer, fixture().rig, es), ParameterError);
}

TEST(EvalReferenceCache, DamagedEntryIsReportedAndRecomputedToTheSameNumbers) {
  const fs::path dir = test::testTempDir("ps_test_eval_");
  const ProbeVolume v = gridVolume(2);
  const EvalSettings es = cachedSettings(dir);
  const EvalResult first = eval(v, es);
  ASSERT_FALSE(first.referenceCached);
  const fs::path entry = filesIn(dir / "cache").at(0);
  const uintmax_t size = fs::file_size(entry);

  const auto expectRecomputed = [&](const char* what) {
    SCOPED_TRACE(what);
    const EvalResult r = eval(v, es);
    EXPECT_FALSE(r.referenceCached);
    ASSERT_EQ(r.notes.size(), 1u);
    EXPECT_NE(r.notes[0].find("damaged reference cache entry"), std::string::npos) << r.notes[0];
    EXPECT_NE(r.notes[0].find(entry.filename().string()), std::string::npos) << r.notes[0];
    expectSameNumbers(r, first);
    // The entry was replaced by a good one.
    EXPECT_EQ(fs::file_size(entry), size);
    const EvalResult again = eval(v, es);
    EXPECT_TRUE(again.referenceCached);
    EXPECT_TRUE(again.notes.empty());
    expectSameNumbers(again, first);
  };

  {  // one byte of a reference irradiance flipped: the CRC no longer matches
    std::fstream f(entry, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(std::streamoff(size / 2));
    const char c = char(f.peek());
    f.seekp(std::streamoff(size / 2));
    f.put(char(c ^ 0x10));
  }
  expectRecomputed("flipped byte");
  fs::resize_file(entry, size / 3);
  expectRecomputed("truncated");
  fs::resize_file(entry, 0);
  expectRecomputed("empty");
  {
    std::ofstream f(entry, std::ios::app | std::ios::binary);
    f << "more";
  }
  expectRecomputed("too long");
}

TEST(EvalReferenceCache, StoredReferenceReadsBackExactly) {
  const fs::path dir = test::testTempDir("ps_test_eval_");
  EvalSettings es;
  es.queries = 16;
  es.referenceSpp = 8;
  const EvalReference ref = computeReference(fixture().tracer, fixture().rig, es);
  ASSERT_EQ(ref.points.size(), 16u);
  EXPECT_EQ(ref, computeReference(fixture().tracer, fixture().rig, es));  // deterministic
  const ReferenceCache cache(dir / "cache");
  std::string problem;
  EXPECT_FALSE(cache.find(42, 16, &problem).has_value());
  EXPECT_TRUE(problem.empty());  // missing, not damaged
  cache.store(42, ref);
  const auto back = cache.find(42, 16, &problem);
  ASSERT_TRUE(back.has_value());
  EXPECT_TRUE(problem.empty());
  EXPECT_EQ(*back, ref);
  // Asked for another query count, the entry does not fit.
  EXPECT_FALSE(cache.find(42, 17, &problem).has_value());
  EXPECT_NE(problem.find("truncated"), std::string::npos) << problem;
}

TEST(EvalReferenceCache, UncreatableCacheFolderIsAFileError) {
  const fs::path dir = test::testTempDir("ps_test_eval_");
  { std::ofstream(dir / "file") << "x"; }
  EvalSettings es = cachedSettings(dir);
  es.cacheDir = dir / "file" / "cache";
  EXPECT_THROW(eval(gridVolume(2), es), FileError);
}

TEST(EvalReferenceCache, UnwritableEntryIsANoteAndTheNumbersStandNotAnError) {
  const fs::path dir = test::testTempDir("ps_test_eval_");
  const ProbeVolume v = gridVolume(2);
  const EvalSettings es = cachedSettings(dir);
  EvalSettings noCache = es;
  noCache.cacheDir.reset();
  const EvalResult expected = eval(v, noCache);
  // A folder where the entry should be: it can be neither read nor replaced.
  const uint64_t key =
      ReferenceCache::key(es.sceneHash, fixture().rig, fixture().tracer.scene().bounds, es,
                          !punctualLightPositions(fixture().tracer.scene(), fixture().rig).empty());
  const ReferenceCache cache(*es.cacheDir);
  fs::create_directories(cache.entryPath(key) / "x");
  const EvalResult r = eval(v, es);
  EXPECT_FALSE(r.referenceCached);
  expectSameNumbers(r, expected);
  ASSERT_EQ(r.notes.size(), 2u);
  EXPECT_NE(r.notes[0].find("damaged reference cache entry"), std::string::npos) << r.notes[0];
  EXPECT_NE(r.notes[0].find("not a regular file"), std::string::npos) << r.notes[0];
  EXPECT_NE(r.notes[1].find("could not be cached"), std::string::npos) << r.notes[1];
  std::printf("%s\n%s\n", r.notes[0].c_str(), r.notes[1].c_str());
  // No temporary file is left behind.
  EXPECT_EQ(filesIn(*es.cacheDir).size(), 1u);
}

// Where the leaks are: a volume whose eight probes span the cube [-1, 1]^3, in the domain
// [-2, 2]^3, with a wall (x in [1.2, 1.3], spanning the domain) beyond its x = 1 face. The
// queries outside the cube are clamped to it (7/8 of the volume outside the wall); those beyond
// the wall see none of the probes they are clamped to, and nothing leaks inside the cube.
TEST(Eval, SaysWhichQueriesAreOutsideTheHullAndLeakThere) {
  Scene s;
  ps::testing::addBox(s, {1.2, -3, -3}, {1.3, 3, 3}, ps::testing::addMaterial(s, {0.5, 0.5, 0.5}),
                      /*inward=*/false);
  const Tracer tracer(s);
  LightingRig rig;
  rig.skyRadiance = {1, 1, 1};
  std::vector<Vec3> corners;
  for (int i = 0; i < 8; ++i)
    corners.push_back({i & 1 ? 1.0 : -1.0, i & 2 ? 1.0 : -1.0, i & 4 ? 1.0 : -1.0});
  const ProbeVolume v = volumeFromProbes(corners, std::vector<ShRgb>(8));
  EvalSettings es;
  es.queries = 4096;
  es.referenceSpp = 1;
  Bounds3 domain;
  domain.extend({-2, -2, -2});
  domain.extend({2, 2, 2});
  es.domain = {domain};
  const EvalResult r = evaluateVolume(tracer, rig, v, es);
  // Of the valid volume (64 - 1.6 m^3 of wall), the cube holds 8 m^3 and 11.2 m^3 lie beyond the
  // wall. 5 standard deviations of the draw.
  const double valid = 64 - 1.6, n = es.queries;
  const double outside = 1 - 8 / valid, beyond = 11.2 / valid;
  EXPECT_NEAR(r.outsideHullFraction, outside, 5 * std::sqrt(outside * (1 - outside) / n));
  EXPECT_NEAR(r.leakingOutsideHullFraction, beyond, 5 * std::sqrt(beyond * (1 - beyond) / n));
  EXPECT_EQ(r.leakingFraction, r.leakingOutsideHullFraction);
  // Per query: outside is where the point is outside the cube, and a leak outside is beyond the
  // wall.
  // (Points within 1e-4 of the cube's faces are left out of the per-query check: locate()
  // counts a point within its barycentric slack as inside.)
  size_t out = 0, leakOut = 0;
  for (const EvalQuery& q : r.perQuery) {
    out += q.outside ? 1 : 0;
    leakOut += q.outside && q.leaking ? 1 : 0;
    const double m = std::max({std::abs(q.point.x), std::abs(q.point.y), std::abs(q.point.z)});
    if (std::abs(m - 1) < 1e-4) continue;
    EXPECT_EQ(q.outside, m > 1) << q.point;
    EXPECT_EQ(q.leaking, q.point.x > 1.3) << q.point;
  }
  EXPECT_EQ(double(out) / n, r.outsideHullFraction);
  EXPECT_EQ(double(leakOut) / n, r.leakingOutsideHullFraction);
}

// The SH floor against physics: a sun alone over a black floor, so the reference is exactly
// E max(0, n.l) and a probe's order-2 SH holds exactly the sun's projection (no ray noise). A probe
// at a query then gives E (1/4 + c/2 + 5/16 P2(c)), c = n.l (the clamped cosine's Legendre terms
// up to order 2), whatever the placement: over uniform normals a relative RMS of sqrt(2) / 16.
TEST(Eval, ShFloorOfASunAloneIsTheClampedCosinesOrder2Error) {
  const Scene scene = ps::testing::floorScene();
  const Tracer tracer(scene);
  LightingRig rig;
  Light sun;
  sun.type = LightType::Directional;
  sun.direction = {0, -1, 0};  // travelling down
  sun.intensity = {1, 1, 1};
  rig.lights.push_back(sun);
  const std::vector<Vec3> pts = {{-2, 0.5, -2}, {2, 0.5, -2}, {0, 0.5, 2}, {0, 3, 0}};
  // Black probes: the volume is wholly wrong, and the floor does not read it.
  const ProbeVolume v = volumeFromProbes(pts, std::vector<ShRgb>(pts.size()));
  EvalSettings es;
  es.queries = 4096;
  es.referenceSpp = 1;
  es.domain = {Bounds3{{-1, 0.5, -1}, {1, 2.5, 1}}};
  EXPECT_FALSE(evaluateVolume(tracer, rig, v, es).shFloorRelRmse.has_value());
  es.floorSpp = 1;
  const EvalResult r = evaluateVolume(tracer, rig, v, es);
  ASSERT_TRUE(r.shFloorRelRmse.has_value());
  double num = 0, den = 0;
  for (const EvalQuery& q : r.perQuery) {
    const double c = q.normal.y;
    const double exact = std::max(0.0, c);
    const double order2 = 0.25 + 0.5 * c + 5.0 / 16.0 * 0.5 * (3 * c * c - 1);
    EXPECT_NEAR(q.reference, exact, 1e-6);
    num += (order2 - exact) * (order2 - exact);
    den += exact * exact;
  }
  EXPECT_NEAR(*r.shFloorRelRmse, std::sqrt(num / den), 1e-4);
  EXPECT_NEAR(*r.shFloorRelRmse, std::sqrt(2.0) / 16, 0.005);  // this draw of 4096 normals
  EXPECT_NEAR(r.relRmse, 1.0, 1e-12);
  es.floorSpp = -1;
  EXPECT_THROW(evaluateVolume(tracer, rig, v, es), ParameterError);
}
