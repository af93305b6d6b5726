// Delaunay tetrahedralization (Sukys 3.2.1): properties checked with CGAL's exact predicates and
// exact rational volumes, over seeded random input and every degenerate family.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/common/Error.h"
#include "core/math/Random.h"
#include "core/tessellation/Tetrahedralization.h"
#include "tests/core/DelaunayCheck.h"
#include "tests/core/PointSets.h"

namespace ps {
namespace {

using testing::randomPoints;

using testing::checkDelaunay;
using testing::det3;
using testing::P3;
using testing::Q;
using testing::toCgal;
std::vector<Vec3> grid(int n, Vec3 origin = {0, 0, 0}, double step = 1) {
  return testing::gridPoints(n, origin, step);
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

}  // namespace
}  // namespace ps
