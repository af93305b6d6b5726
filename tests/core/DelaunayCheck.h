#pragma once
// The Delaunay property checker shared by the tessellation tests: every property
// tetrahedralize() promises, decided with CGAL's exact predicates and exact rational volumes.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Exact_rational.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/convex_hull_3.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <vector>

#include "core/math/Vec3.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps::testing {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using Q = CGAL::Exact_rational;

inline P3 toCgal(Vec3 p) {
  return P3(p.x, p.y, p.z);
}

inline Q det3(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {  // exact det[b - a, c - a, d - a]
  const Q ax(a.x), ay(a.y), az(a.z);
  const Q bx = Q(b.x) - ax, by = Q(b.y) - ay, bz = Q(b.z) - az;
  const Q cx = Q(c.x) - ax, cy = Q(c.y) - ay, cz = Q(c.z) - az;
  const Q dx = Q(d.x) - ax, dy = Q(d.y) - ay, dz = Q(d.z) - az;
  return bx * (cy * dz - cz * dy) - by * (cx * dz - cz * dx) + bz * (cx * dy - cy * dx);
}

// 6 x the volume of the convex hull, exactly.
inline Q hullVolume6(const std::vector<Vec3>& pts) {
  std::vector<P3> ps;
  for (Vec3 p : pts) ps.push_back(toCgal(p));
  CGAL::Surface_mesh<P3> hull;
  CGAL::convex_hull_3(ps.begin(), ps.end(), hull);
  const Vec3 o = pts[0];
  Q sum(0);
  for (auto f : hull.faces()) {
    std::vector<Vec3> v;
    for (auto vx : CGAL::vertices_around_face(hull.halfedge(f), hull)) {
      const P3& p = hull.point(vx);
      v.push_back({p.x(), p.y(), p.z()});
    }
    EXPECT_EQ(v.size(), 3u);
    sum += det3(o, v[0], v[1], v[2]);  // outward faces: positive contribution
  }
  return sum;
}

// Every property the header promises, checked exactly: each input point is a vertex (exactly
// equal), vertices are distinct and all used, every tet is positively oriented, neighbours are
// symmetric and share the face opposite vertex i, every interior face is locally Delaunay, and
// (with checkVolume) the tets' exact total volume equals the convex hull's.
inline void checkDelaunay(const std::vector<Vec3>& input, const Tetrahedralization& t,
                          bool checkVolume = true) {
  ASSERT_EQ(t.vertexOfInput.size(), input.size());
  ASSERT_EQ(t.tets.size(), t.neighbors.size());
  ASSERT_FALSE(t.tets.empty());
  const int32_t nv = static_cast<int32_t>(t.vertices.size());
  // Every input point is present, exactly; vertices are distinct.
  for (size_t i = 0; i < input.size(); ++i) {
    ASSERT_GE(t.vertexOfInput[i], 0);
    ASSERT_LT(t.vertexOfInput[i], nv);
    ASSERT_EQ(t.vertices[t.vertexOfInput[i]], input[i]) << "input " << i;
  }
  {
    std::vector<std::array<double, 3>> s;
    for (Vec3 v : t.vertices) s.push_back({v.x, v.y, v.z});
    std::sort(s.begin(), s.end());
    ASSERT_EQ(std::adjacent_find(s.begin(), s.end()), s.end()) << "duplicate vertices";
  }
  std::vector<char> used(nv, 0);
  const int32_t nt = static_cast<int32_t>(t.tets.size());
  int hullFaces = 0;
  for (int32_t k = 0; k < nt; ++k) {
    const auto& tet = t.tets[k];
    P3 p[4];
    for (int i = 0; i < 4; ++i) {
      ASSERT_GE(tet[i], 0);
      ASSERT_LT(tet[i], nv);
      used[tet[i]] = 1;
      p[i] = toCgal(t.vertices[tet[i]]);
    }
    ASSERT_EQ(CGAL::orientation(p[0], p[1], p[2], p[3]), CGAL::POSITIVE) << "tet " << k;
    for (int i = 0; i < 4; ++i) {
      const int32_t n = t.neighbors[k][i];
      if (n < 0) {
        ++hullFaces;
        continue;
      }
      ASSERT_LT(n, nt);
      // Symmetric, sharing the 3 vertices other than i.
      const auto& nb = t.neighbors[n];
      const auto back = std::find(nb.begin(), nb.end(), k);
      ASSERT_NE(back, nb.end()) << "tet " << k << " face " << i;
      const int j = static_cast<int>(back - nb.begin());
      std::array<int32_t, 3> mine{}, theirs{};
      for (int a = 0, m = 0, o = 0; a < 4; ++a) {
        if (a != i) mine[m++] = tet[a];
        if (a != j) theirs[o++] = t.tets[n][a];
      }
      std::sort(mine.begin(), mine.end());
      std::sort(theirs.begin(), theirs.end());
      ASSERT_EQ(mine, theirs) << "tet " << k << " face " << i;
      // Locally Delaunay: the neighbour's far vertex is not strictly inside the circumsphere
      // (exact side_of_oriented_sphere; for a positive tet, the positive side is the inside).
      // On it (a cospherical tie) is allowed: symbolic perturbation decided the split.
      const P3 far = toCgal(t.vertices[t.tets[n][j]]);
      ASSERT_NE(CGAL::side_of_oriented_sphere(p[0], p[1], p[2], p[3], far), CGAL::ON_POSITIVE_SIDE)
          << "tet " << k << " face " << i;
    }
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0) << "vertices in no tet";
  EXPECT_EQ(hullFaces % 2, 0);  // a closed triangulated surface has an even face count
  if (checkVolume) {
    Q sum(0);
    for (const auto& tet : t.tets)
      sum += det3(t.vertices[tet[0]], t.vertices[tet[1]], t.vertices[tet[2]], t.vertices[tet[3]]);
    EXPECT_TRUE(sum == hullVolume6(t.vertices)) << "tets do not fill the convex hull exactly";
  }
}

}  // namespace ps::testing
