#pragma once
// Delaunay tetrahedralization of probe positions (Sukys 3.2.1, after Cupisz 2012), built with
// exact predicates and symbolic perturbation, so degenerate input (grids, cospherical and
// coplanar sets, duplicates) never gives a wrong mesh.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/math/Vec3.h"

namespace ps {

struct Tetrahedralization {
  /// Distinct input points, exactly as given, in order of first appearance.
  std::vector<Vec3> vertices;
  /// Input index -> vertex index; exact duplicates (==) map to the same vertex.
  std::vector<int32_t> vertexOfInput;
  /// Vertex indices of each finite tetrahedron, positively oriented: with a, b, c, d its
  /// vertices, det[b - a, c - a, d - a] > 0 (CGAL::orientation(a, b, c, d) == POSITIVE), i.e.
  /// d lies on the side of plane (a, b, c) from which a, b, c appear counterclockwise; e.g.
  /// (0,0,0), (1,0,0), (0,1,0), (0,0,1).
  std::vector<std::array<int32_t, 4>> tets;
  /// Neighbour i is the tet sharing the face opposite vertex i; -1 when that face is on the
  /// convex hull.
  std::vector<std::array<int32_t, 4>> neighbors;
};

/// Delaunay tetrahedralization of `points` (exact predicates; cospherical sets are resolved by
/// symbolic perturbation, so the result is a valid Delaunay mesh of the convex hull for every
/// input). Every input point is a vertex. Throws ps::ParameterError naming the point index for
/// NaN or infinite coordinates, and when the points span fewer than 3 dimensions (fewer than 4
/// affinely independent points, including empty input).
Tetrahedralization tetrahedralize(std::span<const Vec3> points);

}  // namespace ps
