// Rooms found in the domain without volumes drawn by hand (core/domain/Rooms.h).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "core/common/Error.h"
#include "core/domain/Rooms.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;

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
