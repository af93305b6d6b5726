// Live edits (QT_QPA_PLATFORM=offscreen): a probe moved into a dark room is captured there
// alone in the background, quickly and then at the bake's sample count, and the inspector, the
// preview volume and the lit preview's grid follow in place while the event loop keeps running.
// It prints how long the preview took to reflect the move:
//   PS_LIVE_SCENE=SCENE.glb PS_LIVE_SUN=1 build/tests/ui/test_live_edits
// measures another scene (PS_LIVE_SUN=1 adds a sun and a sky when the scene brings no light).
#include <QDir>
#include <QDoubleSpinBox>
#include <QElapsedTimer>
#include <QLabel>
#include <QSettings>
#include <QSignalSpy>
#include <QSpinBox>
#include <QTemporaryDir>
#include <QTimer>
#include <QtTest>
#include <cmath>
#include <cstdio>

#include "core/traversal/ProbeVolume.h"
#include "ui/Document.h"
#include "ui/InspectorPanel.h"
#include "ui/LightingField.h"
#include "ui/MainWindow.h"
#include "ui/PlacementPanel.h"
#include "ui/Viewport.h"

using namespace ps;
using namespace ps::ui;

namespace {
QString scenePath() {
  const QByteArray env = qgetenv("PS_LIVE_SCENE");
  return env.isEmpty() ? QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf")
                       : QString::fromLocal8Bit(env);
}

double meanRadiance(const ShRgb& sh) {
  return luminance(sh.c[0]) * 0.282095;
}

/// The lit preview's value (mean radiance) in the grid cell nearest `p`.
double previewAt(const ShGrid& grid, Vec3 p) {
  double best = 1e300, value = 0;
  for (size_t i = 0; i < grid.size(); ++i)
    if (const double d = length(grid.centre(i) - p); d < best) {
      best = d;
      value = meanRadiance(grid.sh[i]);
    }
  return value;
}

/// The preview volume's interpolated SH at `p` (null when outside or no volume).
std::optional<ShRgb> volumeAt(Viewport* vp, Vec3 p) {
  const std::optional<ProbeVolume>& v = vp->previewVolume();
  if (!v) return std::nullopt;
  const VolumeLocation loc = locate(*v, p);
  if (loc.tet < 0) return std::nullopt;
  return interpolate(*v, loc);
}

/// The move the tests make: the brightest probe (two-rooms: beside room A's lamp) into the
/// darkest place, half-way between the darkest captured probe and its nearest neighbour (free
/// space, as both are). With `lowest`, among the probes of the lowest layer only (within 5 cm of
/// the lowest captured probe's height): those light the floor, which a view from above shows.
std::pair<uint64_t, Vec3> brightIntoDark(const std::vector<Probe>& probes, bool lowest = false) {
  auto movable = [](const Probe& p) { return p.sh.has_value(); };
  double floorY = 1e300;
  for (const Probe& p : probes)
    if (movable(p)) floorY = std::min(floorY, p.position.y);
  auto counts = [&](size_t i) {
    return movable(probes[i]) && (!lowest || probes[i].position.y <= floorY + 0.05);
  };
  size_t bright = 0, dark = 0;
  while (bright < probes.size() && !counts(bright)) ++bright;
  dark = bright;
  for (size_t i = 0; i < probes.size(); ++i) {
    if (!counts(i)) continue;
    if (!probes[bright].sh || meanRadiance(*probes[i].sh) > meanRadiance(*probes[bright].sh))
      bright = i;
    if (!probes[dark].sh || meanRadiance(*probes[i].sh) < meanRadiance(*probes[dark].sh)) dark = i;
  }
  size_t nearest = probes.size();
  for (size_t i = 0; i < probes.size(); ++i)
    if (i != dark && i != bright && counts(i) &&
        (nearest == probes.size() || length(probes[i].position - probes[dark].position) <
                                         length(probes[nearest].position - probes[dark].position)))
      nearest = i;
  return {probes[bright].id, (probes[dark].position + probes[nearest].position) * 0.5};
}

/// Opens the scene with its proposal (a sun and a sky first with PS_LIVE_SUN). False on failure.
bool openWithProposal(MainWindow& w) {
  Document* doc = w.document();
  const bool sun = !qgetenv("PS_LIVE_SUN").isEmpty();
  doc->setAutoPropose(!sun);
  if (!w.openScene(scenePath())) return false;
  if (sun) {
    LightingRig rig;
    Light light;
    light.type = LightType::Directional;
    light.name = "sun";
    light.direction = normalize(Vec3(-0.4, -0.8, -0.45));
    light.intensity = Rgb(6, 5.6, 5);
    rig.lights.push_back(light);
    rig.skyRadiance = Rgb(0.3, 0.4, 0.6);
    doc->setRig(rig, "Sun and sky");
    doc->proposeCandidates();
  }
  if (doc->isBusy()) {
    QSignalSpy done(doc, &Document::jobFinished);
    if (!done.wait(600000) || !done.first().first().toString().isEmpty()) return false;
  }
  return doc->probes().size() >= 8;
}

/// Longest pause of the event loop while it waits for `spy` (ms): the view stays interactive
/// when this stays small.
struct StallMeter {
  QTimer timer;
  QElapsedTimer clock;
  qint64 last = 0, worst = 0;
  StallMeter() {
    timer.setInterval(5);
    QObject::connect(&timer, &QTimer::timeout, [this] {
      const qint64 now = clock.elapsed();
      worst = std::max(worst, now - last);
      last = now;
    });
    clock.start();
    timer.start();
  }
  /// Starts measuring afresh (after the test's own synchronous work).
  void reset() { last = clock.elapsed(); }
};
}  // namespace

class TestLiveEdits : public QObject {
  Q_OBJECT
  QTemporaryDir settingsDir_;

 private slots:
  void initTestCase() {
    if (!QFile::exists(scenePath())) QSKIP("scene not present");
    QSettings::setDefaultFormat(QSettings::IniFormat);
    QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settingsDir_.path());
    QCoreApplication::setOrganizationName("ProbeStudioTest");
    QCoreApplication::setApplicationName("test_live_edits");
  }

  void aMovedProbeIsCapturedWhereItWentAndThePreviewFollows() {
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    Document* doc = w.document();
    Viewport* vp = w.viewport();
    vp->setPreviewLighting(true);
    const bool custom = !qgetenv("PS_LIVE_SCENE").isEmpty();
    QVERIFY(openWithProposal(w));
    QVERIFY(doc->probes().size() >= 8);
    // The bake's samples are the final capture's (kept small for the suite's time).
    w.placementPanel()->bakeSamplesBox()->setValue(custom ? 1024 : 256);
    QCOMPARE(doc->liveCaptureSettings().finalSamples, custom ? 1024 : 256);

    const auto& probes = doc->probes();
    const auto [id, to] = brightIntoDark(probes);
    const Vec3 from = doc->probe(id)->position;
    const ShRgb oldSh = *doc->probe(id)->sh;
    const double before = previewAt(vp->previewGrid(), to);
    w.selectProbes({quint64(id)});

    StallMeter stalls;
    QElapsedTimer clock;
    QSignalSpy captured(doc, &Document::liveCaptured);
    clock.start();
    doc->moveProbe(id, to, doc->newMergeKey());
    // At once: no capture at the new place yet, one on its way, the inspector says so.
    QVERIFY(!doc->probe(id)->sh);
    QVERIFY(doc->isQuickCapturePending(id));
    bool saysCapturing = false;
    for (QLabel* l : w.inspector()->findChildren<QLabel*>())
      saysCapturing |= l->text().contains("capturing");
    QVERIFY(saysCapturing);

    // The quick capture lands in the background.
    stalls.reset();
    QVERIFY(captured.wait(60000));
    qint64 worstStall = stalls.worst;
    const double quickSeconds = double(clock.nsecsElapsed()) * 1e-9;
    QCOMPARE(captured.first().at(0).toULongLong(), quint64(id));
    QCOMPARE(captured.first().at(1).toInt(), doc->liveCaptureSettings().previewSamples);
    QVERIFY(doc->probe(id)->sh);
    const ShRgb quickSh = *doc->probe(id)->sh;
    QVERIFY(!(quickSh == oldSh));
    // The preview: the volume holds the probe at its new place with its new light, and the lit
    // preview's grid changed there.
    QElapsedTimer rebuild;
    rebuild.start();
    const std::optional<ShRgb> there = volumeAt(vp, to);
    const double after = previewAt(vp->previewGrid(), to);
    const double rebuildSeconds = double(rebuild.nsecsElapsed()) * 1e-9;
    QVERIFY(there);
    QVERIFY2(std::abs(meanRadiance(*there) - meanRadiance(quickSh)) <=
                 1e-3 * std::max(meanRadiance(quickSh), 1e-6),
             qPrintable(
                 QStringLiteral("%1 vs %2").arg(meanRadiance(*there)).arg(meanRadiance(quickSh))));
    QVERIFY2(std::abs(after - before) > 1e-3 * std::max(before, 1e-6),
             qPrintable(QStringLiteral("%1 -> %2").arg(before).arg(after)));
    bool saysIrradiance = false;
    for (QLabel* l : w.inspector()->findChildren<QLabel*>())
      saysIrradiance |= l->text().contains("W/m");
    QVERIFY(saysIrradiance);

    // Then the bake's sample count.
    stalls.reset();
    stalls.worst = 0;
    QVERIFY(captured.size() >= 2 || captured.wait(600000));
    worstStall = std::max(worstStall, stalls.worst);
    const double finalSeconds = double(clock.nsecsElapsed()) * 1e-9;
    QCOMPARE(captured.at(1).at(1).toInt(), doc->liveCaptureSettings().finalSamples);
    QVERIFY(!(*doc->probe(id)->sh == quickSh));
    QVERIFY(!doc->isCapturingLive());
    // The event loop never stalled for long: the view stayed interactive.
    QVERIFY2(worstStall < 250, qPrintable(QString::number(worstStall)));
    std::printf(
        "live edit (%s, %zu probes): quick capture (%d rays) in %.3f s, preview rebuilt in "
        "%.3f s: preview reflects the move after %.3f s; final capture (%d rays) after %.3f s; "
        "longest event-loop pause %lld ms\n",
        qPrintable(QFileInfo(scenePath()).fileName()), doc->probes().size(),
        doc->liveCaptureSettings().previewSamples, quickSeconds, rebuildSeconds,
        quickSeconds + rebuildSeconds, doc->liveCaptureSettings().finalSamples, finalSeconds,
        qlonglong(worstStall));

    // Undo puts the probe back with the light it had there; no capture runs for it.
    doc->undoStack()->undo();
    QCOMPARE(doc->probe(id)->position, from);
    QVERIFY(*doc->probe(id)->sh == oldSh);
    QVERIFY(!doc->isCapturingLive());
    // Redo moves it again and captures it again.
    doc->undoStack()->redo();
    QVERIFY(doc->isQuickCapturePending(id));
    QVERIFY(captured.wait(60000));
    QVERIFY(doc->probe(id)->sh);
  }

  void theShownViewReflectsTheMove() {
    if (QGuiApplication::platformName() == QLatin1String("offscreen"))
      QSKIP("needs OpenGL: run under xvfb-run (ui.test_live_edits_shown)");
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    Document* doc = w.document();
    Viewport* vp = w.viewport();
    w.resize(1400, 900);
    w.show();
    QVERIFY(QTest::qWaitForWindowExposed(&w));
    QVERIFY(openWithProposal(w));
    vp->setProbesVisible(false);  // the lit surfaces only, not the moved probe's sphere
    vp->setPreviewLighting(true);
    vp->frameAll();
    vp->update();
    // The view draws the probes' light for the probes as they are: a rebuild started before
    // they were all captured may land first, and the view then starts another.
    QTRY_VERIFY_WITH_TIMEOUT(
        vp->fieldsCurrent() && vp->shading() == Viewport::Shading::Probes && !doc->isBusy(), 60000);
    const auto [id, to] = brightIntoDark(doc->probes(), true);
    const Vec3 from = doc->probe(id)->position;
    const ShRgb oldSh = *doc->probe(id)->sh;
    const QImage before = vp->grabFramebuffer();

    QElapsedTimer clock;
    QSignalSpy captured(doc, &Document::liveCaptured);
    clock.start();
    doc->moveProbe(id, to, doc->newMergeKey());
    QVERIFY(captured.wait(60000));
    // The drawn fields carry the capture: the preview volume has the probe at its new place with
    // its new light (the brightest probe's light moved into the darkest place differs). A rebuild
    // under way when the capture landed may bring older fields first.
    auto showsTheCapture = [&] {
      const ProbeVolume* v = vp->drawnPreviewVolume();
      if (!v || vp->shading() != Viewport::Shading::Probes) return false;
      for (size_t i = 0; i < v->probeCount(); ++i)
        if (length(v->position(int32_t(i)) - to) < 1e-4)
          return std::abs(meanRadiance(v->probeSh(int32_t(i))) - meanRadiance(oldSh)) >
                 1e-3 * meanRadiance(oldSh);
      return false;
    };
    QTRY_VERIFY_WITH_TIMEOUT(showsTheCapture(), 60000);
    const double seconds = double(clock.nsecsElapsed()) * 1e-9;
    const QImage after = vp->grabFramebuffer();
    const double frameSeconds = double(clock.nsecsElapsed()) * 1e-9;
    // The pixels that visibly change (by more than 8 in some channel), near the new place or the
    // place it left (within an eighth of the frame's width of where they project) and elsewhere:
    // the view's exposure is metered from the surfaces in view, so the rest of the frame stays.
    const double scale = double(before.width()) / std::max(vp->width(), 1);
    const int r = before.width() / 8;
    std::vector<QPoint> centres;
    for (Vec3 world : {to, from})
      if (const std::optional<QPointF> c = vp->project(world))
        centres.emplace_back(int(c->x() * scale), int(c->y() * scale));
    QVERIFY(!centres.empty());
    long changedNear = 0, changedElsewhere = 0;
    for (int y = 0; y < before.height(); ++y)
      for (int x = 0; x < before.width(); ++x) {
        const QRgb a = before.pixel(x, y), b = after.pixel(x, y);
        const int d = std::max({std::abs(qRed(a) - qRed(b)), std::abs(qGreen(a) - qGreen(b)),
                                std::abs(qBlue(a) - qBlue(b))});
        if (d <= 8) continue;
        bool near = false;
        for (const QPoint& c : centres) near |= std::abs(x - c.x()) < r && std::abs(y - c.y()) < r;
        ++(near ? changedNear : changedElsewhere);
      }
    const QByteArray artifacts = qgetenv("PS_ARTIFACTS");
    if (!artifacts.isEmpty()) {
      QDir().mkpath(QString::fromLocal8Bit(artifacts));
      const QString base = QString::fromLocal8Bit(artifacts) + "/live-edit-" +
                           QFileInfo(scenePath()).completeBaseName();
      before.save(base + "-before.png");
      after.save(base + "-after.png");
    }
    std::printf(
        "shown view (%s): the lit preview reflects the move after %.3f s (frame read back at "
        "%.3f s); pixels changed near the new and the old place %ld, elsewhere %ld\n",
        qPrintable(QFileInfo(scenePath()).fileName()), seconds, frameSeconds, changedNear,
        changedElsewhere);
    // Measured on two-rooms (1400 x 900 window, software GL): 20879 pixels changed near the two
    // places and 113608 elsewhere in 3 of 3 runs (30480 and 127678 with another capture's
    // random streams). The lowest layer is the covering's hull corners, 0.15 m above the floor:
    // the floor, below them, reads its light from the hull's bottom face, so moving one changes
    // the floor far from it too. A view that did not reflect the move changes none: the bounds
    // leave a factor of 10 below the fewest seen near, and of 3.7 on the share near.
    QVERIFY2(
        changedNear > 2000 && 20 * changedNear > changedElsewhere,
        qPrintable(QStringLiteral("%1 near, %2 elsewhere").arg(changedNear).arg(changedElsewhere)));
  }

  void aMovedSelectionIsCapturedTogether() {
    if (!qgetenv("PS_LIVE_SCENE").isEmpty()) QSKIP("two-rooms only");
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    Document* doc = w.document();
    QVERIFY(openWithProposal(w));
    w.placementPanel()->bakeSamplesBox()->setValue(64);  // the quick capture is the last
    std::vector<std::pair<uint64_t, Vec3>> targets;
    for (size_t i = 0; i < 20 && i < doc->probes().size(); ++i)
      targets.emplace_back(doc->probes()[i].id, doc->probes()[i].position + Vec3(0, 0.1, 0));
    QSignalSpy captured(doc, &Document::liveCaptured);
    QElapsedTimer clock;
    clock.start();
    doc->moveProbes(targets, doc->newMergeKey());  // one undo step, as a dragged selection
    QVERIFY(doc->isQuickCapturePending());
    QTRY_VERIFY_WITH_TIMEOUT(!doc->isCapturingLive(), 60000);
    std::printf("%zu probes moved together: captured in %.3f s\n", targets.size(),
                double(clock.nsecsElapsed()) * 1e-9);
    QCOMPARE(captured.count(), int(targets.size()));
    for (const auto& [id, to] : targets) {
      QCOMPARE(doc->probe(id)->position, to);
      QVERIFY(doc->probe(id)->sh);
    }
  }

  void aLightingChangeDropsCapturesOfTheOldLight() {
    if (!qgetenv("PS_LIVE_SCENE").isEmpty()) QSKIP("two-rooms only");
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    Document* doc = w.document();
    doc->setAutoPropose(false);
    QVERIFY(w.openScene(scenePath()));
    w.placementPanel()->bakeSamplesBox()->setValue(4096);
    const uint64_t id = doc->addManualProbe(Vec3(-2.0, 1.2, 0.5), "Add");
    QVERIFY(doc->probe(id)->sh);  // the quick capture, at once
    QVERIFY(doc->isCapturingLive());
    const ShRgb quick = *doc->probe(id)->sh;
    // The light changes while the final capture runs: it is dropped, the SH stays.
    LightingRig rig;
    rig.skyRadiance = Rgb(5, 5, 5);
    doc->setRig(rig, "Sky");
    QSignalSpy captured(doc, &Document::liveCaptured);
    QTRY_VERIFY_WITH_TIMEOUT(!doc->isCapturingLive(), 60000);
    QCOMPARE(captured.count(), 0);
    QVERIFY(*doc->probe(id)->sh == quick);
    // Added probes get the bake's count after their quick capture.
    w.placementPanel()->bakeSamplesBox()->setValue(128);
    const uint64_t second = doc->addManualProbe(Vec3(-1.0, 1.0, -0.5), "Add");
    QVERIFY(captured.wait(60000));
    QCOMPARE(captured.first().at(0).toULongLong(), quint64(second));
    QCOMPARE(captured.first().at(1).toInt(), 128);
    QCOMPARE(doc->undoStack()->count(), 3);  // two adds and the rig: no step of its own
  }
};

QTEST_MAIN(TestLiveEdits)
#include "test_live_edits.moc"
