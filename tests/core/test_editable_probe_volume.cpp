// EditableProbeVolume: after every edit of seeded random sequences (inside and outside the hull,
// on random and degenerate input, with duplicates) the locally updated runtime volume equals a
// rebuild from the same mesh, array by array, and answers queries as the rebuild does; failed
// edits change nothing; the rows an edit reports are exactly the rows that changed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "core/common/Error.h"
#include "core/math/Random.h"
#include "core/traversal/EditableProbeVolume.h"
#include "core/traversal/ProbeVolume.h"
#include "tests/core/PointSets.h"

namespace ps {
namespace {

using testing::gridPoints;
using testing::randomPoints;

ShRgb randomSh(uint64_t& s) {
  ShRgb out;
  for (int k = 0; k < kShCoeffCount; ++k) out.c[k] = Rgb(uniform01(s), uniform01(s), uniform01(s));
  return out;
}

// The probes' SH as the editable volume should hold them: per id, tracked by the test.
struct Model {
  std::vector<ShRgb> sh;
};

ProbeVolume rebuild(const EditableProbeVolume& e, const Model& model) {
  const EditableTetrahedralization& t = e.tetrahedralization();
  std::vector<ShRgb> shOfVertex(t.mesh().vertices.size());
  for (size_t k = 0; k < shOfVertex.size(); ++k)
    shOfVertex[k] = model.sh[t.idsAt(int32_t(k)).front()];
  return buildProbeVolume(t.mesh(), shOfVertex);
}

bool sameFrames(const ProbeVolume& a, const ProbeVolume& b) {
  return a.frames.size() == b.frames.size() &&
         std::memcmp(a.frames.data(), b.frames.data(), a.frames.size() * sizeof(a.frames[0])) == 0;
}

// The incremental volume against a rebuild of the same mesh, and queries against the rebuild's.
void expectEqualToRebuild(const EditableProbeVolume& e, const Model& model, uint64_t seed) {
  const ProbeVolume& v = e.volume();
  const ProbeVolume ref = rebuild(e, model);
  ASSERT_EQ(v.tets, ref.tets);
  ASSERT_EQ(v.neighbors, ref.neighbors);
  EXPECT_EQ(v.matrices, ref.matrices);
  EXPECT_EQ(v.thinTets, ref.thinTets);
  EXPECT_TRUE(sameFrames(v, ref));
  EXPECT_EQ(v.positions, ref.positions);
  EXPECT_EQ(v.sh, ref.sh);
  auto hullA = v.hullFaces, hullB = ref.hullFaces;
  std::sort(hullA.begin(), hullA.end());
  std::sort(hullB.begin(), hullB.end());
  EXPECT_EQ(hullA, hullB);
  for (int32_t t : v.locatorGrid) ASSERT_TRUE(t >= 0 && size_t(t) < v.tets.size()) << t;
  // Cold queries (from the locator) inside and around the hull: the same tet and weights.
  Bounds3 box;
  for (size_t i = 0; i < v.probeCount(); ++i) box.extend(v.position(int32_t(i)));
  uint64_t s = streamSeed(seed, 5);
  for (int q = 0; q < 200; ++q) {
    Vec3 p;
    for (int a = 0; a < 3; ++a)
      p[a] = box.lo[a] + (uniform01(s) * 1.4 - 0.2) * (box.hi[a] - box.lo[a]);
    const VolumeLocation a = locate(v, p), b = locate(ref, p);
    ASSERT_EQ(a.outside, b.outside) << "query " << q;
    if (!b.outside) {
      ASSERT_EQ(a.tet, b.tet) << "query " << q;
      EXPECT_EQ(a.weights, b.weights);
    } else {
      // Clamped to the hull: where the nearest hull point is on an edge or a vertex, several
      // hull faces tie and the order of hullFaces picks one; the value is the same.
      const ShRgb x = interpolate(v, a), y = interpolate(ref, b);
      for (int k = 0; k < kShCoeffCount; ++k)
        for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(x.c[k][ch], y.c[k][ch], 1e-6) << "query " << q;
    }
  }
}

// Rows of the mesh that differ from `before` must all be reported.
void expectReportCoversChanges(const Tetrahedralization& before, const Tetrahedralization& after,
                               const TetEditReport& r) {
  EXPECT_EQ(r.tetCountBefore, before.tets.size());
  EXPECT_EQ(r.vertexCountBefore, before.vertices.size());
  for (size_t t = 0; t < after.tets.size(); ++t) {
    const bool changed = t >= before.tets.size() || after.tets[t] != before.tets[t] ||
                         after.neighbors[t] != before.neighbors[t];
    if (changed) {
      EXPECT_TRUE(std::binary_search(r.changedTets.begin(), r.changedTets.end(), int32_t(t)))
          << "tet slot " << t << " changed but was not reported";
    }
  }
  for (size_t k = 0; k < after.vertices.size(); ++k) {
    const bool changed = k >= before.vertices.size() || !(after.vertices[k] == before.vertices[k]);
    if (changed) {
      EXPECT_TRUE(
          std::binary_search(r.changedVertices.begin(), r.changedVertices.end(), int32_t(k)))
          << "vertex slot " << k << " changed but was not reported";
    }
  }
}

template <class Draw>
void randomEdits(EditableProbeVolume& e, Model& model, uint64_t seed, int edits, int checkEvery,
                 bool local, Draw draw) {
  uint64_t s = streamSeed(seed, 77);
  size_t maxChanged = 0;
  for (int k = 0; k < edits; ++k) {
    const EditableTetrahedralization& t = e.tetrahedralization();
    std::vector<int32_t> live;
    for (size_t id = 0; id < t.idCount(); ++id)
      if (t.isLive(int32_t(id))) live.push_back(int32_t(id));
    const int32_t pick = live[size_t(uniform01(s) * live.size())];
    const Tetrahedralization before = t.mesh();
    const double u = uniform01(s);
    TetEditReport r;
    if (u < 0.3) {
      const ShRgb sh = randomSh(s);
      r = e.insert(draw(s), sh);
      model.sh.push_back(sh);
    } else if (u < 0.55 && live.size() > 40) {
      r = e.remove(pick);
    } else if (u < 0.9) {
      r = e.move(pick, draw(s));
    } else {
      const ShRgb sh = randomSh(s);
      e.setSh(pick, sh);
      model.sh[pick] = sh;
      continue;
    }
    expectReportCoversChanges(before, t.mesh(), r);
    maxChanged = std::max(maxChanged, r.changedTets.size());
    if ((k + 1) % checkEvery == 0 || k + 1 == edits) {
      expectEqualToRebuild(e, model, seed + k);
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
  if (local) {
    EXPECT_LT(maxChanged, e.volume().tets.size() / 4) << "of " << e.volume().tets.size();
  }
}

EditableProbeVolume make(const std::vector<Vec3>& pts, Model& model, uint64_t seed) {
  uint64_t s = streamSeed(seed, 3);
  model.sh.clear();
  for (size_t i = 0; i < pts.size(); ++i) model.sh.push_back(randomSh(s));
  return EditableProbeVolume(pts, model.sh);
}

TEST(EditableProbeVolume, StartsEqualToBuildProbeVolume) {
  Model model;
  const EditableProbeVolume e = make(randomPoints(500, 1), model, 1);
  expectEqualToRebuild(e, model, 1);
}

TEST(EditableProbeVolume, RandomEditsEqualARebuildAfterEveryEdit) {
  for (uint64_t seed : {2u, 3u}) {
    Model model;
    EditableProbeVolume e = make(randomPoints(400, seed), model, seed);
    randomEdits(e, model, seed, 250, 1, true,
                [](uint64_t& s) { return Vec3(uniform01(s), uniform01(s), uniform01(s)); });
  }
}

TEST(EditableProbeVolume, EditsOutsideTheHullKeepHullFacesAndLocator) {
  // Targets in a box twice the initial one: the hull grows and shrinks, and probes leave the
  // locator's box (its cells then clamp; the walk still finds the tet).
  Model model;
  EditableProbeVolume e = make(randomPoints(300, 4), model, 4);
  randomEdits(e, model, 4, 200, 1, true, [](uint64_t& s) {
    return Vec3(-0.5, -0.5, -0.5) + Vec3(uniform01(s), uniform01(s), uniform01(s)) * 2.0;
  });
}

TEST(EditableProbeVolume, EditsOnDegenerateInputEqualARebuild) {
  // A grid edited with grid positions: cospherical ties and exact duplicates everywhere.
  Model model;
  EditableProbeVolume g = make(gridPoints(6), model, 6);
  randomEdits(g, model, 6, 150, 1, false, [](uint64_t& s) {
    return Vec3(int(uniform01(s) * 8) - 1, int(uniform01(s) * 8) - 1, int(uniform01(s) * 8) - 1);
  });
}

TEST(EditableProbeVolume, DuplicatesTakeTheLowestIdsSh) {
  Model model;
  const auto pts = randomPoints(100, 8);
  EditableProbeVolume e = make(pts, model, 8);
  uint64_t s = 99;
  const ShRgb other = randomSh(s);
  const int32_t dup = e.insert(pts[10], other).probe;
  model.sh.push_back(other);
  const int32_t vertex = e.tetrahedralization().mesh().vertexOfInput[10];
  EXPECT_EQ(e.tetrahedralization().mesh().vertexOfInput[dup], vertex);
  EXPECT_EQ(e.volume().probeSh(vertex).c[0][0], float(model.sh[10].c[0][0]));
  e.remove(10);
  EXPECT_EQ(e.volume().probeSh(vertex).c[0][0], float(other.c[0][0]));
  expectEqualToRebuild(e, model, 8);
}

TEST(EditableProbeVolume, FailedEditsChangeNothing) {
  // Four coplanar points and an apex: the apex cannot go, nor move into the plane.
  const std::vector<Vec3> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.5, 0.5, 1}};
  Model model;
  EditableProbeVolume e = make(pts, model, 9);
  const ProbeVolume before = e.volume();
  EXPECT_THROW(e.remove(4), ParameterError);
  EXPECT_THROW(e.move(4, {0.3, 0.3, 0}), ParameterError);
  EXPECT_THROW(e.move(4, {0, 0, 0}), ParameterError);  // onto a probe in the plane
  EXPECT_THROW(e.insert({0, std::nan(""), 0}, ShRgb{}), ParameterError);
  EXPECT_THROW(e.remove(17), ParameterError);
  EXPECT_THROW(e.setSh(17, ShRgb{}), ParameterError);
  const ProbeVolume& after = e.volume();
  EXPECT_EQ(after.tets, before.tets);
  EXPECT_EQ(after.neighbors, before.neighbors);
  EXPECT_EQ(after.positions, before.positions);
  EXPECT_EQ(after.hullFaces, before.hullFaces);
  EXPECT_EQ(after.locatorGrid, before.locatorGrid);
  expectEqualToRebuild(e, model, 9);
  // A move off the plane is fine, and so is one that keeps another probe off it.
  e.move(4, {0.5, 0.5, -2});
  e.insert({0.2, 0.2, 3}, ShRgb{});
  model.sh.push_back(ShRgb{});
  e.move(4, {0.3, 0.3, 0});
  expectEqualToRebuild(e, model, 9);
  EXPECT_THROW(EditableProbeVolume(pts, std::vector<ShRgb>(2)), ParameterError);
}

}  // namespace
}  // namespace ps
