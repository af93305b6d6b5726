// Runtime probe volume traversal (Sukys 3.2.1 "Traversal"): locate() against an exact oracle
// (CGAL orientation of the float positions), on-boundary queries, termination from every hint,
// continuity across the hull, slivers, linear reproduction and clamping outside the hull.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Exact_rational.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "core/common/Tolerances.h"
#include "core/math/Random.h"
#include "core/traversal/ProbeVolume.h"
#include "tests/core/PointSets.h"

namespace ps {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;

#if defined(__SANITIZE_ADDRESS__)
constexpr int kScale = 10;  // ASan is ~5x slower: fewer queries
#else
constexpr int kScale = 1;
#endif

P3 toCgal(Vec3 p) {
  return P3(p.x, p.y, p.z);
}

using testing::randomFloatPoints;

// SH whose every coefficient is an affine function of position: barycentric interpolation
// reproduces it exactly.
ShRgb linearSh(Vec3 p) {
  ShRgb s;
  for (int k = 0; k < kShCoeffCount; ++k)
    for (int ch = 0; ch < 3; ++ch)
      s.c[k][ch] = 2.0 + (k + 1) * 0.1 * p.x - (ch + 1) * 0.2 * p.y + 0.05 * (k - ch) * p.z;
  return s;
}

ProbeVolume buildLinear(const std::vector<Vec3>& pts) {
  const Tetrahedralization t = tetrahedralize(pts);
  std::vector<ShRgb> sh;
  for (Vec3 v : t.vertices) sh.push_back(linearSh(Vec3(float(v.x), float(v.y), float(v.z))));
  return buildProbeVolume(t, sh);
}

// Exact: p is in the closed tet (no face sees it on the negative side).
bool containsExactly(const ProbeVolume& v, int32_t t, Vec3 p) {
  P3 q[4];
  for (int i = 0; i < 4; ++i) q[i] = toCgal(v.position(v.tets[t][i]));
  const P3 x = toCgal(p);
  return CGAL::orientation(x, q[1], q[2], q[3]) != CGAL::NEGATIVE &&
         CGAL::orientation(q[0], x, q[2], q[3]) != CGAL::NEGATIVE &&
         CGAL::orientation(q[0], q[1], x, q[3]) != CGAL::NEGATIVE &&
         CGAL::orientation(q[0], q[1], q[2], x) != CGAL::NEGATIVE;
}

// Smallest barycentric of p in tet t, in double from orientations (for near-boundary slack).
double minBarycentric(const ProbeVolume& v, int32_t t, Vec3 p) {
  Vec3 q[4];
  for (int i = 0; i < 4; ++i) q[i] = v.position(v.tets[t][i]);
  auto o = [](Vec3 a, Vec3 b, Vec3 c, Vec3 d) { return dot(b - a, cross(c - a, d - a)); };
  const double vol = o(q[0], q[1], q[2], q[3]);
  return std::min({o(p, q[1], q[2], q[3]), o(q[0], p, q[2], q[3]), o(q[0], q[1], p, q[3]),
                   o(q[0], q[1], q[2], p)}) /
         vol;
}

// Exhaustive exact search, bucketed: each tet is listed in every cell of a uniform grid that its
// bounding box overlaps, and a query tests (with exact orientations) every tet of its cell.
// Returns every tet whose closed volume contains p: one for a generic point, several on shared
// faces, edges and vertices, none outside the hull. The bucketing only skips tets whose box
// excludes p (the same floor() maps a box's corners and p, and it is monotone).
class ExactTetIndex {
 public:
  explicit ExactTetIndex(const ProbeVolume& v, int cellsPerAxis = 24) : v_(v), n_(cellsPerAxis) {
    for (size_t i = 0; i < v.probeCount(); ++i) box_.extend(v.position(int32_t(i)));
    cells_.resize(size_t(n_) * n_ * n_);
    for (int32_t t = 0; t < int32_t(v.tets.size()); ++t) {
      Bounds3 b;
      for (int32_t i : v.tets[t]) b.extend(v.position(i));
      const auto lo = cellOf(b.lo), hi = cellOf(b.hi);
      for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y)
          for (int x = lo[0]; x <= hi[0]; ++x) cells_[x + n_ * (y + n_ * z)].push_back(t);
    }
  }
  std::vector<int32_t> containing(Vec3 p) const {
    std::vector<int32_t> out;
    for (int a = 0; a < 3; ++a)
      if (p[a] < box_.lo[a] || p[a] > box_.hi[a]) return out;
    const auto c = cellOf(p);
    for (int32_t t : cells_[c[0] + n_ * (c[1] + n_ * c[2])])
      if (containsExactly(v_, t, p)) out.push_back(t);
    return out;
  }

 private:
  std::array<int, 3> cellOf(Vec3 p) const {
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a) {
      const double x = std::floor((p[a] - box_.lo[a]) / (box_.hi[a] - box_.lo[a]) * n_);
      c[a] = int(std::clamp(x, 0.0, double(n_ - 1)));
    }
    return c;
  }
  const ProbeVolume& v_;
  int n_;
  Bounds3 box_;
  std::vector<std::vector<int32_t>> cells_;
};

// The exact barycentrics of p in tet t of the float positions (rational arithmetic), rounded to
// double once at the end.
std::array<double, 4> exactBarycentrics(const ProbeVolume& v, int32_t t, Vec3 p) {
  using Q = CGAL::Exact_rational;
  auto o = [](Vec3 a, Vec3 b, Vec3 c, Vec3 d) -> Q {  // not an expression template of locals
    const Q bx = Q(b.x) - Q(a.x), by = Q(b.y) - Q(a.y), bz = Q(b.z) - Q(a.z);
    const Q cx = Q(c.x) - Q(a.x), cy = Q(c.y) - Q(a.y), cz = Q(c.z) - Q(a.z);
    const Q dx = Q(d.x) - Q(a.x), dy = Q(d.y) - Q(a.y), dz = Q(d.z) - Q(a.z);
    return bx * (cy * dz - cz * dy) + by * (cz * dx - cx * dz) + bz * (cx * dy - cy * dx);
  };
  Vec3 q[4];
  for (int i = 0; i < 4; ++i) q[i] = v.position(v.tets[t][i]);
  const Q vol = o(q[0], q[1], q[2], q[3]);
  return {
      CGAL::to_double(o(p, q[1], q[2], q[3]) / vol), CGAL::to_double(o(q[0], p, q[2], q[3]) / vol),
      CGAL::to_double(o(q[0], q[1], p, q[3]) / vol), CGAL::to_double(o(q[0], q[1], q[2], p) / vol)};
}

void expectValidWeights(const VolumeLocation& loc, double tolerance = 1e-6) {
  ASSERT_GE(loc.tet, 0);
  double sum = 0;
  for (float w : loc.weights) {
    ASSERT_TRUE(std::isfinite(w));
    EXPECT_GE(w, -tolerance);
    EXPECT_LE(w, 1 + tolerance);
    sum += w;
  }
  EXPECT_NEAR(sum, 1.0, 1e-5);
}

// The located tet contains p exactly, or p is within the walk's slack of it (near a face).
void expectFound(const ProbeVolume& v, Vec3 p, const VolumeLocation& loc, int& nearMisses) {
  ASSERT_FALSE(loc.outside) << p;
  expectValidWeights(loc);
  if (containsExactly(v, loc.tet, p)) return;
  ++nearMisses;
  EXPECT_GE(minBarycentric(v, loc.tet, p), -2.0 * tol::kBarycentricSlack) << p;
}

double relDiff(const ShRgb& a, const ShRgb& b) {
  double d = 0, m = 0;
  for (int k = 0; k < kShCoeffCount; ++k)
    for (int ch = 0; ch < 3; ++ch) {
      d = std::max(d, std::abs(a.c[k][ch] - b.c[k][ch]));
      m = std::max({m, std::abs(a.c[k][ch]), std::abs(b.c[k][ch])});
    }
  return d / m;
}

// A volume whose hull is exactly the unit cube: 8 corners plus random interior points.
std::vector<Vec3> cubeWithInterior(int n, uint64_t seed) {
  auto pts = randomFloatPoints(n, seed, {0.05, 0.05, 0.05}, 0.9);
  for (int c = 0; c < 8; ++c) pts.push_back({double(c & 1), double((c >> 1) & 1), double(c >> 2)});
  return pts;
}

TEST(ProbeVolume, LayoutAndMatrices) {
  const auto pts = randomFloatPoints(300, 3);
  const Tetrahedralization t = tetrahedralize(pts);
  std::vector<ShRgb> sh(t.vertices.size());
  for (size_t i = 0; i < sh.size(); ++i)
    for (int k = 0; k < kShCoeffCount; ++k) sh[i].c[k] = Rgb(i, k, -double(k));
  const ProbeVolume v = buildProbeVolume(t, sh);
  ASSERT_EQ(v.probeCount(), t.vertices.size());
  ASSERT_EQ(v.sh.size(), 27 * t.vertices.size());
  EXPECT_EQ(v.sh[27 * 5 + 3 * 2 + 1], 2.0f);  // coefficient-major: c[2].g of probe 5
  for (size_t i = 0; i < sh.size(); ++i) EXPECT_EQ(v.probeSh(int32_t(i)), sh[i]);
  // M [v0 - v3, v1 - v3, v2 - v3] = I, and each vertex gets weight 1 at itself.
  size_t hull = 0;
  for (size_t k = 0; k < v.tets.size(); ++k) {
    for (int i = 0; i < 4; ++i) {
      const Vec3 p = v.position(v.tets[k][i]);
      const auto& m = v.matrices[k];
      const Vec3 d = p - v.position(v.tets[k][3]);
      for (int r = 0; r < 3; ++r) {
        const double w = m[3 * r] * d.x + m[3 * r + 1] * d.y + m[3 * r + 2] * d.z;
        EXPECT_NEAR(w, r == i ? 1.0 : 0.0, 1e-4);
      }
      hull += v.neighbors[k][i] < 0;
    }
  }
  EXPECT_EQ(v.hullFaces.size(), hull);
  for (auto [tet, face] : v.hullFaces) EXPECT_EQ(v.neighbors[tet][face], -1);
}

TEST(ProbeVolume, LocateEqualsExhaustiveExactSearch) {
  // 100k random points (10k under ASan), alternating cold starts and walks from the last tet,
  // each compared with the exhaustive exact search.
  const ProbeVolume v = buildLinear(randomFloatPoints(2000, 5));
  const ExactTetIndex oracle(v);
  const uint64_t fallbacksBefore = detail::locateBruteForceCount();
  uint64_t s = streamSeed(5, 1);
  int nearMisses = 0, inside = 0, outside = 0, same = 0;
  const int n = 100000 / kScale;
  int32_t hint = -1;
  for (int i = 0; i < n; ++i) {
    const Vec3 p(uniform01(s), uniform01(s), uniform01(s));
    const bool cold = i % 2 == 0;
    const VolumeLocation loc = locate(v, p, cold ? -1 : hint);
    hint = loc.tet;
    const std::vector<int32_t> found = oracle.containing(p);
    if (loc.outside) {
      ++outside;
      EXPECT_TRUE(found.empty()) << p << " is in tet " << found[0];
      expectValidWeights(loc);
      continue;
    }
    ++inside;
    if (std::find(found.begin(), found.end(), loc.tet) != found.end()) {
      ++same;
      expectValidWeights(loc);
    } else {
      // Only within the walk's slack of a face of the tet returned (counted, and rare).
      expectFound(v, p, loc, nearMisses);
    }
  }
  std::printf("%d inside (%d the exhaustive search's tet), %d outside, %d within slack\n", inside,
              same, outside, nearMisses);
  EXPECT_GT(inside, n / 2);
  EXPECT_LT(nearMisses, n / 1000 + 1);
  EXPECT_EQ(same + nearMisses, inside);
  EXPECT_EQ(detail::locateBruteForceCount(), fallbacksBefore);
}

TEST(ProbeVolume, PointsOnVerticesEdgesAndFaces) {
  const ProbeVolume v = buildLinear(randomFloatPoints(500, 7));
  const uint64_t fallbacksBefore = detail::locateBruteForceCount();
  int nearMisses = 0;
  for (size_t k = 0; k < v.tets.size(); k += 3) {
    const auto& t = v.tets[k];
    Vec3 q[4];
    for (int i = 0; i < 4; ++i) q[i] = v.position(t[i]);
    // A vertex, an edge midpoint and a face point (exact in double for float inputs).
    const Vec3 queries[3] = {q[k % 4], (q[0] + q[1]) * 0.5, (q[1] * 2 + q[2] + q[3]) * 0.25};
    for (const Vec3& p : queries) {
      for (int32_t hint : {-1, int32_t(k), int32_t((k * 7919) % v.tets.size())}) {
        const VolumeLocation loc = locate(v, p, hint);
        expectFound(v, p, loc, nearMisses);
      }
    }
    // At a vertex, that probe's weight is 1.
    const VolumeLocation loc = locate(v, q[0]);
    for (int i = 0; i < 4; ++i)
      if (v.tets[loc.tet][i] == t[0]) {
        EXPECT_NEAR(loc.weights[i], 1.0f, 1e-5);
      }
  }
  EXPECT_EQ(nearMisses, 0);
  EXPECT_EQ(detail::locateBruteForceCount(), fallbacksBefore);
}

TEST(ProbeVolume, GridQueriesOnVerticesEdgesAndFacesMatchExhaustiveSearch) {
  // A regular grid: every cell cospherical, so the split into tets (by symbolic perturbation)
  // may include flat ones. Queries exactly at grid vertices, edge and face midpoints and cell
  // centres, from a cold start and from several hints, land in a tet that contains them
  // exactly, never a flat one, and reproduce the linear SH.
  const ProbeVolume v = buildLinear(testing::gridPoints(6));
  const ExactTetIndex oracle(v);
  const uint64_t fallbacksBefore = detail::locateBruteForceCount();
  std::vector<Vec3> queries;
  for (int z = 0; z <= 10; ++z)
    for (int y = 0; y <= 10; ++y)
      for (int x = 0; x <= 10; ++x) queries.push_back(Vec3(x, y, z) * 0.5);
  const int32_t n = int32_t(v.tets.size());
  for (size_t i = 0; i < queries.size(); ++i) {
    const Vec3 p = queries[i];
    const std::vector<int32_t> found = oracle.containing(p);
    ASSERT_FALSE(found.empty()) << p;
    for (int32_t hint : {-1, int32_t(i % n), int32_t((i * 7919) % n)}) {
      const VolumeLocation loc = locate(v, p, hint);
      ASSERT_FALSE(loc.outside) << p;
      expectValidWeights(loc);
      EXPECT_NE(std::find(found.begin(), found.end(), loc.tet), found.end()) << p;
      EXPECT_NE(v.matrices[loc.tet], (std::array<float, 9>{})) << "flat tet for " << p;
      EXPECT_LT(relDiff(interpolate(v, loc), linearSh(p)), 2e-6) << p;
    }
  }
  EXPECT_EQ(detail::locateBruteForceCount(), fallbacksBefore);
}

TEST(ProbeVolume, WalkFromEveryHintTerminates) {
  const ProbeVolume v = buildLinear(randomFloatPoints(400, 9));
  const uint64_t fallbacksBefore = detail::locateBruteForceCount();
  uint64_t s = streamSeed(9, 1);
  int nearMisses = 0;
  for (int i = 0; i < 20 / kScale + 2; ++i) {
    const Vec3 p(0.2 + 0.6 * uniform01(s), 0.2 + 0.6 * uniform01(s), 0.2 + 0.6 * uniform01(s));
    const int32_t expected = locate(v, p).tet;
    for (int32_t hint = 0; hint < int32_t(v.tets.size()); ++hint) {
      const VolumeLocation loc = locate(v, p, hint);
      if (loc.tet != expected) expectFound(v, p, loc, nearMisses);
    }
  }
  EXPECT_EQ(nearMisses, 0);
  EXPECT_EQ(detail::locateBruteForceCount(), fallbacksBefore);
}

TEST(ProbeVolume, InterpolationReproducesLinearFunction) {
  const ProbeVolume v = buildLinear(cubeWithInterior(1000, 11));
  uint64_t s = streamSeed(11, 1);
  int32_t hint = -1;
  for (int i = 0; i < 20000 / kScale; ++i) {
    const Vec3 p(uniform01(s), uniform01(s), uniform01(s));
    const VolumeLocation loc = locate(v, p, hint);
    hint = loc.tet;
    ASSERT_FALSE(loc.outside) << p;  // the hull is the unit cube
    EXPECT_LT(relDiff(interpolate(v, loc), linearSh(p)), 2e-6) << p;
  }
}

TEST(ProbeVolume, ContinuousAcrossTheHull) {
  // Non-linear SH (random per probe) so that the check is about the located tet and weights.
  const auto pts = randomFloatPoints(800, 13);
  const Tetrahedralization t = tetrahedralize(pts);
  std::vector<ShRgb> sh(t.vertices.size());
  uint64_t s = streamSeed(13, 1);
  for (auto& x : sh)
    for (auto& c : x.c) c = Rgb(0.5 + uniform01(s), 0.5 + uniform01(s), 0.5 + uniform01(s));
  const ProbeVolume v = buildProbeVolume(t, sh);
  int outsideCount = 0, within1e4 = 0;
  for (auto [tet, face] : v.hullFaces) {
    Vec3 q[3];
    for (int i = 0; i < 3; ++i) q[i] = v.position(v.tets[tet][(face + 1 + i) & 3]);
    const Vec3 inward = v.position(v.tets[tet][face]);
    Vec3 n = normalize(cross(q[1] - q[0], q[2] - q[0]));
    if (dot(n, inward - q[0]) > 0) n = -n;  // outward
    const Vec3 p = (q[0] + q[1] + q[2]) / 3.0;
    const double eps = 1e-7;
    const VolumeLocation in = locate(v, p - n * eps), on = locate(v, p),
                         out = locate(v, p + n * eps);
    expectValidWeights(in);
    expectValidWeights(on);
    expectValidWeights(out);
    outsideCount += out.outside;
    // Continuity: the interpolant is linear in the hull tet, with directional derivative along
    // n of sum_i (grad w_i . n) s_i; outside, the value is that of the nearest hull point (or,
    // within the walk's slack, the weights with the tiny negative one dropped). So the jump
    // across the face is at most ~3 eps sum_i |grad w_i . n| max|s|. Hull tets of a random
    // cloud are often flat (large gradients), so the bound is per face.
    Vec3 x[4];
    for (int i = 0; i < 4; ++i) x[i] = v.position(v.tets[tet][i]);
    const Vec3 a = x[0] - x[3], b = x[1] - x[3], c = x[2] - x[3];
    const double det = dot(a, cross(b, c));
    const Vec3 g[3] = {cross(b, c) / det, cross(c, a) / det, cross(a, b) / det};
    const double dn[4] = {dot(g[0], n), dot(g[1], n), dot(g[2], n), -dot(g[0] + g[1] + g[2], n)};
    const double slope = std::abs(dn[0]) + std::abs(dn[1]) + std::abs(dn[2]) + std::abs(dn[3]);
    const double maxS = 1.5;
    const double jump = relDiff(interpolate(v, in), interpolate(v, out));
    EXPECT_LT(jump, (3 * eps * slope * maxS + 1e-6) / 0.5) << "slope " << slope;
    EXPECT_LT(relDiff(interpolate(v, on), interpolate(v, out)), (eps * slope * maxS + 1e-6) / 0.5);
    within1e4 += jump < 1e-4;
  }
  std::printf("%d of %zu hull faces: jump across the hull < 1e-4 relative\n", within1e4,
              v.hullFaces.size());
  EXPECT_GT(outsideCount, 0);
  EXPECT_GT(within1e4, int(v.hullFaces.size()) * 3 / 4);  // measured: 112 of 136
}

TEST(ProbeVolume, FarOutsideGivesNearestHullPoint) {
  const ProbeVolume v = buildLinear(cubeWithInterior(300, 17));
  // Nearest hull points are exact: on a face, and at a corner.
  const struct {
    Vec3 query, nearest;
  } cases[] = {{{100, 0.3, 0.6}, {1, 0.3, 0.6}},
               {{0.25, -50, 0.75}, {0.25, 0, 0.75}},
               {{5, 5, 5}, {1, 1, 1}},
               {{-1e6, 0.5, 2}, {0, 0.5, 1}}};
  for (const auto& c : cases) {
    for (int32_t hint : {-1, 0}) {
      const VolumeLocation loc = locate(v, c.query, hint);
      EXPECT_TRUE(loc.outside);
      expectValidWeights(loc);
      const ShRgb got = interpolate(v, loc);
      EXPECT_LT(relDiff(got, linearSh(c.nearest)), 2e-6) << c.query;
      EXPECT_FALSE(got.c[0].isBlack());
    }
  }
}

TEST(ProbeVolume, FarQueriesAreNeverBlackAndClampToTheHull) {
  // Random directions at distances 2 to 1e6 from a random cloud's centre: every answer is
  // outside, finite, not black, and is the value at a hull point q = sum w_i v_i (linear SH
  // reproduced there) no farther from p than any probe (the nearest hull point is at least as
  // close as the nearest vertex).
  const auto pts = randomFloatPoints(500, 43);
  const ProbeVolume v = buildLinear(pts);
  uint64_t s = streamSeed(43, 1);
  for (int i = 0; i < 2000 / kScale; ++i) {
    const Vec3 dir = uniformSphere(uniform01(s), uniform01(s));
    const double dist = 2 * std::pow(10.0, 5.7 * uniform01(s));
    const Vec3 p = Vec3(0.5, 0.5, 0.5) + dir * dist;
    const VolumeLocation loc = locate(v, p, i % 2 ? -1 : int32_t(i % v.tets.size()));
    ASSERT_TRUE(loc.outside) << p;
    expectValidWeights(loc);
    Vec3 q;
    for (int k = 0; k < 4; ++k) q = q + v.position(v.tets[loc.tet][k]) * double(loc.weights[k]);
    const ShRgb got = interpolate(v, loc);
    EXPECT_FALSE(got.c[0].isBlack()) << p;
    EXPECT_LT(relDiff(got, linearSh(q)), 2e-6) << p;
    double nearestProbe = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < v.probeCount(); ++k)
      nearestProbe = std::min(nearestProbe, length(v.position(int32_t(k)) - p));
    EXPECT_LE(length(q - p), nearestProbe * (1 + 1e-6)) << p;
  }
}

TEST(ProbeVolume, HullClampGivesLocatesOwnClamp) {
  // The grid's ring search stops only when no unvisited cell can hold a nearer face: the same
  // tet and weights, bit for bit, for points near the hull (where many faces are about as near)
  // and far from it, and for a hull of coplanar faces (a grid, the layout of boundary samples).
  for (const std::vector<Vec3>& pts : {randomFloatPoints(400, 7), cubeWithInterior(300, 17),
                                       testing::gridPoints(6, {0, 0, 0}, 0.2)}) {
    const ProbeVolume v = buildLinear(pts);
    const HullClamp clamp(v);
    uint64_t s = streamSeed(11, pts.size());
    size_t outside = 0;
    for (int i = 0; i < 3000 / kScale; ++i) {
      const Vec3 dir = uniformSphere(uniform01(s), uniform01(s));
      const double dist = 0.3 * std::pow(10.0, 3 * uniform01(s));
      const Vec3 p = Vec3(0.5, 0.5, 0.5) + dir * dist;
      const VolumeLocation a = locate(v, p, -1);
      const VolumeLocation b = locate(v, p, -1, &clamp);
      ASSERT_EQ(a.outside, b.outside) << p;
      ASSERT_EQ(a.tet, b.tet) << p;
      ASSERT_EQ(a.weights, b.weights) << p;
      if (a.outside) {
        ++outside;
        const VolumeLocation c = clamp.clamp(p);
        EXPECT_EQ(c.tet, a.tet);
        EXPECT_EQ(c.weights, a.weights);
      }
    }
    EXPECT_GT(outside, 1000u / kScale);
  }
}

TEST(ProbeVolume, SliverTetsGiveValidWeights) {
  const uint64_t fallbacksBefore = detail::locateBruteForceCount();
  // (a) four nearly coplanar, nearly cospherical points plus far apexes.
  {
    const std::vector<Vec3> pts = {{0, 0, 0},     {1, 0, 0},      {0, 1, 0},       {1, 1, 1e-6},
                                   {0.5, 0.5, 5}, {0.5, 0.5, -5}, {0.3, 0.6, 1e-7}};
    const ProbeVolume v = buildLinear(pts);
    uint64_t s = streamSeed(19, 0);
    for (int i = 0; i < 20000 / kScale; ++i) {
      const Vec3 p(uniform01(s), uniform01(s), 1e-6 * (uniform01(s) - 0.5));
      const VolumeLocation loc = locate(v, p, i % 2 ? -1 : int32_t(i % v.tets.size()));
      expectValidWeights(loc, 1e-5);
      EXPECT_LT(relDiff(interpolate(v, loc), linearSh(p)), 1e-4) << p;
    }
  }
  // (b) a grid perturbed by 1e-9: the perturbation is lost in float, so many tets are flat.
  {
    std::vector<Vec3> pts;
    uint64_t s = streamSeed(23, 0);
    for (int z = 0; z < 6; ++z)
      for (int y = 0; y < 6; ++y)
        for (int x = 0; x < 6; ++x)
          pts.push_back(Vec3(x, y, z) + Vec3(uniform01(s), uniform01(s), uniform01(s)) * 1e-9);
    const ProbeVolume v = buildLinear(pts);
    int flat = 0;
    for (const auto& m : v.matrices) flat += m == std::array<float, 9>{};
    EXPECT_GT(flat, 0);
    int nearMisses = 0;
    int32_t hint = -1;
    for (int i = 0; i < 20000 / kScale; ++i) {
      const Vec3 p(5 * uniform01(s), 5 * uniform01(s), 5 * uniform01(s));
      const VolumeLocation loc = locate(v, p, hint);
      hint = loc.tet;
      expectValidWeights(loc, 1e-5);
      EXPECT_NE(v.matrices[loc.tet], (std::array<float, 9>{})) << "returned a flat tet";
      expectFound(v, p, loc, nearMisses);
      EXPECT_LT(relDiff(interpolate(v, loc), linearSh(p)), 1e-5) << p;
    }
    EXPECT_LT(nearMisses, 20);
  }
  EXPECT_EQ(detail::locateBruteForceCount(), fallbacksBefore);
}

TEST(ProbeVolume, CyclingWalkFallsBackToBruteForce) {
  // Corrupt the neighbours into a ring (no hull exits), so the walk towards a far point cycles:
  // the cycle is detected, the brute-force backstop runs, and the answer is still the clamp.
  ProbeVolume v = buildLinear(cubeWithInterior(20, 41));
  const int32_t n = int32_t(v.tets.size());
  ASSERT_GT(n, 2);
  for (int32_t k = 0; k < n; ++k)
    v.neighbors[k] = {(k + 1) % n, (k + 1) % n, (k + 1) % n, (k + 1) % n};
  const uint64_t before = detail::locateBruteForceCount();
  const VolumeLocation loc = locate(v, {3, 0.5, 0.25}, 0);
  EXPECT_EQ(detail::locateBruteForceCount(), before + 1);
  EXPECT_TRUE(loc.outside);
  EXPECT_LT(relDiff(interpolate(v, loc), linearSh({1, 0.5, 0.25})), 2e-6);
  // Inside, the backstop finds the containing tet.
  const Vec3 p(0.4, 0.55, 0.6);
  const VolumeLocation in = locate(v, p, 0);
  int nearMisses = 0;
  if (in.tet != 0 || !containsExactly(v, 0, p)) {
    expectFound(v, p, in, nearMisses);
  }
  EXPECT_LT(relDiff(interpolate(v, in), linearSh(p)), 2e-6);
}

TEST(ProbeVolume, FastPathWeightsAreExactWithinTolerance) {
  // locate()'s fast path (a hint tet that clearly contains p) against exact barycentrics: taken
  // exactly when every exact barycentric is clearly above tol::kFastPathMargin in a tet that is
  // not thin, never below it; its weights are in [0, 1], within 1e-7 of the exact ones, sum to
  // 1 within 1e-7, and are what locate() returns from that hint.
  const ProbeVolume v = buildLinear(randomFloatPoints(2000, 47));
  uint64_t s = streamSeed(47, 1);
  int taken = 0, declined = 0;
  double maxFloatError = 0;
  const double margin = tol::kFastPathMargin;
  for (int32_t k = 0; k < int32_t(v.tets.size()); k += 2 * kScale) {
    Vec3 q[4];
    for (int i = 0; i < 4; ++i) q[i] = v.position(v.tets[k][i]);
    for (int sample = 0; sample < 4; ++sample) {
      // Random barycentrics, some of them tiny (near a face, edge or vertex) or slightly negative.
      std::array<double, 4> b;
      double sum = 0;
      for (double& x : b) sum += (x = -std::log(1 - uniform01(s)));
      for (double& x : b) x /= sum;
      if (sample == 3) b[k % 4] = std::pow(10.0, -3 - 5 * uniform01(s)) * (k % 3 ? 1 : -1);
      const Vec3 p = q[0] * b[0] + q[1] * b[1] + q[2] * b[2] + q[3] * (1 - b[0] - b[1] - b[2]);
      const std::array<double, 4> exact = exactBarycentrics(v, k, p);
      const double minExact = *std::min_element(exact.begin(), exact.end());
      std::array<float, 4> w;
      const bool fast = detail::fastWeights(v, k, p, w);
      if (minExact < margin * (1 - 1e-6)) {
        EXPECT_FALSE(fast) << "taken at exact barycentric " << minExact << " for " << p;
      } else if (!v.thinTets[k] && minExact > margin * (1 + 1e-6)) {
        EXPECT_TRUE(fast) << p;
      }
      if (!fast) {
        ++declined;
        continue;
      }
      ++taken;
      double wsum = 0;
      for (int i = 0; i < 4; ++i) {
        EXPECT_GE(w[i], 0.0f);
        EXPECT_LE(w[i], 1.0f);
        EXPECT_NEAR(w[i], exact[i], 1e-7) << p;
        wsum += w[i];
      }
      EXPECT_NEAR(wsum, 1.0, 1e-7) << p;
      // The walk's own test in k (float matrix, as a renderer's) also says "inside": from hint
      // k the walk would have stopped at k, so the fast path does not change the tet found.
      const auto& m = v.matrices[k];
      const Vec3 d = p - q[3];
      double fw[4];
      for (int r = 0; r < 3; ++r) fw[r] = m[3 * r] * d.x + m[3 * r + 1] * d.y + m[3 * r + 2] * d.z;
      fw[3] = 1 - fw[0] - fw[1] - fw[2];
      for (int i = 0; i < 4; ++i) {
        EXPECT_GE(fw[i], -tol::kBarycentricSlack) << p;
        maxFloatError = std::max(maxFloatError, std::abs(fw[i] - exact[i]));
      }
      const VolumeLocation loc = locate(v, p, k);
      ASSERT_EQ(loc.tet, k);
      EXPECT_FALSE(loc.outside);
      EXPECT_EQ(loc.weights, w);
      // From a cold start the walk may stop in a neighbour within its slack (p can be 1e-5 of
      // a small tet's height from a face, much less in a big neighbour's barycentrics).
      const VolumeLocation cold = locate(v, p);
      if (cold.tet != k) {
        EXPECT_GE(minBarycentric(v, cold.tet, p), -tol::kBarycentricSlack) << p;
      }
    }
  }
  std::printf("fast path taken %d times, declined %d times; float-matrix weights off by <= %.2g\n",
              taken, declined, maxFloatError);
  EXPECT_GT(taken, 2 * declined);
  EXPECT_GT(declined, 0);
}

TEST(ProbeVolume, PointsWithin1e7OfAFaceEdgeOrVertexGetExactWeights) {
  // Points at most 1e-7 from a face, an edge or a vertex of their hint tet (inside it, on its
  // boundary, or just outside): the fast path declines them, and locate() returns a tet that
  // contains them exactly (or within the walk's slack) with the exact barycentrics of that tet
  // (negative ones, within the slack, clamped to 0 and the rest renormalised) to within 1e-7.
  const ProbeVolume v = buildLinear(randomFloatPoints(1000, 53));
  const ExactTetIndex oracle(v);
  const uint64_t fallbacksBefore = detail::locateBruteForceCount();
  uint64_t s = streamSeed(53, 1);
  int checked = 0, inTheOraclesTet = 0;
  for (int32_t k = 0; k < int32_t(v.tets.size()); k += 3 * kScale) {
    if (v.matrices[k] == std::array<float, 9>{}) continue;  // flat: no interior
    Vec3 q[4];
    for (int i = 0; i < 4; ++i) q[i] = v.position(v.tets[k][i]);
    const Vec3 centroid = (q[0] + q[1] + q[2] + q[3]) / 4.0;
    const int i = k % 4;
    const Vec3 a = q[(i + 1) & 3], b = q[(i + 2) & 3], c = q[(i + 3) & 3];
    const double u = 0.2 + 0.3 * uniform01(s), t = 0.2 + 0.3 * uniform01(s);
    const Vec3 onFace = a + (b - a) * u + (c - a) * (t * (1 - u));
    const Vec3 onEdge = a + (b - a) * u;
    const Vec3 toCentre = normalize(centroid - onFace);
    for (const Vec3& base : {onFace, onEdge, q[i]}) {
      const Vec3 in = normalize(centroid - base);
      for (double d : {1e-7, 3e-8, 0.0, -3e-8, -1e-7}) {
        const Vec3 p = base + (&base == &onFace ? toCentre : in) * d;
        std::array<float, 4> w;
        EXPECT_FALSE(detail::fastWeights(v, k, p, w)) << p;
        const VolumeLocation loc = locate(v, p, k);
        if (loc.outside) {
          EXPECT_TRUE(oracle.containing(p).empty()) << p;
          continue;
        }
        expectValidWeights(loc);
        const std::vector<int32_t> found = oracle.containing(p);
        inTheOraclesTet += std::find(found.begin(), found.end(), loc.tet) != found.end();
        std::array<double, 4> exact = exactBarycentrics(v, loc.tet, p);
        const double minExact = *std::min_element(exact.begin(), exact.end());
        EXPECT_GE(minExact, -tol::kBarycentricSlack) << p;
        double sum = 0;
        for (double& x : exact) sum += (x = std::max(x, 0.0));
        for (int j = 0; j < 4; ++j) EXPECT_NEAR(loc.weights[j], exact[j] / sum, 1e-7) << p;
        ++checked;
      }
    }
  }
  std::printf("%d near-boundary points checked, %d in a tet that contains them exactly\n", checked,
              inTheOraclesTet);
  EXPECT_GT(checked, 1000 / kScale);
  EXPECT_GT(inTheOraclesTet, checked / 2);
  EXPECT_EQ(detail::locateBruteForceCount(), fallbacksBefore);
}

TEST(ProbeVolume, LocateBatchMatchesLocate) {
  const ProbeVolume v = buildLinear(randomFloatPoints(1000, 29));
  std::vector<Vec3> path;
  for (int i = 0; i < 2000; ++i) {
    const double a = i * 0.005;
    path.push_back(
        {0.5 + 0.45 * std::cos(a), 0.5 + 0.45 * std::sin(a), 0.5 + 0.3 * std::sin(3 * a)});
  }
  // Then incoherent points (each a cold start from the locator) and a jump back onto the path.
  uint64_t s = streamSeed(29, 1);
  for (int i = 0; i < 500; ++i) path.push_back({uniform01(s), uniform01(s), uniform01(s)});
  path.push_back(path[0]);
  path.push_back(path[1]);
  std::vector<VolumeLocation> out(path.size());
  locateBatch(v, path, out);
  for (size_t i = 0; i < path.size(); ++i) {
    const VolumeLocation one = locate(v, path[i]);
    EXPECT_EQ(out[i].outside, one.outside);
    EXPECT_LT(relDiff(interpolate(v, out[i]), interpolate(v, one)), 1e-5);
  }
}

TEST(ProbeVolume, EmptyAndNonFiniteQueries) {
  const ProbeVolume empty;
  EXPECT_EQ(locate(empty, {0, 0, 0}).tet, -1);
  EXPECT_TRUE(interpolate(empty, locate(empty, {0, 0, 0})).c[0].isBlack());
  const ProbeVolume v = buildLinear(randomFloatPoints(50, 31));
  expectValidWeights(locate(v, {std::nan(""), 0, 0}));
  expectValidWeights(locate(v, {std::numeric_limits<double>::infinity(), 0, 0}, 3));
}

}  // namespace

}  // namespace ps
