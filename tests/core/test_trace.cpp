// The Embree wrapper (core/trace/Tracer.h): hits, misses, occlusion, winding, epsilon.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <random>

#include "core/common/Tolerances.h"
#include "core/trace/Tracer.h"

namespace ps {
namespace {

void addTriangle(Scene& s, Vec3 a, Vec3 b, Vec3 c) {
  const auto base = static_cast<uint32_t>(s.vertexCount());
  for (Vec3 p : {a, b, c}) {
    s.positions.insert(s.positions.end(),
                       {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
    s.normals.insert(s.normals.end(), {0.f, 0.f, 1.f});
    s.bounds.extend(p);
  }
  s.indices.insert(s.indices.end(), {base, base + 1, base + 2});
  s.triangleMaterial.push_back(0);
  if (s.materials.empty()) s.materials.push_back({});
}

/// The unit right triangle in the z = 0 plane, counter-clockwise seen from +z.
Scene unitTriangle() {
  Scene s;
  addTriangle(s, {0, 0, 0}, {1, 0, 0}, {0, 1, 0});
  return s;
}

TEST(Tracer, FrontHitHasKnownTUVAndNormal) {
  const Scene s = unitTriangle();
  const Tracer tracer(s);
  const auto hit = tracer.intersect({{0.2, 0.3, 5}, {0, 0, -1}});
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->t, 5.0, 1e-6);
  EXPECT_EQ(hit->triangle, 0u);
  EXPECT_NEAR(hit->u, 0.2, 1e-6);
  EXPECT_NEAR(hit->v, 0.3, 1e-6);
  EXPECT_EQ(hit->geometricNormal, (Vec3{0, 0, 1}));
  EXPECT_TRUE(hit->frontFace);
}

TEST(Tracer, BackHitKeepsTheFrontNormal) {
  const Scene s = unitTriangle();
  const Tracer tracer(s);
  const auto hit = tracer.intersect({{0.1, 0.6, -2}, {0, 0, 1}});
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->t, 2.0, 1e-6);
  EXPECT_NEAR(hit->u, 0.1, 1e-6);
  EXPECT_NEAR(hit->v, 0.6, 1e-6);
  EXPECT_EQ(hit->geometricNormal, (Vec3{0, 0, 1}));
  EXPECT_FALSE(hit->frontFace);
}

TEST(Tracer, TIsInUnitsOfTheDirectionLength) {
  const Scene s = unitTriangle();
  const Tracer tracer(s);
  const auto hit = tracer.intersect({{0.25, 0.25, 3}, {0, 0, -2}});
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->t, 1.5, 1e-6);
}

TEST(Tracer, ObliqueHitOnATiltedTriangle) {
  // Triangle in the plane x + y + z = 1; normal (1,1,1)/sqrt(3) from its winding.
  Scene s;
  addTriangle(s, {1, 0, 0}, {0, 1, 0}, {0, 0, 1});
  const Tracer tracer(s);
  const Vec3 target = Vec3{1, 0, 0} * 0.5 + Vec3{0, 1, 0} * 0.2 + Vec3{0, 0, 1} * 0.3;
  const Vec3 origin{2, -1, 3};
  const auto hit = tracer.intersect({origin, target - origin});
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->t, 1.0, 1e-6);
  EXPECT_NEAR(hit->u, 0.2, 1e-6);
  EXPECT_NEAR(hit->v, 0.3, 1e-6);
  const double k = 1 / std::sqrt(3.0);
  EXPECT_NEAR(hit->geometricNormal.x, k, 1e-12);
  EXPECT_NEAR(hit->geometricNormal.y, k, 1e-12);
  EXPECT_NEAR(hit->geometricNormal.z, k, 1e-12);
  // The origin is on the positive side (2 - 1 + 3 > 1): front.
  EXPECT_TRUE(hit->frontFace);
}

TEST(Tracer, MissesReturnNothing) {
  const Scene s = unitTriangle();
  const Tracer tracer(s);
  EXPECT_FALSE(tracer.intersect({{0.8, 0.8, 1}, {0, 0, -1}}).has_value());  // outside the edge
  EXPECT_FALSE(tracer.intersect({{0.2, 0.2, 1}, {0, 0, 1}}).has_value());   // pointing away
  EXPECT_FALSE(tracer.intersect({{0.2, 0.2, 1}, {1, 0, 0}}).has_value());   // parallel
  EXPECT_FALSE(tracer.intersect({{0.2, 0.2, 1}, {0, 0, -1}, 0, 0.5}).has_value());  // short
  EXPECT_FALSE(tracer.intersect({{0.2, 0.2, 1}, {0, 0, -1}, 1.5}).has_value());     // tMin past
  EXPECT_TRUE(tracer.intersect({{0.2, 0.2, 1}, {0, 0, -1}, 0.5, 1.5}).has_value());
}

TEST(Tracer, OcclusionRespectsTheSegment) {
  const Scene s = unitTriangle();
  const Tracer tracer(s);
  EXPECT_TRUE(tracer.occluded({{0.2, 0.2, 1}, {0, 0, -1}}));
  EXPECT_TRUE(tracer.occluded({{0.2, 0.2, -1}, {0, 0, 1}, 0, 2}));  // from behind too
  EXPECT_FALSE(tracer.occluded({{0.2, 0.2, 1}, {0, 0, -1}, 0, 0.9}));
  EXPECT_FALSE(tracer.occluded({{0.2, 0.2, 1}, {0, 0, -1}, 1.1}));
  EXPECT_FALSE(tracer.occluded({{0.9, 0.9, 1}, {0, 0, -1}}));
  EXPECT_FALSE(tracer.occluded({{0.2, 0.2, 1}, {0, 0, 1}}));
}

TEST(Tracer, ClosestOfTwoStackedTriangles) {
  Scene s;
  addTriangle(s, {0, 0, 0}, {1, 0, 0}, {0, 1, 0});
  addTriangle(s, {0, 0, 2}, {0, 1, 2}, {1, 0, 2});  // clockwise from +z: normal -z
  const Tracer tracer(s);
  const auto down = tracer.intersect({{0.2, 0.2, 5}, {0, 0, -1}});
  ASSERT_TRUE(down.has_value());
  EXPECT_EQ(down->triangle, 1u);
  EXPECT_NEAR(down->t, 3.0, 1e-6);
  EXPECT_EQ(down->geometricNormal, (Vec3{0, 0, -1}));
  EXPECT_FALSE(down->frontFace);
  const auto between = tracer.intersect({{0.2, 0.2, 1}, {0, 0, 1}});
  ASSERT_TRUE(between.has_value());
  EXPECT_EQ(between->triangle, 1u);
  EXPECT_TRUE(between->frontFace);
  const auto up = tracer.intersect({{0.2, 0.2, -1}, {0, 0, 1}});
  ASSERT_TRUE(up.has_value());
  EXPECT_EQ(up->triangle, 0u);
  EXPECT_NEAR(up->t, 1.0, 1e-6);
}

TEST(Tracer, EmptySceneHitsNothing) {
  const Scene s;
  const Tracer tracer(s);
  EXPECT_FALSE(tracer.intersect({{0, 0, 0}, {0, 1, 0}}).has_value());
  EXPECT_FALSE(tracer.occluded({{0, 0, 0}, {0, 1, 0}}));
  EXPECT_DOUBLE_EQ(tracer.rayEpsilon(), tol::kRayOffsetAbsolute);
}

TEST(Tracer, RayEpsilonScalesWithTheScene) {
  Scene s;
  addTriangle(s, {0, 0, 0}, {30, 0, 0}, {0, 40, 0});  // diagonal 50
  const Tracer tracer(s);
  EXPECT_DOUBLE_EQ(tracer.rayEpsilon(), tol::kRayOffsetRelative * 50 + tol::kRayOffsetAbsolute);
}

/// Oracle: Moller-Trumbore in double. Returns t, u, v of a hit in (0, inf).
std::optional<std::array<double, 3>> bruteHit(Vec3 o, Vec3 d, Vec3 a, Vec3 b, Vec3 c) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 pv = cross(d, e2);
  const double det = dot(e1, pv);
  if (std::abs(det) < 1e-14) return std::nullopt;
  const Vec3 tv = o - a;
  const double u = dot(tv, pv) / det;
  const Vec3 qv = cross(tv, e1);
  const double v = dot(d, qv) / det;
  const double t = dot(e2, qv) / det;
  if (u < 0 || v < 0 || u + v > 1 || t <= 0) return std::nullopt;
  return std::array<double, 3>{t, u, v};
}

TEST(Tracer, AgreesWithBruteForceOnRandomSoup) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> box(-1, 1), small(-0.3, 0.3);
  Scene s;
  for (int i = 0; i < 300; ++i) {
    const Vec3 c{box(rng), box(rng), box(rng)};
    addTriangle(s, c + Vec3{small(rng), small(rng), small(rng)},
                c + Vec3{small(rng), small(rng), small(rng)},
                c + Vec3{small(rng), small(rng), small(rng)});
  }
  const Tracer tracer(s);
  std::normal_distribution<double> g;
  int compared = 0, hits = 0;
  for (int k = 0; k < 3000; ++k) {
    const Vec3 o{2 * box(rng), 2 * box(rng), 2 * box(rng)};
    const Vec3 d = normalize(Vec3{g(rng), g(rng), g(rng)});
    // Closest brute-force hit; skip rays that graze an edge or whose two nearest hits are close
    // (float rounding may legitimately pick either).
    double best = INFINITY, second = INFINITY;
    int bestTri = -1;
    std::array<double, 3> bestHit{};
    bool ambiguous = false;
    for (size_t t = 0; t < s.triangleCount(); ++t) {
      const Vec3 a = s.vertex(s.indices[3 * t]), b = s.vertex(s.indices[3 * t + 1]),
                 c = s.vertex(s.indices[3 * t + 2]);
      // Edge grazing: test the same ray against a slightly grown and shrunk triangle.
      const Vec3 m = (a + b + c) / 3;
      const auto grown =
          bruteHit(o, d, m + (a - m) * 1.001, m + (b - m) * 1.001, m + (c - m) * 1.001);
      const auto shrunk =
          bruteHit(o, d, m + (a - m) * 0.999, m + (b - m) * 0.999, m + (c - m) * 0.999);
      if (grown.has_value() != shrunk.has_value()) ambiguous = true;
      const auto h = bruteHit(o, d, a, b, c);
      if (!h) continue;
      if ((*h)[0] < best) {
        second = best;
        best = (*h)[0];
        bestTri = static_cast<int>(t);
        bestHit = *h;
      } else {
        second = std::min(second, (*h)[0]);
      }
    }
    if (ambiguous || second - best < 1e-4 || best < 1e-4) continue;
    ++compared;
    const auto hit = tracer.intersect({o, d});
    ASSERT_EQ(hit.has_value(), bestTri >= 0) << "ray " << k;
    EXPECT_EQ(tracer.occluded({o, d}), bestTri >= 0) << "ray " << k;
    if (!hit) continue;
    ++hits;
    EXPECT_EQ(static_cast<int>(hit->triangle), bestTri) << "ray " << k;
    EXPECT_NEAR(hit->t, bestHit[0], 1e-5);
    EXPECT_NEAR(hit->u, bestHit[1], 1e-4);
    EXPECT_NEAR(hit->v, bestHit[2], 1e-4);
    EXPECT_NEAR(length(hit->geometricNormal), 1.0, 1e-12);
  }
  EXPECT_GT(compared, 2500);
  EXPECT_GT(hits, 300);
}

}  // namespace
}  // namespace ps
