#include "core/domain/Rooms.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <deque>

#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "core/domain/FreeSpaceGrid.h"
#include "core/math/Random.h"

namespace ps {

namespace {

constexpr int kAxes = FreeSpaceGrid::kAxes;

}  // namespace

RoomMap::RoomMap(const Tracer& tracer, std::span<const Bounds3> domain, const RoomSettings& s) {
  if (!(s.doorwayMeters > 0))
    throw ParameterError("doorwayMeters",
                         "expected a width above 0 m, got " + std::to_string(s.doorwayMeters));
  if (!(s.minRoomCubicMeters >= 0))
    throw ParameterError("minRoomCubicMeters", "expected 0 or more cubic metres, got " +
                                                   std::to_string(s.minRoomCubicMeters));
  if (!(s.cellMeters >= 0))
    throw ParameterError("cellMeters", "expected 0 (automatic) or an edge above 0 m, got " +
                                           std::to_string(s.cellMeters));
  if (s.maxCells < 1000)
    throw ParameterError("maxCells",
                         "expected at least 1000 cells, got " + std::to_string(s.maxCells));
  const FreeSpaceGrid::CellChoice choice =
      FreeSpaceGrid::chooseCell(tracer, domain, s.cellMeters, s.doorwayMeters / 4, s.maxCells);
  if (!choice.note.empty()) {
    char cost[160];
    std::snprintf(cost, sizeof cost,
                  "; a %.2f m doorway spans %.1f cells, under 4: openings that narrow may not "
                  "close, and rooms they join are counted as one",
                  s.doorwayMeters, s.doorwayMeters / choice.meters);
    note_ = "rooms: " + choice.note + cost;
  }
  const FreeSpaceGrid grid(tracer, domain, choice.meters, s.maxCells, s.seed);
  box_ = grid.box();
  cell_ = grid.cellMeters();
  for (int a = 0; a < kAxes; ++a) n_[a] = grid.size(a);
  const size_t cells = grid.cellCount();
  auto index = [&](int x, int y, int z) { return grid.index(x, y, z); };
  auto coords = [&](size_t c, int out[kAxes]) { grid.coords(c, out); };
  auto freeCell = [&](size_t c) { return grid.isFree(c); };
  auto forJoined = [&](size_t c, auto&& visit) { grid.forJoined(c, visit); };
  // Free cells against a wall: a side not joined (a surface, geometry or the domain's edge).
  std::vector<char> wall(cells, 0);
  tbb::parallel_for(size_t(0), cells, [&](size_t c) {
    if (!freeCell(c)) return;
    int joined = 0;
    forJoined(c, [&](size_t) { ++joined; });
    wall[c] = joined < 2 * kAxes ? 1 : 0;
  });
  // Each free cell's distance to the nearest wall cell (or cell outside the free space or the
  // grid), in cells, Euclidean between centres, up to levels + 1 (farther: levels + 1).
  const int levels = std::max(1, int(std::ceil(s.doorwayMeters / 2 / cell_)));
  std::vector<std::array<int, kAxes + 1>> ball;  // dx, dy, dz, squared length
  const int reach = levels + 1;
  for (int dz = -reach; dz <= reach; ++dz)
    for (int dy = -reach; dy <= reach; ++dy)
      for (int dx = -reach; dx <= reach; ++dx) {
        const int d2 = dx * dx + dy * dy + dz * dz;
        if (d2 <= reach * reach) ball.push_back({dx, dy, dz, d2});
      }
  std::stable_sort(ball.begin(), ball.end(),
                   [](const auto& a, const auto& b) { return a[3] < b[3]; });
  std::vector<float> clearance(cells, 0.0f);
  tbb::parallel_for(size_t(0), cells, [&](size_t c) {
    if (!freeCell(c)) return;
    int xyz[kAxes];
    coords(c, xyz);
    clearance[c] = float(reach);
    for (const auto& o : ball) {
      const int x = xyz[0] + o[0], y = xyz[1] + o[1], z = xyz[2] + o[2];
      const bool outside = x < 0 || y < 0 || z < 0 || x >= n_[0] || y >= n_[1] || z >= n_[2];
      if (outside || !freeCell(index(x, y, z)) || wall[index(x, y, z)]) {
        clearance[c] = float(std::sqrt(double(o[3])));
        return;
      }
    }
  });
  // The erosion at level k keeps the free cells more than k cells from a wall (level 0: all of
  // them); its connected
  // components (through joins) of at least minRoomCubicMeters are that level's cores. An
  // opening narrower than about 2 k cells closes at level k, so a core that splits into two
  // or more at a deeper level is two rooms joined by a doorway (Bormann et al. sec. III-A
  // erode until rooms separate; here the levels stop at half of doorwayMeters, so that only
  // openings narrower than it separate rooms).
  const double cellVolume = cell_ * cell_ * cell_;
  std::vector<std::vector<int32_t>> coreOf(size_t(levels) + 1);    // per level, per cell; -1
  std::vector<std::vector<size_t>> coreFirst(size_t(levels) + 1);  // per level, per core
  // Each level on its own (in parallel): label -2 marks a cell taken into the component being
  // grown, -3 one of a component too small to be a core.
  tbb::parallel_for(0, levels + 1, [&](int k) {
    std::vector<int32_t>& label = coreOf[size_t(k)];
    label.assign(cells, -1);
    std::vector<size_t> members;
    auto inCore = [&](size_t c) { return freeCell(c) && (k == 0 || clearance[c] > float(k)); };
    for (size_t c = 0; c < cells; ++c) {
      if (!inCore(c) || label[c] != -1) continue;
      members.assign(1, c);
      label[c] = -2;
      for (size_t m = 0; m < members.size(); ++m)
        forJoined(members[m], [&](size_t d) {
          if (label[d] == -1 && inCore(d)) {
            label[d] = -2;
            members.push_back(d);
          }
        });
      const bool core = double(members.size()) * cellVolume >= s.minRoomCubicMeters;
      for (size_t m : members) label[m] = core ? int32_t(coreFirst[size_t(k)].size()) : -3;
      if (core) coreFirst[size_t(k)].push_back(c);
    }
    for (int32_t& l : label)
      if (l == -3) l = -1;
  });
  // The rooms: a core that splits into two or more cores at a deeper level gives those
  // cores' rooms; one that does not (it shrinks as one, or vanishes) is a room itself.
  std::vector<std::vector<std::vector<int32_t>>> kids(size_t(levels) + 1);
  for (int k = 0; k < levels; ++k) {
    kids[size_t(k)].resize(coreFirst[size_t(k)].size());
    for (size_t q = 0; q < coreFirst[size_t(k) + 1].size(); ++q) {
      const int32_t parent = coreOf[size_t(k)][coreFirst[size_t(k) + 1][q]];
      kids[size_t(k)][size_t(parent)].push_back(int32_t(q));
    }
  }
  std::vector<std::pair<int, int32_t>> seeds;  // (level, core)
  auto roomsOf = [&](auto&& self, int k, int32_t q) -> std::vector<std::pair<int, int32_t>> {
    if (k == levels) return {{k, q}};
    const auto& children = kids[size_t(k)][size_t(q)];
    if (children.empty()) return {{k, q}};
    std::vector<std::pair<int, int32_t>> out;
    for (int32_t child : children) {
      auto sub = self(self, k + 1, child);
      out.insert(out.end(), sub.begin(), sub.end());
    }
    if (out.size() < 2) return {{k, q}};
    return out;
  };
  for (size_t q = 0; q < coreFirst[0].size(); ++q) {
    auto found = roomsOf(roomsOf, 0, int32_t(q));
    seeds.insert(seeds.end(), found.begin(), found.end());
  }
  // Every free cell joins the room whose seed reaches it first: a breadth-first search from
  // all seeds' cells at once, in grid order (deterministic). A cell lies in at most one seed's
  // core (seeds are neither ancestors nor descendants of each other).
  std::vector<std::vector<int32_t>> roomOfCore(size_t(levels) + 1);
  for (int k = 0; k <= levels; ++k) roomOfCore[size_t(k)].assign(coreFirst[size_t(k)].size(), -1);
  for (const auto& [k, q] : seeds) roomOfCore[size_t(k)][size_t(q)] = rooms_++;
  room_.assign(cells, -1);
  std::deque<size_t> frontier;
  for (size_t c = 0; c < cells; ++c)
    for (int k = 0; k <= levels; ++k) {
      const int32_t q = coreOf[size_t(k)][c];
      if (q >= 0 && roomOfCore[size_t(k)][size_t(q)] >= 0) {
        room_[c] = roomOfCore[size_t(k)][size_t(q)];
        frontier.push_back(c);
        break;
      }
    }
  coreOf.clear();
  coreOf.shrink_to_fit();
  while (!frontier.empty()) {
    const size_t c = frontier.front();
    frontier.pop_front();
    forJoined(c, [&](size_t d) {
      if (room_[d] == -1) {
        room_[d] = room_[c];
        frontier.push_back(d);
      }
    });
  }
  // Numbered by their volume, largest first (ties by their seed's order).
  std::vector<double> roomVolume(static_cast<size_t>(rooms_), 0.0);
  for (size_t c = 0; c < cells; ++c)
    if (room_[c] >= 0) roomVolume[size_t(room_[c])] += cellVolume;
  std::vector<int> order(static_cast<size_t>(rooms_));
  for (int r = 0; r < rooms_; ++r) order[size_t(r)] = r;
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return roomVolume[size_t(a)] > roomVolume[size_t(b)]; });
  std::vector<int32_t> rank(static_cast<size_t>(rooms_));
  for (int k = 0; k < rooms_; ++k) rank[size_t(order[size_t(k)])] = k;
  for (int32_t& r : room_)
    if (r >= 0) r = rank[size_t(r)];
  for (int k = 0; k < rooms_; ++k) volumes_.push_back(roomVolume[size_t(order[size_t(k)])]);
}

int RoomMap::roomOf(Vec3 p) const {
  if (!box_.contains(p)) return -1;
  const Vec3 q = (p - box_.lo) * (1 / cell_);
  const int x = std::min(int(q.x), n_[0] - 1), y = std::min(int(q.y), n_[1] - 1),
            z = std::min(int(q.z), n_[2] - 1);
  return room_[(size_t(z) * size_t(n_[1]) + size_t(y)) * size_t(n_[0]) + size_t(x)];
}

Vec3 RoomMap::cellCentre(size_t c) const {
  const size_t nx = size_t(n_[0]), ny = size_t(n_[1]);
  return box_.lo +
         Vec3{double(c % nx) + 0.5, double(c / nx % ny) + 0.5, double(c / (nx * ny)) + 0.5} * cell_;
}

std::vector<std::string> RoomMap::roomNames() const {
  std::vector<std::string> names;
  for (int r = 0; r < rooms_; ++r) names.push_back("room " + std::to_string(r + 1));
  return names;
}

}  // namespace ps
