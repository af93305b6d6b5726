// The visibility-aware interpolant's neighbour search (core/traversal/VisibleInterpolation.h,
// fallback 2): a point whose tetrahedron's probes all lie behind walls takes its light from the
// probes near it that see it, and the runtime reader (core/runtime/ps_volume_reader.h) gives the
// same weights.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <random>
#include <utility>
#include <vector>

#include "core/bake/Bake.h"
#include "core/capture/Capture.h"
#include "core/io/VolumeFile.h"
#include "core/runtime/ps_volume_reader.h"
#include "core/trace/Tracer.h"
#include "core/traversal/VisibleInterpolation.h"
#include "tests/core/SceneBuilders.h"
#include "tests/core/TestFiles.h"

namespace fs = std::filesystem;
using namespace ps;
using ps::testing::pointLight;

namespace {

/// Three rooms in a row along x, each 2 m high and 4 m deep (z in [0, 4]): A (x in [0, 1.95]),
/// B (x in [2.05, 2.95]) and C (x in [3.05, 5]), parted by solid walls 0.1 m thick. Only
/// corridor B is lit, by a point light at (2.5, 1.8, 2).
Scene threeRooms() {
  return ps::testing::roomsAlongX({5, 2, 4}, {2.0, 3.0}, pointLight({2.5, 1.8, 2}, {5, 5, 5}));
}

enum class Room { A, B, C };
Room roomOf(Vec3 p) {
  return p.x < 2 ? Room::A : p.x < 3 ? Room::B : Room::C;
}

/// Probes on a jittered 2 x 2 x 4 grid in each of rooms A and C, next to the walls, and two at
/// corridor B's ends (z 0.3 and 3.7): the tetrahedra from A to C span the corridor's middle,
/// where none of their probes sees. Jitter up to 0.1 m per axis, from `seed`.
std::vector<Vec3> probes(uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> j(-0.1, 0.1);
  std::vector<Vec3> p;
  for (double x : {0.6, 1.6, 3.4, 4.4})
    for (double y : {0.5, 1.5})
      for (double z : {0.5, 1.5, 2.5, 3.5}) p.push_back(Vec3{x + j(rng), y + j(rng), z + j(rng)});
  p.push_back(Vec3{2.5 + j(rng), 1.0 + j(rng), 0.3});
  p.push_back(Vec3{2.5 + j(rng), 1.0 + j(rng), 3.7});
  return p;
}

VolumeFile bake(const Tracer& tracer, const std::vector<Vec3>& points) {
  CaptureSettings cs;
  cs.samplesPerProbe = 1024;
  cs.visibilityMaps = true;
  const auto caps = captureProbes(tracer, LightingRig{}, points, cs);
  std::vector<ShRgb> sh;
  std::vector<ProbeVisibility> vis;
  for (const ProbeCapture& c : caps) {
    sh.push_back(c.sh);
    ProbeVisibility v;
    std::copy(c.distanceMoments.begin(), c.distanceMoments.end(), v.distanceMoments.begin());
    v.inside = c.backfaceFraction > 0.25;
    vis.push_back(v);
  }
  VolumeFile vf;
  vf.volume = volumeFromProbes(points, sh, vis);
  vf.metadataJson = "{}";
  return vf;
}

/// Points in corridor B's middle (x in [2.1, 2.9], y in [0.7, 1.3], z in [1, 3]: inside the
/// probes' hull), with a
/// normal for every other one.
struct Query {
  Vec3 p;
  std::optional<Vec3> n;
};
std::vector<Query> corridorPoints(uint64_t seed, int count) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Query> q;
  for (int i = 0; i < count; ++i) {
    const Vec3 p{2.1 + 0.8 * u(rng), 0.7 + 0.6 * u(rng), 1 + 2 * u(rng)};
    const double z = 1 - 2 * u(rng), phi = 2 * kPi * u(rng);
    const Vec3 n{std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z};
    q.push_back({p, i % 2 ? std::optional<Vec3>(n) : std::nullopt});
  }
  return q;
}

}  // namespace

// In the corridor's middle, the tetrahedron of many points spans it from room A to room C: none
// of its four probes sees the point, and the barycentric fallback would read the dark rooms
// through the walls (all its weight is theirs). The neighbour search finds the corridor's own
// probes, and the point takes its light from them. Not from them alone everywhere: within a few
// centimetres of a wall a map's texel (16 x 16, DDGI's Chebyshev test) cannot tell a point just
// behind the wall from one in front of it, and a near probe across the wall keeps some weight.
// Measured over seeds 1 to 5 of the probes' jitter (400 points each): 180 to 216 points served
// by the search, none left barycentric; the mean weight on the other rooms' probes 0.0117 to
// 0.0226, and 0.922 to 0.967 of the points take at least 0.9 of their weight from the corridor.
// The bounds leave a margin of at least half the spread over seeds beyond the worst seed.
TEST(VisibleNeighbours, APointWhoseTetrahedronSpansTheWallsTakesItsOwnRoomsLight) {
  const Scene s = threeRooms();
  const Tracer tracer(s);
  for (uint64_t seed = 1; seed <= 5; ++seed) {
    const VolumeFile vf = bake(tracer, probes(seed));
    const ProbeVolume& v = vf.volume;
    int neighbours = 0, barycentric = 0, ownRoom = 0;
    double otherWeight = 0;
    for (const Query& q : corridorPoints(seed, 400)) {
      const VolumeLocation loc = locate(v, q.p);
      ASSERT_FALSE(loc.outside);
      const VisibleWeights w = visibleWeights(v, loc, q.p, q.n);
      double sum = 0;
      for (int k = 0; k < w.count; ++k) {
        ASSERT_GE(w.weights[size_t(k)], 0);
        sum += w.weights[size_t(k)];
      }
      ASSERT_NEAR(sum, 1, 1e-12);
      if (w.fallback == VisibleFallback::Barycentric) ++barycentric;
      if (w.fallback != VisibleFallback::Neighbours) continue;
      ++neighbours;
      // Every probe of the point's own tetrahedron is in room A or C (else one would see it).
      for (int k = 0; k < 4; ++k)
        EXPECT_NE(roomOf(v.position(v.tets[size_t(loc.tet)][k])), Room::B);
      // The weight on the other rooms' probes, which the barycentric fallback puts at 1; every
      // weighed probe sees the point by its map.
      double other = 0;
      for (int k = 0; k < w.count; ++k) {
        if (w.weights[size_t(k)] > 0) {
          EXPECT_GT(w.factors[size_t(k)], 0);
        }
        if (roomOf(v.position(w.probes[size_t(k)])) != Room::B) other += w.weights[size_t(k)];
      }
      otherWeight += other;
      ownRoom += other <= 0.1;
    }
    const double meanOther = otherWeight / std::max(neighbours, 1);
    const double ownShare = double(ownRoom) / std::max(neighbours, 1);
    std::printf(
        "seed %llu: %d of 400 corridor points from the neighbour search (%d barycentric); mean "
        "weight on the other rooms %.4f, %.3f of the points at least 0.9 from the corridor\n",
        static_cast<unsigned long long>(seed), neighbours, barycentric, meanOther, ownShare);
    EXPECT_EQ(barycentric, 0) << "seed " << seed;
    EXPECT_GE(neighbours, 150) << "seed " << seed;
    EXPECT_LE(meanOther, 0.03) << "seed " << seed;
    EXPECT_GE(ownShare, 0.9) << "seed " << seed;
  }
}

// The runtime reader runs the same search with the same weights: on a saved volume, at points
// of the corridor and all through the rooms, the same probes, count and fallback, and weights
// within 1e-12. A point on a face or edge two tetrahedra share (outside the hull, where the
// clamp lands on a hull edge) may be located in either by builds that round differently (the
// sanitizer build contracts to FMA): for such a tie, the same probes must get the same
// barycentric weights.
TEST(VisibleNeighbours, TheRuntimeReaderAgrees) {
  const Scene s = threeRooms();
  const Tracer tracer(s);
  const fs::path dir = ps::test::testTempDir("ps_test_visible_neighbours_");
  const VolumeFile vf = bake(tracer, probes(3));
  saveVolume(vf, dir / "v.psv");
  const VolumeFile loaded = loadVolume(dir / "v.psv");
  const ProbeVolume& v = loaded.volume;
  ps_runtime::Volume rv;
  std::string error;
  ASSERT_TRUE(ps_runtime::loadVolumeFile((dir / "v.psv").string().c_str(), rv, &error)) << error;
  std::vector<Query> queries = corridorPoints(7, 2000);
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 2000; ++i)
    queries.push_back(
        {Vec3{-0.2 + 5.4 * u(rng), -0.2 + 2.4 * u(rng), -0.2 + 4.4 * u(rng)}, std::nullopt});
  int neighbours = 0, ties = 0;
  for (const Query& q : queries) {
    const VolumeLocation a = locate(v, q.p);
    const ps_runtime::Location b = ps_runtime::locate(rv, q.p.x, q.p.y, q.p.z);
    if (a.tet != b.tet) {
      ++ties;
      std::vector<std::pair<int32_t, float>> ba, bb;
      for (int k = 0; k < 4; ++k) {
        if (a.weights[size_t(k)] > 0)
          ba.push_back({v.tets[size_t(a.tet)][k], a.weights[size_t(k)]});
        if (b.weights[k] > 0) bb.push_back({rv.tets[size_t(b.tet)][k], b.weights[k]});
      }
      std::sort(ba.begin(), ba.end());
      std::sort(bb.begin(), bb.end());
      ASSERT_EQ(ba, bb) << q.p.x << " " << q.p.y << " " << q.p.z;
      continue;
    }
    const VisibleWeights wa = visibleWeights(v, a, q.p, q.n);
    const double n[3] = {q.n ? q.n->x : 0, q.n ? q.n->y : 0, q.n ? q.n->z : 0};
    const ps_runtime::Weights wb =
        ps_runtime::visibleWeights(rv, b, q.p.x, q.p.y, q.p.z, q.n ? n : nullptr);
    ASSERT_EQ(int(wa.fallback), wb.fallback);
    ASSERT_EQ(wa.count, wb.count);
    for (int k = 0; k < wa.count; ++k) {
      ASSERT_EQ(wa.probes[size_t(k)], wb.probes[k]);
      ASSERT_NEAR(wa.weights[size_t(k)], wb.weights[k], 1e-12);
    }
    const ShRgb sa = interpolate(v, wa);
    float sb[27];
    ps_runtime::interpolate(rv, wb, sb);
    for (int k = 0; k < kShCoeffCount; ++k)
      for (int c = 0; c < 3; ++c)
        ASSERT_NEAR(static_cast<float>(sa.c[k][c]), sb[3 * k + c],
                    1e-6 * std::max(1.0, std::abs(sa.c[k][c])));
    neighbours += wa.fallback == VisibleFallback::Neighbours;
  }
  std::printf("%zu queries, %d from the neighbour search, %d ties\n", queries.size(), neighbours,
              ties);
  EXPECT_GT(neighbours, 100);
  EXPECT_LE(ties, int(queries.size() / 100));
}

// The search is bounded: at most kMaxNeighbourProbes probes, none of the point's own
// tetrahedron, no repeats; and a volume whose probes all hide the point keeps the barycentric
// weights.
TEST(VisibleNeighbours, TheSearchIsBoundedAndFallsBackWhenNoProbeSees) {
  const Scene s = threeRooms();
  const Tracer tracer(s);
  VolumeFile vf = bake(tracer, probes(2));
  ProbeVolume& v = vf.volume;
  int searched = 0;
  for (const Query& q : corridorPoints(4, 200)) {
    const VolumeLocation loc = locate(v, q.p);
    const VisibleWeights w = visibleWeights(v, loc, q.p, q.n);
    if (w.fallback != VisibleFallback::Neighbours) continue;
    ++searched;
    ASSERT_GE(w.count, 1);
    ASSERT_LE(w.count, kMaxNeighbourProbes);
    const auto& own = v.tets[size_t(loc.tet)];
    for (int k = 0; k < w.count; ++k) {
      EXPECT_EQ(std::count(own.begin(), own.end(), w.probes[size_t(k)]), 0);
      EXPECT_EQ(std::count(w.probes.begin(), w.probes.begin() + w.count, w.probes[size_t(k)]), 1);
    }
  }
  EXPECT_GT(searched, 0);
  // Every probe flagged inside geometry: no factor above 0, so the barycentric weights stand.
  std::fill(v.probeInside.begin(), v.probeInside.end(), uint8_t(1));
  for (const Query& q : corridorPoints(5, 50)) {
    const VolumeLocation loc = locate(v, q.p);
    const VisibleWeights w = visibleWeights(v, loc, q.p, q.n);
    EXPECT_EQ(w.fallback, VisibleFallback::Barycentric);
    ASSERT_EQ(w.count, 4);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(w.weights[size_t(k)], double(loc.weights[k]));
  }
}

namespace {

/// A volume where only probe `seeing` sees anything: every other probe's map holds a wall at
/// 1 mm in every direction (its factor is 0 for any point farther away), and `seeing`'s a wall at
/// 1 km. Constant SH per probe.
ProbeVolume oneSeeingProbe(const std::vector<Vec3>& points, size_t seeing) {
  std::vector<ShRgb> sh(points.size());
  std::vector<ProbeVisibility> vis(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    sh[i].c[0] = Rgb(double(i + 1), 1, 1);
    const double mu = i == seeing ? 1e3 : 1e-3;
    for (int t = 0; t < kVisibilityTexels; ++t) {
      vis[i].distanceMoments[size_t(2 * t)] = float(mu);
      vis[i].distanceMoments[size_t(2 * t + 1)] = float(mu * mu);
    }
  }
  return volumeFromProbes(points, sh, vis);
}

/// The face search's reach from `tet` (the test's own copy of its rule: the tets within two face
/// steps and their vertices), to tell the points the walk serves from those the face search does.
std::vector<int32_t> faceReach(const ProbeVolume& v, int32_t tet) {
  std::vector<int32_t> tets{tet}, probes;
  size_t begin = 0;
  for (int depth = 0; depth < kNeighbourSearchDepth; ++depth) {
    const size_t end = tets.size();
    for (size_t i = begin; i < end; ++i)
      for (int k = 0; k < 4; ++k) {
        const int32_t n = v.neighbors[size_t(tets[i])][k];
        if (n >= 0 && std::find(tets.begin(), tets.end(), n) == tets.end()) tets.push_back(n);
      }
    begin = end;
  }
  for (int32_t t : tets)
    for (int k = 0; k < 4; ++k) probes.push_back(v.tets[size_t(t)][k]);
  return probes;
}

}  // namespace

// The walk, after the face search: in a sliver of the hull (two jittered layers of probes, 2 m
// apart, and four probes 40 m above them), a point's tetrahedron and the tetrahedra two face
// steps around it may hold only probes far away. When only one probe sees anything, every point
// whose nearest probe it is takes all its light from it, whether it lies in the point's
// tetrahedron, in the face search's reach or beyond it (where only the walk to the nearest probe
// finds it); and the runtime reader gives the same probes and weights.
TEST(VisibleNeighbours, TheWalkReachesThePointsNearestProbe) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> j(-0.2, 0.2), u(0, 1);
  std::vector<Vec3> points;
  for (double y : {0.0, 2.0})
    for (int x = 0; x <= 5; ++x)
      for (int z = 0; z <= 5; ++z)
        points.push_back(Vec3{2.0 * x + j(rng), y + j(rng), 2.0 * z + j(rng)});
  for (double x : {-30.0, 40.0})
    for (double z : {-30.0, 40.0}) points.push_back(Vec3{x, 42.0, z});
  const fs::path dir = ps::test::testTempDir("ps_test_visible_walk_");
  int walked = 0, served = 0;
  for (size_t seeing : {size_t(50), size_t(57), size_t(64)}) {  // probes of the upper layer
    VolumeFile vf;
    vf.volume = oneSeeingProbe(points, seeing);
    vf.metadataJson = "{}";
    saveVolume(vf, dir / "v.psv");
    const ProbeVolume& v = vf.volume;
    ps_runtime::Volume rv;
    std::string error;
    ASSERT_TRUE(ps_runtime::loadVolumeFile((dir / "v.psv").string().c_str(), rv, &error)) << error;
    int32_t s = -1;  // the seeing probe's index in the volume
    for (size_t i = 0; i < v.probeCount(); ++i)
      if (length(v.position(int32_t(i)) - points[seeing]) < 1e-5) s = int32_t(i);
    ASSERT_GE(s, 0);
    for (int i = 0; i < 3000; ++i) {
      const Vec3 p{-0.5 + 11 * u(rng), 2.3 + 6 * u(rng), -0.5 + 11 * u(rng)};
      int32_t nearest = 0;
      for (size_t k = 1; k < v.probeCount(); ++k)
        if (length(p - v.position(int32_t(k))) < length(p - v.position(nearest)))
          nearest = int32_t(k);
      const VolumeLocation loc = locate(v, p);
      ASSERT_GE(loc.tet, 0);
      const VisibleWeights w = visibleWeights(v, loc, p, std::nullopt);
      const ps_runtime::Location b = ps_runtime::locate(rv, p.x, p.y, p.z);
      if (b.tet == loc.tet) {
        const ps_runtime::Weights wb = ps_runtime::visibleWeights(rv, b, p.x, p.y, p.z, nullptr);
        ASSERT_EQ(int(w.fallback), wb.fallback);
        ASSERT_EQ(w.count, wb.count);
        for (int k = 0; k < w.count; ++k) {
          ASSERT_EQ(w.probes[size_t(k)], wb.probes[k]);
          ASSERT_NEAR(w.weights[size_t(k)], wb.weights[k], 1e-12);
        }
      }
      if (nearest != s) continue;
      ++served;
      double onS = 0;
      for (int k = 0; k < w.count; ++k)
        if (w.probes[size_t(k)] == s) onS += w.weights[size_t(k)];
      EXPECT_NEAR(onS, 1.0, 1e-9) << p.x << " " << p.y << " " << p.z;
      const std::vector<int32_t> reach = faceReach(v, loc.tet);
      if (std::find(reach.begin(), reach.end(), s) == reach.end()) ++walked;
    }
  }
  std::printf("%d points nearest the seeing probe, %d of them beyond the face search\n", served,
              walked);
  EXPECT_GT(walked, 0);
}
