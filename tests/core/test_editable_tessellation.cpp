// Editable Delaunay tetrahedralization (insert, remove, move one probe): after seeded random
// edit sequences the mesh passes the exact Delaunay property checker and, for points in general
// position, equals a from-scratch tetrahedralize() of the live probes; each edit is local.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <limits>
#include <string>
#include <vector>

#include "core/common/Error.h"
#include "core/math/Random.h"
#include "core/tessellation/EditableTetrahedralization.h"
#include "core/tessellation/Tetrahedralization.h"
#include "tests/core/DelaunayCheck.h"
#include "tests/core/PointSets.h"

namespace ps {
namespace {

using testing::checkDelaunay;
using testing::gridPoints;
using testing::randomPoints;

using TetKey = std::array<std::array<double, 3>, 4>;

// The mesh as a sorted list of tets, each its sorted vertex positions: independent of numbering.
std::vector<TetKey> canonical(const Tetrahedralization& t) {
  std::vector<TetKey> out;
  for (const auto& tet : t.tets) {
    TetKey k;
    for (int i = 0; i < 4; ++i) {
      const Vec3 p = t.vertices[tet[i]];
      k[i] = {p.x, p.y, p.z};
    }
    std::sort(k.begin(), k.end());
    out.push_back(k);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The live probes and the snapshot restricted to them (vertexOfInput without removed ids), in
// the form checkDelaunay() takes.
struct Live {
  std::vector<Vec3> points;
  Tetrahedralization mesh;
};

Live liveOf(const EditableTetrahedralization& e) {
  Live l;
  l.mesh = e.snapshot();
  std::vector<int32_t> map;
  for (size_t id = 0; id < e.idCount(); ++id) {
    const int32_t v = l.mesh.vertexOfInput[id];
    EXPECT_EQ(v >= 0, e.isLive(int32_t(id))) << "id " << id;
    if (v < 0) continue;
    l.points.push_back(e.position(int32_t(id)));
    map.push_back(v);
  }
  l.mesh.vertexOfInput = map;
  return l;
}

// Checks the edited mesh exactly, and (sameAsScratch) that it equals a from-scratch build.
void checkAgainstScratch(const EditableTetrahedralization& e, bool sameAsScratch) {
  const Live l = liveOf(e);
  checkDelaunay(l.points, l.mesh);
  if (sameAsScratch) {
    EXPECT_EQ(canonical(l.mesh), canonical(tetrahedralize(l.points)));
  }
}

// A seeded sequence of inserts, removes and moves drawing new positions from `draw`; checks
// every `checkEvery` edits. With sameAsScratch (points in general position) each edit must also
// touch only a small part of the mesh; on degenerate input (a grid, whose cospherical cells form
// large conflict regions) the check is only the Delaunay property.
template <class Draw>
void randomEdits(EditableTetrahedralization& e, uint64_t seed, int edits, int checkEvery,
                 bool sameAsScratch, Draw draw) {
  uint64_t s = streamSeed(seed, 99);
  size_t maxTouched = 0;
  for (int k = 0; k < edits; ++k) {
    const double u = uniform01(s);
    std::vector<int32_t> live;
    for (size_t id = 0; id < e.idCount(); ++id)
      if (e.isLive(int32_t(id))) live.push_back(int32_t(id));
    const int32_t pick = live[size_t(uniform01(s) * live.size())];
    TetEditReport r;
    if (u < 0.35) {
      r = e.insert(draw(s));
    } else if (u < 0.6 && live.size() > 50) {
      r = e.remove(pick);
      EXPECT_FALSE(e.isLive(pick));
    } else {
      const Vec3 to = draw(s);
      r = e.move(pick, to);
      EXPECT_EQ(e.position(pick), to);
    }
    EXPECT_GE(r.seconds, 0.0);
    maxTouched = std::max(maxTouched, r.tetsRemoved + r.tetsCreated);
    if ((k + 1) % checkEvery == 0 || k + 1 == edits) {
      checkAgainstScratch(e, sameAsScratch);
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
  // Local: no edit rebuilt more than a quarter of the mesh.
  if (sameAsScratch) {
    EXPECT_LT(maxTouched, e.tetCount() / 4) << "of " << e.tetCount();
  }
}

TEST(EditableTetrahedralization, StartsEqualToTetrahedralize) {
  const auto pts = randomPoints(1000, 3);
  const EditableTetrahedralization e(pts);
  const Tetrahedralization scratch = tetrahedralize(pts);
  const Tetrahedralization snap = e.snapshot();
  EXPECT_EQ(snap.vertices, scratch.vertices);
  EXPECT_EQ(snap.vertexOfInput, scratch.vertexOfInput);
  EXPECT_EQ(canonical(snap), canonical(scratch));
  checkDelaunay(pts, snap);
}

TEST(EditableTetrahedralization, RandomEditSequencesEqualScratchBuild) {
  for (uint64_t seed : {1u, 2u, 3u}) {
    EditableTetrahedralization e(randomPoints(600, seed));
    randomEdits(e, seed, 300, 60, true,
                [](uint64_t& s) { return Vec3(uniform01(s), uniform01(s), uniform01(s)); });
  }
}

TEST(EditableTetrahedralization, EditsOutsideTheHullGrowAndShrinkIt) {
  // New positions in a box twice the initial one: hull faces change on many edits.
  EditableTetrahedralization e(randomPoints(300, 5));
  randomEdits(e, 5, 200, 40, true, [](uint64_t& s) {
    return Vec3(-0.5, -0.5, -0.5) + Vec3(uniform01(s), uniform01(s), uniform01(s)) * 2.0;
  });
}

TEST(EditableTetrahedralization, EditsOnDegenerateInputStayDelaunay) {
  // A grid (every cell cospherical) edited with grid positions: ties everywhere, decided by
  // symbolic perturbation, so the mesh need not equal a scratch build's, but must be Delaunay.
  EditableTetrahedralization g(gridPoints(6));
  randomEdits(g, 7, 150, 30, false, [](uint64_t& s) {
    return Vec3(int(uniform01(s) * 8) - 1, int(uniform01(s) * 8) - 1, int(uniform01(s) * 8) - 1);
  });
  // Coplanar and collinear positions added to a random cloud.
  EditableTetrahedralization c(randomPoints(200, 9));
  randomEdits(c, 9, 150, 30, false, [](uint64_t& s) {
    const double u = uniform01(s), v = uniform01(s);
    return uniform01(s) < 0.5 ? Vec3(u, v, 0.5) : Vec3(u, u, u);
  });
  // Far from the origin, 1e-3 apart.
  EditableTetrahedralization f(gridPoints(5, {1e6, 1e6, 1e6}, 1e-3));
  randomEdits(f, 11, 100, 25, false, [](uint64_t& s) {
    return Vec3(1e6, 1e6, 1e6) +
           Vec3(int(uniform01(s) * 6), int(uniform01(s) * 6), int(uniform01(s) * 6)) * 1e-3;
  });
}

TEST(EditableTetrahedralization, ExactDuplicatesShareAVertex) {
  const auto pts = randomPoints(100, 13);
  EditableTetrahedralization e(pts);
  const auto before = canonical(e.snapshot());
  const TetEditReport r = e.insert(pts[10]);
  EXPECT_EQ(r.probe, 100);
  EXPECT_EQ(r.tetsRemoved + r.tetsCreated, 0u);
  EXPECT_EQ(e.snapshot().vertexOfInput[100], e.snapshot().vertexOfInput[10]);
  // Removing one of the two keeps the vertex; removing both removes it.
  const TetEditReport r1 = e.remove(10);
  EXPECT_EQ(r1.tetsRemoved + r1.tetsCreated, 0u);
  EXPECT_EQ(canonical(e.snapshot()), before);
  const TetEditReport r2 = e.remove(100);
  EXPECT_GT(r2.tetsRemoved, 0u);
  checkAgainstScratch(e, true);
  // Moving onto another probe merges them; moving to where it is changes nothing.
  EXPECT_EQ(e.move(20, e.position(20)).tetsRemoved, 0u);
  e.move(20, pts[30]);
  EXPECT_EQ(e.snapshot().vertexOfInput[20], e.snapshot().vertexOfInput[30]);
  checkAgainstScratch(e, true);
}

std::string errorOf(auto&& f) {
  try {
    f();
  } catch (const ParameterError& e) {
    return e.what();
  }
  return "";
}

TEST(EditableTetrahedralization, BadEditsThrowAndLeaveTheMeshUnchanged) {
  // Four coplanar points and one apex: the apex cannot go.
  const std::vector<Vec3> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.5, 0.5, 1}};
  EditableTetrahedralization e(pts);
  const auto before = canonical(e.snapshot());
  EXPECT_NE(errorOf([&] { e.remove(4); }).find("probe 4 is needed"), std::string::npos);
  EXPECT_EQ(canonical(e.snapshot()), before);
  EXPECT_TRUE(e.isLive(4));
  EXPECT_NE(errorOf([&] {
              e.move(4, {0.3, 0.3, 0});
            }).find("all probes would lie in one plane"),
            std::string::npos);
  EXPECT_EQ(canonical(e.snapshot()), before);
  EXPECT_EQ(e.position(4), Vec3(0.5, 0.5, 1));
  checkAgainstScratch(e, true);
  EXPECT_NE(errorOf([&] { e.remove(7); }).find("probe 7 is not live"), std::string::npos);
  EXPECT_NE(errorOf([&] {
              e.move(-1, {0, 0, 0});
            }).find("probe -1 is not live"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { e.insert({std::nan(""), 0, 0}); }).find("not finite"), std::string::npos);
  EXPECT_NE(errorOf([&] {
              e.move(0, {0, std::numeric_limits<double>::infinity(), 0});
            }).find("not finite"),
            std::string::npos);
  EXPECT_EQ(canonical(e.snapshot()), before);
  // A valid move of the apex keeps the mesh 3-dimensional.
  e.move(4, {0.5, 0.5, -2});
  checkAgainstScratch(e, true);
  // Construction rejects what tetrahedralize() rejects, with the same message.
  const std::vector<Vec3> flat = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  EXPECT_NE(errorOf([&] {
              EditableTetrahedralization x(flat);
            }).find("need at least 4 points not all in one plane"),
            std::string::npos);
}

}  // namespace
}  // namespace ps
