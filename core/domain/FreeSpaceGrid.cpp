#include "core/domain/FreeSpaceGrid.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "core/math/Random.h"

namespace ps {

namespace {

/// The validity rays traced first (the same directions as the first of kDomainValidityRays).
constexpr int kFirstRays = 8;
/// Rounds in which crossed cells take their state from a neighbour (a surface is seldom more
/// than two cells from a clear cell at the grid's sizes).
constexpr int kRounds = 3;

}  // namespace

size_t FreeSpaceGrid::cellsAt(const Bounds3& box, double meters) {
  const Vec3 e = box.extent();
  const double ext[kAxes] = {e.x, e.y, e.z};
  double cells = 1;
  for (int a = 0; a < kAxes; ++a) cells *= std::max(1.0, std::ceil(ext[a] / meters));
  return cells >= 1e18 ? size_t(1e18) : size_t(cells);
}

FreeSpaceGrid::CellChoice FreeSpaceGrid::chooseCell(const Tracer& tracer,
                                                    std::span<const Bounds3> domain,
                                                    double preferredMeters, double ruleMeters,
                                                    size_t maxCells) {
  if (preferredMeters > 0) return {preferredMeters, {}};
  const Bounds3 box = domainBounds(tracer, domain);
  if (cellsAt(box, ruleMeters) <= maxCells) return {ruleMeters, {}};
  // The count falls as the edge grows; the largest extent makes one cell per axis. Bisection
  // keeps `hi` fitting throughout.
  const Vec3 e = box.extent();
  double lo = ruleMeters, hi = std::max({e.x, e.y, e.z, ruleMeters});
  for (int i = 0; i < 64 && hi - lo > 1e-9 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (cellsAt(box, mid) <= maxCells ? hi : lo) = mid;
  }
  char note[256];
  std::snprintf(note, sizeof note,
                "the automatic cell is %.3f m, coarser than the %.3f m the rule needs: %zu cells "
                "at %.3f m are above maxCells %zu",
                hi, ruleMeters, cellsAt(box, ruleMeters), ruleMeters, maxCells);
  return {hi, note};
}

FreeSpaceGrid::FreeSpaceGrid(const Tracer& tracer, std::span<const Bounds3> domain,
                             double cellMeters, size_t maxCells, uint64_t seed)
    : box_(domainBounds(tracer, domain)), cell_(cellMeters) {
  const Vec3 e = box_.extent();
  if (!(e.x * e.y * e.z > 0)) throw ParameterError("domain: the domain has no volume");
  const double ext[kAxes] = {e.x, e.y, e.z};
  const size_t cells = cellsAt(box_, cell_);
  if (cells > maxCells)
    throw ParameterError("cellMeters", "a " + std::to_string(cell_) + " m cell makes " +
                                           std::to_string(cells) + " cells, above maxCells " +
                                           std::to_string(maxCells) +
                                           ": give a larger edge, or 0 for the automatic one");
  for (int a = 0; a < kAxes; ++a) n_[a] = std::max(1, int(std::ceil(ext[a] / cell_)));

  // Crossed cells: those a triangle's plane passes through within the triangle's bounds (a
  // conservative test: a cell it marks may hold none of the triangle), each cell's bounds
  // widened by a ray offset so that a surface on a cell face marks both cells. Bit a: a
  // triangle whose normal has a component along axis a, the only kind a segment along a can
  // cross (one parallel to it is missed by rays, Embree's included).
  std::vector<uint8_t> crossed(cells, 0);
  const Scene& scene = tracer.scene();
  const double pad = tracer.rayEpsilon() + 1e-6 * cell_;
  for (size_t t = 0; t < scene.triangleCount(); ++t) {
    const Vec3 v0 = scene.vertex(scene.indices[3 * t]), v1 = scene.vertex(scene.indices[3 * t + 1]),
               v2 = scene.vertex(scene.indices[3 * t + 2]);
    int lo[kAxes], hi[kAxes];
    bool outside = false;
    for (int a = 0; a < kAxes; ++a) {
      const double tlo = std::min({v0[a], v1[a], v2[a]}) - pad - box_.lo[a];
      const double thi = std::max({v0[a], v1[a], v2[a]}) + pad - box_.lo[a];
      const double flo = std::floor(tlo / cell_), fhi = std::floor(thi / cell_);
      outside = outside || !(fhi >= 0 && flo < n_[a]);
      lo[a] = int(std::max(0.0, flo));
      hi[a] = int(std::min(double(n_[a] - 1), fhi));
    }
    if (outside) continue;
    const Vec3 n = cross(v1 - v0, v2 - v0);
    const double reach = (0.5 * cell_ + pad) * (std::abs(n.x) + std::abs(n.y) + std::abs(n.z));
    const uint8_t axes =
        uint8_t((n.x != 0 ? 1u : 0u) | (n.y != 0 ? 2u : 0u) | (n.z != 0 ? 4u : 0u));
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) {
          const size_t c = index(x, y, z);
          if ((crossed[c] & axes) != axes && std::abs(dot(n, centre(c) - v0)) <= reach)
            crossed[c] |= axes;
        }
  }

  // Free cells: the centre in the domain's boxes and outside geometry (validity rays at one
  // cell of each group of clear cells, crossed cells through their neighbours).
  const std::vector<Bounds3> boxes = domain.empty()
                                         ? std::vector<Bounds3>{box_}
                                         : std::vector<Bounds3>(domain.begin(), domain.end());
  auto inBoxes = [&](Vec3 p) {
    return std::any_of(boxes.begin(), boxes.end(), [&](const Bounds3& b) { return b.contains(p); });
  };
  // The first kFirstRays of the validity rays decide when they agree (all back faces, or
  // none: what closed geometry gives), else all kDomainValidityRays.
  auto outsideGeometry = [&](size_t c) {
    const double first = backfaceFraction(tracer, centre(c), kFirstRays, streamSeed(seed, c));
    if (first == 0 || first == 1) return first == 0;
    return backfaceFraction(tracer, centre(c), kDomainValidityRays, streamSeed(seed, c)) <=
           kDomainInvalidBackfaceFraction;
  };
  // Geometric state per cell: 0 unknown, 1 outside geometry, 2 inside.
  std::vector<char> state(cells, 0);
  // Groups within a block: cells `member` selects, joined through faces where `linked`; each
  // group takes the outcome of its first cell (in grid order).
  int blocks[kAxes];
  for (int a = 0; a < kAxes; ++a) blocks[a] = (n_[a] + kBlock - 1) / kBlock;
  const size_t blockCount = size_t(blocks[0]) * size_t(blocks[1]) * size_t(blocks[2]);
  auto groupBlocks = [&](auto&& member, auto&& linked) {
    tbb::parallel_for(size_t(0), blockCount, [&](size_t b) {
      const int b0 = int(b % size_t(blocks[0])) * kBlock,
                b1 = int((b / size_t(blocks[0])) % size_t(blocks[1])) * kBlock,
                b2 = int(b / (size_t(blocks[0]) * size_t(blocks[1]))) * kBlock;
      const int m0 = std::min(kBlock, n_[0] - b0), m1 = std::min(kBlock, n_[1] - b1),
                m2 = std::min(kBlock, n_[2] - b2);
      constexpr int kCells = kBlock * kBlock * kBlock;
      auto local = [&](int x, int y, int z) { return size_t((z * kBlock + y) * kBlock + x); };
      std::array<char, kCells> seen{};
      std::array<std::array<int, kAxes>, kCells> stack;
      for (int z = 0; z < m2; ++z)
        for (int y = 0; y < m1; ++y)
          for (int x = 0; x < m0; ++x) {
            const size_t c = index(b0 + x, b1 + y, b2 + z);
            if (seen[local(x, y, z)] || !member(c)) continue;
            const char outcome = outsideGeometry(c) ? 1 : 2;
            size_t top = 0;
            stack[top++] = {x, y, z};
            seen[local(x, y, z)] = 1;
            while (top > 0) {
              const std::array<int, kAxes> l = stack[--top];
              const size_t d = index(b0 + l[0], b1 + l[1], b2 + l[2]);
              state[d] = outcome;
              for (int side = 0; side < 2 * kAxes; ++side) {
                std::array<int, kAxes> nb = l;
                nb[size_t(side / 2)] += side % 2 ? 1 : -1;
                if (nb[0] < 0 || nb[1] < 0 || nb[2] < 0 || nb[0] >= m0 || nb[1] >= m1 ||
                    nb[2] >= m2 || seen[local(nb[0], nb[1], nb[2])])
                  continue;
                const size_t f = index(b0 + nb[0], b1 + nb[1], b2 + nb[2]);
                if (!member(f) || !linked(d, f, side / 2)) continue;
                seen[local(nb[0], nb[1], nb[2])] = 1;
                stack[top++] = nb;
              }
            }
          }
    });
  };
  // The segment between the centres of face neighbours c and d crosses no surface: no ray
  // when neither cell holds a triangle crossing their axis.
  auto clearSegment = [&](size_t c, size_t d, int axis) {
    if (((crossed[c] | crossed[d]) & (1u << axis)) == 0) return true;
    Ray ray;
    ray.origin = centre(c);
    ray.direction = centre(d) - ray.origin;
    ray.tMin = 0;
    ray.tMax = 1;
    return !tracer.occluded(ray);
  };
  // Clear cells: a group holds no surface between its cells.
  groupBlocks([&](size_t c) { return !crossed[c]; }, [](size_t, size_t, int) { return true; });
  // Crossed cells, in rounds: a cell takes the state of the first face neighbour (in side
  // order) known before the round whose centre it reaches along a segment that crosses no
  // surface; those that reach none after kRounds rounds are grouped as the clear cells are.
  std::vector<size_t> open;
  for (size_t c = 0; c < cells; ++c)
    if (crossed[c]) open.push_back(c);
  std::vector<char> found(open.size(), 0);
  std::vector<uint8_t> known(cells, 0);  // the round after which the state was set, plus 1
  for (int round = 0; round < kRounds && !open.empty(); ++round) {
    tbb::parallel_for(size_t(0), open.size(), [&](size_t i) {
      const size_t c = open[i];
      int xyz[kAxes];
      coords(c, xyz);
      found[i] = 0;
      for (int side = 0; side < 2 * kAxes && !found[i]; ++side) {
        int nb[kAxes] = {xyz[0], xyz[1], xyz[2]};
        nb[side / 2] += side % 2 ? 1 : -1;
        if (nb[0] < 0 || nb[1] < 0 || nb[2] < 0 || nb[0] >= n_[0] || nb[1] >= n_[1] ||
            nb[2] >= n_[2])
          continue;
        const size_t d = index(nb[0], nb[1], nb[2]);
        // A neighbour known in an earlier round was tried in it.
        if (state[d] != 0 && known[d] == round && clearSegment(d, c, side / 2)) found[i] = state[d];
      }
    });
    // Applied after the round, so that no cell reads a state set in it (deterministic).
    std::vector<size_t> still;
    for (size_t i = 0; i < open.size(); ++i) {
      if (found[i]) {
        state[open[i]] = found[i];
        known[open[i]] = uint8_t(round + 1);
      } else
        still.push_back(open[i]);
    }
    open.swap(still);
  }
  // The rest (inside solids thicker than a cell, mostly): groups joined by free segments.
  groupBlocks([&](size_t c) { return state[c] == 0; }, clearSegment);
  free_.assign(cells, 0);
  tbb::parallel_for(size_t(0), cells,
                    [&](size_t c) { free_[c] = state[c] == 1 && inBoxes(centre(c)) ? 1 : 0; });
  // Joins: bit a when the cell and its +a neighbour are free and the segment between their
  // centres crosses no surface.
  join_.assign(cells, 0);
  tbb::parallel_for(size_t(0), cells, [&](size_t c) {
    if (!free_[c]) return;
    int xyz[kAxes];
    coords(c, xyz);
    for (int a = 0; a < kAxes; ++a) {
      if (xyz[a] + 1 >= n_[a]) continue;
      int nb[kAxes] = {xyz[0], xyz[1], xyz[2]};
      ++nb[a];
      const size_t d = index(nb[0], nb[1], nb[2]);
      if (!free_[d]) continue;
      if (clearSegment(c, d, a)) join_[c] |= uint8_t(1u << a);
    }
  });
}

int64_t FreeSpaceGrid::cellOf(Vec3 p) const {
  if (!box_.contains(p)) return -1;
  const Vec3 q = (p - box_.lo) * (1 / cell_);
  const int x = std::min(int(q.x), n_[0] - 1), y = std::min(int(q.y), n_[1] - 1),
            z = std::min(int(q.z), n_[2] - 1);
  return int64_t(index(x, y, z));
}

}  // namespace ps
