#pragma once
// The runtime probe volume: compact arrays a renderer queries anywhere (Sukys 3.2, Cupisz 2012).
// Per tetrahedron: 4 probe ids, 4 neighbour ids and a 3x3 matrix giving barycentric
// coordinates from (p - v3). Queries outside the convex hull are clamped to the nearest point
// of the hull, which is continuous with the inside and never black.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/math/Sh.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps {

struct ProbeVolume {
  std::vector<float> positions;  ///< 3 per probe
  std::vector<float> sh;         ///< 27 per probe: 9 coefficients x RGB
  std::vector<std::array<int32_t, 4>> tets;
  std::vector<std::array<int32_t, 4>> neighbors;  ///< -1 on the hull
  /// Row-major; w0..2 = M (p - v3), w3 = 1 - sum. M is the inverse of the matrix with columns
  /// v0 - v3, v1 - v3, v2 - v3 (computed in double from the float positions). All zero for a
  /// tet that is flat at float precision (relative volume below tol::kFlatTetRelativeVolume):
  /// such a tet has no interior and locate() never returns it for a point inside the hull.
  std::vector<std::array<float, 9>> matrices;
  /// Hull faces: tet index and the local index of the vertex opposite the hull face.
  std::vector<std::array<int32_t, 2>> hullFaces;
  /// Visibility maps (DDGI, Majercik et al. 2019, sec. 4; layout in core/capture/Capture.h):
  /// visibilityMapSize texels per side, 0 for a volume without maps. Per probe,
  /// 2 visibilityMapSize^2 floats in `visibility` (mean and mean square of the first-hit
  /// distance, m and m^2, texel-major) and one entry in `probeInside` (1: the capture found the
  /// probe inside geometry, and it gets no visibility weight). Both empty without maps.
  int32_t visibilityMapSize = 0;
  std::vector<float> visibility;
  std::vector<uint8_t> probeInside;

  // Derived search data, rebuilt from the arrays above by buildLocator() (buildProbeVolume calls
  // it; a loader that does not store it should call it too). When empty, locate() still works:
  // a cold start then begins at tet 0 and every tet is walked with its matrix.
  /// 1 when the tet is thin (relative volume below tol::kThinTetRelativeVolume): the float
  /// matrix is then too ill-conditioned to decide the walk, which uses double orientations.
  std::vector<uint8_t> thinTets;
  /// Per tet, for locate()'s fast path: the barycentric matrix in double with its origin v3
  /// next to it (w0..2 = m (p - origin), w3 = 1 - sum), one contiguous 96-byte record. Computed
  /// in double from the float positions, so its weights are within ~1e-14 of the exact
  /// barycentrics outside thin tets. Thin and flat tets get NaN (never taken: the walk and the
  /// orientation weights handle them).
  struct alignas(32) Frame {
    double m[9];
    double origin[3];
  };
  std::vector<Frame> frames;
  /// Cold-start locator: a uniform grid of locatorDims cells of size locatorCellSize from
  /// locatorLo over the probes' bounding box; cell (x, y, z), at index
  /// x + dims[0] * (y + dims[1] * z), holds the tet containing (or, outside the hull, the hull
  /// tet nearest to) the cell's centre.
  std::vector<int32_t> locatorGrid;
  std::array<float, 3> locatorLo{};
  std::array<float, 3> locatorCellSize{};
  std::array<int32_t, 3> locatorDims{};

  size_t probeCount() const { return positions.size() / 3; }
  bool hasVisibility() const { return visibilityMapSize > 0; }
  Vec3 position(int32_t i) const {
    return {positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]};
  }
  ShRgb probeSh(int32_t i) const;
};

/// Builds the runtime volume. `shOfVertex` has one entry per tetrahedralization vertex.
ProbeVolume buildProbeVolume(const Tetrahedralization& t, std::span<const ShRgb> shOfVertex);

/// Every length of `v` times `factor` (> 0, finite): a change of unit. Positions and visibility
/// distances (mean times factor, mean square times factor^2) scale; the
/// matrices are recomputed from the scaled float positions, and the locator rebuilt. Every
/// query of the scaled volume at factor * p gives the weights of p in `v` (the interpolant is
/// scale-free), up to float rounding. O(probes + tets + map texels).
void scaleVolume(ProbeVolume& v, double factor);

/// (Re)builds the derived search data (thinTets, frames, locator grid) of `v` from its positions,
/// tets, neighbours and matrices.
void buildLocator(ProbeVolume& v);

struct VolumeLocation {
  int32_t tet = -1;
  std::array<float, 4> weights{};  ///< barycentric, in [0, 1], sum to 1
  bool outside = false;            ///< the query was outside the hull and was clamped to it
};

/// Finds the tetrahedron containing p by walking from `hintTet` (the caller's last one, or -1
/// for a cold start from the locator grid) towards the most negative barycentric coordinate
/// (Sukys 3.2.1, "Traversal"). Weights >= -tol::kBarycentricSlack count as inside. A point
/// outside the hull is clamped to the nearest point of the hull surface (outside = true).
/// Terminates for every input: a walk that cycles or exceeds 4 * tets + 100 steps falls back to
/// a brute-force scan. The walk decides with the float matrices (as a renderer would).
/// Weights: when all four barycentrics from the tet's double frame are >= tol::kFastPathMargin
/// (the point is clearly inside; tried on the hint tet before any walk), those rounded to float:
/// within 1e-7 of the exact barycentrics of p in the tet of the float positions, summing to 1
/// within 1e-7. Otherwise (near a face, edge or vertex, in a thin tet) they are recomputed from
/// double orientations of the positions, clamped to [0, 1] and renormalised. Always finite, in
/// [0, 1], summing to 1 within 1e-7. An out-of-range hint counts as -1. A non-finite p gives tet
/// 0 with equal weights and outside = true; an empty volume (no tets) gives tet = -1.
VolumeLocation locate(const ProbeVolume& v, Vec3 p, int32_t hintTet = -1);

/// The clamp to the hull that locate() does outside it, through a grid of the hull faces built
/// once: for many points clamped against one volume (greedy placement's samples outside its
/// hull). The same face, tet and weights as locate()'s own clamp (a scan of every face). Holds a
/// pointer to `v`, which must outlive it and not change.
class HullClamp {
 public:
  explicit HullClamp(const ProbeVolume& v);
  VolumeLocation clamp(Vec3 p) const;

 private:
  std::array<int, 3> cellOf(Vec3 p) const;
  template <class F>
  void forCells(const std::array<int, 6>& range, const F& f) const;

  const ProbeVolume* v_;
  Bounds3 box_;  ///< of the hull's vertices
  int dims_[3] = {1, 1, 1};
  double cell_[3] = {1, 1, 1};
  std::vector<uint32_t> cellStart_, faces_;  ///< per cell, the hull faces its box touches
};

/// locate() with `clamp` (built from v; nullptr: the plain clamp) for points outside the hull.
VolumeLocation locate(const ProbeVolume& v, Vec3 p, int32_t hintTet, const HullClamp* clamp);

/// locate() for each point. A point within one locator cell of the previous one walks from the
/// previous point's tet (coherent queries, e.g. the samples of a moving object, are then a step
/// or two each); a farther one starts from the locator (a cold query). `out.size()` must equal
/// `points.size()`.
void locateBatch(const ProbeVolume& v, std::span<const Vec3> points, std::span<VolumeLocation> out);

/// SH blended with the location's barycentric weights (zero for tet = -1).
ShRgb interpolate(const ProbeVolume& v, const VolumeLocation& loc);

namespace detail {
/// locate()'s fast path on its own: true, with the weights, when p is inside tet t by at least
/// tol::kFastPathMargin in every barycentric of t's frame; false otherwise (also when the
/// frames are not built, or t is thin or flat). For tests.
bool fastWeights(const ProbeVolume& v, int32_t t, Vec3 p, std::array<float, 4>& weights);
/// How many locate() calls (process-wide) fell back to the brute-force scan; for tests.
uint64_t locateBruteForceCount();
/// Recomputes tet t's matrix, thin flag and frame from its row and the positions, exactly as
/// buildProbeVolume() and buildLocator() do (the arrays must already hold slot t).
void updateTet(ProbeVolume& v, int32_t t);
/// The tet for locator cell `cell` (index as in locatorGrid): the walk from `start` to the
/// cell's centre, as buildLocator() does; `start` when the walk fails.
int32_t locatorCellTet(const ProbeVolume& v, size_t cell, int32_t start);
}  // namespace detail

}  // namespace ps
