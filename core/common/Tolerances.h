#pragma once
// Every tolerance of the project, named, with what it means. Geometry that decides topology
// (orientation, in-sphere) is exact and needs none.
namespace ps::tol {

/// Ray origins are offset from surfaces by this fraction of the scene's bounding-box diagonal
/// (plus an absolute floor), so that a bounce or shadow ray never hits the surface it left.
inline constexpr double kRayOffsetRelative = 1e-5;
inline constexpr double kRayOffsetAbsolute = 1e-6;

/// A probe is inside geometry ("invalid", Kontkanen & Laine sec. 5) when more than this fraction
/// of its rays hit back faces, a back face of double-sided geometry counting half
/// (backfaceFraction).
inline constexpr double kDefaultInvalidBackfaceFraction = 0.25;

/// Barycentric weights of a query point inside a (possibly sliver) tetrahedron may fall this far
/// outside [0, 1] through float rounding; the walk treats -kBarycentricSlack as "inside".
inline constexpr float kBarycentricSlack = 1e-5f;

/// Relative volume of a tetrahedron: 6 * volume / (longest edge)^3 (0.707 for a regular one).
/// Below kThinTetRelativeVolume, the float barycentric matrix can be off by more than
/// kBarycentricSlack / 10 (error ~ 6e-8 / relative volume), so the walk decides with double
/// orientations instead. Below kFlatTetRelativeVolume the tet is treated as flat (no interior).
inline constexpr double kThinTetRelativeVolume = 1e-2;
inline constexpr double kFlatTetRelativeVolume = 1e-12;

/// locate()'s fast path returns the weights of the hint tet directly when all four, from its
/// double-precision frame, are at least this (the point is clearly inside, away from faces,
/// edges and vertices); otherwise the full walk and the exact weights run. Equal to
/// kBarycentricSlack so that the walk's float-matrix test (error <= ~6e-6 outside thin tets)
/// would have stopped in the same tet.
inline constexpr double kFastPathMargin = double(kBarycentricSlack);

/// sinCos2Pi (core/math/SinCos.h) is within this of the exact sin and cos of 2 pi v: the table's
/// rounding (half an ulp), the rounding of the remainder angle (<= 2e-18) and of the final sums
/// (1.1e-16 measured over 1e7 random v; std::sin and std::cos of the rounded 2 pi v: 6.9e-16).
inline constexpr double kSinCos2PiAbsolute = 4e-16;

}  // namespace ps::tol
