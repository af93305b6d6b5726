// The dense field (octree refinement near geometry and where neighbours differ) and the greedy,
// error-driven placement on the bundled scenes.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <span>
#include <tuple>

#include "core/bake/Bake.h"
#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "core/eval/Evaluate.h"
#include "core/eval/PerceptualError.h"
#include "core/math/Random.h"
#include "core/math/Stops.h"
#include "core/placement/Ascent.h"
#include "core/placement/DenseField.h"
#include "core/placement/Greedy.h"
#include "core/placement/GreedyMethod.h"
#include "core/placement/Place.h"
#include "core/placement/SpawnMerge.h"
#include "core/placement/Uniform.h"
#include "core/scene/Scene.h"
#include "core/tessellation/Tetrahedralization.h"
#include "core/trace/Tracer.h"
#include "core/traversal/ProbeVolume.h"
#include "core/traversal/VisibleInterpolation.h"
#include "tests/core/SceneBuilders.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

const fs::path kScenes = fs::path(PS_SOURCE_DIR) / "resources" / "scenes";

// The same under AddressSanitizer: the density and error comparisons depend on the noise level.
constexpr int kFieldSpp = 32;

struct Loaded {
  Scene scene;
  std::unique_ptr<Tracer> tracer;
};

const Loaded& loaded(const std::string& name) {
  static std::map<std::string, Loaded> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    Loaded l;
    l.scene = loadScene(kScenes / name);
    it = cache.emplace(name, std::move(l)).first;
    it->second.tracer = std::make_unique<Tracer>(it->second.scene);
  }
  return it->second;
}

DenseFieldSettings smallField(int maxDepth) {
  DenseFieldSettings s;
  s.maxDepth = maxDepth;
  s.samplesPerProbe = kFieldSpp;
  return s;
}

bool inBox(Vec3 p, Vec3 lo, Vec3 hi) {
  return p.x > lo.x && p.x < hi.x && p.y > lo.y && p.y < hi.y && p.z > lo.z && p.z < hi.z;
}

/// Samples per cubic metre of the field inside the box [lo, hi].
double density(const DenseField& f, Vec3 lo, Vec3 hi) {
  size_t n = 0;
  for (const FieldSample& s : f.samples) n += inBox(s.position, lo, hi) ? 1 : 0;
  const Vec3 e = hi - lo;
  return double(n) / (e.x * e.y * e.z);
}

}  // namespace

TEST(DenseField, IsDeterministicForASeed) {
  const Loaded& l = loaded("pillar-room.gltf");
  const DenseField a = buildDenseField(*l.tracer, {}, smallField(1));
  const DenseField b = buildDenseField(*l.tracer, {}, smallField(1));
  ASSERT_EQ(a.samples.size(), b.samples.size());
  ASSERT_GT(a.samples.size(), 50u);
  for (size_t i = 0; i < a.samples.size(); ++i) {
    EXPECT_EQ(a.samples[i].position, b.samples[i].position);
    EXPECT_EQ(a.samples[i].sh, b.samples[i].sh);
    EXPECT_EQ(a.samples[i].depth, b.samples[i].depth);
    EXPECT_EQ(a.samples[i].luminanceHistogram, b.samples[i].luminanceHistogram);
  }
  // Every sample keeps its rays' histograms: luminance sums to 1, hue to 1 (or 0 when no ray
  // had a hue).
  for (const FieldSample& fs : a.samples) {
    double lum = 0, hue = 0;
    for (double x : fs.luminanceHistogram) lum += x;
    for (double x : fs.hueHistogram) hue += x;
    EXPECT_NEAR(lum, 1.0, 1e-12);
    EXPECT_TRUE(std::abs(hue - 1.0) < 1e-12 || hue == 0.0) << hue;
  }
}

TEST(DenseField, NoSampleInsideGeometryOfThePillarRoom) {
  // pillar-room: interior [-4, 4] x [0, 3] x [-4, 4], pillar [-0.6, 0.6] x [0, 3] x [-0.6, 0.6]
  // (scripts/make_scenes.py); everything else within the bounds is solid wall.
  const Loaded& l = loaded("pillar-room.gltf");
  const DenseField f = buildDenseField(*l.tracer, {}, smallField(2));
  ASSERT_GT(f.samples.size(), 100u);
  for (const FieldSample& s : f.samples) {
    EXPECT_TRUE(inBox(s.position, {-4, 0, -4}, {4, 3, 4})) << s.position;
    EXPECT_FALSE(inBox(s.position, {-0.6, 0, -0.6}, {0.6, 3, 0.6})) << s.position;
    EXPECT_LE(s.backfaceFraction, 0.25);
    EXPECT_EQ(s.f, luminanceDirection(s.sh));
    EXPECT_GT(s.cellSize, 0);
  }
}

TEST(DenseField, RefinesMoreAtTheDoorwayThanInTheOpenMiddleOfARoom) {
  // two-rooms: the doorway is x in [-0.05, 0.05], y in [0, 2.1], z in [-0.5, 0.5]; the middle of
  // room B (x in [0.05, 6.05]) at mid height is open space lit only indirectly.
  const Loaded& l = loaded("two-rooms.gltf");
  const DenseField f = buildDenseField(*l.tracer, {}, smallField(2));
  const double door = density(f, {-0.8, 0.2, -0.9}, {0.8, 2.0, 0.9});
  const double open = density(f, {1.2, 1.0, -2.0}, {3.0, 2.0, -0.5});
  EXPECT_GT(door, 2.0 * open) << "doorway " << door << " /m^3, open " << open << " /m^3";
  ASSERT_EQ(f.splitsPerLevel.size(), 3u);
  EXPECT_GT(f.splitsPerLevel[0], 0u);
  EXPECT_GT(f.splitsPerLevel[1], 0u);
  // Empty space costs little: fewer samples than a uniform grid at the finest spacing.
  const double finest = f.baseSpacingMeters / 4;
  const Vec3 e = f.domain.extent();
  EXPECT_LT(double(f.samples.size()), 0.5 * (e.x / finest) * (e.y / finest) * (e.z / finest));
}

TEST(DenseField, RefinesMoreBesideThePillarThanInOpenSpace) {
  // pillar-room: the pillar is [-0.6, 0.6] x [0, 3] x [-0.6, 0.6]; the box beside its +x face is
  // as large as the open box between the pillar and the room's corner.
  const Loaded& l = loaded("pillar-room.gltf");
  const DenseField f = buildDenseField(*l.tracer, {}, smallField(2));
  const double beside = density(f, {0.6, 0.9, -0.6}, {1.6, 2.1, 0.6});
  const double open = density(f, {-2.8, 0.9, 1.4}, {-1.8, 2.1, 2.6});
  EXPECT_GT(beside, 2.0 * open) << "beside " << beside << " /m^3, open " << open << " /m^3";
}

TEST(DenseField, NeighboursThatDifferAreRefined) {
  // two-rooms: the sun patch in room B and the point light in room A make neighbouring samples
  // differ well beyond their noise; with that criterion off only geometry refines.
  const Loaded& l = loaded("two-rooms.gltf");
  DenseFieldSettings s = smallField(2);
  const DenseField withLight = buildDenseField(*l.tracer, {}, s);
  s.refineRelativeDifference = 1e9;
  const DenseField geometryOnly = buildDenseField(*l.tracer, {}, s);
  EXPECT_GT(withLight.splitsPerLevel[0] + withLight.splitsPerLevel[1],
            geometryOnly.splitsPerLevel[0] + geometryOnly.splitsPerLevel[1]);
  EXPECT_GT(withLight.samples.size(), geometryOnly.samples.size());
}

TEST(DenseField, UniformSkyInAnEmptyBoxIsNotRefined) {
  // One small triangle far away from a 2 m box lit by a constant sky: every sample sees the same
  // radiance, no surface crosses a cell, so nothing splits.
  Scene scene;
  scene.positions = {50, 0, 0, 50.1f, 0, 0, 50, 0.1f, 0};
  scene.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  scene.indices = {0, 1, 2};
  scene.triangleMaterial = {0};
  scene.materials.push_back(Material{});
  for (uint32_t v = 0; v < 3; ++v) scene.bounds.extend(scene.vertex(v));
  const Tracer tracer(scene);
  LightingRig rig;
  rig.skyRadiance = {1, 1, 1};
  DenseFieldSettings s = smallField(2);
  s.importanceVolumes.push_back({"box", {-1, -1, -1}, {1, 1, 1}, 1.0});
  s.baseSpacingMeters = 0.5;
  const DenseField f = buildDenseField(tracer, rig, s);
  EXPECT_EQ(f.samples.size(), 64u);
  for (size_t splits : f.splitsPerLevel) EXPECT_EQ(splits, 0u);
  for (const FieldSample& fs : f.samples) EXPECT_EQ(fs.depth, 0);
}

TEST(DenseField, BoundarySamplesFillTheLayerAlongTheWalls) {
  // pillar-room's interior is [-4, 4] x [0, 3] x [-4, 4]. Cell centres stay half a cell from the
  // floor and the ceiling; boundary samples sit boundaryOffset of the finest cell from them,
  // on the axis line of a leaf centre, inside the room and outside the pillar.
  const Loaded& l = loaded("pillar-room.gltf");
  DenseFieldSettings s = smallField(1);
  const DenseField centres = buildDenseField(*l.tracer, {}, s);
  s.boundarySamples = true;
  const DenseField f = buildDenseField(*l.tracer, {}, s);
  ASSERT_GT(f.samples.size(), centres.samples.size());
  double finest = 1e9;
  for (const FieldSample& c : centres.samples) finest = std::min(finest, c.cellSize);
  const double off = s.boundaryOffset * finest;
  auto nearest = [](const DenseField& d, auto distance) {
    double best = 1e9;
    for (const FieldSample& x : d.samples) best = std::min(best, distance(x.position));
    return best;
  };
  auto toFloor = [](Vec3 p) { return p.y; };
  auto toCeiling = [](Vec3 p) { return 3 - p.y; };
  auto toWall = [](Vec3 p) { return 4 - p.x; };
  for (auto distance : {+toFloor, +toCeiling, +toWall}) {
    EXPECT_GT(nearest(centres, distance), 2 * off);
    EXPECT_NEAR(nearest(f, distance), off, 1e-6);
  }
  size_t boundary = 0;
  for (size_t i = 0; i < f.samples.size(); ++i) {
    const FieldSample& b = f.samples[i];
    if (i < centres.samples.size()) {  // the centres come first, unchanged
      EXPECT_EQ(b.position, centres.samples[i].position);
      EXPECT_FALSE(b.boundary);
      continue;
    }
    ++boundary;
    EXPECT_TRUE(b.boundary);
    EXPECT_FALSE(b.refined);
    EXPECT_GE(b.slab, 0.25 * b.cellSize);
    EXPECT_LT(b.slab, b.cellSize);
    EXPECT_TRUE(inBox(b.position, {-4, 0, -4}, {4, 3, 4})) << b.position;
    EXPECT_FALSE(inBox(b.position, {-0.6, 0, -0.6}, {0.6, 3, 0.6})) << b.position;
    EXPECT_LE(b.backfaceFraction, s.invalidBackfaceFraction);
    EXPECT_GT(greedySampleWeight(b), 0);
  }
  EXPECT_GT(boundary, 100u);
  // maxSamples holds for the boundary samples too: the first ones are kept.
  s.maxSamples = centres.samples.size() + 10;
  const DenseField capped = buildDenseField(*l.tracer, {}, s);
  EXPECT_LE(capped.samples.size(), s.maxSamples);
  EXPECT_GT(capped.samples.size(), centres.samples.size());
  EXPECT_TRUE(capped.refinementTruncated);
}

TEST(DenseField, GreedysSurfaceDepthStaysAtMostTwo) {
  GreedyMethodSettings r;
  EXPECT_EQ(greedyFieldSettings(r).maxDepth, kGreedyFieldDepth);
  EXPECT_EQ(greedyFieldSettings(r).maxSurfaceDepth, kGreedyFieldSurfaceDepth);
  EXPECT_TRUE(greedyFieldSettings(r).boundarySamples);
  r.fieldDepth = 4;  // the default, given explicitly: the same field
  EXPECT_EQ(greedyFieldSettings(r).maxSurfaceDepth, kGreedyFieldSurfaceDepth);
  r.fieldDepth = 1;
  EXPECT_EQ(greedyFieldSettings(r).maxSurfaceDepth, 1);
  r.field.maxSurfaceDepth = 3;  // asked for
  EXPECT_EQ(greedyFieldSettings(r).maxSurfaceDepth, 3);
}

TEST(DenseField, SurfaceDepthStopsGeometrySplitsButNotLightSplits) {
  // two-rooms with the light criterion off: below maxSurfaceDepth nothing splits. With it on,
  // the point light and the sun patch still split cells there.
  const Loaded& l = loaded("two-rooms.gltf");
  DenseFieldSettings s = smallField(3);
  s.maxSurfaceDepth = 1;
  s.refineRelativeDifference = 1e9;
  const DenseField geometryOnly = buildDenseField(*l.tracer, {}, s);
  ASSERT_GE(geometryOnly.splitsPerLevel.size(), 2u);
  EXPECT_GT(geometryOnly.splitsPerLevel[0], 0u);
  EXPECT_EQ(geometryOnly.splitsPerLevel[1], 0u);
  for (const FieldSample& x : geometryOnly.samples) EXPECT_LE(x.depth, 1);
  s.refineRelativeDifference = DenseFieldSettings{}.refineRelativeDifference;
  const DenseField withLight = buildDenseField(*l.tracer, {}, s);
  ASSERT_GE(withLight.splitsPerLevel.size(), 3u);
  EXPECT_GT(withLight.splitsPerLevel[1], 0u);
  s.maxSurfaceDepth = -2;
  EXPECT_THROW(buildDenseField(*l.tracer, {}, s), ParameterError);
  s.maxSurfaceDepth = 1;
  s.boundaryOffset = 0.3;
  EXPECT_THROW(buildDenseField(*l.tracer, {}, s), ParameterError);
}

TEST(DenseField, PrefilteredSamplesIntegrateOnlyTheRoomTheyAreIn) {
  // A closed room of black walls emitting le inward: from inside, every ray sees exactly le.
  // Pre-filtered samples (Kontkanen & Laine sec. 4-6) average over their cell's trilinear
  // support, which for the cells along the walls reaches outside the room; those origins see
  // back faces and are dropped, so every sample is exactly 2 sqrt(pi) le, as point sampling
  // gives. The cells and their validity are the point-sampled field's.
  Scene scene;
  const Rgb le{1, 0.5, 0.25};
  ps::testing::addBox(scene, {-1, -1, -1}, {1, 1, 1},
                      ps::testing::addMaterial(scene, {0, 0, 0}, le),
                      /*inward=*/true);
  const Tracer tracer(scene);
  const LightingRig rig;
  DenseFieldSettings s = smallField(0);
  s.baseSpacingMeters = 0.5;
  s.samplesPerProbe = 512;
  const DenseField point = buildDenseField(tracer, rig, s);
  s.prefilter = true;
  const DenseField pre = buildDenseField(tracer, rig, s);
  ASSERT_EQ(pre.samples.size(), point.samples.size());
  ASSERT_EQ(pre.samples.size(), 64u);
  for (size_t i = 0; i < pre.samples.size(); ++i) {
    EXPECT_EQ(pre.samples[i].position, point.samples[i].position);
    EXPECT_EQ(pre.samples[i].backfaceFraction, point.samples[i].backfaceFraction);
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_NEAR(pre.samples[i].sh.c[0][ch], 2 * std::sqrt(kPi) * le[ch], 1e-9) << i;
  }
}

TEST(DenseField, MaxSamplesGuardsBeforeCapture) {
  const Loaded& l = loaded("pillar-room.gltf");
  DenseFieldSettings s = smallField(2);
  s.maxSamples = 10;
  EXPECT_THROW(buildDenseField(*l.tracer, {}, s), ParameterError);
  s.maxSamples = 400;  // the base grid fits, refinement does not
  const DenseField f = buildDenseField(*l.tracer, {}, s);
  EXPECT_TRUE(f.refinementTruncated);
  EXPECT_LE(f.samples.size(), 400u);
  s.maxDepth = 9;
  EXPECT_THROW(buildDenseField(*l.tracer, {}, s), ParameterError);
  s.maxDepth = 1;
  s.baseSpacingMeters = -1;
  EXPECT_THROW(buildDenseField(*l.tracer, {}, s), ParameterError);
}

TEST(DenseField, CancelsThroughItsProgressCallback) {
  const Loaded& l = loaded("pillar-room.gltf");
  int calls = 0;
  EXPECT_THROW(buildDenseField(*l.tracer, {}, smallField(1),
                               [&](double) {
                                 ++calls;
                                 return false;
                               }),
               Cancelled);
  EXPECT_GE(calls, 1);
}

// ----------------------------------------------------------------------------------- greedy

namespace {

const DenseField& twoRoomsField() {
  static const DenseField f = [] {
    DenseFieldSettings s = smallField(1);
    s.boundarySamples = true;  // greedy's own field has them (core/placement/Place.cpp)
    return buildDenseField(*loaded("two-rooms.gltf").tracer, {}, s);
  }();
  return f;
}

/// twoRoomsField without capture noise (standard errors zero): the field error is then plain
/// relative RMS, which the tests' oracles recompute.
const DenseField& noiselessTwoRoomsField() {
  static const DenseField f = [] {
    DenseField g = twoRoomsField();
    for (FieldSample& sample : g.samples) sample.shStdError = ShRgb{};
    return g;
  }();
  return f;
}

/// The relative RMS error over the 14 normals of the probes' interpolation at `points` against
/// their SH, weighted by `weights`: the oracle for the incremental bookkeeping of placeGreedy.
double errorFromScratch(const ProbeVolume& v, std::span<const Vec3> points,
                        std::span<const ShRgb> sh, std::span<const double> weights) {
  double num = 0, den = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const auto ref = greedyErrorNormalsIrradiance(sh[i]);
    const auto got = greedyErrorNormalsIrradiance(interpolate(v, locate(v, points[i])));
    for (size_t k = 0; k < ref.size(); ++k) {
      num += weights[i] * (got[k] - ref[k]) * (got[k] - ref[k]);
      den += weights[i] * ref[k] * ref[k];
    }
  }
  return std::sqrt(num / den);
}

ProbeVolume volumeOfSamples(const DenseField& f, const std::vector<size_t>& probes) {
  std::vector<Vec3> pos;
  std::vector<ShRgb> sh;
  for (size_t i : probes) {
    pos.push_back(f.samples[i].position);
    sh.push_back(f.samples[i].sh);
  }
  return volumeFromProbes(pos, sh);
}

/// The field error of `probes` (field samples) recomputed from scratch.
double fieldErrorFromScratch(const DenseField& f, const std::vector<size_t>& probes) {
  std::vector<Vec3> points;
  std::vector<ShRgb> sh;
  std::vector<double> weights;
  for (const FieldSample& s : f.samples) {
    points.push_back(s.position);
    sh.push_back(s.sh);
    weights.push_back(greedySampleWeight(s));
  }
  return errorFromScratch(volumeOfSamples(f, probes), points, sh, weights);
}

}  // namespace

TEST(Greedy, ErrorDoesNotIncreaseAsProbesAreAdded) {
  // Without capture noise (standard errors zero) the field error is plain relative RMS, which the
  // oracle below recomputes.
  const DenseField& f = noiselessTwoRoomsField();
  GreedySettings s;
  s.budget = 48;
  const GreedyResult r = placeGreedy(f, {}, s);
  ASSERT_EQ(r.positions.size(), 48u);
  EXPECT_FALSE(r.noImprovement);
  ASSERT_EQ(r.errorHistory.size(), 48u - r.initialCount + 1);
  for (size_t i = 1; i < r.errorHistory.size(); ++i)
    EXPECT_LE(r.errorHistory[i], r.errorHistory[i - 1] * (1 + 1e-9)) << "after addition " << i;
  EXPECT_LT(r.errorHistory.back(), 0.5 * r.errorHistory.front());
  // The incremental bookkeeping (only samples in changed tets recomputed) equals a recompute.
  EXPECT_NEAR(r.fieldError, fieldErrorFromScratch(f, r.sampleIndex), 1e-4 * r.fieldError);
  EXPECT_GT(r.trials, 48 - r.initialCount);
  EXPECT_LT(r.reevaluations, f.samples.size() * r.trials / 2);  // only changed tets
  // Scores: the error each sample had when it was added.
  for (size_t i = r.initialCount; i < r.scores.size(); ++i) EXPECT_GT(r.scores[i], 0);
}

/// Held-out points of two-rooms as place draws them (uniform in the domain, outside geometry),
/// captured without noise (plain relative RMS), equal weights.
struct TwoRoomsHeldOut {
  std::vector<Vec3> points;
  std::vector<ShRgb> sh;
  std::vector<HeldOutSample> samples;
};
const TwoRoomsHeldOut& twoRoomsHeldOut() {
  static const TwoRoomsHeldOut h = [] {
    TwoRoomsHeldOut r;
    const Tracer& tracer = *loaded("two-rooms.gltf").tracer;
    r.points = DomainPoints(tracer, {}, std::span<const Bounds3>{}, 0).drawMany(1500, 5);
    CaptureSettings cs;
    cs.samplesPerProbe = kFieldSpp;
    const std::vector<ProbeCapture> caps = captureProbes(tracer, {}, r.points, cs);
    for (size_t i = 0; i < r.points.size(); ++i) {
      r.samples.push_back({r.points[i], caps[i].sh, ShRgb{}});
      r.sh.push_back(caps[i].sh);
    }
    return r;
  }();
  return h;
}

TEST(Greedy, HeldOutPointsMeasureTheErrorBetweenTheProbes) {
  const DenseField& f = noiselessTwoRoomsField();
  const TwoRoomsHeldOut& h = twoRoomsHeldOut();
  const std::vector<Vec3>& points = h.points;
  ASSERT_GT(points.size(), 1000u);
  GreedySettings s;
  s.budget = 40;
  s.heldOut = h.samples;
  const std::vector<ShRgb>& sh = h.sh;
  const GreedyResult r = placeGreedy(f, {}, s);
  ASSERT_EQ(r.positions.size(), 40u);
  // The probes are field samples, never held-out points.
  for (size_t k = 0; k < r.positions.size(); ++k)
    EXPECT_EQ(r.positions[k], f.samples[r.sampleIndex[k]].position);
  // The error is the held-out points' alone, with equal weights.
  const std::vector<double> ones(points.size(), 1.0);
  const double heldOut = errorFromScratch(volumeOfSamples(f, r.sampleIndex), points, sh, ones);
  EXPECT_NEAR(r.fieldError, heldOut, 1e-4 * heldOut);
  // The field's own samples, some of them probes, see less error than the points between.
  const double onField = fieldErrorFromScratch(f, r.sampleIndex);
  EXPECT_LT(onField, heldOut);
  std::printf("two-rooms, 40 probes: error %.4f on the field's samples, %.4f held out\n", onField,
              heldOut);
}

/// After swaps, which take probes out and put others in: the incremental sums still equal a
/// recompute at the held-out points, and no sample is a probe twice.
void expectSwappedSetExact(const DenseField& f, const TwoRoomsHeldOut& h, const GreedyResult& r) {
  const std::vector<double> ones(h.points.size(), 1.0);
  const double fromScratch =
      errorFromScratch(volumeOfSamples(f, r.sampleIndex), h.points, h.sh, ones);
  EXPECT_NEAR(r.fieldError, fromScratch, 1e-4 * fromScratch);
  std::vector<size_t> sorted = r.sampleIndex;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
}

TEST(Greedy, SwapsLowerTheErrorAndKeepItsSumsExact) {
  const DenseField& f = noiselessTwoRoomsField();
  const TwoRoomsHeldOut& h = twoRoomsHeldOut();
  GreedySettings s;
  s.budget = 16;
  s.heldOut = h.samples;
  const GreedyResult plain = placeGreedy(f, {}, s);
  s.swapPasses = 3;
  s.verifyState = true;
  std::vector<double> reported;
  const GreedyResult swapped = placeGreedy(f, {}, s, [&](double p) {
    reported.push_back(p);
    return true;
  });
  // Progress: once per addition (after the start's probes) and per probe taken out, never
  // going back, below 1 (the caller reports the end).
  EXPECT_EQ(reported.size(), 16 - swapped.initialCount + swapped.swapTries);
  for (size_t k = 0; k < reported.size(); ++k) {
    EXPECT_GE(reported[k], 0.0);
    EXPECT_LT(reported[k], 1.0);
    if (k > 0) {
      EXPECT_GE(reported[k], reported[k - 1]);
    }
  }
  std::printf("progress: %zu reports, the last %.3f; %zu probes taken out in %zu passes\n",
              reported.size(), reported.back(), swapped.swapTries, swapped.swapPasses);
  // After every addition and every swap, the kept state is that of a fresh interpolation.
  EXPECT_EQ(swapped.stateMismatches, 0u);
  EXPECT_EQ(plain.swapPasses, 0u);
  EXPECT_GE(swapped.swapPasses, 1u);
  EXPECT_LE(swapped.swapPasses, 3u);
  EXPECT_GT(swapped.swaps, 0u);
  // Every probe is taken out in the first pass; later passes only those a move touched.
  EXPECT_GE(swapped.swapTries, 16u);
  EXPECT_LE(swapped.swapTries, swapped.swapPasses * 16u);
  EXPECT_GT(swapped.swapTrials, 0u);
  EXPECT_LT(swapped.swapTrials, swapped.trials);
  // The additions are the same; the swaps then lower the error, never raise it.
  EXPECT_EQ(swapped.errorHistory, plain.errorHistory);
  EXPECT_LT(swapped.fieldError, plain.fieldError);
  ASSERT_EQ(swapped.swapErrorHistory.size(), swapped.swapPasses);
  double before = swapped.errorHistory.back();
  for (double e : swapped.swapErrorHistory) {
    EXPECT_LE(e, before * (1 + 1e-9));
    before = e;
  }
  ASSERT_EQ(swapped.positions.size(), 16u);
  expectSwappedSetExact(f, h, swapped);
  for (size_t k = 0; k < swapped.positions.size(); ++k)
    EXPECT_EQ(swapped.positions[k], f.samples[swapped.sampleIndex[k]].position);
  std::printf("two-rooms, 16 probes: error %.4f after the additions, %.4f after %zu swaps\n",
              plain.fieldError, swapped.fieldError, swapped.swaps);
}

TEST(Greedy, SwapsTryTheNearestSamples) {
  // A swap also tries the samples nearest to the probe it took out: moves of one sample, which
  // the far candidates (where the error is then largest) do not offer, lower the error further.
  const DenseField& f = noiselessTwoRoomsField();
  const TwoRoomsHeldOut& h = twoRoomsHeldOut();
  GreedySettings s;
  s.budget = 16;
  s.heldOut = h.samples;
  s.swapPasses = 3;
  s.verifyState = true;
  const GreedyResult far = placeGreedy(f, {}, s);
  s.swapNeighbours = 26;
  const GreedyResult near = placeGreedy(f, {}, s);
  EXPECT_EQ(far.localSwaps, 0u);
  EXPECT_GT(near.localSwaps, 0u);
  EXPECT_LE(near.localSwaps, near.swaps);
  EXPECT_EQ(near.stateMismatches, 0u);
  EXPECT_EQ(near.errorHistory, far.errorHistory);  // the same additions
  // Near moves cost nothing and usually gain: near / far measured 0.92 to 1.00 over field and
  // held-out seeds 1 to 6 (0.9995 for this test's), so the bound is 2 % above the largest.
  EXPECT_LT(near.fieldError, 1.02 * far.fieldError);
  expectSwappedSetExact(f, h, near);
  std::printf(
      "two-rooms, 16 probes: error %.4f with the far candidates, %.4f with the 26 "
      "nearest samples too (%zu of %zu moves to one of them)\n",
      far.fieldError, near.fieldError, near.localSwaps, near.swaps);
}

TEST(Greedy, SameProbesOnOneThreadAsOnMany) {
  // A step's candidates are tried at once, and the best is the one trying them in order would
  // keep, so the thread count changes nothing (additions, swaps and their local moves). With
  // one thread the trials finish in candidate order; with more, in any order.
  const DenseField& f = noiselessTwoRoomsField();
  GreedySettings s;
  s.budget = 16;
  s.heldOut = twoRoomsHeldOut().samples;
  s.swapPasses = 2;
  s.swapNeighbours = 26;
  s.verifyState = true;  // the state each trial starts from is a fresh interpolation's
  const GreedyResult many = placeGreedy(f, {}, s);
  GreedyResult one;
  tbb::task_arena(1).execute([&] { one = placeGreedy(f, {}, s); });
  EXPECT_EQ(one.sampleIndex, many.sampleIndex);
  EXPECT_EQ(one.errorHistory, many.errorHistory);
  EXPECT_EQ(one.swapErrorHistory, many.swapErrorHistory);
  EXPECT_EQ(one.fieldError, many.fieldError);
  EXPECT_EQ(one.trials, many.trials);
  EXPECT_EQ(one.stateMismatches, 0u);
  EXPECT_EQ(many.stateMismatches, 0u);
  EXPECT_GT(many.localSwaps, 0u);
}

TEST(Greedy, SwapsOnTheFieldsOwnSamplesAndWithoutABudget) {
  // No held-out points: the field's samples carry the weights (some of them 0, split cells).
  const DenseField& f = noiselessTwoRoomsField();
  auto place = [&](GreedySettings s) {
    s.verifyState = true;
    const GreedyResult r = placeGreedy(f, {}, s);
    EXPECT_EQ(r.stateMismatches, 0u);
    EXPECT_GT(r.swaps, 0u);
    EXPECT_LT(r.fieldError, r.errorHistory.back());
    EXPECT_NEAR(r.fieldError, fieldErrorFromScratch(f, r.sampleIndex), 1e-4 * r.fieldError);
    return r;
  };
  GreedySettings s;
  s.budget = 16;
  s.swapPasses = 3;
  place(s);
  // An error target and no budget: the swaps run once the target is met.
  GreedySettings t;
  t.maxError = 0.5;
  t.swapPasses = 2;
  EXPECT_LE(place(t).errorHistory.back(), 0.5);
}

TEST(Greedy, HeldOutPointsGoWhereItIsBrightAndWeighTheirVolume) {
  const Loaded& l = loaded("two-rooms.gltf");
  const DenseField& f = twoRoomsField();
  GreedyMethodSettings r;
  const int budget = 64;  // 128 points per probe: 8192
  r.field.samplesPerProbe = kFieldSpp;
  r.objective = GreedyObjective::kEnergy;  // half the points where it is bright
  EXPECT_EQ(greedyHeldOutUniformShare(r), 0.5);
  const std::vector<HeldOutSample> bright = drawGreedyHeldOut(*l.tracer, {}, r, budget, 1, {}, f);
  r.objective = GreedyObjective::kPerceptual;  // all of them by volume
  EXPECT_EQ(greedyHeldOutUniformShare(r), 1.0);
  r.heldOutUniformShare = 1;
  const std::vector<HeldOutSample> even = drawGreedyHeldOut(*l.tracer, {}, r, budget, 1, {}, f);
  // The volume outside geometry, from a plain uniform draw.
  const DomainPoints domain(*l.tracer, {}, std::span<const Bounds3>{},
                            kDefaultLightClearanceRelative);
  const Bounds3 box = domainBounds(*l.tracer, {});
  uint64_t rng = 99;
  int valid = 0;
  const int draws = 20000;
  for (int i = 0; i < draws; ++i) {
    const Vec3 e = box.extent();
    const Vec3 p = box.lo + Vec3(e.x * uniform01(rng), e.y * uniform01(rng), e.z * uniform01(rng));
    valid += domain.valid(p, splitMix64(rng)) ? 1 : 0;
  }
  const double validVolume = box.extent().x * box.extent().y * box.extent().z * valid / draws;
  // 8192 points drawn, those inside walls or the light clearance dropped.
  const double validFraction = double(valid) / draws;
  EXPECT_NEAR(double(even.size()), 8192 * validFraction, 0.03 * 8192 * validFraction);
  // Near the point light: more points, the same volume.
  const Vec3 light = punctualLightPositions(l.tracer->scene(), {}).at(0);
  struct Sums {
    double weight = 0, weightNear = 0;
    double weightSqNear = 0;  ///< sum of squared weights: the near volume's variance
    size_t near = 0;
  };
  auto sums = [&](const std::vector<HeldOutSample>& points) {
    Sums s;
    for (const HeldOutSample& h : points) {
      s.weight += h.weight;
      if (length(h.position - light) < 1.0) {
        s.weightNear += h.weight;
        s.weightSqNear += h.weight * h.weight;
        ++s.near;
      }
    }
    return s;
  };
  const Sums b = sums(bright), u = sums(even);
  EXPECT_NEAR(b.weight, validVolume, 0.03 * validVolume);
  EXPECT_NEAR(u.weight, validVolume, 0.03 * validVolume);
  EXPECT_GT(double(b.near), 3.0 * double(u.near));
  // Both draws estimate the same volume near the light, each a sum of random points' weights
  // whose variance is about the sum of their squared weights: they agree within 4 standard
  // errors of their difference (a false failure about once in 16,000 runs).
  const double differenceStdError = std::sqrt(b.weightSqNear + u.weightSqNear);
  EXPECT_NEAR(b.weightNear, u.weightNear, 4 * differenceStdError)
      << "standard error of the difference " << differenceStdError;
  std::printf(
      "held-out points within 1 m of the light: %zu of %zu (by volume: %zu of %zu); their "
      "volume %.4f and %.4f m^3, standard error of the difference %.4f\n",
      b.near, bright.size(), u.near, even.size(), b.weightNear, u.weightNear, differenceStdError);
}

TEST(Greedy, HeldOutPointsInAThinImportanceVolume) {
  // A 1 mm slab of room A: its cells are one deep, and the count stays what was asked for
  // (cubic cells of the slab's volume would be 25,600, each with a point at least).
  const Loaded& l = loaded("two-rooms.gltf");
  GreedyMethodSettings r;
  const int budget = 64;  // 8192 points
  r.field.samplesPerProbe = kFieldSpp;
  const std::vector<ImportanceVolume> slab = {{"slab", Vec3(-5, 1, -2), Vec3(-1, 1.001, 2), 1}};
  const std::vector<HeldOutSample> points = drawGreedyHeldOut(
      *l.tracer, {}, r, budget, 1, Domain{importanceBoxes(slab), nullptr}, twoRoomsField());
  EXPECT_NEAR(double(points.size()), 8192, 0.05 * 8192);
  double weight = 0;
  for (const HeldOutSample& h : points) {
    EXPECT_TRUE(inBox(h.position, Vec3(-5, 1, -2), Vec3(-1, 1.001, 2))) << h.position;
    weight += h.weight;
  }
  EXPECT_NEAR(weight, 4 * 4 * 0.001, 1e-3 * 0.016);  // all of it is outside geometry
  r.heldOutUniformShare = 2;
  EXPECT_THROW(drawGreedyHeldOut(*l.tracer, {}, r, budget, 1,
                                 Domain{importanceBoxes(slab), nullptr}, twoRoomsField()),
               ParameterError);
}

TEST(Greedy, ProbeValuesFromTheirOwnCapture) {
  // A capture that returns each sample's own field SH changes nothing; each sample is captured
  // once at most.
  const DenseField& f = twoRoomsField();
  GreedySettings s;
  s.budget = 30;
  const GreedyResult plain = placeGreedy(f, {}, s);
  std::vector<Vec3> captured;
  auto fieldValues = [&](std::span<const Vec3> at) {
    std::vector<GreedyProbeValue> values;
    for (const Vec3& p : at) {
      captured.push_back(p);
      for (const FieldSample& fs : f.samples)
        if (fs.position == p) {
          values.push_back({fs.sh, {}, false});
          break;
        }
    }
    return values;
  };
  s.captureProbeValues = fieldValues;
  const GreedyResult own = placeGreedy(f, {}, s);
  EXPECT_EQ(own.positions, plain.positions);
  EXPECT_DOUBLE_EQ(own.fieldError, plain.fieldError);
  EXPECT_GE(captured.size(), own.positions.size());
  std::vector<Vec3> sorted = captured;
  std::sort(sorted.begin(), sorted.end(),
            [](Vec3 a, Vec3 b) { return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z); });
  EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
  // Values that differ from the field's move the probes.
  s.captureProbeValues = [&](std::span<const Vec3> at) {
    return std::vector<GreedyProbeValue>(at.size());
  };
  EXPECT_NE(placeGreedy(f, {}, s).positions, plain.positions);
  // The swaps' candidates, the nearby samples too, are captured before they are tried.
  GreedySettings w;
  w.budget = 30;
  w.swapPasses = 2;
  w.swapNeighbours = 26;
  const GreedyResult plainSwaps = placeGreedy(f, {}, w);
  EXPECT_GT(plainSwaps.localSwaps, 0u);
  w.captureProbeValues = fieldValues;
  const GreedyResult ownSwaps = placeGreedy(f, {}, w);
  EXPECT_EQ(ownSwaps.positions, plainSwaps.positions);
  EXPECT_DOUBLE_EQ(ownSwaps.fieldError, plainSwaps.fieldError);
}

TEST(Greedy, StopsAtTheMaxErrorAndIsDeterministic) {
  const DenseField& f = twoRoomsField();
  GreedySettings s;
  s.maxError = 0.2;
  const GreedyResult a = placeGreedy(f, {}, s);
  const GreedyResult b = placeGreedy(f, {}, s);
  EXPECT_LE(a.fieldError, 0.2);
  ASSERT_GE(a.errorHistory.size(), 2u);
  EXPECT_GT(a.errorHistory[a.errorHistory.size() - 2], 0.2);
  EXPECT_EQ(a.positions, b.positions);
}

TEST(Greedy, MeetsItsBudgetPastTheFieldsNoiseFloor) {
  // cornell at 32 spp: its area light makes the cheap capture noisy, and greedy reaches the
  // noise floor well before 120 probes; the budget is still met, and the error did not rise
  // before that point.
  const DenseField f = buildDenseField(*loaded("cornell.gltf").tracer, {}, smallField(1));
  GreedySettings s;
  s.budget = 120;
  const GreedyResult r = placeGreedy(f, {}, s);
  EXPECT_EQ(r.positions.size(), 120u);
  const size_t monotone =
      r.noImprovement ? r.probesAtNoImprovement - r.initialCount + 1 : r.errorHistory.size();
  for (size_t i = 1; i < monotone; ++i) EXPECT_LE(r.errorHistory[i], r.errorHistory[i - 1]);
  size_t raised = 0;
  for (size_t i = 1; i < r.errorHistory.size(); ++i)
    raised += r.errorHistory[i] > r.errorHistory[i - 1] ? 1 : 0;
  std::printf(
      "cornell: first dead end at %zu probes; %zu of %zu additions raised the field error\n",
      r.probesAtNoImprovement, raised, r.errorHistory.size() - 1);
}

TEST(Greedy, EveryRoomAndBothSidesOfThePillarGetProbes) {
  // two-rooms: room A is x < -0.05, room B x > 0.05; pillar-room: the pillar spans
  // x, z in [-0.6, 0.6] (scripts/make_scenes.py). Every region gets several probes.
  GreedySettings s;
  s.budget = 24;
  const GreedyResult rooms = placeGreedy(twoRoomsField(), {}, s);
  int a = 0, b = 0;
  for (const Vec3& p : rooms.positions) (p.x < 0 ? a : b) += 1;
  // Measured over field seeds 1 to 6: room B (the dim one) 5 or 6 of 24, each pillar side 4 to
  // 19; the bounds are about half the fewest seen.
  EXPECT_GE(a, 3);
  EXPECT_GE(b, 3);
  const DenseField pillar = buildDenseField(*loaded("pillar-room.gltf").tracer, {}, smallField(1));
  const GreedyResult r = placeGreedy(pillar, {}, s);
  int sides[4] = {0, 0, 0, 0};  // -x, +x, -z, +z of the pillar
  for (const Vec3& p : r.positions) {
    sides[0] += p.x < -0.6;
    sides[1] += p.x > 0.6;
    sides[2] += p.z < -0.6;
    sides[3] += p.z > 0.6;
  }
  for (int side : sides) EXPECT_GE(side, 2);
}

TEST(Greedy, PerceptualObjectiveIsRmsStopsAndFillsBothRoomsByVolume) {
  // two-rooms: room A (x < -0.05, a point light) and room B (x > 0.05, a sun patch and the
  // light through the door, on average about a tenth of A's) have the same volume. Held-out
  // points uniform over the domain, equal weights, no capture noise.
  const DenseField& f = noiselessTwoRoomsField();
  const TwoRoomsHeldOut& h = twoRoomsHeldOut();
  GreedySettings s;
  s.budget = 32;
  s.heldOut = h.samples;
  s.objective = GreedyObjective::kPerceptual;
  const GreedyResult perceptual = placeGreedy(f, {}, s);
  ASSERT_EQ(perceptual.positions.size(), 32u);
  // The field error is the RMS in stops over the held-out points (core/math/Stops.h), with the
  // floor at kAdaptationFloorFraction of their median mean luminance over the 14 normals.
  std::vector<double> level;
  for (const ShRgb& sh : h.sh) {
    double m = 0;
    for (double x : greedyErrorNormalsIrradiance(sh)) m += x;
    level.push_back(m / 14);
  }
  std::vector<double> sorted = level;
  std::sort(sorted.begin(), sorted.end());
  const double floor = kAdaptationFloorFraction * sorted[(sorted.size() + 1) / 2 - 1];
  const ProbeVolume v = volumeOfSamples(f, perceptual.sampleIndex);
  double sq = 0;
  for (size_t i = 0; i < h.points.size(); ++i) {
    const auto ref = greedyErrorNormalsIrradiance(h.sh[i]);
    const auto got = greedyErrorNormalsIrradiance(interpolate(v, locate(v, h.points[i])));
    for (size_t k = 0; k < ref.size(); ++k) {
      const double e = errorStops(got[k], ref[k], floor);
      sq += e * e / double(ref.size());
    }
  }
  const double rmsStops = std::sqrt(sq / double(h.points.size()));
  EXPECT_NEAR(perceptual.fieldError, rmsStops, 1e-4 * rmsStops);
  // Rooms of equal volume get probes within a factor of 2.5 of each other (room B / room A
  // measured 1.5 to 1.9 over field and held-out seeds 1 to 6); the energy objective, led by room
  // A's light, gives room B fewer (7 to 10 of 32, against 19 to 21).
  auto roomCounts = [](const GreedyResult& r) {
    std::pair<int, int> ab{0, 0};
    for (const Vec3& p : r.positions) (p.x < 0 ? ab.first : ab.second) += 1;
    return ab;
  };
  const auto [pa, pb] = roomCounts(perceptual);
  s.objective = GreedyObjective::kEnergy;
  const auto [ea, eb] = roomCounts(placeGreedy(f, {}, s));
  std::printf("two-rooms, 32 probes: room A / room B %d / %d (perceptual), %d / %d (energy)\n", pa,
              pb, ea, eb);
  EXPECT_LE(2 * pa, 5 * pb);
  EXPECT_LE(2 * pb, 5 * pa);
  EXPECT_GT(pb, eb);
}

TEST(Greedy, VisibleInterpolantIsTheRuntimesAndKeepsItsStateExact) {
  // With visibility, greedy's error at its held-out points is the volume's visibility-aware
  // interpolant (core/traversal/VisibleInterpolation.h, as eval and the runtime read a baked
  // volume) of the probes' own values and maps; its incremental state stays that of a fresh
  // interpolation after every change.
  const DenseField& f = noiselessTwoRoomsField();
  const TwoRoomsHeldOut& h = twoRoomsHeldOut();
  const Tracer& tracer = *loaded("two-rooms.gltf").tracer;
  // Each probe's value: its field SH (noiseless) and the map of a real capture at its place.
  std::map<std::tuple<double, double, double>, GreedyProbeValue> captured;
  auto capture = [&](std::span<const Vec3> at) {
    CaptureSettings cs;
    cs.samplesPerProbe = 256;
    cs.visibilityMaps = true;
    const std::vector<ProbeCapture> caps = captureProbes(tracer, {}, at, cs);
    std::vector<GreedyProbeValue> values;
    for (size_t k = 0; k < at.size(); ++k) {
      GreedyProbeValue v{{}, caps[k].distanceMoments, caps[k].backfaceFraction > 0.25};
      for (const FieldSample& fs : f.samples)
        if (fs.position == at[k]) v.sh = fs.sh;
      captured[{at[k].x, at[k].y, at[k].z}] = v;
      values.push_back(std::move(v));
    }
    return values;
  };
  GreedySettings s;
  s.budget = 24;
  s.heldOut = h.samples;
  s.objective = GreedyObjective::kPerceptual;
  s.captureProbeValues = capture;
  s.visibility = true;
  s.swapPasses = 1;
  s.verifyState = true;
  const GreedyResult r = placeGreedy(f, {}, s);
  ASSERT_EQ(r.positions.size(), 24u);
  EXPECT_EQ(r.stateMismatches, 0u);
  std::vector<ShRgb> sh;
  std::vector<ProbeVisibility> vis(r.positions.size());
  for (size_t i = 0; i < r.positions.size(); ++i) {
    const Vec3 p = r.positions[i];
    const GreedyProbeValue& v = captured.at({p.x, p.y, p.z});
    sh.push_back(v.sh);
    ASSERT_EQ(v.distanceMoments.size(), size_t(kVisibilityFloats));
    std::copy(v.distanceMoments.begin(), v.distanceMoments.end(), vis[i].distanceMoments.begin());
    vis[i].inside = v.inside;
  }
  const ProbeVolume volume = volumeFromProbes(r.positions, sh, vis);
  ASSERT_TRUE(volume.hasVisibility());
  std::vector<double> level;
  for (const ShRgb& x : h.sh) {
    double m = 0;
    for (double e : greedyErrorNormalsIrradiance(x)) m += e;
    level.push_back(m / 14);
  }
  std::sort(level.begin(), level.end());
  const double floor = kAdaptationFloorFraction * level[(level.size() + 1) / 2 - 1];
  double sq = 0, barycentricSq = 0;
  size_t neighbourPoints = 0;
  for (size_t i = 0; i < h.points.size(); ++i) {
    const auto ref = greedyErrorNormalsIrradiance(h.sh[i]);
    // Greedy's state has no neighbour search: where no probe of a point's tetrahedron sees it,
    // greedy reads it with the barycentric fallback (through the wall, as the runtime would
    // without the search), so it counts there the error a probe of the point's own would remove.
    const VisibleWeights w = visibleWeights(volume, h.points[i], {});
    const bool searched = w.fallback == VisibleFallback::Neighbours;
    neighbourPoints += searched ? 1 : 0;
    const auto got = greedyErrorNormalsIrradiance(
        searched ? interpolate(volume, locate(volume, h.points[i])) : interpolate(volume, w));
    const auto bary =
        greedyErrorNormalsIrradiance(interpolate(volume, locate(volume, h.points[i])));
    for (size_t k = 0; k < ref.size(); ++k) {
      const double e = errorStops(got[k], ref[k], floor), b = errorStops(bary[k], ref[k], floor);
      sq += e * e / double(ref.size());
      barycentricSq += b * b / double(ref.size());
    }
  }
  const double rmsStops = std::sqrt(sq / double(h.points.size()));
  EXPECT_NEAR(r.fieldError, rmsStops, 1e-4 * rmsStops);
  EXPECT_LT(neighbourPoints, h.points.size() / 4);  // the comparison is mostly the runtime's
  // The same probes read without their maps: visibility must be doing something here.
  EXPECT_GT(std::abs(std::sqrt(barycentricSq / double(h.points.size())) - rmsStops), 1e-3);
  // Without captures there are no maps: refused, naming the parameter.
  GreedySettings bad = s;
  bad.captureProbeValues = nullptr;
  try {
    placeGreedy(f, {}, bad);
    ADD_FAILURE() << "expected a ParameterError";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "interpolant");
  }
}

TEST(Greedy, KeepsLockedProbesAndBuildsAroundThem) {
  const DenseField& f = noiselessTwoRoomsField();
  // Two kept probes at field samples, with their SH, so that the error can be recomputed.
  const size_t far = f.samples.size() / 2;
  std::vector<KeptProbe> kept = {{f.samples[7].position, f.samples[7].sh, {}, false},
                                 {f.samples[far].position, f.samples[far].sh, {}, false}};
  GreedySettings s;
  s.budget = 20;
  s.verifyState = true;
  for (int passes : {0, 2}) {
    s.swapPasses = passes;  // swaps move the new probes only
    const GreedyResult r = placeGreedy(f, kept, s);
    EXPECT_EQ(r.stateMismatches, 0u);
    EXPECT_EQ(r.positions.size(), 18u);
    for (const Vec3& p : r.positions)
      for (const KeptProbe& k : kept) EXPECT_NE(p, k.position);
    if (passes > 0) {
      EXPECT_GT(r.swaps, 0u);
    }
    std::vector<size_t> all = {7, far};
    all.insert(all.end(), r.sampleIndex.begin(), r.sampleIndex.end());
    EXPECT_NEAR(r.fieldError, fieldErrorFromScratch(f, all), 1e-4 * r.fieldError)
        << passes << " swap passes";
  }
}

TEST(Greedy, RejectsBadParameters) {
  const DenseField& f = twoRoomsField();
  GreedySettings s;
  EXPECT_THROW(placeGreedy(f, {}, s), ParameterError);  // neither budget nor error
  s.budget = 3;
  EXPECT_THROW(placeGreedy(f, {}, s), ParameterError);
  s.budget = 5;
  const std::vector<KeptProbe> kept(2, KeptProbe{});
  EXPECT_THROW(placeGreedy(f, kept, s), ParameterError);  // room for fewer than 4 new probes
  DenseField tiny;
  tiny.samples.resize(3);
  EXPECT_THROW(placeGreedy(tiny, {}, s), ParameterError);
  // A budget past the field's samples is refused before any trial, naming the budget.
  DenseField small = f;
  small.samples.resize(12);
  s.budget = 13;
  try {
    placeGreedy(small, {}, s);
    ADD_FAILURE() << "a budget of 13 on 12 field samples accepted";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "budget") << e.what();
  }
  s.budget = 8;
  s.swapPasses = -1;
  EXPECT_THROW(placeGreedy(f, {}, s), ParameterError);
  s.swapPasses = 1;
  s.swapMinGain = 1;
  EXPECT_THROW(placeGreedy(f, {}, s), ParameterError);
  s.swapMinGain = 0.01;
  s.swapNeighbours = -1;
  EXPECT_THROW(placeGreedy(f, {}, s), ParameterError);
}

TEST(Uniform, BudgetGivesTheProbeCountWithinTenPercent) {
  // Cubic grids of cornell's box jump from 27 to 64 points: 32 needs a grid that is not cubic.
  // The counts the placement benchmark uses, on the bundled scenes: within 10 % of the budget.
  for (const char* scene : {"cornell.gltf", "pillar-room.gltf", "two-rooms.gltf"})
    for (int budget : {64, 128, 256}) {
      const UniformBudgetResult u = placeUniformBudget(*loaded(scene).tracer, budget, {});
      EXPECT_LE(std::abs(double(u.points.size()) - budget), 0.1 * budget)
          << scene << " " << budget << ": " << u.points.size();
    }
  const UniformBudgetResult c = placeUniformBudget(*loaded("cornell.gltf").tracer, 32, {});
  EXPECT_LE(std::abs(double(c.points.size()) - 32), 3.2) << c.points.size();
  const Vec3 a = c.axisSpacingMeters;
  ASSERT_GT(a.x * a.y * a.z, 0);  // per-axis spacings, within a factor 1.5 of each other
  EXPECT_LE(std::max({a.x, a.y, a.z}), 1.5 * std::min({a.x, a.y, a.z}));
  EXPECT_NEAR(c.spacingMeters, std::cbrt(a.x * a.y * a.z), 1e-12);
  // Along each axis the points lie on the grid of that axis' spacing.
  for (const Vec3& p : c.points)
    for (int k = 0; k < 3; ++k) {
      const double steps = (p[k] - c.points[0][k]) / a[k];
      EXPECT_NEAR(steps, std::round(steps), 1e-9);
    }
}

TEST(Uniform, BudgetGridsSpanThreeDimensionsInAFlatRoom) {
  // A 10 x 1.2 x 10 m room: the cubic spacing for 32 points (about 1.5 m) fits one layer in its
  // height, a flat grid no volume can be made of (as dream-apartment's cubic grids at 32 and 64
  // are). The budget's grids keep at least two points along each axis.
  Scene scene;
  ps::testing::addBox(scene, {-5, 0, -5}, {5, 1.2, 5},
                      ps::testing::addMaterial(scene, {0.5, 0.5, 0.5}), /*inward=*/true);
  const Tracer tracer(scene);
  for (int budget : {8, 32, 64}) {
    const UniformBudgetResult u = placeUniformBudget(tracer, budget, {});
    EXPECT_LE(std::abs(double(u.points.size()) - budget), 0.1 * budget)
        << budget << ": " << u.points.size();
    std::vector<double> heights;
    for (const Vec3& p : u.points) heights.push_back(p.y);
    std::sort(heights.begin(), heights.end());
    heights.erase(std::unique(heights.begin(), heights.end()), heights.end());
    EXPECT_EQ(heights.size(), 2u) << budget;
    // The horizontal axes keep one spacing, within a factor 1.5 of each other.
    const Vec3 a = u.axisSpacingMeters;
    ASSERT_GT(a.x * a.y * a.z, 0) << budget;
    EXPECT_NEAR(a.y, 1.2 / 2.5, 1e-12);
    EXPECT_LE(std::max(a.x, a.z), 1.5 * std::min(a.x, a.z)) << budget;
    // The volume can be made: the points are not coplanar.
    EXPECT_NO_THROW(tetrahedralize(u.points)) << budget;
  }
  // A solid slab fills the room's lower half: a layer of two falls inside it, and the search
  // goes on to more layers until the valid points span 3D.
  ps::testing::addBox(scene, {-4.9, 0, -4.9}, {4.9, 0.6, 4.9},
                      ps::testing::addMaterial(scene, {0.5, 0.5, 0.5}), /*inward=*/false);
  const Tracer slabTracer(scene);
  for (int budget : {8, 16, 32, 64}) {
    const UniformBudgetResult u = placeUniformBudget(slabTracer, budget, {});
    for (const Vec3& p : u.points) EXPECT_GT(p.y, 0.6) << budget;
    EXPECT_NO_THROW(tetrahedralize(u.points)) << budget;
  }
}

TEST(Greedy, BeatsUniformOnTwoRoomsAtEqualProbeCount) {
  // Both sets captured at the same spp and measured by core/eval against a path-traced
  // reference at the same random queries.
  const Loaded& l = loaded("two-rooms.gltf");
  const int budget = 32;
  const UniformBudgetResult u = placeUniformBudget(*l.tracer, budget, {});
  GreedySettings gs;
  gs.budget = int(u.points.size());  // equal probe count
  const GreedyResult g = placeGreedy(twoRoomsField(), {}, gs);
  ASSERT_EQ(g.positions.size(), u.points.size());
  CaptureSettings cs;
  cs.samplesPerProbe = 256;
  EvalSettings es;
  // Many queries: rel_rmse is dominated by the few that land near the point light.
  es.queries = 2048;
  es.referenceSpp = 64;
  auto eval = [&](const std::vector<Vec3>& pts) {
    const auto caps = captureProbes(*l.tracer, {}, pts, cs);
    std::vector<ShRgb> sh;
    for (const auto& c : caps) sh.push_back(c.sh);
    return evaluateVolume(*l.tracer, {}, volumeFromProbes(pts, sh), es);
  };
  const EvalResult eu = eval(u.points);
  const EvalResult eg = eval(g.positions);
  EXPECT_LT(eg.relRmse, eu.relRmse) << "greedy " << eg.relRmse << ", uniform " << eu.relRmse
                                    << " at " << u.points.size() << " probes";
  std::printf("two-rooms, %zu probes: rel_rmse greedy %.4f, uniform %.4f\n", u.points.size(),
              eg.relRmse, eu.relRmse);
}

TEST(Greedy, DefaultFieldBeatsUniformAndKeepsOffTheLight) {
  // The place pipeline's greedy (the field refined to depth 4 by the light, to depth 2 by the
  // geometry, with boundary samples; no probe within the light clearance) against the uniform grid
  // at 64 probes, both captured at the same spp and measured against the same path-traced reference
  // (which keeps the same clearance), each objective on its own figure. The bounds leave room for
  // the test's smaller capture.
  const Loaded& l = loaded("two-rooms.gltf");
  PlaceRequest r;
  r.budget = 64;
  r.method = "uniform";
  const ProbeSet u = placeProbeSet(*l.tracer, {}, r).set;
  r.method = "greedy";
  const ProbeSet p = placeProbeSet(*l.tracer, {}, r).set;  // the perceptual objective
  r.parameters.setText("objective", "energy");
  const ProbeSet g = placeProbeSet(*l.tracer, {}, r).set;
  ASSERT_EQ(g.probes.size(), 64u);
  ASSERT_EQ(p.probes.size(), 64u);
  CaptureSettings cs;
  cs.samplesPerProbe = 256;
  cs.visibilityMaps = true;
  EvalSettings es;
  es.queries = 4096;
  es.referenceSpp = 64;
  // Each set read as a baked volume is: with its probes' visibility maps.
  auto eval = [&](const ProbeSet& o) {
    std::vector<Vec3> pts;
    for (const Probe& probe : o.probes) pts.push_back(probe.position);
    const auto caps = captureProbes(*l.tracer, {}, pts, cs);
    std::vector<ShRgb> sh;
    std::vector<ProbeVisibility> vis(caps.size());
    for (size_t i = 0; i < caps.size(); ++i) {
      sh.push_back(caps[i].sh);
      std::copy(caps[i].distanceMoments.begin(), caps[i].distanceMoments.end(),
                vis[i].distanceMoments.begin());
      vis[i].inside = caps[i].backfaceFraction > 0.25;
    }
    return evaluateVolume(*l.tracer, {}, volumeFromProbes(pts, sh, vis), es);
  };
  const EvalResult vu = eval(u), vg = eval(g), vp = eval(p);
  const double eu = vu.relRmse, eg = vg.relRmse;
  EXPECT_LT(eg, 0.85 * eu) << "greedy " << eg << ", uniform " << eu << " (" << u.probes.size()
                           << " probes)";
  // In stops, against one floor (the queries and references are the same for all three).
  const double floor = adaptationFloor(vu.perQuery);
  auto rmsStops = [&](const EvalResult& v) {
    return summarizeStops(queryStops(v.perQuery, floor)).rms;
  };
  const double su = rmsStops(vu), sg = rmsStops(vg), sp = rmsStops(vp);
  // The 64-spp reference's own noise is in every query's stops and pulls sp / su towards 1:
  // measured 0.92 to 0.96 over placement and eval seeds 1 to 5, and 1.05 for seed 1 in a build
  // with FMA contraction, so this figure does not tell the two apart at this reference. The
  // bound only catches a perceptual greedy clearly behind the grid (10 % beyond the largest
  // ratio seen). Energy greedy's rel_rmse (eg / eu 0.34 to 0.64 over the seeds) and the
  // objectives' stops (sp / sg 0.74 to 0.83) do tell apart.
  EXPECT_LT(sp, 1.15 * su) << "greedy (perceptual) " << sp << " stops, uniform " << su;
  EXPECT_LT(sp, sg) << "greedy (perceptual) " << sp << " stops, greedy (energy) " << sg;
  const double clearance = kDefaultLightClearanceRelative * l.tracer->scene().bounds.diagonal();
  for (const ProbeSet* set : {&g, &p})
    for (const Probe& probe : set->probes)
      for (const Vec3& light : punctualLightPositions(l.tracer->scene(), {}))
        EXPECT_GE(length(probe.position - light), clearance) << probe.position;
  std::printf(
      "two-rooms, 64 probes: rel_rmse greedy (energy) %.4f, greedy (perceptual) %.4f, uniform "
      "%.4f (%zu probes); RMS stops %.3f, %.3f, %.3f\n",
      eg, vp.relRmse, eu, u.probes.size(), sg, sp, su);
}

// --------------------------------------------------------------------- methods and pipeline

TEST(PlacementMethods, TableIsSortedWithUniqueNamesAndEachMethodTakesItsOwnParameters) {
  const auto table = placementMethodTable();
  ASSERT_EQ(table.size(), 5u);
  for (size_t i = 1; i < table.size(); ++i) EXPECT_LT(table[i - 1].name, table[i].name);
  for (const PlacementMethod& m : table) {
    EXPECT_FALSE(m.summary.empty()) << m.name;
    // Its defaults are valid: no parameters and a budget of 64.
    EXPECT_NO_THROW(createPlacer(m, {}, {64, 0})) << m.name;
    // Each parameter it lists is read: a value that is not a number of it is refused by name.
    for (std::string_view name : m.parameters) {
      PlaceParameters p;
      p.set(std::string(name), std::nan(""));
      try {
        createPlacer(m, p, {64, 0});
        ADD_FAILURE() << m.name << " accepted NaN for " << name;
      } catch (const ParameterError& e) {
        EXPECT_EQ(e.parameter(), name) << e.what();
      }
    }
  }
}

TEST(PlacementMethods, RefusalsNameTheParameterInTheCoresTerms) {
  auto parameterOf = [](const std::string& method, const PlaceParameters& p, int budget,
                        size_t kept = 0) -> std::string {
    try {
      createPlacer(findPlacementMethod(method), p, {budget, kept});
    } catch (const ParameterError& e) {
      EXPECT_EQ(std::string(e.what()), e.parameter() + ": " + e.problem());
      return e.parameter();
    }
    return "(accepted)";
  };
  PlaceParameters spacing;
  spacing.set("spacingMeters", 1);
  EXPECT_EQ(parameterOf("greedy", spacing, 64), "spacingMeters");   // not greedy's
  EXPECT_EQ(parameterOf("uniform", spacing, 64), "spacingMeters");  // with a budget
  EXPECT_EQ(parameterOf("uniform", spacing, 0), "(accepted)");
  PlaceParameters swaps;
  swaps.set("swapPasses", -1);
  EXPECT_EQ(parameterOf("greedy", swaps, 64), "swapPasses");
  swaps.set("swapPasses", 1.5);
  EXPECT_EQ(parameterOf("greedy", swaps, 64), "swapPasses");  // not a whole number
  EXPECT_EQ(parameterOf("greedy", {}, 0), "budget");          // neither budget nor maxError
  EXPECT_EQ(parameterOf("greedy", {}, 8, 6), "budget");       // fewer than 4 new probes
  PlaceParameters share;
  share.set("heldOutUniformShare", 2);
  EXPECT_EQ(parameterOf("greedy", share, 64), "heldOutUniformShare");
  // The objective is a word from a list, which the refusal gives.
  PlaceParameters objective;
  objective.setText("objective", "energy");
  EXPECT_EQ(parameterOf("greedy", objective, 64), "(accepted)");
  EXPECT_EQ(parameterOf("uniform", objective, 64), "objective");  // not uniform's
  objective.setText("objective", "brightness");
  try {
    createPlacer(findPlacementMethod("greedy"), objective, {64, 0});
    ADD_FAILURE() << "objective \"brightness\" accepted";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "objective");
    EXPECT_EQ(e.problem(), "expected one of perceptual, energy, got \"brightness\"");
  }
  PlaceParameters numericObjective;
  numericObjective.set("objective", 1);
  EXPECT_EQ(parameterOf("greedy", numericObjective, 64), "objective");
  PlaceParameters aggressiveness;
  aggressiveness.set("aggressiveness", 0);
  EXPECT_EQ(parameterOf("chajdas", aggressiveness, 0), "aggressiveness");
  EXPECT_EQ(parameterOf("spawn-merge", {}, 6), "budget");  // fewer than 8 new probes
  PlaceParameters depth;
  depth.set("fieldDepth", 9);
  EXPECT_EQ(parameterOf("chajdas", depth, 0), "fieldDepth");
  try {
    findPlacementMethod("grid");
    ADD_FAILURE() << "an unknown method was found";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "method");
    EXPECT_NE(std::string(e.what()).find("available: ascent, chajdas, greedy, spawn-merge, "
                                         "uniform"),
              std::string::npos)
        << e.what();
  }
}

TEST(PlacePipeline, KeepsLockedAndAcceptedProbesRejectsStayAndLeakProbesAreMarked) {
  const Loaded& l = loaded("two-rooms.gltf");
  ProbeSet set;
  Probe locked, accepted, candidate, rejected;
  locked.position = Vec3(-3, 1.2, 0);
  locked.locked = true;
  accepted.position = Vec3(3, 1.2, 0);
  accepted.state = ProbeState::Accepted;
  candidate.position = Vec3(-3, 1.2, 1);
  rejected.state = ProbeState::Rejected;
  const uint64_t lockedId = set.add(locked), acceptedId = set.add(accepted),
                 candidateId = set.add(candidate);
  PlaceRequest r;
  r.budget = 64;
  r.keepAccepted = true;
  // A rejected probe at a grid point of a run without it: that spot stays empty.
  const PlaceResult plain = placeProbeSet(*l.tracer, set, r);
  rejected.position = plain.set.probes.back().position;
  const uint64_t rejectedId = set.add(rejected);
  const PlaceResult placed = placeProbeSet(*l.tracer, set, r);
  EXPECT_EQ(placed.kept, 2u);
  EXPECT_EQ(placed.nearRejected, 1u);
  EXPECT_EQ(placed.set.placement.method, "uniform");
  EXPECT_EQ(placed.set.placement.budget, 64);
  EXPECT_GT(placed.set.placement.spacingMeters, 0);
  std::vector<uint64_t> ids;
  for (const Probe& p : placed.set.probes) ids.push_back(p.id);
  ASSERT_GE(ids.size(), 3u);
  EXPECT_EQ(ids[0], lockedId);
  EXPECT_EQ(ids[1], acceptedId);
  EXPECT_EQ(ids[2], rejectedId);
  EXPECT_EQ(std::count(ids.begin(), ids.end(), candidateId), 0);  // replaced
  // The covering's probes, then the method's; both new, both away from the rejected spot.
  EXPECT_GT(placed.covered, 0u);
  EXPECT_EQ(placed.set.probes.size(), 3 + placed.covered + placed.placed);
  for (size_t i = 3; i < placed.set.probes.size(); ++i) {
    const bool covering = i < 3 + placed.covered;
    EXPECT_EQ(placed.set.probes[i].method, covering ? "coverage" : "uniform");
    EXPECT_EQ(placed.set.probes[i].state, ProbeState::Candidate);
    EXPECT_GE(length(placed.set.probes[i].position - rejected.position),
              covering ? 0.5 : 0.5 * placed.set.placement.spacingMeters);
  }
  // Keeping the candidates as well: three kept, the new probes in the state asked for.
  r.keepCandidates = true;
  r.newState = ProbeState::Accepted;
  const PlaceResult both = placeProbeSet(*l.tracer, set, r);
  EXPECT_EQ(both.kept, 3u);
  for (size_t i = 4; i < both.set.probes.size(); ++i)
    EXPECT_EQ(both.set.probes[i].state, ProbeState::Accepted);
}

// ----------------------------------------------------------------------------------- ascent

TEST(Ascent, ClimbsTowardsThePointLightWithoutEnteringGeometry) {
  // pillar-room, full capture: f at a probe that sees the point light at (2, 2.7, 1.5) points
  // mostly at it, so the lit probes end closer to it; the rejection keeps every probe in the
  // room and out of the pillar.
  const Loaded& l = loaded("pillar-room.gltf");
  const std::vector<Vec3> start = placeUniformBudget(*l.tracer, 48, {}).points;
  AscentSettings s;
  s.mode = CaptureMode::Full;
  s.samplesPerProbe = kFieldSpp;
  const AscentResult a = placeAscent(*l.tracer, {}, start, s);
  const AscentResult b = placeAscent(*l.tracer, {}, start, s);
  EXPECT_EQ(a.positions, b.positions);
  ASSERT_EQ(a.positions.size(), start.size());
  EXPECT_GT(a.steps, start.size());
  const Vec3 light(2, 2.7, 1.5);
  double before = 0, after = 0;
  for (size_t i = 0; i < start.size(); ++i) {
    before += length(start[i] - light);
    after += length(a.positions[i] - light);
    EXPECT_TRUE(inBox(a.positions[i], {-4, 0, -4}, {4, 3, 4})) << a.positions[i];
    EXPECT_FALSE(inBox(a.positions[i], {-0.6, 0, -0.6}, {0.6, 3, 0.6})) << a.positions[i];
  }
  EXPECT_LT(after, 0.8 * before);
}

TEST(Ascent, RejectsBadParameters) {
  const Loaded& l = loaded("pillar-room.gltf");
  const std::vector<Vec3> start = {Vec3(1, 1, 1)};
  AscentSettings s;
  s.iterations = 0;
  EXPECT_THROW(placeAscent(*l.tracer, {}, start, s), ParameterError);
  s = AscentSettings{};
  s.stepMeters = 0;
  EXPECT_THROW(placeAscent(*l.tracer, {}, start, s), ParameterError);
}

// ------------------------------------------------------------------------------ spawn-merge

TEST(SpawnMerge, SpawnsWhereLightingDiffersWithinTheCapAndOutsideGeometry) {
  // pillar-room: the point light and the pillar's shadow make neighbours differ; the probe cap
  // holds; no probe ends inside the pillar or outside the room; deterministic for a seed.
  const Loaded& l = loaded("pillar-room.gltf");
  const UniformBudgetResult grid = placeUniformBudget(*l.tracer, 32, {});
  SpawnMergeSettings s;
  s.spacingMeters = grid.spacingMeters;
  s.maxProbes = 64;
  s.samplesPerProbe = kFieldSpp;
  const SpawnMergeResult a = placeSpawnMerge(*l.tracer, {}, grid.points, {}, s);
  const SpawnMergeResult b = placeSpawnMerge(*l.tracer, {}, grid.points, {}, s);
  ASSERT_EQ(a.probes.size(), b.probes.size());
  for (size_t i = 0; i < a.probes.size(); ++i)
    EXPECT_EQ(a.probes[i].position, b.probes[i].position);
  EXPECT_GT(a.spawned, 0u);
  EXPECT_LE(a.probes.size(), 64u);
  EXPECT_GT(a.probes.size(), grid.points.size());
  for (const SpawnMergeProbe& p : a.probes) {
    EXPECT_TRUE(inBox(p.position, {-4, 0, -4}, {4, 3, 4})) << p.position;
    EXPECT_FALSE(inBox(p.position, {-0.6, 0, -0.6}, {0.6, 3, 0.6})) << p.position;
  }
}

TEST(SpawnMerge, MergesCloseProbesWithTheSameLighting) {
  // A constant sky and no occluder near the probes: every pair within the merge distance is
  // alike, so the 8 probes of a small cube (edge 0.2 spacing) merge pairwise.
  Scene scene;
  scene.positions = {50, 0, 0, 50.1f, 0, 0, 50, 0.1f, 0};
  scene.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  scene.indices = {0, 1, 2};
  scene.triangleMaterial = {0};
  scene.materials.push_back(Material{});
  for (uint32_t v = 0; v < 3; ++v) scene.bounds.extend(scene.vertex(v));
  scene.bounds.extend({-1, -1, -1});
  const Tracer tracer(scene);
  LightingRig rig;
  rig.skyRadiance = {1, 1, 1};
  std::vector<Vec3> cube;
  for (int i = 0; i < 8; ++i) cube.push_back(Vec3(i & 1, (i >> 1) & 1, (i >> 2) & 1) * 0.2);
  SpawnMergeSettings s;
  s.spacingMeters = 1.0;
  s.maxIterations = 1;
  s.samplesPerProbe = 256;
  const SpawnMergeResult r = placeSpawnMerge(tracer, rig, cube, {}, s);
  EXPECT_EQ(r.merged, 4u);
  EXPECT_EQ(r.spawned, 0u);
  EXPECT_EQ(r.probes.size(), 4u);
}
