// Regional greedy (core/placement/RegionalGreedy.h) on synthetic dense fields: the budget placed
// exactly, the same probes run after run, and the budget shared by the error of each region.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/common/Error.h"
#include "core/placement/GreedyMethod.h"
#include "core/placement/PlacementMethod.h"
#include "core/placement/RegionalGreedy.h"
#include "core/trace/Tracer.h"
#include "tests/core/SceneBuilders.h"

namespace ps {
namespace {

/// A cell-centred grid of samples (cells of `h` metres) over [0, 16] x [0, 3] x [0, 3] m, their
/// radiance uniform (SH DC only) and of value 1 where x < 8; where x >= 8, a bright spot at
/// (12, 1.5, 1.5) adds 20 / (1 + d^2) to the DC term and tilts the l = 1 band towards it.
DenseField halfLitField(double h) {
  DenseField f;
  f.baseSpacingMeters = h;
  for (double x = 0.5 * h; x < 16; x += h)
    for (double y = 0.5 * h; y < 3; y += h)
      for (double z = 0.5 * h; z < 3; z += h) {
        FieldSample s;
        s.position = {x, y, z};
        s.cellSize = h;
        double dc = 1;
        Vec3 tilt;
        if (x >= 8) {
          const Vec3 d = Vec3(12, 1.5, 1.5) - s.position;
          const double bump = 20 / (1 + dot(d, d));
          dc += bump;
          tilt = d * (0.1 * bump / (1 + std::sqrt(dot(d, d))));
        }
        s.sh.c[0] = Rgb(dc, dc, dc);
        s.sh.c[1] = Rgb(tilt.y, tilt.y, tilt.y);
        s.sh.c[2] = Rgb(tilt.z, tilt.z, tilt.z);
        s.sh.c[3] = Rgb(tilt.x, tilt.x, tilt.x);
        f.domain.extend(s.position);
        f.samples.push_back(s);
      }
  return f;
}

TEST(RegionalGreedy, PlacesTheBudgetDeterministically) {
  const DenseField f = halfLitField(0.5);
  GreedySettings s;
  s.budget = 64;
  s.swapPasses = 1;
  s.swapNeighbours = 8;
  const RegionalGreedyResult a = placeRegionalGreedy(f, {}, s, 4, {});
  const RegionalGreedyResult b = placeRegionalGreedy(f, {}, s, 4, {});
  ASSERT_EQ(a.positions.size(), 64u);
  ASSERT_EQ(a.regions.size(), 4u);
  EXPECT_EQ(a.sampleIndex, b.sampleIndex);
  EXPECT_EQ(a.fieldError, b.fieldError);
  size_t sum = 0;
  for (const GreedyRegion& r : a.regions) {
    EXPECT_TRUE(r.refused.empty()) << r.refused;
    sum += r.probes;
  }
  EXPECT_EQ(sum, 64u);
  // Every probe is a field sample of its own region's box, and no sample is used twice.
  std::vector<char> used(f.samples.size(), 0);
  for (size_t i : a.sampleIndex) {
    ASSERT_LT(i, f.samples.size());
    EXPECT_FALSE(used[i]);
    used[i] = 1;
  }
  size_t k = 0;
  for (const GreedyRegion& r : a.regions)
    for (size_t m = 0; m < r.probes; ++m, ++k) {
      const Vec3 p = a.positions[k];
      EXPECT_TRUE(p.x >= r.box.lo.x && p.x <= r.box.hi.x && p.y >= r.box.lo.y &&
                  p.y <= r.box.hi.y && p.z >= r.box.lo.z && p.z <= r.box.hi.z);
    }
}

TEST(RegionalGreedy, RegionsGetProbesByTheirError) {
  // Two regions, cut at x = 8: the uniform half is interpolated exactly by its initial
  // corners, so its error curve is flat and every further probe goes to the lit half.
  const DenseField f = halfLitField(0.5);
  GreedySettings s;
  s.budget = 48;
  const RegionalGreedyResult r = placeRegionalGreedy(f, {}, s, 2, {});
  ASSERT_EQ(r.regions.size(), 2u);
  const GreedyRegion& uniform = r.regions[0].box.hi.x < 8 ? r.regions[0] : r.regions[1];
  const GreedyRegion& lit = r.regions[0].box.hi.x < 8 ? r.regions[1] : r.regions[0];
  EXPECT_LT(uniform.box.hi.x, 8);
  EXPECT_GT(lit.box.lo.x, 8);
  EXPECT_EQ(uniform.probes, 8u) << "the uniform half keeps only its initial corners";
  EXPECT_EQ(lit.probes, 40u);
  EXPECT_LT(uniform.weightedErrSq, 1e-12 * lit.weightedErrSq + 1e-20);
  // The measuring pass saw past the lit region's final count, so its share was the error's.
  EXPECT_GT(lit.measuredProbes, 24u);
}

/// A 0.5 m grid of samples over rooms along x (x in [0, 4 rooms]), y in [0, 3], z in [0, 6],
/// those in a wall left out; each room lit by a lamp at its centre.
DenseField roomsField(const RoomMap& rooms, int count) {
  DenseField f;
  f.baseSpacingMeters = 0.5;
  for (double x = 0.25; x < 4 * count; x += 0.5)
    for (double y = 0.25; y < 3; y += 0.5)
      for (double z = 0.25; z < 6; z += 0.5) {
        FieldSample smp;
        smp.position = {x, y, z};
        smp.cellSize = 0.5;
        if (rooms.roomOf(smp.position) < 0) continue;                           // in a wall
        const Vec3 d = Vec3(2 + 4 * std::floor(x / 4), 2.5, 3) - smp.position;  // a lamp a room
        const double dc = 1 + 10 / (1 + dot(d, d));
        smp.sh.c[0] = Rgb(dc, dc, dc);
        f.domain.extend(smp.position);
        f.samples.push_back(smp);
      }
  return f;
}

TEST(RegionalGreedy, RegionsAreWholeRoomsTheSameOnOneThreadAndOnMany) {
  // Six rooms in a row (x in [4k, 4k + 4], walls at x = 4, 8, ..., 20): four k-d regions would
  // cut through rooms; with the rooms (each half a region's share), every region is a union of
  // whole rooms.
  const Scene scene = testing::roomsInARow(6);
  const Tracer tracer(scene);
  const RoomMap rooms(tracer, {});
  ASSERT_EQ(rooms.roomCount(), 6);
  const DenseField f = roomsField(rooms, 6);
  GreedySettings s;
  s.budget = 80;
  s.swapPasses = 1;
  s.swapNeighbours = 8;
  RegionalGreedyResult one;
  tbb::task_arena(1).execute([&] { one = placeRegionalGreedy(f, {}, s, 4, {}, {}, &rooms); });
  const RegionalGreedyResult many = placeRegionalGreedy(f, {}, s, 4, {}, {}, &rooms);
  EXPECT_EQ(one.sampleIndex, many.sampleIndex);
  EXPECT_EQ(one.fieldError, many.fieldError);
  ASSERT_EQ(many.positions.size(), 80u);
  ASSERT_EQ(many.regions.size(), 4u);
  // Each room's samples all lie in one region's box, and the boxes do not share a room.
  for (int room = 0; room < 6; ++room) {
    int holding = 0;
    for (const GreedyRegion& r : many.regions)
      holding += r.samples > 0 && r.box.lo.x < 4 * room + 2 && r.box.hi.x > 4 * room + 2;
    EXPECT_EQ(holding, 1) << "room " << room;
  }
  for (const GreedyRegion& r : many.regions) {
    ASSERT_GT(r.samples, 0u);
    EXPECT_LT(std::abs(r.box.lo.x - 4 * std::round(r.box.lo.x / 4)), 0.3) << r.box.lo.x;
    EXPECT_LT(std::abs(r.box.hi.x - 4 * std::round(r.box.hi.x / 4)), 0.3) << r.box.hi.x;
  }
}

// A room that weighs more than a region (here two rooms, each one and a half regions' share)
// is parted by the k-d planes rather than given whole to one region: every region gets
// samples and probes, and the regions' samples differ by at most a factor of 2 (whole rooms
// would leave a region with none, or one with three times another's).
TEST(RegionalGreedy, ARoomLargerThanARegionIsParted) {
  const Scene scene = testing::roomsInARow(2);
  const Tracer tracer(scene);
  const RoomMap rooms(tracer, {});
  ASSERT_EQ(rooms.roomCount(), 2);
  const DenseField f = roomsField(rooms, 2);
  GreedySettings s;
  s.budget = 48;
  const RegionalGreedyResult r = placeRegionalGreedy(f, {}, s, 3, {}, {}, &rooms);
  ASSERT_EQ(r.regions.size(), 3u);
  size_t fewest = f.samples.size(), most = 0;
  for (const GreedyRegion& g : r.regions) {
    EXPECT_TRUE(g.refused.empty()) << g.refused;
    EXPECT_GT(g.probes, 0u);
    fewest = std::min(fewest, g.samples);
    most = std::max(most, g.samples);
  }
  EXPECT_LE(most, 2 * fewest);
}

// A region whose error points are mostly unresolved (every sample's standard error as large as
// its light) skips its swaps and says so, and keeps the first pass's probes: the same probes as
// a run that asks for no swaps.
TEST(RegionalGreedy, RegionsWhoseLightIsUnresolvedDoNotSwap) {
  DenseField f = halfLitField(0.5);
  for (FieldSample& smp : f.samples)
    for (int k = 0; k < kShCoeffCount; ++k) smp.shStdError.c[k] = smp.sh.c[0] * 2.0;
  GreedySettings s;
  s.objective = GreedyObjective::kPerceptual;
  s.budget = 48;
  s.swapPasses = 2;
  s.swapNeighbours = 8;
  const RegionalGreedyResult swapsAsked = placeRegionalGreedy(f, {}, s, 2, {});
  s.swapPasses = 0;
  const RegionalGreedyResult noSwaps = placeRegionalGreedy(f, {}, s, 2, {});
  ASSERT_GT(swapsAsked.unresolvedShare, kGreedyUnresolvedShareLimit);
  for (const GreedyRegion& r : swapsAsked.regions) {
    if (r.probes > 0) {
      EXPECT_TRUE(r.swapsSkipped);
    }
  }
  for (const GreedyRegion& r : noSwaps.regions) EXPECT_FALSE(r.swapsSkipped);
  EXPECT_EQ(swapsAsked.swaps, 0u);
  EXPECT_EQ(swapsAsked.sampleIndex, noSwaps.sampleIndex);
}

TEST(RegionalGreedy, RefusesTooSmallABudget) {
  const DenseField f = halfLitField(1.0);
  GreedySettings s;
  s.budget = 20;
  EXPECT_THROW(placeRegionalGreedy(f, {}, s, 4, {}), ParameterError);
}

TEST(RegionalGreedy, AutoSplitsOnlyLargeBudgets) {
  // Plain greedy up to kRegionalMinNewProbes new probes: the scenes' benchmarks (32 to 512
  // probes) run as they did.
  EXPECT_EQ(regionalGreedyRegions(32), 1);
  EXPECT_EQ(regionalGreedyRegions(512), 1);
  EXPECT_EQ(regionalGreedyRegions(size_t(kRegionalMinNewProbes) + 1),
            (kRegionalMinNewProbes + 1) / kRegionalProbesPerRegion);
  EXPECT_EQ(regionalGreedyRegions(4096), 4096 / kRegionalProbesPerRegion);
  GreedyMethodSettings m;
  EXPECT_EQ(greedyRegions(m, 512, 0), 1);
  EXPECT_EQ(greedyRegions(m, 0, 0), 1);
  m.regions = 1;
  EXPECT_EQ(greedyRegions(m, 4096, 0), 1);
}

TEST(RegionalGreedy, RegionsParameterIsChecked) {
  auto refusal = [](const std::string& word, int budget) -> std::string {
    PlaceParameters p;
    p.setText("regions", word);
    try {
      greedyPlacementMethod().create(p, PlaceBasics{budget, 0});
    } catch (const ParameterError& e) {
      return e.parameter();
    }
    return "";
  };
  EXPECT_EQ(refusal("auto", 64), "");
  EXPECT_EQ(refusal("off", 64), "");
  EXPECT_EQ(refusal("4", 64), "");
  EXPECT_EQ(refusal("many", 64), "regions");
  EXPECT_EQ(refusal("0", 64), "regions");
  EXPECT_EQ(refusal("4x", 64), "regions");
  EXPECT_EQ(refusal("16", 64), "regions");  // 8 new probes per region at least
}

}  // namespace
}  // namespace ps
