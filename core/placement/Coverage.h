#pragma once
// Coverage before error: the probes a set needs before any error-driven addition, so that no
// room is left to read its light through a wall from another room's probes and no part of the
// domain is left outside the probes' hull, where a query is clamped to the hull's surface.
//
// 1. Rooms (core/domain/Rooms.h). Each room of the domain gets probes of its own until every
//    one of its cells but a small share sees one of them (the segment between them is free):
//    the probe tetrahedral interpolation and the visibility maps need, because a point reads
//    its light from the probes of its tetrahedron that see it (core/traversal/
//    VisibleInterpolation.h), and a point no probe of its room sees can only read through a
//    wall. This is the art-gallery covering of a room by guards, solved greedily as a
//    maximum-coverage set cover (each new probe sees the most cells not yet seen); kept probes
//    in a room count.
// 2. The hull. A point outside the probes' convex hull is clamped to it (Sukys 3.2.1 extends the
//    volume only inside the hull), so each of 26 directions (the faces, edges and corners of a
//    cube) where no probe reaches within a cell of the domain's extreme cell gets a probe at the
//    most extreme cell within that reach that keeps 0.15 m from surfaces along the axes (a
//    probe on the floor captures half a sphere of floor, and its SH rings along it).
//
// The count of these probes, kept ones included, is the smallest budget that covers the scene:
// `place` refuses a smaller one with that number (core/placement/Place.h).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/common/Progress.h"
#include "core/domain/DomainPoints.h"
#include "core/domain/Rooms.h"
#include "core/math/Vec3.h"
#include "core/trace/Tracer.h"

namespace ps {

struct CoverageSettings {
  RoomSettings rooms;
  /// A room counts as covered when at most this share of its tested cells sees no probe of it:
  /// cells behind furniture or in a niche are seen by no central position, and chasing each
  /// costs a probe that lowers the error little.
  double unseenShare = 0.05;
  /// Probes at most per room from the covering (a long, winding corridor may need more; the
  /// error-driven method adds them where they pay).
  int maxProbesPerRoom = 4;
  /// Cells tested at most per room (an even subsample of its cells in the domain): each new
  /// probe costs one ray per tested cell.
  int testedCellsPerRoom = 1024;
  /// Candidate positions scored per new probe (the unseen cell nearest the unseen cells'
  /// centroid, and others drawn among the unseen), each against at most scoredCells of them.
  int candidates = 16;
  int scoredCells = 256;
  /// Put the domain inside the probes' hull (step 2 of the header).
  bool hull = true;
  /// The point and spot lights, and the clearance kept from them (metres): a probe beside a
  /// lamp captures a near-singular irradiance and spreads it over its whole fan of tetrahedra
  /// (the ball greedy and eval keep out of, kDefaultLightClearanceRelative). A room whose cells
  /// all lie within it gets its probes as far from the lights as its cells go.
  std::vector<Vec3> lights;
  double lightClearanceMeters = 0;
  uint64_t seed = 1;
};

struct CoverageResult {
  std::vector<Vec3> probes;  ///< the new probes, room by room (largest room first), then the hull's
  size_t roomProbes = 0;     ///< of probes, those placed to cover rooms
  size_t hullProbes = 0;     ///< of probes, those placed for the hull
  int rooms = 0;             ///< rooms with cells in the domain
  int roomsCoveredByKept = 0;  ///< of them, rooms the kept probes already covered
  /// Rooms whose unseen share stayed above CoverageSettings::unseenShare at maxProbesPerRoom.
  int roomsPartlyCovered = 0;
  std::string roomNote;                    ///< RoomMap::note(), or empty
  std::shared_ptr<const RoomMap> roomMap;  ///< the rooms found
};

/// The probes that cover `domain` (header) around the `kept` ones; `avoid` are spots no new
/// probe comes within `avoidMeters` of (the artist's rejected probes). Deterministic for
/// settings.seed (rooms are covered in parallel, each with its own random stream). Throws
/// ps::ParameterError for settings out of range, ps::Cancelled when `progress` returns false.
CoverageResult coverDomain(const Tracer& tracer, const Domain& domain, std::span<const Vec3> kept,
                           std::span<const Vec3> avoid, double avoidMeters,
                           const CoverageSettings& settings = {}, const ProgressFn& progress = {});

struct RoomCount {
  int rooms = 0;  ///< rooms with cells in the domain
  int empty = 0;  ///< of them, rooms holding none of the probes
};

/// How many rooms of `domain` hold none of `probes` (for a set placed without the covering).
RoomCount roomsWithoutProbes(const Tracer& tracer, const Domain& domain,
                             std::span<const Vec3> probes, const RoomSettings& settings = {});

}  // namespace ps
