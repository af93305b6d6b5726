// Pre-filtered capture (Kontkanen & Laine sec. 4 eq. 5-6, sec. 6 Algorithm 2) against exact
// answers: a point light's light averaged over a node's trilinear support (not its value at the
// node), and a furnace room whose node's support pokes through a wall (origins outside the
// domain of interest are dropped, so the room's radiance comes out exactly).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "core/capture/PrefilteredCapture.h"
#include "core/common/Error.h"
#include "tests/core/SceneBuilders.h"

namespace ps {
namespace {

using testing::addBox;
using testing::addMaterial;
using testing::floorScene;
using testing::pointLight;

TEST(PrefilteredCapture, PointLightIsAveragedOverTheTrilinearSupport) {
  // A point light over a black floor: L is zero for every ray, so a node's SH is the
  // b-weighted average over its support of E(x) Y(w_light(x)), E = I / d^2 (eq. 5).
  const Scene s = floorScene();
  const Tracer tracer(s);
  LightingRig rig;
  const Light lamp = pointLight({0, 3, 0}, {10, 20, 5});
  rig.lights.push_back(lamp);
  const PrefilterNode node{{0.2, 2.0, -0.1}, 0.6};
  // Eq. 5 by a tent-weighted midpoint rule, 60^3 points.
  ShRgb want;
  const int n = 60;
  double wsum = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        const double t[3] = {-1 + (i + 0.5) * 2.0 / n, -1 + (j + 0.5) * 2.0 / n,
                             -1 + (k + 0.5) * 2.0 / n};
        const double w = (1 - std::abs(t[0])) * (1 - std::abs(t[1])) * (1 - std::abs(t[2]));
        const Vec3 x = node.position + Vec3(t[0], t[1], t[2]) * node.halfWidth;
        const Vec3 d = lamp.position - x;
        want.addSample(normalize(d), lamp.intensity * (1 / dot(d, d)), w);
        wsum += w;
      }
  want = want * (1 / wsum);
  CaptureSettings settings;
  settings.samplesPerProbe = 65536;
  const std::vector<PrefilterNode> nodes = {node};
  const ProbeCapture c = capturePrefiltered(tracer, rig, nodes, settings)[0];
  EXPECT_EQ(c.samples, settings.samplesPerProbe);
  EXPECT_EQ(c.backfaceFraction, 0.0);
  // Point sampling at the node, for contrast: eq. 4.
  ShRgb point;
  const Vec3 d0 = lamp.position - node.position;
  point.addSample(normalize(d0), lamp.intensity * (1 / dot(d0, d0)), 1.0);
  for (int i = 0; i < kShCoeffCount; ++i)
    for (int ch = 0; ch < 3; ++ch) {
      const double tol = 4 * c.shStdError.c[i][ch] + 1e-3 * std::abs(want.c[0][ch]);
      EXPECT_NEAR(c.sh.c[i][ch], want.c[i][ch], tol) << "coefficient " << i << " channel " << ch;
    }
  // The average is well above the point value (1/d^2 is convex), far beyond the noise.
  for (int ch = 0; ch < 3; ++ch) {
    std::printf("c00 channel %d: pre-filtered %.5f (exact %.5f), point-sampled %.5f\n", ch,
                c.sh.c[0][ch], want.c[0][ch], point.c[0][ch]);
    EXPECT_GT(want.c[0][ch], 1.04 * point.c[0][ch]);
    EXPECT_GT(want.c[0][ch] - point.c[0][ch], 8 * c.shStdError.c[0][ch]);
  }
}

TEST(PrefilteredCapture, OriginsOutsideTheDomainOfInterestAreDropped) {
  // A black-walled room emitting le inward (single-sided walls facing in). A node 0.1 m from
  // the +x wall with a half-width of 0.5 m draws 32 % of its origins outside the room; those
  // see the walls' back faces and are dropped, so every kept ray sees le: c00 is exactly
  // 2 sqrt(pi) le. Kept outside origins would see black (escaping rays, back faces).
  Scene s;
  const Rgb le{1, 0.5, 0.25};
  addBox(s, {-1, -1, -1}, {1, 1, 1}, addMaterial(s, {0, 0, 0}, le), /*inward=*/true);
  const Tracer tracer(s);
  const LightingRig rig;
  CaptureSettings settings;
  settings.samplesPerProbe = 8192;
  const std::vector<PrefilterNode> nodes = {{{0.9, 0.2, -0.3}, 0.5}, {{0, 0, 0}, 0.5}};
  const auto caps = capturePrefiltered(tracer, rig, nodes, settings);
  for (const ProbeCapture& c : caps)
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_NEAR(c.sh.c[0][ch], 2 * std::sqrt(kPi) * le[ch], 1e-9 * le[ch]);
  // P(x > 1) for a tent centred at 0.9 of half-width 0.5: (1 - 0.2)^2 / 2 = 0.32.
  EXPECT_NEAR(caps[0].backfaceFraction, 0.32, 0.02);
  EXPECT_EQ(caps[0].samples, int(std::lround((1 - caps[0].backfaceFraction) * 8192)));
  EXPECT_EQ(caps[1].backfaceFraction, 0.0);  // the support is inside the room
  // Its irradiance is pi le for every normal (within the noise of the l >= 1 bands).
  for (Vec3 nrm : {Vec3{1, 0, 0}, Vec3{0, -1, 0}, Vec3{0, 0, 1}})
    for (const ProbeCapture& c : caps)
      EXPECT_NEAR(luminance(c.sh.irradiance(nrm)), kPi * luminance(le), 0.05 * kPi * luminance(le));
  // A node wholly outside the room keeps nothing: zero SH, backfaceFraction 1.
  const std::vector<PrefilterNode> outside = {{{3, 0, 0}, 0.5}};
  const ProbeCapture o = capturePrefiltered(tracer, rig, outside, settings)[0];
  EXPECT_EQ(o.samples, 0);
  EXPECT_EQ(o.backfaceFraction, 1.0);
  EXPECT_EQ(o.sh.c[0], (Rgb{0, 0, 0}));
}

TEST(PrefilteredCapture, DeterministicForAnyThreadCountAndBadSettingsThrow) {
  Scene s;
  addBox(s, {-1, -1, -1}, {1, 1, 1}, addMaterial(s, {0.5, 0.5, 0.5}, {1, 1, 1}), true);
  const Tracer tracer(s);
  const LightingRig rig;
  CaptureSettings settings;
  settings.samplesPerProbe = 256;
  std::vector<PrefilterNode> nodes;
  for (int i = 0; i < 12; ++i) nodes.push_back({{-0.8 + 0.15 * i, 0.1, 0}, 0.3});
  settings.threads = 1;
  const auto a = capturePrefiltered(tracer, rig, nodes, settings);
  settings.threads = 2;
  const auto b = capturePrefiltered(tracer, rig, nodes, settings);
  for (size_t i = 0; i < nodes.size(); ++i) {
    EXPECT_EQ(a[i].sh, b[i].sh);
    EXPECT_EQ(a[i].samples, b[i].samples);
  }
  const std::vector<PrefilterNode> flat = {{{0, 0, 0}, 0.0}};
  EXPECT_THROW(capturePrefiltered(tracer, rig, flat, settings), ParameterError);
  CaptureSettings adaptive = settings;
  adaptive.targetRelativeError = 0.02;
  EXPECT_THROW(capturePrefiltered(tracer, rig, nodes, adaptive), ParameterError);
  const Scene dark = floorScene();
  const Tracer darkTracer(dark);
  EXPECT_THROW(capturePrefiltered(darkTracer, rig, nodes, settings), ParameterError);
}

}  // namespace
}  // namespace ps
