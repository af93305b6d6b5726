#pragma once
// The rooms of the domain, found without anything drawn by hand, so that eval can report a dim
// room's error on its own (core/eval/PerceptualError.h): a grid over the domain's free space,
// eroded until doorways close, whose connected cores are the rooms, each grown back over the
// free space it reaches first. This is morphological room segmentation as robot maps use it
// (Bormann et al. 2016, "Room segmentation: survey, implementation, and analysis", ICRA,
// sec. III-A), on a 3D grid whose walls are found by rays: a thin wall that holds no cell
// centre still cuts the grid, because neighbouring cells are joined only when the segment
// between their centres is free.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/math/Vec3.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

struct RoomSettings {
  /// Openings narrower than this close under the erosion (a door is 0.8 to 1 m wide; a room
  /// narrower than this in two axes is not told apart from its neighbours), metres.
  double doorwayMeters = 1.2;
  /// A core smaller than this is no room (the space under a table, a niche), cubic metres.
  double minRoomCubicMeters = 2.0;
  /// Grid cell edge in metres; 0: doorwayMeters / 4, or when that makes more than maxCells
  /// cells the finest edge that does not (with a note(): doorways may not close).
  double cellMeters = 0;
  /// Most cells of the grid: its memory, about 16 + 4 (levels + 1) bytes per cell while
  /// building (levels: doorwayMeters / 2 in cells) and 8 per cell of each level's largest
  /// connected free space; 4 kept (each cell's room).
  size_t maxCells = 16000000;
  uint64_t seed = 1;  ///< of the validity rays (DomainPoints::valid)
};

/// Which room each cell of a grid over the domain belongs to.
class RoomMap {
 public:
  /// Segments the boxes' union (the scene bounds when there are none). Cells whose centre is
  /// inside geometry (DomainPoints::valid) or outside the boxes belong to no room. Throws
  /// ps::ParameterError for settings out of range (an automatic cell never makes too many
  /// cells). Cost: FreeSpaceGrid's rays, then per free cell a search of the ball of
  /// doorwayMeters / 2 for the nearest wall, and a connected-component pass per level.
  RoomMap(const Tracer& tracer, std::span<const Bounds3> domain, const RoomSettings& settings = {});

  /// The room of the cell holding p (0 to roomCount() - 1), or -1 (outside the grid, in
  /// geometry, or in free space that no room's core reaches).
  int roomOf(Vec3 p) const;
  int roomCount() const { return rooms_; }
  /// The volume of each room's cells, cubic metres; rooms are numbered largest first.
  const std::vector<double>& roomVolumes() const { return volumes_; }
  /// "room 1", "room 2", ... in room order.
  std::vector<std::string> roomNames() const;
  double cellMeters() const { return cell_; }
  /// The grid's cells, x fastest: cellCount() of them, cell c's room (as roomOf()) and centre.
  size_t cellCount() const { return room_.size(); }
  int roomOfCell(size_t c) const { return room_[c]; }
  Vec3 cellCentre(size_t c) const;
  /// Empty, or one line when the automatic cell is coarser than doorwayMeters / 4 because the
  /// domain would need more than maxCells cells: the figures, and what it may cost.
  const std::string& note() const { return note_; }

 private:
  Bounds3 box_;
  double cell_ = 0;
  int n_[3] = {0, 0, 0};
  std::vector<int32_t> room_;  ///< per cell; -1: none
  int rooms_ = 0;
  std::vector<double> volumes_;
  std::string note_;
};

}  // namespace ps
