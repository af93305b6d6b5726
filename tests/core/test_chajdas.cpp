// Chajdas et al. placement on hand-built fields with known sinks, and on pillar-room.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/placement/Chajdas.h"
#include "core/placement/Uniform.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

const fs::path kScenes = fs::path(PS_SOURCE_DIR) / "resources" / "scenes";

// SH of the radiance of point lights seen from p: each light of intensity I at distance d is a
// delta of irradiance I / d^2 from its direction w, projected as c_lm = (I / d^2) Y_lm(w).
ShRgb pointLightsSh(Vec3 p, const std::vector<std::pair<Vec3, Rgb>>& lights) {
  ShRgb sh;
  for (const auto& [pos, intensity] : lights) {
    const Vec3 d = pos - p;
    const double r2 = std::max(dot(d, d), 1e-4);
    const auto y = shBasis(normalize(d));
    for (int k = 0; k < kShCoeffCount; ++k) sh.c[k] += intensity * (y[k] / r2);
  }
  return sh;
}

// A grid field over [0, nx) x [0, ny) x [0, nz) (unit spacing) lit by `lights`; samples for
// which `dark` holds get zero SH.
std::vector<FieldSample> gridField(int nx, int ny, int nz,
                                   const std::vector<std::pair<Vec3, Rgb>>& lights,
                                   bool (*dark)(Vec3) = nullptr) {
  std::vector<FieldSample> f;
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x) {
        FieldSample s;
        s.position = {double(x), double(y), double(z)};
        if (!dark || !dark(s.position)) s.sh = pointLightsSh(s.position, lights);
        s.f = luminanceDirection(s.sh);
        s.cellSize = 1;
        f.push_back(s);
      }
  return f;
}

}  // namespace

TEST(Chajdas, TwoPointLightsGiveTwoSinksAtTheLights) {
  // Two equal lights 10 samples apart in a 16 x 5 x 5 field: every particle drains to the
  // nearer one; the sinks are two, too far apart to merge at aggressiveness 2 (reach 8).
  const Vec3 l1{2.3, 2.2, 2.1}, l2{12.6, 2.1, 1.8};
  const auto field = gridField(16, 5, 5, {{l1, {1, 1, 1}}, {l2, {1, 1, 1}}});
  ChajdasSettings s;
  s.aggressiveness = 2;
  const ChajdasResult r = placeChajdas(field, s);
  EXPECT_EQ(r.unlitSamples, 0u);
  EXPECT_EQ(r.sinks, 2u);
  EXPECT_EQ(r.candidateClusters, 2u);
  ASSERT_GE(r.probes.size(), 2u);
  // Each representative is a field sample; both halves get probes; scores add up to the field.
  bool near1 = false, near2 = false;
  double total = 0;
  for (const ChajdasProbe& p : r.probes) {
    EXPECT_EQ(p.position, field[p.sampleIndex].position);
    near1 |= p.position.x < 8;
    near2 |= p.position.x >= 8;
    total += p.score;
  }
  EXPECT_TRUE(near1 && near2);
  EXPECT_DOUBLE_EQ(total, double(field.size()));
  // Aggressive enough, the two matching sinks merge into one cluster (sec. 2.3).
  s.aggressiveness = 100;
  EXPECT_EQ(placeChajdas(field, s).candidateClusters, 1u);
}

TEST(Chajdas, SinksAreTheSamplesNextToTheLights) {
  const Vec3 l1{2.3, 2.2, 2.1}, l2{12.6, 2.1, 1.8};
  const auto field = gridField(16, 5, 5, {{l1, {1, 1, 1}}, {l2, {1, 1, 1}}});
  ChajdasSettings s;
  s.aggressiveness = 0.01;  // no merging of sinks: the sinks themselves
  const ChajdasResult r = placeChajdas(field, s);
  EXPECT_LE(r.sinks, 4u);
  EXPECT_GE(r.sinks, 2u);
  // The brightest samples (next to each light) are among the probes.
  bool at1 = false, at2 = false;
  for (const ChajdasProbe& p : r.probes) {
    at1 |= length(p.position - l1) < 1.0;
    at2 |= length(p.position - l2) < 1.0;
  }
  EXPECT_TRUE(at1 && at2);
}

TEST(Chajdas, ProbesKeepTheirClearanceFromPointLights) {
  // The same sinks as above, now with the lights given: no representative within the clearance
  // (a capture next to a bulb is the 1/r^2 singularity), yet both lights' halves get probes.
  const Vec3 l1{2.3, 2.2, 2.1}, l2{12.6, 2.1, 1.8};
  const auto field = gridField(16, 5, 5, {{l1, {1, 1, 1}}, {l2, {1, 1, 1}}});
  ChajdasSettings s;
  s.aggressiveness = 0.01;
  s.punctualLights = {l1, l2};
  s.lightClearanceMeters = 1.5;
  const ChajdasResult r = placeChajdas(field, s);
  bool near1 = false, near2 = false;
  for (const ChajdasProbe& p : r.probes) {
    EXPECT_GE(length(p.position - l1), 1.5);
    EXPECT_GE(length(p.position - l2), 1.5);
    near1 |= p.position.x < 8;
    near2 |= p.position.x >= 8;
  }
  EXPECT_TRUE(near1 && near2);
}

TEST(Chajdas, AggressivenessMergesMore) {
  const auto field =
      gridField(12, 4, 4, {{{2.2, 2.5, 1.4}, {1, 0.8, 0.6}}, {{9.1, 1.2, 2.3}, {0.3, 0.5, 1}}});
  size_t previous = std::numeric_limits<size_t>::max();
  for (double a : {0.1, 0.3, 1.0, 3.0}) {
    ChajdasSettings s;
    s.aggressiveness = a;
    const size_t count = placeChajdas(field, s).probes.size();
    EXPECT_LE(count, previous) << "aggressiveness " << a;
    previous = count;
  }
}

TEST(Chajdas, IsDeterministic) {
  const auto field = gridField(10, 4, 4, {{{2.2, 2.5, 1.4}, {1, 1, 1}}});
  const ChajdasResult a = placeChajdas(field), b = placeChajdas(field);
  ASSERT_EQ(a.probes.size(), b.probes.size());
  for (size_t i = 0; i < a.probes.size(); ++i) {
    EXPECT_EQ(a.probes[i].sampleIndex, b.probes[i].sampleIndex);
    EXPECT_EQ(a.probes[i].score, b.probes[i].score);
  }
}

TEST(Chajdas, UnlitRegionGetsProbesByKMeans) {
  // Half the field (x >= 8) is completely dark (Chajdas Fig. 3b): particle tracing places
  // nothing there; the k-means over unlit samples (Sukys 3.1.3) does.
  const auto field =
      gridField(16, 4, 4, {{{2.2, 2.5, 1.4}, {1, 1, 1}}}, [](Vec3 p) { return p.x >= 8; });
  const ChajdasResult r = placeChajdas(field);
  EXPECT_EQ(r.unlitSamples, 8u * 4 * 4);
  size_t unlitProbes = 0;
  for (const ChajdasProbe& p : r.probes) {
    if (p.unlit) {
      ++unlitProbes;
      EXPECT_GE(p.position.x, 8);
    } else {
      EXPECT_LT(p.position.x, 8);
    }
  }
  EXPECT_GE(unlitProbes, 1u);
  double total = 0;
  for (const ChajdasProbe& p : r.probes) total += p.score;
  EXPECT_DOUBLE_EQ(total, double(field.size()));
}

TEST(Chajdas, ImportanceVolumeGivesMoreProbesThere) {
  const auto field = gridField(12, 4, 4, {{{5.5, 2.5, 1.5}, {1, 1, 1}}});
  const size_t plain = placeChajdas(field).probes.size();
  ChajdasSettings s;
  s.importanceVolumes.push_back({"important", {0, 0, 0}, {12, 4, 4}, 4.0});
  EXPECT_GT(placeChajdas(field, s).probes.size(), plain);
}

TEST(Chajdas, MatchDistanceSeparatesColourBrightnessAndDirection) {
  const ShRgb white = pointLightsSh({0, 0, 0}, {{{0, 1, 0}, {1, 1, 1}}});
  EXPECT_DOUBLE_EQ(probeMatchDistance(white, white, -10, 4), 0.0);
  const ShRgb blue = pointLightsSh({0, 0, 0}, {{{0, 1, 0}, {0.2, 0.4, 2.5}}});
  const ShRgb brighter = white * 16;
  const ShRgb sideways = pointLightsSh({0, 0, 0}, {{{1, 0, 0}, {1, 1, 1}}});
  EXPECT_GT(probeMatchDistance(white, blue, -10, 4), 0.1);
  EXPECT_GT(probeMatchDistance(white, brighter, -10, 4), 0.1);
  EXPECT_GT(probeMatchDistance(white, sideways, -10, 4), 0.1);
  EXPECT_LT(probeMatchDistance(white, white * 1.02, -10, 4), 0.05);
}

TEST(Chajdas, BadInputThrowsParameterError) {
  EXPECT_THROW(placeChajdas(std::vector<FieldSample>{}), ParameterError);
  const auto field = gridField(4, 4, 4, {{{1.5, 1.5, 1.5}, {1, 1, 1}}});
  ChajdasSettings s;
  s.aggressiveness = 0;
  EXPECT_THROW(placeChajdas(field, s), ParameterError);
  s.aggressiveness = std::nan("");
  EXPECT_THROW(placeChajdas(field, s), ParameterError);
  // A flat field (one layer) is traced nowhere but still gets probes.
  const auto flat = gridField(6, 6, 1, {{{2.5, 2.5, 0.5}, {1, 1, 1}}});
  EXPECT_FALSE(placeChajdas(flat).probes.empty());
}

TEST(Chajdas, PillarRoomFromACapturedField) {
  const Scene scene = loadScene(kScenes / "pillar-room.gltf");
  const Tracer tracer(scene);
  UniformSettings us;
  us.spacingMeters = 0.6;  // 800 samples; the same under ASan (a few seconds there)
  const std::vector<Vec3> points = placeUniform(tracer, us);
  CaptureSettings cs;
  cs.samplesPerProbe = 64;
  const auto captures = captureProbes(tracer, LightingRig{}, points, cs);
  std::vector<FieldSample> field(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    field[i].position = points[i];
    field[i].sh = captures[i].sh;
    field[i].f = luminanceDirection(captures[i].sh);
    field[i].cellSize = us.spacingMeters;
  }
  const ChajdasResult r = placeChajdas(field);
  std::printf("pillar-room: %zu samples, %zu sinks, %zu candidate clusters, %zu probes (%.3f s)\n",
              field.size(), r.sinks, r.candidateClusters, r.probes.size(), r.seconds);
  ASSERT_FALSE(r.probes.empty());
  EXPECT_LT(r.probes.size(), field.size() / 3);
  // The sink of the point light (2, 2.7, 1.5) is found: a probe within two spacings of it.
  double nearest = 1e9;
  for (const ChajdasProbe& p : r.probes) {
    nearest = std::min(nearest, length(p.position - Vec3{2.0, 2.7, 1.5}));
    EXPECT_LE(backfaceFraction(tracer, p.position, 128, 3), 0.25) << p.position;
  }
  EXPECT_LT(nearest, 2 * us.spacingMeters);
  // --budget: the aggressiveness giving 40 probes within 10 % (or the closest count found).
  const ChajdasBudgetResult b = placeChajdasBudget(field, 40);
  std::printf("pillar-room budget 40: %zu probes at aggressiveness %.3f\n", b.result.probes.size(),
              b.aggressiveness);
  EXPECT_NEAR(double(b.result.probes.size()), 40.0, 8.0);
  EXPECT_THROW(placeChajdasBudget(field, 3), ParameterError);
  // Both sides of the pillar (x in [-0.6, 0.6], z in [-0.6, 0.6]) get probes.
  bool east = false, west = false;
  for (const ChajdasProbe& p : r.probes) {
    east |= p.position.x > 0.6;
    west |= p.position.x < -0.6;
  }
  EXPECT_TRUE(east && west);
}
