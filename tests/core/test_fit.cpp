// Least-squares probe values (core/bake/LeastSquaresFit): the solver reproduces what the
// interpolation can represent exactly and keeps unreached probes; the fit lowers a volume's
// error against a path-traced reference; bad settings are refused before anything is traced;
// the bake records it.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/bake/Bake.h"
#include "core/bake/LeastSquaresFit.h"
#include "core/common/Error.h"
#include "core/eval/Evaluate.h"
#include "core/math/Random.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

using namespace ps;

namespace {

const std::filesystem::path kScenes = std::filesystem::path(PS_SOURCE_DIR) / "resources" / "scenes";

struct Cornell {
  Scene scene = loadScene(kScenes / "cornell.gltf");
  Tracer tracer{scene};
  LightingRig rig;
  Cornell() { rig.skyRadiance = {0.5, 0.5, 0.5}; }
};

Cornell& cornell() {
  static Cornell c;
  return c;
}

std::vector<Vec3> grid(int n, Vec3 lo, Vec3 hi) {
  std::vector<Vec3> pts;
  for (int x = 0; x < n; ++x)
    for (int y = 0; y < n; ++y)
      for (int z = 0; z < n; ++z)
        pts.push_back({lo.x + (hi.x - lo.x) * x / (n - 1), lo.y + (hi.y - lo.y) * y / (n - 1),
                       lo.z + (hi.z - lo.z) * z / (n - 1)});
  return pts;
}

/// SH whose every value is an affine function of the position (a different one per value).
ShRgb affineSh(Vec3 p) {
  ShRgb s;
  for (int k = 0; k < kShCoeffCount; ++k)
    s.c[size_t(k)] = Rgb(1 + k + 0.5 * p.x - 0.25 * p.y, 2 - 0.1 * k * p.z, 0.3 * p.x * (k % 3));
  return s;
}

/// A set of accepted probes at `points`, with the Cornell rig.
ProbeSet acceptedSet(const std::vector<Vec3>& points) {
  ProbeSet set;
  set.rig = cornell().rig;
  for (const Vec3& p : points) {
    Probe pr;
    pr.position = p;
    pr.state = ProbeState::Accepted;
    set.probes.push_back(pr);
  }
  return set;
}

}  // namespace

TEST(LeastSquaresValues, ReproduceAnAffineFieldFromWrongStartingValues) {
  // The barycentric interpolant holds any affine field exactly: fitted to points sampled from
  // one, the probes take its values, whatever they held before (zeros here), up to the small
  // pull towards them.
  const std::vector<Vec3> pts = grid(4, {0, 0, 0}, {3, 2, 3});
  std::vector<ShRgb> zeros(pts.size());
  ProbeVolume v = volumeFromProbes(pts, zeros);
  std::vector<VolumeLocation> at;
  std::vector<ShRgb> targets;
  uint64_t rng = 3;
  for (int i = 0; i < 4000; ++i) {
    // Inside and around the hull (clamped points count with their face's weights).
    const Vec3 p(-0.3 + 3.6 * uniform01(rng), -0.3 + 2.6 * uniform01(rng),
                 -0.3 + 3.6 * uniform01(rng));
    const VolumeLocation loc = locate(v, p);
    at.push_back(loc);
    // The target is the field where the interpolation evaluates (the clamped point outside).
    Vec3 q;
    for (int c = 0; c < 4; ++c)
      q = q + v.position(v.tets[size_t(loc.tet)][size_t(c)]) * loc.weights[size_t(c)];
    targets.push_back(affineSh(q));
  }
  int iterations = 0;
  const std::vector<float> fitted = leastSquaresValues(v, at, targets, 1e-9, &iterations);
  EXPECT_GT(iterations, 0);
  double worst = 0;
  for (size_t i = 0; i < v.probeCount(); ++i) {
    const ShRgb want = affineSh(v.position(int32_t(i)));
    for (int k = 0; k < kShCoeffCount; ++k) {
      const Rgb w = want.c[size_t(k)];
      const float* got = fitted.data() + i * 27 + 3 * size_t(k);
      worst =
          std::max({worst, std::abs(got[0] - w.r), std::abs(got[1] - w.g), std::abs(got[2] - w.b)});
    }
  }
  EXPECT_LT(worst, 1e-4);
}

TEST(LeastSquaresValues, ProbesNoPointReachesKeepTheirValues) {
  // Points only in the lower half of a grid: the top layer's probes get no weight from them and
  // keep their values; with no point at all every probe does.
  const std::vector<Vec3> pts = grid(3, {0, 0, 0}, {2, 2, 2});
  std::vector<ShRgb> sh(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) sh[i] = affineSh(pts[i]);
  ProbeVolume v = volumeFromProbes(pts, sh);
  std::vector<VolumeLocation> at;
  std::vector<ShRgb> targets;
  uint64_t rng = 5;
  for (int i = 0; i < 500; ++i) {
    const Vec3 p(2 * uniform01(rng), 0.9 * uniform01(rng), 2 * uniform01(rng));
    at.push_back(locate(v, p));
    targets.push_back(ShRgb{});  // far from the probes' values: they move where reached
  }
  const std::vector<float> fitted = leastSquaresValues(v, at, targets, 0.01);
  for (size_t i = 0; i < v.probeCount(); ++i) {
    const float y = v.positions[3 * i + 1];
    const float before = v.sh[i * 27], after = fitted[i * 27];
    if (y > 1.5f) {
      EXPECT_NEAR(after, before, 1e-5 * std::abs(before)) << i;
    } else if (y < 0.5f) {
      EXPECT_LT(std::abs(after), 0.5 * std::abs(before)) << i;
    }
  }
  const std::vector<float> none = leastSquaresValues(v, {}, {}, 0.01);
  for (size_t j = 0; j < v.sh.size(); ++j) EXPECT_NEAR(none[j], v.sh[j], 1e-6);
}

TEST(Fit, LowersTheErrorAgainstTheReference) {
  // A coarse grid in the Cornell box (sky through its open side, the area light under the
  // ceiling): the fitted volume is closer to the path-traced reference than the point-sampled
  // one, at the fit points and at eval's queries (other points: another seed's stream).
  const std::vector<Vec3> pts = grid(4, {-2.6, 0.2, -2.6}, {2.6, 5.3, 2.6});
  CaptureSettings cs;
  cs.samplesPerProbe = 512;
  std::vector<ShRgb> sh;
  for (const auto& c : captureProbes(cornell().tracer, cornell().rig, pts, cs)) sh.push_back(c.sh);
  const ProbeVolume plain = volumeFromProbes(pts, sh);
  ProbeVolume fitted = plain;
  FitSettings fs;
  fs.pointsPerProbe = 64;
  fs.samplesPerPoint = 64;
  const FitResult r = fitProbeValues(cornell().tracer, cornell().rig, fitted, {}, fs);
  EXPECT_EQ(r.points, pts.size() * 64);
  EXPECT_LT(r.residualAfter, r.residualBefore);
  EXPECT_NE(fitted.sh, plain.sh);
  EvalSettings es;
  es.queries = 2048;
  es.referenceSpp = 256;
  const double before = evaluateVolume(cornell().tracer, cornell().rig, plain, es).relRmse;
  const double after = evaluateVolume(cornell().tracer, cornell().rig, fitted, es).relRmse;
  std::printf("rel_rmse %.4f point-sampled, %.4f fitted\n", before, after);
  EXPECT_LT(after, 0.9 * before);
  // Deterministic for the seed.
  ProbeVolume again = plain;
  fitProbeValues(cornell().tracer, cornell().rig, again, {}, fs);
  EXPECT_EQ(again.sh, fitted.sh);
}

TEST(Fit, BadSettingsAreRefusedBeforeTheCapture) {
  FitSettings s;
  s.pointsPerProbe = 0;
  EXPECT_THROW(checkFitSettings(s), ParameterError);
  s = {};
  s.samplesPerPoint = 0;
  EXPECT_THROW(checkFitSettings(s), ParameterError);
  for (double bad : {0.0, -1.0, std::nan("")}) {
    s = {};
    s.regularization = bad;
    EXPECT_THROW(checkFitSettings(s), ParameterError);
  }
  s = {};
  s.lightClearanceRelative = 0.5;
  EXPECT_THROW(checkFitSettings(s), ParameterError);
  s = {};
  EXPECT_NO_THROW(checkFitSettings(s, 39'000));               // 4.99 million fit points
  EXPECT_THROW(checkFitSettings(s, 40'000), ParameterError);  // 5.12 million
  // The bake checks before it traces anything: a cancelled progress would throw Cancelled.
  const ProbeSet set = acceptedSet(grid(2, {-1, 1, -1}, {1, 3, 1}));
  BakeSettings bs;
  bs.fit = FitSettings{};
  bs.fit->regularization = -1;
  EXPECT_THROW(bakeProbeSet(set, cornell().tracer, bs, [](double) { return false; }),
               ParameterError);
  // So is a flat importance volume, where no fit point can be drawn.
  ProbeSet flat = set;
  flat.importanceVolumes.push_back({"flat", {0, 1, 0}, {1, 1, 1}, 1.0});
  bs.fit = FitSettings{};
  EXPECT_THROW(bakeProbeSet(flat, cornell().tracer, bs, [](double) { return false; }),
               ParameterError);
  EXPECT_THROW(bakeProbeSet(set, cornell().tracer, bs, [](double) { return false; }), Cancelled);
}

TEST(Fit, TheBakeRecordsTheFitInTheVolume) {
  const ProbeSet set = acceptedSet(grid(3, {-2.5, 0.3, -2.5}, {2.5, 5.2, 2.5}));
  BakeSettings bs;
  bs.capture.samplesPerProbe = 64;
  const BakeResult plain = bakeProbeSet(set, cornell().tracer, bs);
  EXPECT_FALSE(plain.fit);
  EXPECT_FALSE(nlohmann::json::parse(plain.file.metadataJson).contains("fit"));
  bs.fit = FitSettings{};
  bs.fit->pointsPerProbe = 16;
  bs.fit->samplesPerPoint = 16;
  const BakeResult fitted = bakeProbeSet(set, cornell().tracer, bs);
  ASSERT_TRUE(fitted.fit);
  EXPECT_EQ(fitted.fit->points, 27u * 16);
  const auto meta = nlohmann::json::parse(fitted.file.metadataJson);
  ASSERT_TRUE(meta.contains("fit"));
  EXPECT_EQ(meta["fit"]["method"], "least-squares");
  EXPECT_EQ(meta["fit"]["points_per_probe"], 16);
  EXPECT_EQ(meta["fit"]["points"], 27 * 16);
  EXPECT_EQ(fitted.file.volume.tets, plain.file.volume.tets);
  EXPECT_NE(fitted.file.volume.sh, plain.file.volume.sh);
}
