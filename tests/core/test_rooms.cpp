// Rooms found in the domain without volumes drawn by hand (core/domain/Rooms.h).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "SceneBuilders.h"
#include "core/common/Error.h"
#include "core/domain/FreeSpaceGrid.h"
#include "core/domain/Rooms.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;
using namespace ps::testing;

namespace {

const fs::path kScenes = fs::path(PS_SOURCE_DIR) / "resources" / "scenes";

}  // namespace

TEST(Rooms, TwoRoomsJoinedByADoorAreTwoRoomsOfEqualVolume) {
  // two-rooms (scripts/make_scenes.py): rooms A (x < -0.05) and B (x > 0.05), 6 x 3 x 6 m each,
  // joined by a 1 m wide, 2.1 m high doorway in the wall at x = 0; a cabinet stands in A's
  // corner x in [-5.6, -3.8], z in [-2.95, -2.45], a block in B's, x in [1.5, 2.7], z in
  // [1.6, 2.4].
  const Scene scene = loadScene(kScenes / "two-rooms.gltf");
  const Tracer tracer(scene);
  const RoomMap rooms(tracer, {});
  ASSERT_EQ(rooms.roomCount(), 2);
  const double a = rooms.roomVolumes()[0], b = rooms.roomVolumes()[1];
  EXPECT_NEAR(a, b, 0.1 * b);
  EXPECT_NEAR(a + b, 2 * 6 * 3 * 6, 0.15 * 2 * 6 * 3 * 6);
  // Every point of a room, the doorway's sides included, is in its room; none in the other.
  for (double x : {-5.5, -3.0, -0.5})
    for (double y : {0.5, 1.5, 2.5})
      for (double z : {-2.0, 0.0, 2.5}) {
        EXPECT_EQ(rooms.roomOf({x, y, z}), rooms.roomOf({-3, 1.5, 0})) << x << " " << y << " " << z;
        EXPECT_EQ(rooms.roomOf({-x, y, z}), rooms.roomOf({3, 1.5, 0}))
            << -x << " " << y << " " << z;
      }
  EXPECT_NE(rooms.roomOf({-3, 1.5, 0}), rooms.roomOf({3, 1.5, 0}));
  EXPECT_EQ(rooms.roomOf({100, 0, 0}), -1);  // outside the grid
  EXPECT_EQ(rooms.roomNames(), (std::vector<std::string>{"room 1", "room 2"}));
}

TEST(Rooms, OneRoomWithAPillarOrABoxInsideIsOneRoom) {
  for (const char* name : {"pillar-room.gltf", "cornell.gltf"}) {
    const Scene scene = loadScene(kScenes / name);
    const Tracer tracer(scene);
    EXPECT_EQ(RoomMap(tracer, {}).roomCount(), 1) << name;
  }
}

TEST(Rooms, WiderOpeningsThanTheDoorwayJoinRooms) {
  // With openings under 0.6 m closing, two-rooms' 1 m doorway keeps the rooms as one.
  const Scene scene = loadScene(kScenes / "two-rooms.gltf");
  const Tracer tracer(scene);
  RoomSettings s;
  s.doorwayMeters = 0.6;
  s.cellMeters = 0.15;
  EXPECT_EQ(RoomMap(tracer, {}, s).roomCount(), 1);
}

TEST(Rooms, ADomainTooLargeForTheRulesCellGetsACoarserOneAndStillFindsTheRooms) {
  // twoRoomsWithADoor's bounds, 12.4 x 3.4 x 6.4 m, make 11088 cells of the rule's 0.3 m
  // (doorway 1.2 m / 4): at most 3000 cells the automatic cell is coarser, not refused, and
  // the 1 m doorway still parts the two rooms, each of its volume within half a cell over its
  // walls, floor and ceiling.
  const Scene scene = twoRoomsWithADoor();
  const Tracer tracer(scene);
  const RoomMap fine(tracer, {});
  EXPECT_NEAR(fine.cellMeters(), 0.3, 1e-12);
  EXPECT_TRUE(fine.note().empty()) << fine.note();
  ASSERT_EQ(fine.roomCount(), 2);
  RoomSettings s;
  s.maxCells = 3000;
  const RoomMap coarse(tracer, {}, s);
  EXPECT_GT(coarse.cellMeters(), 0.3);
  EXPECT_LE(FreeSpaceGrid::cellsAt(scene.bounds, coarse.cellMeters()), 3000u);
  EXPECT_NE(coarse.note().find("coarser than the 0.300 m"), std::string::npos) << coarse.note();
  EXPECT_NE(coarse.note().find("above maxCells 3000"), std::string::npos) << coarse.note();
  ASSERT_EQ(coarse.roomCount(), 2) << coarse.note();
  const double room = 5.95 * 3 * 6, surface = 2 * (5.95 * 3 + 5.95 * 6 + 3 * 6);
  for (int r = 0; r < 2; ++r) {
    EXPECT_NEAR(fine.roomVolumes()[size_t(r)], room, surface * fine.cellMeters() / 2);
    EXPECT_NEAR(coarse.roomVolumes()[size_t(r)], room, surface * coarse.cellMeters() / 2);
  }
  EXPECT_NE(coarse.roomOf({3, 1.5, 3}), coarse.roomOf({9, 1.5, 3}));
  EXPECT_EQ(coarse.roomOf({1, 1, 1}), coarse.roomOf({5, 2, 5}));
  // An edge given that makes more cells is refused, naming it.
  s.cellMeters = 0.3;
  try {
    RoomMap(tracer, {}, s);
    FAIL() << "no throw";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "cellMeters");
  }
}

TEST(Rooms, RejectsBadSettingsNamingThem) {
  const Scene scene = loadScene(kScenes / "two-rooms.gltf");
  const Tracer tracer(scene);
  auto parameterOf = [&](const RoomSettings& s) -> std::string {
    try {
      RoomMap(tracer, {}, s);
    } catch (const ParameterError& e) {
      return e.parameter();
    }
    return "(accepted)";
  };
  RoomSettings s;
  s.doorwayMeters = 0;
  EXPECT_EQ(parameterOf(s), "doorwayMeters");
  s = {};
  s.minRoomCubicMeters = -1;
  EXPECT_EQ(parameterOf(s), "minRoomCubicMeters");
  s = {};
  s.cellMeters = -0.1;
  EXPECT_EQ(parameterOf(s), "cellMeters");
  s = {};
  s.cellMeters = 0.001;  // billions of cells
  EXPECT_EQ(parameterOf(s), "cellMeters");
}

TEST(Rooms, TheRealApartmentHasSeveralRooms) {
  const fs::path file = fs::path(PS_SHARED_SCENES_DIR) / "dream-apartment" / "dream-apartment.glb";
  if (!fs::exists(file)) GTEST_SKIP() << "shared scene not found: " << file;
  const Scene scene = loadScene(file);
  const Tracer tracer(scene);
  const RoomMap rooms(tracer, {});
  std::printf("dream-apartment: %d rooms (cell %.2f m):", rooms.roomCount(), rooms.cellMeters());
  for (double v : rooms.roomVolumes()) std::printf(" %.1f m^3", v);
  std::printf("\n");
  EXPECT_GE(rooms.roomCount(), 3);
  for (size_t k = 1; k < rooms.roomVolumes().size(); ++k)
    EXPECT_LE(rooms.roomVolumes()[k], rooms.roomVolumes()[k - 1]);
}
