// Delaunay tetrahedralization (Sukys 3.2.1): properties checked with CGAL's exact predicates and
// exact rational volumes, over seeded random input and every degenerate family.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Exact_rational.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/convex_hull_3.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "core/common/Error.h"
#include "core/math/Random.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using Q = CGAL::Exact_rational;

P3 toCgal(Vec3 p) {
  return P3(p.x, p.y, p.z);
}

Q det3(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {  // exact det[b - a, c - a, d - a]
  const Q ax(a.x), ay(a.y), az(a.z);
  const Q bx = Q(b.x) - ax, by = Q(b.y) - ay, bz = Q(b.z) - az;
  const Q cx = Q(c.x) - ax, cy = Q(c.y) - ay, cz = Q(c.z) - az;
  const Q dx = Q(d.x) - ax, dy = Q(d.y) - ay, dz = Q(d.z) - az;
  return bx * (cy * dz - cz * dy) - by * (cx * dz - cz * dx) + bz * (cx * dy - cy * dx);
}

// 6 x the volume of the convex hull, exactly.
Q hullVolume6(const std::vector<Vec3>& pts) {
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

// Every property the header promises, checked exactly.
void checkDelaunay(const std::vector<Vec3>& input, const Tetrahedralization& t,
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
      // Locally Delaunay: the neighbour's far vertex is not strictly inside the circumsphere.
      const P3 far = toCgal(t.vertices[t.tets[n][j]]);
      ASSERT_NE(CGAL::side_of_bounded_sphere(p[0], p[1], p[2], p[3], far), CGAL::ON_BOUNDED_SIDE)
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

std::vector<Vec3> randomPoints(int n, uint64_t seed, Vec3 lo = {0, 0, 0}, double size = 1) {
  std::vector<Vec3> pts;
  uint64_t s = streamSeed(seed, 0);
  for (int i = 0; i < n; ++i) {
    const double x = uniform01(s), y = uniform01(s), z = uniform01(s);
    pts.push_back(lo + Vec3(x, y, z) * size);
  }
  return pts;
}

std::vector<Vec3> grid(int n, Vec3 origin = {0, 0, 0}, double step = 1) {
  std::vector<Vec3> pts;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) pts.push_back(origin + Vec3(x, y, z) * step);
  return pts;
}

std::string errorOf(const std::vector<Vec3>& pts) {
  try {
    tetrahedralize(pts);
  } catch (const ParameterError& e) {
    return e.what();
  }
  return "";
}

TEST(Tetrahedralization, ConventionIsCgalPositiveOrientation) {
  // The header's example: the unit corner tet is positive in CGAL's sense and in det form.
  const std::vector<Vec3> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  EXPECT_EQ(CGAL::orientation(toCgal(pts[0]), toCgal(pts[1]), toCgal(pts[2]), toCgal(pts[3])),
            CGAL::POSITIVE);
  EXPECT_TRUE(det3(pts[0], pts[1], pts[2], pts[3]) > Q(0));
  const Tetrahedralization t = tetrahedralize(pts);
  ASSERT_EQ(t.tets.size(), 1u);
  EXPECT_EQ(t.neighbors[0], (std::array<int32_t, 4>{-1, -1, -1, -1}));
  const auto& v = t.tets[0];
  EXPECT_TRUE(det3(t.vertices[v[0]], t.vertices[v[1]], t.vertices[v[2]], t.vertices[v[3]]) > Q(0));
  checkDelaunay(pts, t);
}

TEST(Tetrahedralization, RandomPointsAreDelaunay) {
  for (uint64_t seed : {1u, 2u, 3u}) {
    const auto pts = randomPoints(2000, seed);
    const Tetrahedralization t = tetrahedralize(pts);
    EXPECT_EQ(t.vertices.size(), 2000u);
    checkDelaunay(pts, t);
  }
}

TEST(Tetrahedralization, IsDeterministic) {
  const auto pts = randomPoints(500, 7);
  const Tetrahedralization a = tetrahedralize(pts), b = tetrahedralize(pts);
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.neighbors, b.neighbors);
}

TEST(Tetrahedralization, RegularGridEveryCellCospherical) {
  const auto pts = grid(10);
  const Tetrahedralization t = tetrahedralize(pts);
  checkDelaunay(pts, t);
  // Every Delaunay tet of a cubic grid lies in one unit cell (its circumsphere is empty).
  for (const auto& tet : t.tets) {
    Bounds3 b;
    for (int32_t i : tet) b.extend(t.vertices[i]);
    EXPECT_EQ(b.extent(), Vec3(1, 1, 1));
  }
}

TEST(Tetrahedralization, CosphericalShell) {
  // Integer points exactly on the sphere x^2 + y^2 + z^2 = 25^2 (all cospherical, exactly).
  std::vector<Vec3> shell;
  const int r = 25;
  for (int x = -r; x <= r; ++x)
    for (int y = -r; y <= r; ++y)
      for (int z = -r; z <= r; ++z)
        if (x * x + y * y + z * z == r * r) shell.push_back({double(x), double(y), double(z)});
  ASSERT_GT(shell.size(), 100u);
  checkDelaunay(shell, tetrahedralize(shell));
  auto withCentre = shell;
  withCentre.push_back({0, 0, 0});
  checkDelaunay(withCentre, tetrahedralize(withCentre));
}

TEST(Tetrahedralization, CoplanarAndCollinearSubsets) {
  auto pts = randomPoints(500, 11);
  uint64_t s = streamSeed(11, 1);
  for (int i = 0; i < 200; ++i) pts.push_back({uniform01(s), uniform01(s), 0.5});  // a plane
  for (int i = 0; i < 15; ++i)
    for (int j = 0; j < 15; ++j) pts.push_back({i / 14.0, j / 14.0, 0.25});  // a planar grid
  for (int i = 0; i < 100; ++i) {
    const double u = uniform01(s);
    pts.push_back({u, u, u});  // the main diagonal
    pts.push_back({0.1 + 0.8 * u, 0.3, 0.7});
  }
  checkDelaunay(pts, tetrahedralize(pts));
}

TEST(Tetrahedralization, ExactDuplicatesAreMerged) {
  const auto base = randomPoints(500, 13);
  std::vector<Vec3> pts;
  uint64_t s = streamSeed(13, 1);
  for (const Vec3& p : base) {
    const int copies = 1 + int(uniform01(s) * 3);
    for (int c = 0; c < copies; ++c) pts.push_back(p);
  }
  for (size_t i = pts.size() - 1; i > 0; --i)  // shuffle
    std::swap(pts[i], pts[size_t(uniform01(s) * (i + 1))]);
  const Tetrahedralization t = tetrahedralize(pts);
  EXPECT_EQ(t.vertices.size(), base.size());
  checkDelaunay(pts, t);
  // Order of first appearance: vertex k first appears before vertex k + 1.
  int32_t seen = -1;
  for (int32_t v : t.vertexOfInput) {
    EXPECT_LE(v, seen + 1);
    seen = std::max(seen, v);
  }
}

TEST(Tetrahedralization, FarFromOriginTinySpacing) {
  // Grid spacing 1e-3 at 1e6 (not exactly representable: nearly cospherical cells) plus
  // random points in the same box.
  auto pts = grid(7, {1e6, 1e6, 1e6}, 1e-3);
  const auto rnd = randomPoints(300, 17, {1e6, 1e6, 1e6}, 6e-3);
  pts.insert(pts.end(), rnd.begin(), rnd.end());
  checkDelaunay(pts, tetrahedralize(pts));
}

TEST(Tetrahedralization, TwoClustersOfVeryDifferentScale) {
  auto pts = randomPoints(300, 19, {0, 0, 0}, 1e-3);
  const auto big = randomPoints(300, 23, {-500, -500, -500}, 1e3);
  pts.insert(pts.end(), big.begin(), big.end());
  checkDelaunay(pts, tetrahedralize(pts));
}

TEST(Tetrahedralization, RejectsNonFinite) {
  auto pts = randomPoints(10, 29);
  pts[3].y = std::nan("");
  EXPECT_NE(errorOf(pts).find("points[3]"), std::string::npos) << errorOf(pts);
  pts[3].y = 0.5;
  pts[7].z = -std::numeric_limits<double>::infinity();
  EXPECT_NE(errorOf(pts).find("points[7]"), std::string::npos) << errorOf(pts);
  EXPECT_NE(errorOf(pts).find("finite"), std::string::npos);
}

TEST(Tetrahedralization, RejectsLowDimension) {
  EXPECT_NE(errorOf({}).find("got 0 distinct points"), std::string::npos) << errorOf({});
  const std::vector<Vec3> three = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_NE(errorOf(three).find("got 3 distinct points spanning dimension 2"), std::string::npos)
      << errorOf(three);
  std::vector<Vec3> plane, line, same;
  uint64_t s = streamSeed(31, 0);
  for (int i = 0; i < 100; ++i) {
    const double u = uniform01(s), v = uniform01(s);
    plane.push_back({u, v, 2 * u});     // all in the tilted plane z = 2x, exactly
    line.push_back({u, 2 * u, 4 * u});  // exactly collinear (scaling by 2 is exact)
    same.push_back({0.5, 0.25, 1});
  }
  EXPECT_NE(errorOf(plane).find("spanning dimension 2"), std::string::npos) << errorOf(plane);
  EXPECT_NE(errorOf(line).find("spanning dimension 1"), std::string::npos) << errorOf(line);
  EXPECT_NE(errorOf(same).find("got 1 distinct points spanning dimension 0"), std::string::npos)
      << errorOf(same);
  EXPECT_NE(errorOf(same).find("need at least 4 points not all in one plane"), std::string::npos);
}

TEST(Tetrahedralization, Timing) {
#if defined(__SANITIZE_ADDRESS__)
  const int n = 10000;
#else
  const int n = 100000;
#endif
  const auto pts = randomPoints(n, 37);
  auto t0 = std::chrono::steady_clock::now();
  const Tetrahedralization t = tetrahedralize(pts);
  auto t1 = std::chrono::steady_clock::now();
  const auto g = grid(20);
  const Tetrahedralization tg = tetrahedralize(g);
  auto t2 = std::chrono::steady_clock::now();
  std::printf(
      "tetrahedralize: %d random points -> %zu tets in %.3f s; 20^3 grid -> %zu tets in "
      "%.3f s\n",
      n, t.tets.size(), std::chrono::duration<double>(t1 - t0).count(), tg.tets.size(),
      std::chrono::duration<double>(t2 - t1).count());
  EXPECT_EQ(t.vertices.size(), size_t(n));
  checkDelaunay(g, tg);
}

}  // namespace
}  // namespace ps
