// Leak refinement (Sukys 3.2.2): edges of the probe mesh that cross walls, and the probes added
// on each side of them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <unistd.h>

#include "core/bake/Bake.h"
#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "core/eval/Evaluate.h"
#include "core/io/SceneHash.h"
#include "core/math/Random.h"
#include "core/placement/LeakRefine.h"
#include "core/placement/Uniform.h"
#include "core/scene/Scene.h"
#include "core/tessellation/Tetrahedralization.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

const fs::path kScenes = fs::path(PS_SOURCE_DIR) / "resources" / "scenes";

// Two-rooms: the shared wall is the slab x in [-0.05, 0.05] with a doorway at z in [-0.5, 0.5],
// y < 2.1; room A is x < 0, room B x > 0.
struct TwoRooms {
  Scene scene = loadScene(kScenes / "two-rooms.gltf");
  Tracer tracer{scene};
};

TwoRooms& twoRooms() {
  static TwoRooms t;
  return t;
}

// The coarse uniform set of the tests: 1.2 m cells, two layers, about a hundred probes.
std::vector<Vec3> coarseSet(const Tracer& tracer) {
  UniformSettings us;
  us.spacingMeters = 1.2;
  return placeUniform(tracer, us);
}

}  // namespace

TEST(LeakRefine, SegmentThroughTheThinWallEntersGeometryBothWays) {
  const Tracer& tracer = twoRooms().tracer;
  Hit d;
  ASSERT_TRUE(segmentEntersGeometry(tracer, {-1, 1.5, -2}, {1, 1.5, -2}, &d));
  EXPECT_NEAR(d.t, 0.95, 1e-6);  // the wall's face at x = -0.05
  ASSERT_TRUE(segmentEntersGeometry(tracer, {1, 1.5, -2}, {-1, 1.5, -2}, &d));
  EXPECT_NEAR(d.t, 0.95, 1e-6);  // its face at x = +0.05
  // Through the doorway, and within one room: nothing.
  EXPECT_FALSE(segmentEntersGeometry(tracer, {-1, 1, 0}, {1, 1, 0}));
  EXPECT_FALSE(segmentEntersGeometry(tracer, {-4, 1, -2}, {-1, 2, 2}));
  // Degenerate segment: nothing.
  EXPECT_FALSE(segmentEntersGeometry(tracer, {-1, 1, 0}, {-1, 1, 0}));
}

TEST(LeakRefine, SegmentStartingInsideAWallOnlyCountsTheNextSolid) {
  const Tracer& tracer = twoRooms().tracer;
  // From inside the shared wall into room B: only back faces (leaving the wall): no crossing.
  EXPECT_FALSE(segmentEntersGeometry(tracer, {0, 1.5, -2}, {2, 1.5, -2}));
  // From inside the shared wall through room B to beyond the east wall: enters the east wall.
  Hit d;
  ASSERT_TRUE(segmentEntersGeometry(tracer, {0, 1.5, -2}, {6.2, 1.5, -2}, &d));
  EXPECT_NEAR(d.t, 6.05, 1e-6);
}

TEST(LeakRefine, CoarseTwoRoomsSetLeaksAndRefinementRemovesMostLeaks) {
  const Tracer& tracer = twoRooms().tracer;
  const std::vector<Vec3> probes = coarseSet(tracer);
  ASSERT_GE(probes.size(), 20u);
  const size_t before = countLeakingEdges(tracer, probes);
  EXPECT_GT(before, 0u) << "the coarse set should have edges through the shared wall";

  const LeakRefineResult r = refineLeaks(tracer, probes);
  EXPECT_EQ(r.leakingEdgesBefore, before);
  EXPECT_GT(r.added.size(), 0u);
  ASSERT_EQ(r.addedScore.size(), r.added.size());
  for (double sc : r.addedScore) EXPECT_GE(sc, 1.0);
  // Recount independently on the refined set.
  std::vector<Vec3> all = probes;
  all.insert(all.end(), r.added.begin(), r.added.end());
  EXPECT_EQ(countLeakingEdges(tracer, all), r.leakingEdgesAfter);
  // What refinement removes is interpolation across the wall over large distances: the volume
  // of the tetrahedra with an edge through geometry falls (measured 0.111 -> 0.035). The number
  // of such edges does not (measured 25 -> 191): the added probes hug both sides of the wall, and
  // the short edges between them still pass through it, by design (Sukys 3.2.2: hits closer to
  // a vertex than a fraction of the edge lengths add nothing, so no dense cluster forms).
  EXPECT_LT(r.leakingVolumeFractionAfter, 0.6 * r.leakingVolumeFractionBefore)
      << "before " << r.leakingVolumeFractionBefore << ", after " << r.leakingVolumeFractionAfter;
  std::printf(
      "two-rooms, %zu probes: leaking edges %zu -> %zu of %zu, leaking volume %.4f -> "
      "%.4f, %zu probes added in %d rounds (%.3f s)\n",
      probes.size(), before, r.leakingEdgesAfter, r.edgesAfter, r.leakingVolumeFractionBefore,
      r.leakingVolumeFractionAfter, r.added.size(), r.iterations, r.seconds);

  // No added probe is inside geometry, and every one has no probe closer than a few cm.
  for (size_t i = 0; i < r.added.size(); ++i) {
    EXPECT_LE(backfaceFraction(tracer, r.added[i], 256, 99 + i), 0.25) << r.added[i];
    for (size_t j = 0; j < all.size(); ++j) {
      if (j != probes.size() + i) {
        EXPECT_GT(length(all[j] - r.added[i]), 0.05);
      }
    }
  }
  // Probes were added on both sides of the shared wall.
  bool sideA = false, sideB = false;
  for (const Vec3& p : r.added) {
    if (std::abs(p.x) < 1.0 && p.x < 0) sideA = true;
    if (std::abs(p.x) < 1.0 && p.x > 0) sideB = true;
  }
  EXPECT_TRUE(sideA && sideB);
}

TEST(LeakRefine, AProbeHuggingTheWallDoesNotStandForTheOtherSide) {
  // One probe of room A 1 cm from the shared wall (its face at x = -0.05), the others a metre
  // and more away on both sides. The edges from room B to it cross the wall; room B's side needs
  // a probe of its own by the wall, although the hugging probe is within the merge spacing of
  // it: that probe is behind the wall and must not count.
  const Tracer& tracer = twoRooms().tracer;
  const std::vector<Vec3> probes = {{-1.5, 0.5, -3},  {-1.5, 2.5, -3}, {-1.5, 1.5, -1},
                                    {-0.06, 1.5, -2}, {1.5, 0.5, -3},  {1.5, 2.5, -3},
                                    {1.5, 1.5, -1},   {1.5, 1.5, -2.5}};
  const LeakRefineResult r = refineLeaks(tracer, probes);
  bool besideOnB = false;
  for (const Vec3& p : r.added)
    besideOnB = besideOnB ||
                (p.x > 0.05 && p.x < 0.6 && std::abs(p.y - 1.5) < 0.8 && std::abs(p.z + 2) < 0.8);
  EXPECT_TRUE(besideOnB) << r.added.size() << " probes added";
}

TEST(LeakRefine, IsDeterministic) {
  const Tracer& tracer = twoRooms().tracer;
  const std::vector<Vec3> probes = coarseSet(tracer);
  const LeakRefineResult a = refineLeaks(tracer, probes);
  const LeakRefineResult b = refineLeaks(tracer, probes);
  EXPECT_EQ(a.added, b.added);
  EXPECT_EQ(a.addedScore, b.addedScore);
}

TEST(LeakRefine, ConvergesAndARefinedSetAddsNothingMore) {
  // Without the round cap, refinement stops by itself (no dense cluster grows: measured 107
  // probes added in 12 rounds), and refining its result again adds (next to) nothing.
  const Tracer& tracer = twoRooms().tracer;
  std::vector<Vec3> probes = coarseSet(tracer);
  LeakRefineSettings s;
  s.maxIterations = 40;
  const LeakRefineResult first = refineLeaks(tracer, probes, s);
  EXPECT_LT(first.iterations, 40);
  EXPECT_LT(first.added.size(), 2 * probes.size());
  probes.insert(probes.end(), first.added.begin(), first.added.end());
  const LeakRefineResult second = refineLeaks(tracer, probes, s);
  EXPECT_LE(second.added.size(), 2u) << first.added.size() << " then " << second.added.size();
}

TEST(LeakRefine, SetInOneOpenRoomCornerAddsNothing) {
  const Scene scene = loadScene(kScenes / "pillar-room.gltf");
  const Tracer tracer(scene);
  // Eight probes in a corner of the pillar room, away from the pillar: no edge crosses anything.
  std::vector<Vec3> probes;
  for (int i = 0; i < 8; ++i)
    probes.push_back({-3.0 + 1.5 * (i & 1), 0.5 + 1.5 * ((i >> 1) & 1), -3.0 + 1.5 * (i >> 2)});
  const LeakRefineResult r = refineLeaks(tracer, probes);
  EXPECT_EQ(r.leakingEdgesBefore, 0u);
  EXPECT_EQ(r.leakingEdgesAfter, 0u);
  EXPECT_TRUE(r.added.empty());
  EXPECT_EQ(r.iterations, 0);
}

TEST(LeakRefine, CapsAreRespected) {
  const Tracer& tracer = twoRooms().tracer;
  const std::vector<Vec3> probes = coarseSet(tracer);
  LeakRefineSettings s;
  s.maxAdded = 3;
  EXPECT_LE(refineLeaks(tracer, probes, s).added.size(), 3u);
  s = {};
  s.maxIterations = 0;
  const LeakRefineResult none = refineLeaks(tracer, probes, s);
  EXPECT_TRUE(none.added.empty());
  EXPECT_EQ(none.leakingEdgesAfter, none.leakingEdgesBefore);
}

TEST(LeakRefine, BadInputThrowsParameterError) {
  const Tracer& tracer = twoRooms().tracer;
  const std::vector<Vec3> flat = {{-1, 1, -1}, {1, 1, -1}, {1, 1, 1}, {-1, 1, 1}};
  EXPECT_THROW(refineLeaks(tracer, flat), ParameterError);
  EXPECT_THROW(refineLeaks(tracer, std::vector<Vec3>{}), ParameterError);
  const std::vector<Vec3> probes = coarseSet(tracer);
  LeakRefineSettings s;
  s.offsetRelative = 0;
  EXPECT_THROW(refineLeaks(tracer, probes, s), ParameterError);
  s = {};
  s.maxIterations = -1;
  EXPECT_THROW(refineLeaks(tracer, probes, s), ParameterError);
}

TEST(LeakRefine, BakeRefinesThroughTheCacheAndEvalLeaksLess) {
  const Tracer& tracer = twoRooms().tracer;
  const fs::path dir = fs::temp_directory_path() / ("ps_test_leak_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  ProbeSet set;
  set.scenePath = (kScenes / "two-rooms.gltf").string();
  for (const Vec3& p : coarseSet(tracer)) {
    Probe pr;
    pr.position = p;
    pr.state = ProbeState::Accepted;
    set.add(pr);
  }
  BakeSettings bs;
  bs.capture.samplesPerProbe = 128;  // the same under ASan: its assertions need this much
  bs.cacheDir = dir / "cache";
  bs.sceneHash = sceneContentHash(kScenes / "two-rooms.gltf");
  bs.leakRefine = false;
  const BakeResult plain = bakeProbeSet(set, tracer, bs);
  EXPECT_EQ(plain.probes, set.probes.size());
  EXPECT_EQ(plain.leakProbesAdded, 0u);

  bs.leakRefine = true;
  const BakeResult refined = bakeProbeSet(set, tracer, bs);
  EXPECT_GT(refined.leakProbesAdded, 0u);
  EXPECT_EQ(refined.probes, set.probes.size() + refined.leakProbesAdded);
  EXPECT_EQ(refined.file.volume.probeCount(), refined.probes);
  // The set's probes come from the cache; only the added ones are traced.
  EXPECT_EQ(refined.cacheHits, set.probes.size());
  EXPECT_EQ(refined.captured, refined.leakProbesAdded);
  EXPECT_EQ(bakeProbeSet(set, tracer, bs).captured, 0u);

  EvalSettings es;
  es.queries = 192;
  es.referenceSpp = 256;
  // The refinement and the cuts against the barycentric interpolant they are for (the volumes
  // carry visibility maps, which eval would otherwise use).
  es.useVisibility = false;
  const EvalResult before = evaluateVolume(tracer, set.rig, plain.file.volume, es);
  const EvalResult after = evaluateVolume(tracer, set.rig, refined.file.volume, es);
  std::printf(
      "two-rooms eval, %zu -> %zu probes: rel RMSE %.4f -> %.4f, p95 %.4f -> %.4f, "
      "leaking %.4f -> %.4f\n",
      before.probes, after.probes, before.relRmse, after.relRmse, before.p95RelError,
      after.p95RelError, before.leakingFraction, after.leakingFraction);
  EXPECT_GT(before.leakingFraction, 0.0);
  EXPECT_LT(after.leakingFraction, before.leakingFraction);
  // The probes added against leaks must not cost accuracy: 192 queries resolve rel_rmse only
  // to its standard error (both about 0.32, 0.001 apart, where it was measured), so the bound
  // is two of the difference's standard errors.
  EXPECT_LT(after.relRmse,
            before.relRmse + 2 * std::hypot(before.relRmseStdError, after.relRmseStdError))
      << "standard errors " << before.relRmseStdError << ", " << after.relRmseStdError;

  // The leak cuts (on by default), and the probes for them (off by default): more queries, for
  // the leaking fraction only (a cheap reference).
  ASSERT_TRUE(refined.leakCuts.has_value());
  EXPECT_GT(refined.leakCuts->planes, 0u);
  EXPECT_EQ(refined.leakCutProbesAdded, 0u);
  bs.leakCutProbes = true;
  const BakeResult withProbes = bakeProbeSet(set, tracer, bs);
  EXPECT_GT(withProbes.leakCutProbesAdded, 0u);
  EXPECT_LT(withProbes.leakCuts->hiddenSamplesAfter,
            withProbes.leakCuts->hiddenSamplesBefore / 100);
  es.queries = 4096;
  es.referenceSpp = 1;
  const double leakingBefore =
      evaluateVolume(tracer, set.rig, plain.file.volume, es).leakingFraction;
  const double leakingCut =
      evaluateVolume(tracer, set.rig, refined.file.volume, es).leakingFraction;
  const double leakingProbes =
      evaluateVolume(tracer, set.rig, withProbes.file.volume, es).leakingFraction;
  std::printf(
      "leaking at %d queries: %.5f -> %.5f with %zu cut planes -> %.5f with %zu probes for them\n",
      es.queries, leakingBefore, leakingCut, refined.leakCuts->planes, leakingProbes,
      withProbes.leakCutProbesAdded);
  EXPECT_GT(leakingBefore, 0.05);
  EXPECT_LT(leakingCut, leakingBefore / 5);
  EXPECT_LE(leakingProbes, 0.001);
  fs::remove_all(dir);
}

// The cuts alone (no probe added), on the coarse set's mesh: the points drawn that interpolate
// a probe behind a wall mostly stop doing so, and eval's queries leak far less.
TEST(LeakCuts, CutsAloneEndMostLeaksOfACoarseSet) {
  const Tracer& tracer = twoRooms().tracer;
  const std::vector<Vec3> probes = coarseSet(tracer);
  const Tetrahedralization t = tetrahedralize(probes);
  const ProbeVolume plain = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
  ProbeVolume cut = plain;
  const LeakCutResult r = computeLeakCuts(tracer, cut, {});
  EXPECT_GT(r.tetsCut, 0u);
  EXPECT_EQ(r.planes, cut.cutPlanes.size());
  EXPECT_EQ(cut.cutStart.size(), cut.tets.size() + 1);
  EXPECT_LT(r.hiddenSamplesAfter, r.hiddenSamplesBefore / 20);
  // Deterministic.
  ProbeVolume again = plain;
  computeLeakCuts(tracer, again, {});
  EXPECT_EQ(again.cutStart, cut.cutStart);
  ASSERT_EQ(again.cutPlanes.size(), cut.cutPlanes.size());
  for (size_t c = 0; c < cut.cutPlanes.size(); ++c) {
    EXPECT_EQ(again.cutPlanes[c].plane, cut.cutPlanes[c].plane);
    EXPECT_EQ(again.cutPlanes[c].hide, cut.cutPlanes[c].hide);
  }
  EvalSettings es;
  es.queries = 2048;
  es.referenceSpp = 1;
  const double before = evaluateVolume(tracer, {}, plain, es).leakingFraction;
  const double after = evaluateVolume(tracer, {}, cut, es).leakingFraction;
  std::printf("coarse two-rooms set, leaking at %d queries: %.4f -> %.4f with %zu cut planes\n",
              es.queries, before, after, r.planes);
  EXPECT_GT(before, 0.05);
  EXPECT_LT(after, before / 10);
}

// A plane is infinite: one through a surface that hides a probe from some points can cut off
// probes in plain view of others. overCutWeight makes that cost (LeakCutSettings).
TEST(LeakCuts, PlanesLeaveAloneThePointsThatSeeEveryProbe) {
  const Tracer& tracer = twoRooms().tracer;
  const std::vector<Vec3> probes = coarseSet(tracer);
  const Tetrahedralization t = tetrahedralize(probes);
  const ProbeVolume plain = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
  ProbeVolume leaksOnly = plain, balanced = plain;
  LeakCutSettings s;
  s.overCutWeight = 0;
  computeLeakCuts(tracer, leaksOnly, {}, s);
  computeLeakCuts(tracer, balanced, {});
  // Valid points of the scene that see every probe they interpolate without cuts: how many have
  // their weights moved by more than 0.05 (total variation), and how many leak with the cuts.
  const DomainPoints domain(tracer, {}, std::span<const Bounds3>{}, 0.0);
  uint64_t rng = 99;
  int clean = 0, movedLeaksOnly = 0, movedBalanced = 0, leakLeaksOnly = 0, leakBalanced = 0;
  auto moved = [](const VolumeLocation& a, const VolumeLocation& b) {
    double tv = 0;
    for (int k = 0; k < 4; ++k) tv += std::abs(a.weights[k] - b.weights[k]);
    return 0.5 * tv > 0.05;
  };
  for (int i = 0; i < 4096; ++i) {
    const std::optional<Vec3> p = domain.draw(rng);
    if (!p) continue;
    const VolumeLocation before = locate(plain, *p);
    uint32_t hidden = 0;
    for (int k = 0; k < 4; ++k) {
      const Vec3 d = plain.position(plain.tets[size_t(before.tet)][size_t(k)]) - *p;
      const double len = length(d);
      if (len > 2 * tracer.rayEpsilon() &&
          tracer.occluded(Ray{*p, d / len, tracer.rayEpsilon(), len - tracer.rayEpsilon()}))
        hidden |= 1u << k;
    }
    auto leaks = [&](const VolumeLocation& l) {
      for (int k = 0; k < 4; ++k)
        if ((hidden >> k & 1) && l.weights[k] > 0) return true;
      return false;
    };
    const VolumeLocation a = locate(leaksOnly, *p), b = locate(balanced, *p);
    leakLeaksOnly += leaks(a);
    leakBalanced += leaks(b);
    bool seesAll = true;
    for (int k = 0; k < 4; ++k) seesAll = seesAll && !((hidden >> k & 1) && before.weights[k] > 0);
    if (!seesAll) continue;
    ++clean;
    movedLeaksOnly += moved(before, a);
    movedBalanced += moved(before, b);
  }
  std::printf(
      "coarse two-rooms set, 4096 points, %d seeing every probe they interpolate: weights "
      "moved at %d (leaks alone) / %d (default); leaking %d / %d\n",
      clean, movedLeaksOnly, movedBalanced, leakLeaksOnly, leakBalanced);
  EXPECT_GT(clean, 2000);
  EXPECT_GT(movedLeaksOnly, 40);
  EXPECT_LT(movedBalanced * 2, movedLeaksOnly);
  EXPECT_LT(leakBalanced, 3 * leakLeaksOnly + 20);
}

// Beyond an edge or a corner of the hull a query is clamped onto it and interpolates the two
// probes of the edge, or the corner's one; no hull face's prism holds it, so the cuts draw their
// points for it over the domain, located as queries are. A box of probes above room A's floor,
// its lower north edge at y 1.2, z -2: a point in the gap between the cabinet and the west wall
// (x < -5.6, below the cabinet's top at 0.9, z < -2.45) is clamped onto that edge or its west
// corner (x -5.9), sees that corner past the cabinet's west face and not the east one (x -4.5)
// across the cabinet.
TEST(LeakCuts, QueriesClampedToAHullEdgeGetCutsToo) {
  const Tracer& tracer = twoRooms().tracer;
  std::vector<Vec3> probes;
  for (double x : {-5.9, -4.5})
    for (double y : {1.2, 2.6})
      for (double z : {-2.0, -0.5}) probes.push_back({x, y, z});
  const Tetrahedralization t = tetrahedralize(probes);
  const ProbeVolume plain = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
  ProbeVolume cut = plain;
  LeakCutSettings s;
  s.samplesTotal = size_t(1) << 16;  // 22000 points a cubic metre in the box, 240 over the scene
  computeLeakCuts(tracer, cut, {}, s);
  // Points of the gap, as eval tests them: a vertex with weight the point cannot see.
  auto leaks = [&](const ProbeVolume& v, Vec3 p) {
    const VolumeLocation loc = locate(v, p);
    for (int k = 0; k < 4; ++k) {
      if (!(loc.weights[size_t(k)] > 0)) continue;
      const Vec3 d = v.position(v.tets[size_t(loc.tet)][size_t(k)]) - p;
      const double len = length(d);
      if (tracer.occluded(Ray{p, d / len, tracer.rayEpsilon(), len - tracer.rayEpsilon()}))
        return true;
    }
    return false;
  };
  uint64_t rng = 5;
  int onEdge = 0, leakBefore = 0, leakAfter = 0;
  const int n = 400;
  for (int i = 0; i < n; ++i) {
    const Vec3 p(-6.0 + 0.35 * uniform01(rng), 0.05 + 0.8 * uniform01(rng),
                 -2.9 + 0.4 * uniform01(rng));
    const VolumeLocation loc = locate(plain, p);
    int weighted = 0;
    for (float w : loc.weights) weighted += w > 0 ? 1 : 0;
    onEdge += loc.outside && weighted <= 2;
    leakBefore += leaks(plain, p);
    leakAfter += leaks(cut, p);
  }
  std::printf(
      "%d points beside the cabinet, %d clamped to an edge or a corner of the hull: %d leak "
      "without cuts, %d with them\n",
      n, onEdge, leakBefore, leakAfter);
  EXPECT_EQ(onEdge, n);
  EXPECT_GT(leakBefore, n / 2);
  EXPECT_LT(leakAfter, leakBefore / 10);
}

TEST(LeakCuts, ProgressReportsEachTetrahedronAndCancelLeavesTheVolumeAsItWas) {
  const Tracer& tracer = twoRooms().tracer;
  const std::vector<Vec3> probes = coarseSet(tracer);
  const Tetrahedralization t = tetrahedralize(probes);
  ProbeVolume v = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
  // Reported after each tetrahedron, increasing, ending at 1.
  std::vector<double> seen;
  ProbeVolume whole = v;
  computeLeakCuts(tracer, whole, {}, {}, [&](double f) {
    seen.push_back(f);
    return true;
  });
  ASSERT_EQ(seen.size(), v.tets.size());
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(seen.back(), 1.0);
  // Cancelled at the first report: no cuts, the volume as it was (here, with whole's cuts).
  ProbeVolume cut = whole;
  EXPECT_THROW(computeLeakCuts(tracer, cut, {}, {}, [](double) { return false; }), Cancelled);
  EXPECT_EQ(cut.cutStart, whole.cutStart);
  EXPECT_EQ(cut.cutPlanes.size(), whole.cutPlanes.size());
}

TEST(LeakCuts, BadSettingsThrowParameterError) {
  const Tracer& tracer = twoRooms().tracer;
  const std::vector<Vec3> probes = coarseSet(tracer);
  const Tetrahedralization t = tetrahedralize(probes);
  ProbeVolume v = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
  LeakCutSettings s;
  s.maxPlanesPerTet = 9;
  EXPECT_THROW(computeLeakCuts(tracer, v, {}, s), ParameterError);
  s = {};
  s.samplesPerTet = 0;
  EXPECT_THROW(computeLeakCuts(tracer, v, {}, s), ParameterError);
  s = {};
  s.overCutWeight = -0.5;
  EXPECT_THROW(computeLeakCuts(tracer, v, {}, s), ParameterError);
  s.overCutWeight = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(computeLeakCuts(tracer, v, {}, s), ParameterError);
  s = {};
  s.refineRounds = -1;
  EXPECT_THROW(refineForLeakCuts(tracer, {}, probes, {}, s), ParameterError);
}

// The probes added for the cuts are outside geometry. Two-rooms' floor and ceiling are one slab
// per room, meeting under the shared wall, whose top is the ceiling's underside: there a ray
// may hit either of two coincident faces. Were the front one counted, points inside the slabs
// would show back-face fractions near the threshold, which the cuts' 16 validity rays can
// pass; seeing none of their tetrahedron's probes, they are just what refineForLeakCuts looks
// for, and would become probes. backfaceFraction finds such pairs and tells a shared face from
// a back-to-back sheet by what lies past it.
TEST(LeakCuts, ProbesAddedForTheCutsAreOutsideGeometry) {
  const Tracer& tracer = twoRooms().tracer;
  const LeakCutSettings s;
  // Whether a coarse grid leaves points the cuts cannot serve turns on the last bits of the
  // cuts' fits (an FMA build adds none at 1.2 m), so grids of other spacings are tried until
  // one adds probes; every probe added is checked.
  std::vector<Vec3> added;
  for (double spacing : {1.2, 1.0, 1.4, 0.9}) {
    UniformSettings us;
    us.spacingMeters = spacing;
    const LeakCutRefineResult r = refineForLeakCuts(tracer, {}, placeUniform(tracer, us), {}, s);
    added.insert(added.end(), r.added.begin(), r.added.end());
    if (!added.empty()) break;
  }
  ASSERT_GT(added.size(), 0u) << "no grid of 0.9 to 1.4 m left points for the cuts";
  size_t inside = 0;
  for (size_t i = 0; i < added.size(); ++i) {
    const Vec3 p = added[i];
    // The slabs: floor y < 0, ceiling y > 3, outer walls, the shared wall but its doorway.
    const bool inSlab = p.y < 0 || p.y > 3 || p.z < -3 || p.z > 3 || p.x < -6.05 ||
                        (p.x > 6.05 && !(p.z > -0.8 && p.z < 0.8 && p.y > 1 && p.y < 2.2)) ||
                        (std::abs(p.x) < 0.05 && !(std::abs(p.z) < 0.5 && p.y < 2.1));
    const double backface = backfaceFraction(tracer, p, 1024, 7 + i);
    if (inSlab || backface > 0.25) {
      ++inside;
      std::printf("inside geometry: (%.4f, %.4f, %.4f), back-face fraction %.3f\n", p.x, p.y, p.z,
                  backface);
    }
  }
  std::printf("%zu probes added for the cuts, %zu inside geometry\n", added.size(), inside);
  EXPECT_EQ(inside, 0u);
}

// A sliver on the hull that is flat once its corners are floats (the volume's positions): its
// opposite vertex lies in the plane of its hull faces, so it cannot tell their outside. The
// points drawn beyond those faces must stay beyond them, not run inwards across the domain and
// through the shared wall, where they would leave many points leaking.
TEST(LeakCuts, AHullSliverFlatInFloatDrawsBeyondItsFacesOutwards) {
  const Tracer& tracer = twoRooms().tracer;
  auto cutsOf = [&](double bulge, int* flatOnHull) {
    std::vector<Vec3> probes;
    for (double y : {0.5, 2.5})
      for (double z : {-2.0, 2.0}) probes.push_back({-5.9, y, z});
    probes[3].x -= bulge;
    for (double y : {0.5, 2.5})
      for (double z : {-2.0, 2.0}) probes.push_back({5.9, y + 0.1 * z, z});
    const Tetrahedralization t = tetrahedralize(probes);
    ProbeVolume v = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
    *flatOnHull = 0;
    for (const auto& hullFace : v.hullFaces) {
      const auto& q = v.tets[size_t(hullFace[0])];
      const Vec3 a = v.position(q[0]);
      *flatOnHull +=
          dot(cross(v.position(q[1]) - a, v.position(q[2]) - a), v.position(q[3]) - a) == 0.0;
    }
    LeakCutSettings s;
    s.samplesTotal = size_t(1) << 16;
    return computeLeakCuts(tracer, v, {}, s);
  };
  int flat = 0, flatWithout = 0;
  // Out of the face's plane by far less than a float's step at 5.9 m (5e-7).
  const LeakCutResult sliver = cutsOf(1e-9, &flat);
  const LeakCutResult plain = cutsOf(0.0, &flatWithout);
  std::printf(
      "with the sliver (%d hull faces of flat tets): %zu points drawn, %zu leak after the cuts; "
      "without it (%d): %zu, %zu\n",
      flat, sliver.samples, sliver.hiddenSamplesAfter, flatWithout, plain.samples,
      plain.hiddenSamplesAfter);
  ASSERT_GT(flat, 0) << "the set must hold a hull sliver that is flat in floats";
  EXPECT_EQ(flatWithout, 0);
  // The strip beyond the west faces is 0.15 m deep: about as many points as without the sliver
  // (other tets, other leaks), not a prism as deep as the building, which would draw several
  // times as many points and leave most of them leaking.
  EXPECT_LT(sliver.samples, plain.samples * 11 / 10);
  EXPECT_LT(sliver.hiddenSamplesAfter, 2 * plain.hiddenSamplesAfter + 100);
}
