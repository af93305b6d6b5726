// The domain of interest (core/domain/DomainPoints.h) and the reachable space it is by default
// (core/domain/ReachableSpace.h): what it keeps, what it leaves out, and that placement and eval
// keep to it.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "SceneBuilders.h"
#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "core/domain/FreeSpaceGrid.h"
#include "core/domain/ReachableSpace.h"
#include "core/eval/Evaluate.h"
#include "core/io/ProbeSet.h"
#include "core/math/Random.h"
#include "core/placement/Place.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;
using namespace ps::testing;

namespace {

const fs::path kScenes = fs::path(PS_SOURCE_DIR) / "resources" / "scenes";

/// A closed house (an 8 x 3 x 8 m room inside 0.2 m walls, floor and roof) standing on a
/// ground quad of half-size `groundHalf` at y = 0; with `poleHeight` > 0 a thin solid pole
/// at the ground's corner lifts the scene bounds to that height.
Scene houseOnGround(double groundHalf, double poleHeight) {
  Scene s;
  const uint32_t m = addMaterial(s, {0.5, 0.5, 0.5});
  addQuad(s, {-groundHalf, 0, -groundHalf}, {0, 0, 2 * groundHalf}, {2 * groundHalf, 0, 0}, m);
  addBox(s, {-4, 0.2, -4}, {4, 3.2, 4}, m, true);           // the room, seen from inside
  addBox(s, {-4.2, 0.0, -4.2}, {4.2, 3.4, 4.2}, m, false);  // the shell, seen from outside
  if (poleHeight > 0)
    addBox(s, {groundHalf - 0.2, 0, groundHalf - 0.2}, {groundHalf, poleHeight, groundHalf}, m,
           false);
  return s;
}

/// The share of `points` valid in `inside`.
double shareInside(const std::vector<Vec3>& points, const ReachableSpace& inside) {
  size_t n = 0;
  for (const Vec3& p : points) n += inside.contains(p) ? 1 : 0;
  return points.empty() ? 0.0 : double(n) / double(points.size());
}

}  // namespace

TEST(ReachableSpace, TwoRoomsHoldsAllOfItsFreeSpace) {
  const Scene scene = loadScene(kScenes / "two-rooms.gltf");
  const Tracer tracer(scene);
  const ReachableSpace reach(tracer, {});
  EXPECT_TRUE(reach.interior());
  // Uniform points of the free space of the scene bounds (the bounds rule's domain).
  const DomainPoints bounds(tracer, LightingRig{}, std::span<const Bounds3>{}, 0.0);
  const std::vector<Vec3> free = bounds.drawMany(4000, 3);
  ASSERT_GT(free.size(), 3900u);
  EXPECT_GT(shareInside(free, reach), 0.99);
  // Both rooms, floor to ceiling.
  for (double x : {-5.5, -3.0, -0.5, 0.5, 3.0, 5.5})
    for (double y : {0.3, 1.5, 2.7}) EXPECT_TRUE(reach.contains({x, y, 0.0})) << x << " " << y;
  // Its cells: the rooms', and those against their walls (partly inside the walls).
  EXPECT_GT(reach.reachableCubicMeters(), 2 * 6 * 3 * 6);
  EXPECT_LT(reach.reachableCubicMeters(), 2 * 6.5 * 3.5 * 6.5);
}

TEST(ReachableSpace, AnInteriorLeavesOutTheAirAroundItsWalls) {
  // The ground reaches 0.8 m beyond the house's walls: the rooms outweigh the band outside.
  const Scene scene = houseOnGround(5.0, 0.0);
  const Tracer tracer(scene);
  const ReachableSpace reach(tracer, {});
  EXPECT_TRUE(reach.interior()) << reach.summary();
  for (double x : {-3.5, 0.0, 3.5})
    for (double y : {0.5, 1.7, 3.0}) {
      EXPECT_TRUE(reach.contains({x, y, 0.0})) << x << " " << y;   // inside
      EXPECT_FALSE(reach.contains({4.7, y, x})) << x << " " << y;  // beside the walls
      EXPECT_FALSE(reach.contains({x, y, -4.7})) << x << " " << y;
    }
  EXPECT_GT(reach.reachableCubicMeters(), 8 * 3 * 8);
  EXPECT_LT(reach.reachableCubicMeters(), 9 * 4 * 9);  // a layer of cells around it at most
  // Its shell, drawn by the editor: faces inside the room, none out on the ground.
  const auto shell = reach.shellFaces(0);
  ASSERT_GT(shell.size(), 4 * 8 * 8u);
  for (const auto& face : shell)
    for (const Vec3& p : face) {
      EXPECT_LE(std::abs(p.x), 4.0) << p;
      EXPECT_LE(std::abs(p.z), 4.0) << p;
    }
  EXPECT_LE(reach.shellFaces(100).size(), 100u);
}

TEST(ReachableSpace, AnExteriorKeepsTheBandAboveItsGroundAndNotTheAirAbove) {
  // A 40 x 40 m ground with the house on it and a 12 m pole: an exterior, whose band is the
  // 3 m above the ground (and the roof); the air above it is left out.
  const Scene scene = houseOnGround(20.0, 12.0);
  const Tracer tracer(scene);
  ReachableSettings s;
  s.cellMeters = 0.5;
  const ReachableSpace reach(tracer, {}, s);
  EXPECT_FALSE(reach.interior()) << reach.summary();
  for (double x : {-15.0, -8.0, 8.0, 15.0})
    for (double z : {-15.0, 0.0, 15.0}) {
      EXPECT_TRUE(reach.contains({x, 0.3, z})) << x << " " << z;
      EXPECT_TRUE(reach.contains({x, 2.2, z})) << x << " " << z;
      EXPECT_FALSE(reach.contains({x, 3.6, z})) << x << " " << z;
      EXPECT_FALSE(reach.contains({x, 8.0, z})) << x << " " << z;
    }
  EXPECT_TRUE(reach.contains({0, 1.5, 0}));     // inside the house
  EXPECT_FALSE(reach.contains({0, 8.0, 0}));    // high above its roof
  EXPECT_FALSE(reach.contains({0, 3.3, 4.1}));  // inside its wall
  // A band of 1 m keeps less.
  s.bandMeters = 1.0;
  const ReachableSpace low(tracer, {}, s);
  EXPECT_TRUE(low.contains({8, 0.3, 8}));
  EXPECT_FALSE(low.contains({8, 2.2, 8}));
}

TEST(FreeSpaceGrid, TheAutomaticCellFitsMaxCellsAfterTheCeil) {
  // The full generated level's bounds, 200 x 14.3 x 60 m: cbrt(volume / maxCells) would make
  // more than maxCells cells once each axis is rounded up; the edge chosen never does, and is
  // the finest that does not.
  const Scene scene = twoRoomsWithADoor();
  const Tracer tracer(scene);
  const std::vector<Bounds3> level = {{Vec3(0, 0, 0), Vec3(200, 14.3, 60)}};
  for (size_t maxCells : {size_t(1000), size_t(400000), size_t(1234567), size_t(10000000)}) {
    const FreeSpaceGrid::CellChoice c = FreeSpaceGrid::chooseCell(tracer, level, 0, 0.25, maxCells);
    EXPECT_LE(FreeSpaceGrid::cellsAt(level[0], c.meters), maxCells);
    EXPECT_GT(FreeSpaceGrid::cellsAt(level[0], c.meters * (1 - 1e-6)), maxCells);
    EXPECT_NE(c.note.find("above maxCells " + std::to_string(maxCells)), std::string::npos);
  }
  // The rule's edge when it fits; an edge given is kept.
  EXPECT_EQ(FreeSpaceGrid::chooseCell(tracer, level, 0, 1.0, 1000000).meters, 1.0);
  EXPECT_TRUE(FreeSpaceGrid::chooseCell(tracer, level, 0, 1.0, 1000000).note.empty());
  EXPECT_EQ(FreeSpaceGrid::chooseCell(tracer, level, 0.1, 0.25, 1000).meters, 0.1);
}

TEST(FreeSpaceGrid, ItsGroupsGiveEveryCellItsOwnValidityOnClosedGeometry) {
  // The grid tests validity once per group of cells with no surface between them; on closed
  // boxes every cell then has the outcome its own test gives (DomainPoints::valid).
  const Scene built = twoRoomsWithADoor(), house = houseOnGround(5.0, 0.0);
  const Scene bundled = loadScene(kScenes / "two-rooms.gltf");
  for (const Scene* scene : {&built, &house, &bundled})
    for (double cell : {0.25, 0.37}) {
      const Tracer tracer(*scene);
      const FreeSpaceGrid grid(tracer, {}, cell, 1000000, 1);
      const DomainPoints points(tracer, LightingRig{}, std::span<const Bounds3>{}, 0.0);
      size_t differ = 0;
      for (size_t c = 0; c < grid.cellCount(); ++c)
        differ += grid.isFree(c) != points.valid(grid.centre(c), streamSeed(1, c));
      EXPECT_EQ(differ, 0u) << "of " << grid.cellCount() << " cells at " << cell << " m";
    }
}

TEST(ReachableSpace, ADomainTooLargeForTheRulesCellGetsACoarserOneAndKeepsItsSpace) {
  // twoRoomsWithADoor's bounds make 18200 cells of 0.25 m: at most 3000 the automatic cell is
  // coarser, with a note, not refused; the space kept is the rooms' within half a cell over
  // their walls, floors and ceilings, and the middle of both rooms is in it.
  const Scene scene = twoRoomsWithADoor();
  const Tracer tracer(scene);
  const ReachableSpace fine(tracer, {});
  EXPECT_EQ(fine.cellMeters(), 0.25);
  EXPECT_TRUE(fine.note().empty()) << fine.note();
  ReachableSettings s;
  s.maxCells = 3000;
  const ReachableSpace coarse(tracer, {}, s);
  EXPECT_GT(coarse.cellMeters(), 0.25);
  EXPECT_LE(FreeSpaceGrid::cellsAt(scene.bounds, coarse.cellMeters()), 3000u);
  EXPECT_NE(coarse.note().find("above maxCells 3000"), std::string::npos) << coarse.note();
  EXPECT_NE(coarse.summary().find(coarse.note()), std::string::npos);
  EXPECT_TRUE(fine.interior() && coarse.interior()) << coarse.summary();
  const double rooms = 2 * 5.95 * 3 * 6, surface = 2 * 2 * (5.95 * 3 + 5.95 * 6 + 3 * 6);
  EXPECT_NEAR(fine.keptFreeCubicMeters(), rooms, surface * fine.cellMeters() / 2) << fine.summary();
  EXPECT_NEAR(coarse.keptFreeCubicMeters(), rooms, surface * coarse.cellMeters() / 2)
      << coarse.summary();
  for (double x : {1.0, 3.0, 9.0, 11.0})
    for (double y : {0.5, 1.5, 2.5}) EXPECT_TRUE(coarse.contains({x, y, 3.0})) << x << " " << y;
  // An edge given that makes more cells is refused, naming it.
  s.cellMeters = 0.25;
  try {
    ReachableSpace(tracer, {}, s);
    FAIL() << "no throw";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "cellMeters");
  }
}

TEST(ReachableSpace, EnclosureNearItsLimitIsEachCellsOwnOutcome) {
  // Inside Cornell's open-fronted box about a quarter of the rays escape, the enclosure test's
  // limit: there its outcome is noise, and must not be spread over neighbours. Each cell tested
  // on its own keeps 64.5 m^3 of it (and 214.5 m^3 of two-rooms, which has no opening).
  for (const auto& [name, kept] : {std::pair{"cornell.gltf", 64.5}, {"two-rooms.gltf", 214.5}}) {
    const Scene scene = loadScene(kScenes / name);
    const Tracer tracer(scene);
    const ReachableSpace reach(tracer, {});
    EXPECT_NEAR(reach.keptFreeCubicMeters(), kept, 0.005 * kept) << name << ": " << reach.summary();
  }
}

TEST(ReachableSpace, IsDeterministicAndDrawsStayInIt) {
  const Scene scene = loadScene(kScenes / "cornell.gltf");
  const Tracer tracer(scene);
  const Domain a = makeDomain(tracer, {}, DomainSettings{});
  const Domain b = makeDomain(tracer, {}, DomainSettings{});
  ASSERT_TRUE(a.reachable && b.reachable);
  EXPECT_EQ(a.reachable->cellCorners(), b.reachable->cellCorners());
  // Cornell's box is taller than the band: its top is left out.
  EXPECT_LT(a.reachable->reachableCubicMeters(), 0.8 * a.reachable->freeCubicMeters());
  const DomainPoints pa(tracer, LightingRig{}, a, 0.02), pb(tracer, LightingRig{}, b, 0.02);
  const std::vector<Vec3> da = pa.drawMany(2000, 5), db = pb.drawMany(2000, 5);
  EXPECT_EQ(da, db);
  EXPECT_NE(da, pa.drawMany(2000, 6));
  EXPECT_EQ(shareInside(da, *a.reachable), 1.0);
  // Uniform over the reachable volume: the two halves of its height range hold shares of the
  // points in proportion to their volumes (within sampling noise).
  double lo = 1e9, hi = -1e9;
  for (const Vec3& c : a.reachable->cellCorners()) {
    lo = std::min(lo, c.y);
    hi = std::max(hi, c.y + a.reachable->cellMeters());
  }
  const double mid = 0.5 * (lo + hi);
  size_t cellsBelow = 0, pointsBelow = 0;
  for (const Vec3& c : a.reachable->cellCorners())
    cellsBelow += c.y + 0.5 * a.reachable->cellMeters() < mid;
  for (const Vec3& p : da) pointsBelow += p.y < mid;
  EXPECT_NEAR(double(pointsBelow) / double(da.size()),
              double(cellsBelow) / double(a.reachable->cellCorners().size()), 0.05);
}

TEST(Domain, TheBoundsRuleIsTheBoxesAsBefore) {
  const Scene scene = loadScene(kScenes / "two-rooms.gltf");
  const Tracer tracer(scene);
  DomainSettings s;
  s.rule = DomainRule::Bounds;
  const Domain d = makeDomain(tracer, {}, s);
  EXPECT_FALSE(d.reachable);
  const DomainPoints viaDomain(tracer, LightingRig{}, d, 0.02);
  const DomainPoints viaBoxes(tracer, LightingRig{}, std::span<const Bounds3>{}, 0.02);
  EXPECT_EQ(viaDomain.drawMany(500, 9), viaBoxes.drawMany(500, 9));
  // Importance volumes are the domain as drawn under either rule.
  const std::vector<Bounds3> box = {{Vec3(-5, 0.5, -2), Vec3(-1, 2.5, 2)}};
  EXPECT_FALSE(makeDomain(tracer, box, DomainSettings{}).reachable);
}

TEST(Domain, MalformedSettingsAreNamed) {
  EXPECT_EQ(parseDomainRule("reachable"), DomainRule::Reachable);
  EXPECT_EQ(parseDomainRule("bounds"), DomainRule::Bounds);
  try {
    parseDomainRule("everywhere");
    FAIL() << "no throw";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "domain");
    EXPECT_NE(std::string(e.what()).find("reachable or bounds"), std::string::npos) << e.what();
  }
  auto named = [](ReachableSettings s) {
    try {
      checkReachableSettings(s);
    } catch (const ParameterError& e) {
      return e.parameter();
    }
    return std::string();
  };
  ReachableSettings s;
  EXPECT_EQ(named(s), "");
  s.bandMeters = 0;
  EXPECT_EQ(named(s), "bandMeters");
  s = {};
  s.maxSlopeDeg = 90;
  EXPECT_EQ(named(s), "maxSlopeDeg");
  s = {};
  s.cellMeters = -1;
  EXPECT_EQ(named(s), "cellMeters");
  s = {};
  s.maxOpenFraction = 1.5;
  EXPECT_EQ(named(s), "maxOpenFraction");
}

TEST(Domain, EvalQueriesAndGreedyProbesLieInIt) {
  const Scene scene = loadScene(kScenes / "cornell.gltf");
  const Tracer tracer(scene);
  const Domain domain = makeDomain(tracer, {}, DomainSettings{});
  ASSERT_TRUE(domain.reachable);
  EvalSettings es;
  es.queries = 300;
  es.referenceSpp = 4;
  es.reachable = domain.reachable;
  const EvalReference ref = computeReference(tracer, LightingRig{}, es);
  ASSERT_EQ(ref.points.size(), 300u);
  EXPECT_EQ(shareInside(ref.points, *domain.reachable), 1.0);

  ProbeSet set;
  PlaceRequest r;
  r.method = "greedy";
  r.budget = 24;
  r.parameters.set("fieldSamplesPerProbe", 16);
  r.parameters.set("fieldDepth", 1);
  r.parameters.set("heldOutPerProbe", 4);
  r.parameters.set("candidateSamplesPerProbe", 16);
  r.parameters.set("swapPasses", 0);
  const PlaceResult placed = placeProbeSet(tracer, set, r);
  ASSERT_EQ(placed.set.probes.size(), 24u);
  for (const Probe& p : placed.set.probes)
    EXPECT_TRUE(domain.reachable->contains(p.position)) << p.position;
  PlaceRequest u;
  u.budget = 24;
  for (const Probe& p : placeProbeSet(tracer, set, u).set.probes)
    EXPECT_TRUE(domain.reachable->contains(p.position)) << p.position;
}
