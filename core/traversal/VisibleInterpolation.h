#pragma once
// The visibility-aware interpolant: irradiance SH at a point p (with an optional surface normal
// n) from a probe volume that carries visibility maps (ProbeVolume::visibility). It combines the
// tetrahedral volume's barycentric weights (Sukys 3.2.1) with DDGI's per-probe weights
// (Majercik et al. 2019, "Dynamic Diffuse Global Illumination with Ray-Traced Irradiance
// Probes", JCGT 8(2), sec. 5.2). For probe i of p's tetrahedron, with barycentric weight b_i
// (as locate() gives them):
//
//   r = |p - x_i| (m), dir = (p - x_i) / r;
//   mu, mu2 = the bilinear lookup (octahedral seams wrapped) of probe i's map in dir;
//   chebyshev: c = 1 when r <= mu, else var / (var + (r - mu)^2) with
//              var = max(0, mu2 - mu^2) + (kVisibilityVarianceBias mu)^2   (the variance bias);
//   sharpened: v = c^3;
//   normal term (only with n): s = ((dot(-dir, n) + 1) / 2)^2 + 0.2 ("smooth backface");
//   f = v s, crushed below 0.2 to f^3 / 0.04, and 0 below kVisibilityMinFactor;
//   f = 0 for a probe the capture found inside geometry; f = 1 for p within 1e-6 m of x_i;
//   w_i = b_i f, renormalised to sum 1.
//
// Fallbacks, in order, each taken only when the one before gives nothing:
//   1. every w_i is 0: f_i alone over the tetrahedron's four probes (the probes of p's
//      tetrahedron that see p, whatever p's barycentric position), renormalised;
//   2. every f_i is 0 too (no probe of p's tetrahedron sees p): the neighbour search. The
//      tetrahedra within kNeighbourSearchDepth face steps of p's, breadth first (its four face
//      neighbours in local order, then theirs), give their vertices not in p's tetrahedron, in
//      that order, the first kMaxNeighbourProbes of them; each with f_j > 0 (the same factor)
//      weighs f_j / d_j^2, d_j = |p - x_j|, renormalised. Within one tetrahedron the candidates
//      are fixed, so these weights vary continuously with p. When none of them sees p either (p
//      in a sliver of the hull, whose probes and their neighbours lie far away): the walk. From
//      the vertex of p's tetrahedron nearest p, it steps to the nearest vertex of that probe's
//      star (the tetrahedra around it) while that is nearer p, which ends at p's nearest probe;
//      that probe's star gives its vertices not in p's tetrahedron, nearest first, the first
//      kMaxNeighbourProbes, weighed as above. Its candidates change where p's nearest probe
//      does, and the light may step there;
//   3. no candidate sees p either: the barycentric weights b_i.
// A point is therefore never read through a wall while a probe of its tetrahedron or of the
// search sees it. The result's weights are always finite, non-negative and sum to 1 (within
// float rounding).
//
// The runtime reader (core/runtime/ps_volume_reader.h) computes the same weights with the same
// operations in double, and the same search; a volume without maps answers with its
// barycentric weights. The search needs only the tetrahedra's stored face neighbours: nothing is
// added to the volume or computed at load (docs/leaks.md weighs the alternatives).
#include <array>
#include <cstdint>
#include <optional>

#include "core/math/Sh.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

/// Added to each texel's variance as (kVisibilityVarianceBias mu)^2: a texel whose rays all hit
/// one flat wall has a variance near 0, and without the bias its test would turn from 1 to 0
/// within the wall's own noise.
inline constexpr double kVisibilityVarianceBias = 0.05;
/// A probe's factor f below this counts as 0 (the probe is taken as unseen).
inline constexpr double kVisibilityMinFactor = 1e-3;
/// The neighbour search's reach in face steps from p's tetrahedron: at most 4 + 12 tetrahedra.
inline constexpr int kNeighbourSearchDepth = 2;
/// The neighbour search examines at most this many probes (the first in its order). With the
/// tetrahedron's four, the most factors one query computes: 4 + 16 = 20.
inline constexpr int kMaxNeighbourProbes = 16;
/// The walk towards p's nearest probe (the neighbour search's second part) takes at most this
/// many steps, and reads at most kMaxStarTets tetrahedra around each probe it visits.
inline constexpr int kMaxWalkSteps = 64;
inline constexpr int kMaxStarTets = 128;
/// The most probes one query's weights blend (the neighbour search's).
inline constexpr int kMaxVisibleProbes = kMaxNeighbourProbes;

/// How the final weights were found.
enum class VisibleFallback : uint8_t {
  None,         ///< b_i f_i, renormalised
  Visibility,   ///< every b_i f_i was 0: f_i alone
  Barycentric,  ///< every f_i was 0, and no probe of the neighbour search sees p: b_i
  Neighbours,   ///< every f_i was 0: the probes of the neighbour search that see p
};

/// The probes a query blends and their final weights: the four of its tetrahedron, or those of
/// the neighbour search that see it (VisibleFallback::Neighbours).
struct VisibleWeights {
  int32_t tet = -1;  ///< p's tet (locate()); -1: the volume has no tets (count 0)
  /// Entries of probes, weights and factors in use: 4 (the tet's vertices, in its order), or 1
  /// to kMaxNeighbourProbes with Neighbours (in the search's order); 0 for tet = -1. The entries
  /// from `count` on are unspecified (not cleared: the struct is made once per query).
  int32_t count = 0;
  std::array<int32_t, kMaxVisibleProbes> probes;  ///< probe indices
  std::array<double, kMaxVisibleProbes> weights;  ///< final, non-negative, sum 1
  std::array<double, kMaxVisibleProbes> factors;  ///< f (1 when the volume has no maps)
  bool outside = false;                           ///< p is outside the hull (locate() clamped it)
  VisibleFallback fallback = VisibleFallback::None;
};

/// DDGI's visibility v (chebyshev test, sharpened: the header's formula without the normal term
/// and the crush) of point p from a probe at x whose map is `map` (mapSize x mapSize texels,
/// the layout of core/capture/Capture.h); 1 for a null map.
double mapVisibility(const float* map, int mapSize, Vec3 x, Vec3 p);

/// The factor f of the header (normal term, crush and floor included) of a probe at x with
/// `map` (null: v = 1) for point p; 0 for a probe the capture found `inside` geometry.
double visibilityFactor(const float* map, int mapSize, bool inside, Vec3 x, Vec3 p,
                        const std::optional<Vec3>& n);

/// The final weights from a tetrahedron's barycentric weights and its probes' factors: b_i f_i
/// renormalised, or the header's fallbacks 1 and 3 (Visibility, Barycentric); the neighbour
/// search between them needs the volume and is visibleWeights()'s. Every interpolant of the
/// project (eval, greedy's error, the runtime reader's twin in double) goes through these steps.
VisibleFallback combineVisibleWeights(const std::array<double, 4>& barycentric,
                                      const std::array<double, 4>& factors,
                                      std::array<double, 4>& weights);

/// DDGI's visibility factor v of probe `probe` for point p (chebyshev test, sharpened; the
/// header's formula, without the normal term and the crush). 1 when the volume has no maps.
double probeVisibility(const ProbeVolume& v, int32_t probe, Vec3 p);

/// The barycentric weights of `loc` as VisibleWeights: the tet's four probes, factors 1 (what
/// visibleWeights() gives for a volume without maps; count 0 for tet = -1).
VisibleWeights barycentricWeights(const ProbeVolume& v, const VolumeLocation& loc);

/// The final weights at p for location `loc` (locate(v, p, ...)); `normal`, when given, is
/// p's unit surface normal. Without maps: the barycentric weights. Cost: the four factors and,
/// only when none of them sees p, the neighbour search (at most 16 tetrahedra visited and
/// kMaxNeighbourProbes more factors).
VisibleWeights visibleWeights(const ProbeVolume& v, const VolumeLocation& loc, Vec3 p,
                              const std::optional<Vec3>& normal);

/// locate() then visibleWeights(): the weights at p (hint as for locate()).
VisibleWeights visibleWeights(const ProbeVolume& v, Vec3 p, const std::optional<Vec3>& normal,
                              int32_t hintTet = -1);

/// The SH blended with `w`'s weights (zero for tet = -1).
ShRgb interpolate(const ProbeVolume& v, const VisibleWeights& w);

/// Irradiance SH at p with optional normal: visibleWeights() then interpolate().
ShRgb interpolateVisible(const ProbeVolume& v, Vec3 p, const std::optional<Vec3>& normal,
                         int32_t hintTet = -1);

}  // namespace ps
