#pragma once
// A grid of cubic cells over a domain's bounding box whose free cells (centre outside geometry,
// inside the domain's boxes) are joined to their face neighbours where the segment between the
// two centres crosses no surface: a thin wall that holds no cell centre still cuts the grid.
// The room segmentation (core/domain/Rooms.h) and the reachable space
// (core/domain/ReachableSpace.h) are both computed on it.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/math/Vec3.h"
#include "core/trace/Tracer.h"

namespace ps {

class FreeSpaceGrid {
 public:
  static constexpr int kAxes = 3;

  /// Cells of edge `cellMeters` (> 0) over domainBounds(tracer, domain), cell-centred from its
  /// low corner (the last cell along an axis may overhang it). Free cells: the centre inside the
  /// domain's boxes and outside geometry, as DomainPoints::valid tests it without lights (32
  /// validity rays seeded by streamSeed(seed, cell)), tested once per group of cells that hold
  /// no surface between them:
  ///  - a cell no triangle's plane crosses within the triangle's bounds is clear; the clear
  ///    cells of a block of kBlock^3 cells joined through faces form a group;
  ///  - a crossed cell takes the outcome of a face neighbour whose centre it reaches along a
  ///    segment that crosses no surface (in rounds, from the clear cells outwards);
  ///  - crossed cells left (inside solids thicker than a cell) are grouped within their block
  ///    as the clear cells are, through such segments.
  /// Each group takes the outcome of its first cell in grid order. On closed geometry that is
  /// each cell's own outcome; on open geometry (a sheet, a mesh with holes) a group's cells may
  /// see different shares of back faces, and all take the first one's.
  /// Throws ps::ParameterError("cellMeters") when the grid would exceed `maxCells` cells, or
  /// ps::ParameterError when the domain has no volume. Memory: 2 bytes per cell kept, 3 more
  /// and 9 per crossed cell while building. Cost: a pass over each triangle's cells, 8 validity
  /// rays per group (32 where those 8 disagree), a segment ray per pair of crossed neighbours whose
  /// surfaces could block it, in parallel; deterministic.
  FreeSpaceGrid(const Tracer& tracer, std::span<const Bounds3> domain, double cellMeters,
                size_t maxCells, uint64_t seed);

  /// Edge of a block, in cells, whose clear cells share one validity test.
  static constexpr int kBlock = 8;

  /// Cells of edge `meters` over the box `box`, counted as the grid lays them (each axis
  /// ceil(extent / meters), at least 1).
  static size_t cellsAt(const Bounds3& box, double meters);

  /// The edge a grid over the domain is built with, and why it is coarser than the rule asks
  /// when it is.
  struct CellChoice {
    double meters = 0;
    /// Empty, or one line: the automatic edge is above `ruleMeters` because that edge would
    /// make more than maxCells cells (figures included); the caller adds what it costs.
    std::string note;
  };
  /// `preferredMeters` when above 0 (the constructor refuses it if it makes too many cells);
  /// else `ruleMeters` when its grid holds at most `maxCells` cells, else the finest edge
  /// whose grid (counted after the per-axis ceil) holds at most `maxCells`, with a note.
  /// Never throws for an automatic edge.
  static CellChoice chooseCell(const Tracer& tracer, std::span<const Bounds3> domain,
                               double preferredMeters, double ruleMeters, size_t maxCells);

  size_t cellCount() const { return free_.size(); }
  double cellMeters() const { return cell_; }
  const Bounds3& box() const { return box_; }
  int size(int axis) const { return n_[axis]; }
  size_t index(int x, int y, int z) const {
    return (size_t(z) * size_t(n_[1]) + size_t(y)) * size_t(n_[0]) + size_t(x);
  }
  void coords(size_t c, int out[kAxes]) const {
    out[0] = int(c % size_t(n_[0]));
    out[1] = int((c / size_t(n_[0])) % size_t(n_[1]));
    out[2] = int(c / (size_t(n_[0]) * size_t(n_[1])));
  }
  Vec3 centre(size_t c) const {
    int xyz[kAxes];
    coords(c, xyz);
    return box_.lo + Vec3((xyz[0] + 0.5) * cell_, (xyz[1] + 0.5) * cell_, (xyz[2] + 0.5) * cell_);
  }
  /// The cell holding p, or -1 outside the grid's box.
  int64_t cellOf(Vec3 p) const;
  bool isFree(size_t c) const { return free_[c] != 0; }
  /// Bit a: the cell and its +a neighbour are free and joined.
  uint8_t joins(size_t c) const { return join_[c]; }

  /// Calls visit(d) for each neighbour d the free cell c is joined to.
  template <class Visit>
  void forJoined(size_t c, Visit&& visit) const {
    int xyz[kAxes];
    coords(c, xyz);
    for (int a = 0; a < kAxes; ++a) {
      if (join_[c] & (1u << a)) {
        int nb[kAxes] = {xyz[0], xyz[1], xyz[2]};
        ++nb[a];
        visit(index(nb[0], nb[1], nb[2]));
      }
      if (xyz[a] > 0) {
        int nb[kAxes] = {xyz[0], xyz[1], xyz[2]};
        --nb[a];
        const size_t d = index(nb[0], nb[1], nb[2]);
        if (join_[d] & (1u << a)) visit(d);
      }
    }
  }

 private:
  Bounds3 box_;
  double cell_ = 0;
  int n_[kAxes] = {0, 0, 0};
  std::vector<char> free_;
  std::vector<uint8_t> join_;
};

}  // namespace ps
