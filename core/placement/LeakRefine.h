#pragma once
// Leak refinement (Sukys 3.2.2, "Raytracing along the edges"): the Delaunay tetrahedralization of
// a probe set interpolates across walls wherever one of its edges crosses geometry. Every edge
// is traced both ways; where it enters front-facing geometry, a probe is added on that side of
// the hit, so that each side of the wall is sampled by probes of its own. Iterated to a cap.
#include <cstdint>
#include <span>
#include <vector>

#include "core/common/Progress.h"
#include "core/math/Vec3.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

struct LeakRefineSettings {
  /// Tetrahedralize -> trace -> add rounds at most; each round traces the new mesh's edges.
  int maxIterations = 6;
  /// Cap on the probes added over all rounds (a round that would exceed it adds the first ones).
  size_t maxAdded = 100000;
  /// A vertex asks for a probe on its side only when the hit is farther from it than this
  /// fraction of its local scale (the mean length of its mesh edges): a vertex already near the
  /// wall samples that side (Sukys Fig. 14, probes B and C; the threshold is relative to edge
  /// lengths as the paper asks, here those around the vertex, so that the probes added in one
  /// round do not ask for more between themselves in the next: no dense cluster forms).
  double minHitDistanceRelative = 0.2;
  /// The new probe is this fraction of the vertex's local scale off the hit (at most half the
  /// distance from the vertex to the hit; along the normal, at most half-way to what is there).
  double offsetRelative = 0.1;
  /// Offset the new probe from the hit along the surface's normal instead of back along the
  /// edge: the probes made for one wall then form a layer parallel to it.
  bool offsetAlongNormal = true;
  /// A new probe is dropped when an existing or already added probe it can see lies closer than
  /// this fraction of the vertex's local scale (several edges from one vertex hitting one wall
  /// make one probe, not six; a probe behind the wall does not count).
  double minSpacingRelative = 0.35;
  /// Validity of the new probes (Kontkanen & Laine sec. 5): rays and back-face fraction.
  int validityRays = 64;
  double invalidBackfaceFraction = 0.25;  ///< tol::kDefaultInvalidBackfaceFraction
  uint64_t seed = 1;
};

struct LeakRefineResult {
  std::vector<Vec3> added;  ///< new probe positions, in the order they were added
  /// Per added probe: how many edge crossings asked for it (1 + those merged into it).
  std::vector<double> addedScore;
  /// Leaking edges (edges crossing front-facing geometry) of the mesh before refinement and of
  /// the final mesh (input plus added probes).
  size_t leakingEdgesBefore = 0;
  size_t leakingEdgesAfter = 0;
  size_t edgesAfter = 0;  ///< edges of the final mesh
  /// Fraction of the mesh's volume in tetrahedra with a leaking edge, before and after. The
  /// added probes hug both sides of each wall, so edges still cross it between them, but the
  /// tetrahedra that interpolate across it shrink to a thin slab around it: this is the measure
  /// of what refinement achieves.
  double leakingVolumeFractionBefore = 0;
  double leakingVolumeFractionAfter = 0;
  int iterations = 0;  ///< rounds that traced the mesh (the last may add nothing)
  double seconds = 0;
};

/// True when the segment a -> b enters front-facing geometry (a ray from a towards b arrives at
/// a surface against its normal, grazing hits within tol::kLeakGrazingCos excepted), i.e. there
/// is the outside of a solid between a and b. Sets `hit` (its t in metres from a) when given.
bool segmentEntersGeometry(const Tracer& tracer, Vec3 a, Vec3 b, Hit* hit = nullptr);

/// Number of edges of the Delaunay tetrahedralization of `probes` that enter front-facing
/// geometry in either direction. Throws ps::ParameterError when the probes span less than 3D.
size_t countLeakingEdges(const Tracer& tracer, std::span<const Vec3> probes);

/// Adds probes until no edge of the Delaunay mesh of probes + added leaks (or the caps are hit).
/// `probes` are kept as they are; the result holds only the added ones. Deterministic for a
/// seed. Throws ps::ParameterError when the probes span less than 3D or a setting is out of
/// range, ps::Cancelled through `progress`.
LeakRefineResult refineLeaks(const Tracer& tracer, std::span<const Vec3> probes,
                             const LeakRefineSettings& settings = {},
                             const ProgressFn& progress = {});

/// Leak cuts. Refinement leaves the tetrahedra between the probe layers on each side of a wall
/// crossing it: a Delaunay mesh must span the wall, so a query in that slab (or in a tetrahedron
/// reaching past the layers where they are sparse) still interpolates a probe behind the wall.
/// A cut is a plane through the surface such a probe is hidden by: the query then interpolates
/// only its tetrahedron's probes on its own side (applyCuts in core/traversal/ProbeVolume.h),
/// one dot product per plane at run time.
struct LeakCutSettings {
  /// Points drawn uniformly in each tetrahedron (at least; in [1, 65536]), and beyond each of its
  /// hull faces, where queries are clamped to the face, in proportion to the volume out to the
  /// domain's edge. A point that sees every vertex counts as drawn; one that does not, only when
  /// it is valid, and then it asks for cuts.
  int samplesPerTet = 32;
  /// Points drawn in all, shared out by volume (a tetrahedron gets at least samplesPerTet;
  /// at most 2^32): queries are uniform in the domain, so the cuts are tested where they will be.
  /// As many again at most (and 2^22) are drawn uniformly over the domain for the queries
  /// clamped to an edge or a corner of the hull, which lie beyond no face: each goes to the
  /// tetrahedron locate() gives it, and where they are sparser than the tetrahedra's points each
  /// weighs as many of those as it stands for, so that a cut's cost counts volume.
  size_t samplesTotal = size_t(1) << 18;
  /// A tetrahedron in which a point found a hidden vertex draws more, up to this many times
  /// samplesPerTet (in [1, 1024]).
  int denseFactor = 8;
  /// Planes per tetrahedron at most (<= ProbeVolume::kMaxCutsPerTet).
  int maxPlanesPerTet = 8;
  /// What a cut costs, in leaking points, per unit of weight it moves at a point that sees every
  /// probe it interpolates (beyond a hull face: the face's three; the total variation of its
  /// weights, 0 to 1): a plane is infinite, and one through a pillar's face hides probes from
  /// points in plain view of them too. Non-negative; 0 counts the leaks alone. The default 0.25
  /// spares queries that see all their probes from planes that end few leaks but move their
  /// weights, at the cost of leaving those few leaks (its effect on rel_rmse is not measured
  /// under today's defaults).
  double overCutWeight = 0.25;
  /// Validity of a point that sees a vertex hidden (Kontkanen & Laine sec. 5).
  int validityRays = 16;
  double invalidBackfaceFraction = 0.25;  ///< tol::kDefaultInvalidBackfaceFraction
  uint64_t seed = 1;
  /// refineForLeakCuts: rounds of (tetrahedralize, cut, add probes where the cuts leave a leak)
  /// at most, the points it takes per leaking tetrahedron and round, and the probes it may add
  /// in all.
  int refineRounds = 8;
  size_t unresolvedPerTet = 1;
  size_t maxAdded = 10000;
};

struct LeakCutResult {
  size_t tetsCut = 0;  ///< tetrahedra that got at least one plane
  size_t planes = 0;
  /// Points drawn that interpolate a vertex they cannot see, before and after the cuts.
  size_t hiddenSamplesBefore = 0;
  size_t hiddenSamplesAfter = 0;
  /// Points drawn that count (LeakCutSettings::samplesPerTet), those drawn over the domain for
  /// the hull's edges and corners included (each once, whatever its weight).
  size_t samples = 0;
  /// Per tetrahedron the cuts leave leaking, up to unresolvedPerTet of its points that still
  /// interpolate a probe they cannot see (each the farthest from the tetrahedron's vertices and
  /// those before it), in tet order.
  std::vector<Vec3> unresolved;
  size_t tetsUnresolved = 0;
  double seconds = 0;
};

/// Fills v.cutStart and v.cutPlanes (replacing any cuts it had). Per tetrahedron: the candidate
/// cuts come from the surfaces hit by the rays from its points to the vertices they cannot see,
/// each a (plane, side, vertices) to hide; greedily, the candidate that most lowers the cost
/// (the points interpolating a hidden vertex, each by the volume it stands for, plus the
/// over-cut: LeakCutSettings::overCutWeight) is taken, or on a tie the one that hides the most
/// (point, hidden vertex) pairs (a point behind a wall and a cabinet needs two planes before its
/// count falls), up to the cap on planes; the shortest run of picks with the lowest cost is
/// kept. Deterministic for a seed. Throws ps::ParameterError for settings out of range.
/// `domain`: where queries can be (the importance volumes' boxes; empty: the scene bounds),
/// which bounds the points drawn outside the hull. `progress` gets the fraction of tetrahedra
/// cut, after each one; when it returns false no further tetrahedron starts, v is left as it
/// was and ps::Cancelled is thrown.
LeakCutResult computeLeakCuts(const Tracer& tracer, ProbeVolume& v, std::span<const Bounds3> domain,
                              const LeakCutSettings& settings = {},
                              const ProgressFn& progress = {});

/// Where the cuts cannot stop a leak (a query sees none of the probes its cell keeps, as beside
/// a box whose faces' planes cut off the probes it sees, or outside the hull in a window's
/// recess), a probe at that point ends it: rounds of tetrahedralize -> computeLeakCuts -> add
/// the unresolved points (those not within a millimetre-scale distance of a probe), until none
/// is left or the caps are hit. Of the rounds' probe sets, the one whose cuts leave the fewest
/// drawn points leaking is kept (computeLeakCuts with the same settings then gives bake the
/// same cuts). Returns the added probes, in order. Deterministic for a seed.
struct LeakCutRefineResult {
  std::vector<Vec3> added;
  int rounds = 0;             ///< rounds that computed cuts
  size_t unresolvedTets = 0;  ///< tetrahedra the cuts leave leaking, with the probes kept
  double seconds = 0;
};
/// Points within eval's clearance of a point or spot light of the scene or `rig` add no probe.
LeakCutRefineResult refineForLeakCuts(const Tracer& tracer, const LightingRig& rig,
                                      std::span<const Vec3> probes, std::span<const Bounds3> domain,
                                      const LeakCutSettings& settings = {});

}  // namespace ps
