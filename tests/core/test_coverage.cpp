// Coverage before error (core/placement/Coverage.h): every room gets probes of its own that see
// it, the domain lies inside the probes' hull, and `place` refuses a budget below the covering.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "core/domain/Rooms.h"
#include "core/placement/Coverage.h"
#include "core/placement/Place.h"
#include "core/trace/Tracer.h"
#include "tests/core/SceneBuilders.h"

using namespace ps;
using namespace ps::testing;

namespace {

constexpr int kRooms = 5;

struct Row {
  Scene scene = roomsInARow(kRooms);
  Tracer tracer{scene};
  Domain domain = makeDomain(tracer, {}, DomainSettings{});
  RoomMap rooms{tracer, {}};
};

const Row& row() {
  static const Row r;
  return r;
}

bool sees(const Tracer& tracer, Vec3 a, Vec3 b) {
  const Vec3 d = b - a;
  return length(d) < 1e-9 || !tracer.occluded(Ray{a, d, 1e-6, 1 - 1e-6});
}

}  // namespace

TEST(Coverage, EveryRoomGetsProbesOfItsOwnThatSeeIt) {
  const Row& w = row();
  ASSERT_EQ(w.rooms.roomCount(), kRooms);
  const CoverageResult c = coverDomain(w.tracer, w.domain, {}, {}, 0);
  EXPECT_EQ(c.rooms, kRooms);
  EXPECT_EQ(c.roomProbes + c.hullProbes, c.probes.size());
  // Each room: probes of its own, and (a convex room) every cell in the domain seen by one.
  for (int r = 0; r < kRooms; ++r) {
    std::vector<Vec3> own;
    for (const Vec3& p : std::span(c.probes).first(c.roomProbes))
      if (w.rooms.roomOf(p) == r) own.push_back(p);
    ASSERT_FALSE(own.empty()) << "room " << r;
    size_t cells = 0, unseen = 0;
    for (size_t k = 0; k < w.rooms.cellCount(); ++k) {
      const Vec3 p = w.rooms.cellCentre(k);
      if (w.rooms.roomOfCell(k) != r || !w.domain.contains(p)) continue;
      ++cells;
      unseen +=
          std::none_of(own.begin(), own.end(), [&](const Vec3& q) { return sees(w.tracer, q, p); });
    }
    ASSERT_GT(cells, 0u);
    EXPECT_LE(double(unseen), CoverageSettings{}.unseenShare * double(cells)) << "room " << r;
  }
  // The hull: in every direction of a cube's faces, edges and corners, the probes reach as far
  // as the domain's cells, within a cell.
  for (int z = -1; z <= 1; ++z)
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x) {
        if (x == 0 && y == 0 && z == 0) continue;
        const Vec3 d = normalize(Vec3{double(x), double(y), double(z)});
        double cellMost = -1e300, probeMost = -1e300;
        for (size_t k = 0; k < w.rooms.cellCount(); ++k)
          if (w.rooms.roomOfCell(k) >= 0 && w.domain.contains(w.rooms.cellCentre(k)))
            cellMost = std::max(cellMost, dot(d, w.rooms.cellCentre(k)));
        for (const Vec3& p : c.probes) probeMost = std::max(probeMost, dot(d, p));
        EXPECT_GE(probeMost, cellMost - w.rooms.cellMeters()) << d;
      }
  // Deterministic, whatever the threads' order.
  const CoverageResult again = coverDomain(w.tracer, w.domain, {}, {}, 0);
  ASSERT_EQ(again.probes.size(), c.probes.size());
  for (size_t i = 0; i < c.probes.size(); ++i) EXPECT_EQ(again.probes[i], c.probes[i]);
}

TEST(Coverage, KeptProbesCoverTheirRoomAndRejectedSpotsStayEmpty) {
  const Row& w = row();
  const Vec3 keptAt{2, 1.5, 3};       // the middle of room x in [0, 3.95]
  const Vec3 rejectedAt{10, 1.5, 3};  // the middle of room x in [8.05, 11.95]
  const CoverageResult c = coverDomain(w.tracer, w.domain, std::vector<Vec3>{keptAt},
                                       std::vector<Vec3>{rejectedAt}, 1.0);
  EXPECT_EQ(c.roomsCoveredByKept, 1);
  for (const Vec3& p : std::span(c.probes).first(c.roomProbes))
    EXPECT_NE(w.rooms.roomOf(p), w.rooms.roomOf(keptAt)) << p;
  for (const Vec3& p : c.probes) EXPECT_GE(length(p - rejectedAt), 1.0) << p;
  ASSERT_GE(w.rooms.roomOf(rejectedAt), 0);
  EXPECT_TRUE(std::any_of(c.probes.begin(), c.probes.end(), [&](const Vec3& p) {
    return w.rooms.roomOf(p) == w.rooms.roomOf(rejectedAt);
  }));
}

TEST(Coverage, PlaceRefusesABudgetBelowTheCoveringWithItsSize) {
  const Row& w = row();
  ProbeSet set;
  PlaceRequest r;  // uniform on the reachable domain
  r.budget = 0;
  const PlaceResult free = placeProbeSet(w.tracer, set, r);
  const size_t minimum = free.minimumBudget;
  EXPECT_EQ(free.covered, minimum);
  ASSERT_GE(minimum, size_t(kRooms));
  r.budget = int(minimum) - 1;
  try {
    placeProbeSet(w.tracer, set, r);
    FAIL() << "a budget below the covering was accepted";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "budget");
    EXPECT_NE(std::string(e.what()).find("give at least " + std::to_string(minimum)),
              std::string::npos)
        << e.what();
  }
  // At the minimum, the covering alone, and every room holds a probe.
  r.budget = int(minimum);
  const PlaceResult exact = placeProbeSet(w.tracer, set, r);
  EXPECT_EQ(exact.set.probes.size(), minimum);
  std::vector<int> held(kRooms, 0);
  for (const Probe& p : exact.set.probes)
    if (w.rooms.roomOf(p.position) >= 0) ++held[size_t(w.rooms.roomOf(p.position))];
  for (int k = 0; k < kRooms; ++k) EXPECT_GT(held[size_t(k)], 0) << "room " << k;
  // Above it, the method fills the budget (uniform: within 10 %).
  r.budget = int(minimum) + 40;
  const PlaceResult more = placeProbeSet(w.tracer, set, r);
  EXPECT_NEAR(double(more.set.probes.size()), double(r.budget), 0.1 * r.budget);
  // Without the covering, the notes count the rooms left dark, if any.
  r.cover = false;
  r.budget = 6;
  const PlaceResult bare = placeProbeSet(w.tracer, set, r);
  EXPECT_EQ(bare.minimumBudget, 0u);
}
