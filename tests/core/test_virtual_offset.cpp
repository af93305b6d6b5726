// Virtual offset (core/capture/VirtualOffset.h): an invalid probe inside a solid moves to the
// nearest valid point just outside it; a valid probe stays where it is.
#include <gtest/gtest.h>

#include <cmath>

#include "core/capture/Capture.h"
#include "core/capture/VirtualOffset.h"
#include "core/common/Error.h"
#include "tests/core/SceneBuilders.h"

namespace ps {
namespace {

void addQuad(Scene& s, Vec3 corner, Vec3 e1, Vec3 e2, uint32_t material) {
  const auto base = static_cast<uint32_t>(s.vertexCount());
  const Vec3 n = normalize(cross(e1, e2));
  for (Vec3 p : {corner, corner + e1, corner + e1 + e2, corner + e2}) {
    s.positions.insert(s.positions.end(), {float(p.x), float(p.y), float(p.z)});
    s.normals.insert(s.normals.end(), {float(n.x), float(n.y), float(n.z)});
    s.bounds.extend(p);
  }
  s.indices.insert(s.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  s.triangleMaterial.insert(s.triangleMaterial.end(), {material, material});
}

/// A solid 2 x 2 x 2 box at the origin (faces outward) standing in a closed 10 m room (faces
/// inward): the space between them is the domain of interest.
Scene boxInRoom() {
  Scene s;
  Material m;
  m.albedo = {0.5, 0.5, 0.5};
  s.materials.push_back(m);
  auto box = [&](Vec3 lo, Vec3 hi, bool inward) {
    const Vec3 d = hi - lo;
    const Vec3 x{d.x, 0, 0}, y{0, d.y, 0}, z{0, 0, d.z};
    struct Face {
      Vec3 corner, e1, e2;  // cross(e1, e2) points inwards
    };
    const Face faces[] = {{lo, z, x}, {{lo.x, hi.y, lo.z}, x, z},
                          {lo, y, z}, {{hi.x, lo.y, lo.z}, z, y},
                          {lo, x, y}, {{lo.x, lo.y, hi.z}, y, x}};
    for (const Face& f : faces)
      inward ? addQuad(s, f.corner, f.e1, f.e2, 0) : addQuad(s, f.corner, f.e2, f.e1, 0);
  };
  box({-1, -1, -1}, {1, 1, 1}, false);
  box({-5, -5, -5}, {5, 5, 5}, true);
  return s;
}

TEST(VirtualOffset, ProbeInsideASolidMovesToTheNearestFaceOutside) {
  const Scene s = boxInRoom();
  const Tracer tracer(s);
  const Vec3 p{0.7, 0.1, -0.2};  // 0.3 m from the +x face, 0.8 m or more from the others
  ASSERT_GT(backfaceFraction(tracer, p, 64, 1), 0.9);
  VirtualOffsetSettings vs;
  vs.pushOutMeters = 0.05;
  const auto q = virtualOffset(tracer, p, vs);
  ASSERT_TRUE(q.has_value());
  EXPECT_EQ(backfaceFraction(tracer, *q, 256, 7), 0.0) << *q;
  // Out through the +x face, pushed 5 cm beyond it, near the point straight across.
  EXPECT_NEAR(q->x, 1.05, 1e-6) << *q;
  EXPECT_LT(length(*q - p), 0.3 + 0.05 + 0.25) << *q;
  // The probe captured there sees the room's light, not the solid's black inside.
  LightingRig rig;
  rig.lights.push_back(testing::pointLight({3, 3, 3}, {10, 10, 10}));
  CaptureSettings cs;
  cs.samplesPerProbe = 256;
  const std::vector<Vec3> at = {p, *q};
  const auto caps = captureProbes(tracer, rig, at, cs);
  EXPECT_EQ(caps[0].sh.c[0].r, 0.0);
  EXPECT_GT(caps[1].sh.c[0].r, 0.0);
}

TEST(VirtualOffset, ProbeInsideADoubleSidedSolidLeavesThroughItsBackFaces) {
  // The same box, double-sided (as every asset of the shared real scenes is): the probe is
  // invalid (its back faces count half) and leaves through the nearest face, as from a
  // single-sided solid.
  Scene s = boxInRoom();
  Material twoSided = s.materials[0];
  twoSided.doubleSided = true;
  s.materials.push_back(twoSided);
  for (size_t t = 0; t < 12; ++t) s.triangleMaterial[t] = 1;  // the box's 6 faces come first
  const Tracer tracer(s);
  const Vec3 p{0.7, 0.1, -0.2};
  ASSERT_GT(backfaceFraction(tracer, p, 64, 1), 0.25);
  VirtualOffsetSettings vs;
  vs.pushOutMeters = 0.05;
  const auto q = virtualOffset(tracer, p, vs);
  ASSERT_TRUE(q.has_value());
  EXPECT_NEAR(q->x, 1.05, 1e-6) << *q;
  EXPECT_EQ(backfaceFraction(tracer, *q, 256, 7), 0.0) << *q;
}

TEST(VirtualOffset, ValidProbeStaysAndBadSettingsThrow) {
  const Scene s = boxInRoom();
  const Tracer tracer(s);
  const Vec3 p{3, 0, 0};
  const auto q = virtualOffset(tracer, p);
  ASSERT_TRUE(q.has_value());
  EXPECT_EQ(*q, p);
  VirtualOffsetSettings bad;
  bad.rays = 0;
  EXPECT_THROW(virtualOffset(tracer, p, bad), ParameterError);
  bad.rays = 8;
  bad.pushOutMeters = -1;
  EXPECT_THROW(virtualOffset(tracer, p, bad), ParameterError);
}

TEST(VirtualOffset, DefaultPushIsScaledToTheScene) {
  const Scene s = boxInRoom();
  const Tracer tracer(s);
  const auto q = virtualOffset(tracer, {0.9, 0, 0});
  ASSERT_TRUE(q.has_value());
  // 0.5 % of the room's diagonal (17.3 m): 8.7 cm beyond the +x face.
  EXPECT_NEAR(q->x, 1.0 + 0.005 * s.bounds.diagonal(), 1e-6) << *q;
}

}  // namespace
}  // namespace ps
