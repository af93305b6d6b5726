// The data behind the viewport's lighting overlays (LightingField.h), against oracles: f as the
// brute-force sum of Chajdas eq. 1 over many directions, the grid sampling against locate +
// interpolate, leaking edges on two-rooms' shared wall, the luminance distance in stops.
#include <QtTest>
#include <array>
#include <cstdio>
#include <random>
#include <set>

#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"
#include "ui/LightingField.h"

using namespace ps;
using namespace ps::ui;

namespace {
const QString kScene = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");

/// A random but plausible radiance SH: a constant plus a few coloured lobes.
ShRgb randomSh(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  ShRgb sh;
  for (int lobe = 0; lobe < 3; ++lobe) {
    const double z = 2 * u(rng) - 1, phi = 2 * kPi * u(rng), r = std::sqrt(1 - z * z);
    const Vec3 d(r * std::cos(phi), z, r * std::sin(phi));
    const auto y = shBasis(d);
    const Rgb c(u(rng), u(rng), u(rng));
    for (int i = 0; i < kShCoeffCount; ++i) sh.c[size_t(i)] += c * y[size_t(i)];
  }
  sh.c[0] += Rgb(1, 1, 1) * (u(rng) + 0.5);
  return sh;
}

}  // namespace

class TestLightingField : public QObject {
  Q_OBJECT
 private slots:
  void directionVectorIsTheSumOfEquationOne() {
    // Oracle: f = sum w_i * lum(L(w_i)) * dOmega over a fine Fibonacci sphere (Chajdas eq. 1).
    std::mt19937 rng(5);
    const int n = 20000;
    for (int trial = 0; trial < 50; ++trial) {
      const ShRgb sh = randomSh(rng);
      Vec3 sum;
      for (int i = 0; i < n; ++i) {
        const double z = 1 - (2 * i + 1.0) / n, r = std::sqrt(1 - z * z);
        const double phi = i * kPi * (3 - std::sqrt(5.0));
        const Vec3 w(r * std::cos(phi), r * std::sin(phi), z);
        sum += w * (luminance(sh.radiance(w)) * 4 * kPi / n);
      }
      const Vec3 f = luminanceDirection(sh);
      QVERIFY2(length(f - sum) <= 1e-3 * std::max(length(sum), 1e-3),
               qPrintable(QString("%1 vs %2").arg(length(f)).arg(length(sum))));
    }
    // A constant environment has no direction.
    ShRgb flat;
    flat.c[0] = Rgb(2, 2, 2);
    QCOMPARE(length(luminanceDirection(flat)), 0.0);
  }

  void luminanceDistanceIsInStops() {
    ShRgb a, b;
    a.c[0] = Rgb(1, 1, 1);
    b.c[0] = Rgb(4, 4, 4);
    QVERIFY(std::abs(luminanceDistanceStops(a, b) - 2.0) < 1e-12);
    QCOMPARE(luminanceDistanceStops(b, a), luminanceDistanceStops(a, b));
    QCOMPARE(luminanceDistanceStops(a, a), 0.0);
    QCOMPARE(luminanceDistanceStops(ShRgb(), ShRgb()), 0.0);
    QVERIFY(std::abs(meanLuminance(a) - 0.282095) < 1e-12);
  }

  void previewVolumeUsesTheChosenProbesAndTheGridInterpolatesIt() {
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> u(0, 4);
    std::vector<Probe> probes;
    for (int i = 0; i < 60; ++i) {
      Probe p;
      p.id = uint64_t(i + 1);
      p.position = Vec3(u(rng), u(rng), u(rng));
      p.sh = randomSh(rng);
      p.state = i % 3 == 0 ? ProbeState::Accepted
                           : (i % 3 == 1 ? ProbeState::Candidate : ProbeState::Rejected);
      if (i == 4) p.sh.reset();  // uncaptured: never used
      probes.push_back(p);
    }
    const auto acc = buildPreviewVolume(probes, PreviewSource::Accepted);
    const auto all = buildPreviewVolume(probes, PreviewSource::AllCaptured);
    QVERIFY(acc && all);
    QCOMPARE(acc->probeCount(), size_t(20));
    QCOMPARE(all->probeCount(), size_t(39));  // accepted + candidates, minus the uncaptured one
    // Too few (or flat) probes: no volume.
    std::vector<Probe> flat(probes.begin(), probes.begin() + 3);
    QVERIFY(!buildPreviewVolume(flat, PreviewSource::AllCaptured));

    const Bounds3 box(Vec3(0.5, 0.5, 0.5), Vec3(3.5, 2.0, 3.0));
    const ShGrid g = sampleGrid(*all, box, 12);
    QCOMPARE(g.dims[0], 12);
    QCOMPARE(g.dims[1], 6);
    QCOMPARE(g.dims[2], 10);
    QCOMPARE(g.size(), size_t(12 * 6 * 10));
    for (size_t i = 0; i < g.size(); i += 7) {
      const Vec3 c = g.centre(i);
      QVERIFY(box.contains(c));
      const ShRgb expect = interpolate(*all, locate(*all, c));
      for (int k = 0; k < kShCoeffCount; ++k)
        QVERIFY(std::abs(luminance(g.sh[i].c[size_t(k)]) - luminance(expect.c[size_t(k)])) < 1e-6);
    }
    // The edges: each once, and each one a tet's.
    const auto edges = tetEdges(*all);
    const auto stops = edgeLuminanceDistances(*all, edges);
    QCOMPARE(stops.size(), edges.size());
    for (size_t i = 0; i < edges.size(); i += 5)
      QVERIFY(std::abs(stops[i] - luminanceDistanceStops(all->probeSh(edges[i][0]),
                                                         all->probeSh(edges[i][1]))) < 1e-5);
    QVERIFY(std::is_sorted(edges.begin(), edges.end()));
    QVERIFY(std::adjacent_find(edges.begin(), edges.end()) == edges.end());
    // Euler: V - E + F - T = 1 for a triangulated ball.
    std::set<std::array<int32_t, 3>> faces;
    for (const auto& t : all->tets)
      for (int skip = 0; skip < 4; ++skip) {
        std::array<int32_t, 3> f;
        int k = 0;
        for (int j = 0; j < 4; ++j)
          if (j != skip) f[size_t(k++)] = t[size_t(j)];
        std::sort(f.begin(), f.end());
        faces.insert(f);
      }
    QCOMPARE(int64_t(all->probeCount()) - int64_t(edges.size()) + int64_t(faces.size()) -
                 int64_t(all->tets.size()),
             int64_t(1));
  }

  void edgesThroughTheSharedWallLeak() {
    if (!QFile::exists(kScene)) QSKIP("two-rooms.gltf not present");
    const Scene scene = loadScene(kScene.toStdString());
    const Tracer tracer(scene);
    const Bounds3 b = scene.bounds;
    const Vec3 e = b.extent();
    // Probes on both sides of the wall between the rooms (find it: a horizontal ray across).
    const Vec3 from(b.lo.x + 0.1 * e.x, b.lo.y + 0.4 * e.y, b.lo.z + 0.3 * e.z);
    const auto hit = tracer.intersect(Ray{from, Vec3(1, 0, 0), tracer.rayEpsilon()});
    QVERIFY(hit);
    const double wallX = from.x + hit->t;
    std::vector<Probe> probes;
    for (int side = 0; side < 2; ++side)
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
          Probe p;
          p.state = ProbeState::Accepted;
          p.position = Vec3(wallX + (side ? 0.6 : -0.6) + 0.1 * i, b.lo.y + (0.3 + 0.3 * j) * e.y,
                            b.lo.z + 0.3 * e.z + 0.4 * (i + j));
          p.sh = ShRgb();
          probes.push_back(p);
        }
    const auto v = buildPreviewVolume(probes, PreviewSource::Accepted);
    QVERIFY(v);
    const auto edges = tetEdges(*v);
    const auto leaks = leakingEdges(tracer, *v, edges);
    int crossing = 0, leaking = 0;
    for (size_t i = 0; i < edges.size(); ++i) {
      const Vec3 a = v->position(edges[i][0]), c = v->position(edges[i][1]);
      const bool crosses = (a.x - wallX) * (c.x - wallX) < 0;
      if (!crosses) {
        QCOMPARE(int(leaks[i]), 0);  // within a room: nothing in between
        continue;
      }
      ++crossing;
      leaking += leaks[i];
      // Oracle: a ray perpendicular to the wall through the crossing point meets the wall there
      // unless that point is in the doorway.
      const Vec3 x = a + (c - a) * ((wallX - a.x) / (c.x - a.x));
      const auto wall = tracer.intersect(Ray{Vec3(x.x - 0.5, x.y, x.z), Vec3(1, 0, 0), 0.0, 1.0});
      QCOMPARE(bool(leaks[i]), wall.has_value());
    }
    QVERIFY(crossing > 0);
    QVERIFY(leaking > 0);
  }
};

QTEST_MAIN(TestLightingField)
#include "test_lighting_field.moc"
