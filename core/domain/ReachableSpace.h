#pragma once
// The space a player can reach, found from the scene alone: the free cells of a grid
// (core/domain/FreeSpaceGrid.h) within a height band above a walkable surface (one facing up,
// +Y in glTF, at most maxSlopeDeg from level), and, when the scene is an interior, only the
// enclosed ones (most of their rays hit geometry). Above a roof, beside the outer walls and in
// the air above the band a player never stands, so probes there light nobody and errors
// measured there weigh nothing a player sees. An exterior (no enclosure worth the name) keeps
// the whole band above its ground.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/math/Vec3.h"
#include "core/trace/Tracer.h"

namespace ps {

struct ReachableSettings {
  /// Height of the band above walkable surfaces, metres: a storey (ceilings at 2.4 to 2.7 m),
  /// so an ordinary room is kept whole, and outdoors a standing player's eyes (1.6 to 1.8 m)
  /// with a third-person camera about a metre above them.
  double bandMeters = 3.0;
  /// Steepest walkable surface, degrees from level (a ramp or stair flight is at most 35 to 40).
  double maxSlopeDeg = 45;
  /// Cell edge, metres; 0: 0.25 m (a quarter of a doorway), or when that makes more than
  /// maxCells cells the finest edge that does not (with a note(): coarser than the rule needs).
  double cellMeters = 0;
  /// Most cells of the grid: its memory, about 10 bytes per cell and 24 per reachable cell
  /// (the full generated level, 200 x 60 x 14.3 m, is 11.1 million cells at 0.25 m).
  size_t maxCells = 16000000;
  /// Rays per band cell of the enclosure test; a cell is enclosed when at most
  /// maxOpenFraction of them escape the scene (hit nothing).
  int enclosureRays = 32;
  double maxOpenFraction = 0.25;
  /// The scene is an interior, and its reachable space the enclosed band cells, when those
  /// make at least this share of the band's volume.
  double interiorShare = 0.5;
  uint64_t seed = 1;  ///< of the validity and enclosure rays
};

/// Throws ps::ParameterError naming the setting ("bandMeters", "maxSlopeDeg", "cellMeters",
/// "maxCells", "enclosureRays", "maxOpenFraction", "interiorShare") when out of range.
void checkReachableSettings(const ReachableSettings& settings);

class ReachableSpace {
 public:
  /// The reachable cells of a grid over domainBounds(tracer, domain). Throws as
  /// checkReachableSettings and FreeSpaceGrid do. Cost: 32 validity rays per cell, 3 segment
  /// rays per free cell, 1 + enclosureRays per band cell, in parallel; deterministic.
  ReachableSpace(const Tracer& tracer, std::span<const Bounds3> domain,
                 const ReachableSettings& settings = {});

  /// True when p lies in a reachable cell: a free cell of the rule, or a cell whose centre is
  /// inside geometry beside one (so that the free space up to a wall is kept).
  bool contains(Vec3 p) const;
  /// The reachable cells, in grid order (x fastest), as their low corners; each a cube of
  /// cellMeters().
  const std::vector<Vec3>& cellCorners() const { return corners_; }
  double cellMeters() const { return cell_; }
  /// The faces between a free cell the rule keeps and a cell it does not (or the grid's edge):
  /// the shell of the space, a cell inside walls (the cells against them are not part of it),
  /// each face as its 4 corners in order, in grid order; every k-th of them when there are more
  /// than `maxFaces` (k the smallest keeping at most maxFaces; 0: all of them), for drawing.
  std::vector<std::array<Vec3, 4>> shellFaces(size_t maxFaces) const;
  bool interior() const { return interior_; }
  /// Volumes in cubic metres: the free cells', the band's, the enclosed band's, the free cells'
  /// the rule keeps, and the reachable cells' (those against walls included, whose centre is
  /// inside geometry: the volume draws are spread over before the validity test).
  double freeCubicMeters() const { return freeVolume_; }
  double keptFreeCubicMeters() const { return keptVolume_; }
  double bandCubicMeters() const { return bandVolume_; }
  double enclosedCubicMeters() const { return enclosedVolume_; }
  double reachableCubicMeters() const { return double(corners_.size()) * cell_ * cell_ * cell_; }
  double seconds() const { return seconds_; }  ///< wall time of the construction
  /// One line: the rule's outcome ("reachable domain: 107.2 of 316.4 m^3 free (interior; ...").
  std::string summary() const;
  /// Empty, or one line when the automatic cell is coarser than 0.25 m because the domain would
  /// need more than maxCells cells: the figures, and what the coarser cell may cost.
  const std::string& note() const { return note_; }

 private:
  Bounds3 box_;
  double cell_ = 0;
  int n_[3] = {0, 0, 0};
  std::vector<char> reachable_;  ///< per grid cell
  std::vector<char>
      kept_;  ///< per grid cell: the rule's free cells (reachable_ less those against walls)
  std::vector<Vec3> corners_;
  bool interior_ = false;
  std::string note_;
  double freeVolume_ = 0, bandVolume_ = 0, enclosedVolume_ = 0, keptVolume_ = 0, seconds_ = 0;
};

}  // namespace ps
