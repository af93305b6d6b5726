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
#include "core/trace/Tracer.h"

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

}  // namespace ps
