// The viewport as a lighting artist sees it (run under Xvfb's software GL,
// ui.test_viewport_lighting): lit from the start (by the probes once captured, by the scene's own
// lights before), exposed from what is on screen (few clipped pixels, no black frame) on two-rooms
// and dream-apartment, the rig's sun as a gizmo dragged through the undo stack, the slice dragged
// by its outline and the sky behind the scene. Screenshots go to $PS_ARTIFACTS when it is set.
#include <QDir>
#include <QElapsedTimer>
#include <QLabel>
#include <QMouseEvent>
#include <QSignalSpy>
#include <QtTest>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/capture/DirectLight.h"
#include "core/scene/EnvironmentMap.h"
#include "core/trace/Tracer.h"
#include "ui/Document.h"
#include "ui/MainWindow.h"
#include "ui/SceneLighting.h"
#include "ui/Viewport.h"

using namespace ps;
using namespace ps::ui;

namespace {

const QString kTwoRooms = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");
const QString kApartment =
    QStringLiteral(PS_SHARED_SCENES_DIR "/dream-apartment/dream-apartment.glb");

/// A pixel counts as clipped when a channel reaches 254 of 255 (8-bit sRGB).
constexpr int kClippedLevel = 254;
/// At most this share of a frame's pixels may clip.
constexpr double kMaxClippedFraction = 0.03;
/// Not a black frame: the median 8-bit luma of the scene's pixels reaches kMinMedianLuma (a
/// scene without a sky leaves its outside walls black) and their 90th percentile kMinP90Luma.
constexpr int kMinMedianLuma = 30;
constexpr int kMinP90Luma = 150;

QString waitForJob(Document* doc, int timeoutMs = 300000) {
  if (!doc->isBusy()) return {};
  QSignalSpy done(doc, &Document::jobFinished);
  if (!done.wait(timeoutMs)) return QStringLiteral("timeout");
  return done.first().first().toString();
}

void mouse(QWidget* w, QEvent::Type type, QPointF pos, Qt::MouseButtons buttons) {
  QMouseEvent e(type, pos, w->mapToGlobal(pos), Qt::LeftButton, buttons, Qt::NoModifier);
  QCoreApplication::sendEvent(w, &e);
}

/// A left drag from `from` to `to` in `steps` moves.
void drag(QWidget* w, QPointF from, QPointF to, int steps = 8) {
  mouse(w, QEvent::MouseButtonPress, from, Qt::LeftButton);
  for (int i = 1; i <= steps; ++i)
    mouse(w, QEvent::MouseMove, from + (to - from) * (double(i) / steps), Qt::LeftButton);
  mouse(w, QEvent::MouseButtonRelease, to, Qt::NoButton);
}

int luma(QRgb c) {
  return (qRed(c) * 2126 + qGreen(c) * 7152 + qBlue(c) * 722) / 10000;
}

/// True when the pixel shows the background gradient (Viewport::backgroundTop/Bottom).
bool isBackground(const QImage& img, int x, int y) {
  const double t = 1.0 - (y + 0.5) / img.height();
  const QColor top = Viewport::backgroundTop(), bottom = Viewport::backgroundBottom();
  const QRgb c = img.pixel(x, y);
  return std::abs(qRed(c) - (bottom.red() + (top.red() - bottom.red()) * t)) <= 3 &&
         std::abs(qGreen(c) - (bottom.green() + (top.green() - bottom.green()) * t)) <= 3 &&
         std::abs(qBlue(c) - (bottom.blue() + (top.blue() - bottom.blue()) * t)) <= 3;
}

struct Exposure {
  double clipped = 0;  ///< share of all pixels
  int medianLuma = 0;  ///< of the pixels that are not the background
  int p90Luma = 0;     ///< of the same
};

/// `sky`: the scene has a sky (constant radiance), whose colour the corner pixel shows.
Exposure measure(const QImage& img, bool sky) {
  const QRgb skyColour = img.pixel(2, 2);
  const auto isSky = [&](QRgb c) {
    return sky && std::abs(qRed(c) - qRed(skyColour)) <= 3 &&
           std::abs(qGreen(c) - qGreen(skyColour)) <= 3 &&
           std::abs(qBlue(c) - qBlue(skyColour)) <= 3;
  };
  size_t clipped = 0;
  std::vector<int> lumas;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      const QRgb c = img.pixel(x, y);
      clipped += std::max({qRed(c), qGreen(c), qBlue(c)}) >= kClippedLevel ? 1 : 0;
      if (!isBackground(img, x, y) && !isSky(c)) lumas.push_back(luma(c));
    }
  Exposure e;
  e.clipped = double(clipped) / double(size_t(img.width()) * size_t(img.height()));
  if (!lumas.empty()) {
    std::sort(lumas.begin(), lumas.end());
    e.medianLuma = lumas[lumas.size() / 2];
    e.p90Luma = lumas[lumas.size() * 9 / 10];
  }
  return e;
}

/// The frame as the window shows it, with the lighting brought up to date first.
QImage frame(Viewport* vp) {
  vp->frameAll();
  (void)vp->previewVolume();
  (void)vp->sceneLightGrid();
  QImage img = vp->grabFramebuffer().convertToFormat(QImage::Format_RGB32);
  return img;
}

void saveArtifact(const QImage& img, const QString& name) {
  const QByteArray dir = qgetenv("PS_ARTIFACTS");
  if (dir.isEmpty()) return;
  QDir().mkpath(QString::fromLocal8Bit(dir));
  img.save(QString::fromLocal8Bit(dir) + "/" + name);
}

double meanAbsDifference(const QImage& a, const QImage& b) {
  double sum = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      const QRgb p = a.pixel(x, y), q = b.pixel(x, y);
      sum += std::abs(qRed(p) - qRed(q)) + std::abs(qGreen(p) - qGreen(q)) +
             std::abs(qBlue(p) - qBlue(q));
    }
  return sum / (3.0 * a.width() * a.height());
}

/// The dream-apartment's rig of the placement benchmark (BENCHMARKS.md, "Placement quality
/// under the default pipeline"): a sun from (0.4, 0.8, 0.3) at 3 W/m² and a sky of radiance
/// (0.3, 0.4, 0.6).
LightingRig sunAndSky() {
  LightingRig rig;
  Light sun;
  sun.type = LightType::Directional;
  sun.name = "sun";
  sun.direction = -normalize(Vec3(0.4, 0.8, 0.3));
  sun.intensity = Rgb(3, 3, 3);
  rig.lights.push_back(sun);
  rig.skyRadiance = Rgb(0.3, 0.4, 0.6);
  return rig;
}

class Window {
 public:
  Window() {
    w.setQuiet(true);
    w.setPromptOnClose(false);
    w.document()->setAutoPropose(false);
    w.resize(1280, 860);
    w.show();
  }
  MainWindow w;
  Document* doc() { return w.document(); }
  Viewport* vp() { return w.viewport(); }
};

}  // namespace

class TestViewportLighting : public QObject {
  Q_OBJECT
 private slots:
  void initTestCase() {
    if (QGuiApplication::platformName() == QLatin1String("offscreen"))
      QSKIP("needs a display with OpenGL: runs under xvfb-run (ui.test_viewport_lighting)");
  }

  void capturedProbesLightTheDefaultView() {
    Window win;
    QVERIFY(win.w.openPath(kTwoRooms));
    QVERIFY(QTest::qWaitForWindowExposed(&win.w));
    win.doc()->proposeCandidates();
    QCOMPARE(waitForJob(win.doc()), QString());
    Viewport* vp = win.vp();
    const QImage lit = frame(vp);
    QCOMPARE(vp->shading(), Viewport::Shading::Probes);
    vp->setFlatShading(true);
    QCOMPARE(vp->shading(), Viewport::Shading::Flat);
    const QImage flat = frame(vp);
    saveArtifact(lit, "viewport-two-rooms-probes.png");
    saveArtifact(flat, "viewport-two-rooms-flat.png");
    const double diff = meanAbsDifference(lit, flat);
    QVERIFY2(diff > 8, qPrintable(QString::number(diff)));
  }

  void beforeCaptureTheSceneLightsTheView() {
    Window win;
    QVERIFY(win.w.openPath(kTwoRooms));
    QVERIFY(QTest::qWaitForWindowExposed(&win.w));
    Viewport* vp = win.vp();
    const QImage img = frame(vp);
    QCOMPARE(vp->shading(), Viewport::Shading::SceneLights);
    saveArtifact(img, "viewport-two-rooms-scene-lights.png");
    // Floor points of the room the lamp does not reach: those the sun reaches are brighter, in
    // the light grid and on screen, than those in the shadow of the walls.
    const Scene& scene = *win.doc()->scene();
    const Tracer& tracer = *win.doc()->tracer();
    const Light *sun = nullptr, *lamp = nullptr;
    for (const Light& l : scene.lights) (l.type == LightType::Directional ? sun : lamp) = &l;
    QVERIFY(sun && lamp);
    const ShGrid& grid = vp->sceneLightGrid();
    QVERIFY(grid.size() > 0);
    double sunGrid = 0, shadeGrid = 0, sunPx = 0, shadePx = 0;
    int sunCount = 0, shadeCount = 0;
    const Bounds3 b = scene.bounds;
    for (int i = 0; i < 60; ++i)
      for (int k = 0; k < 40; ++k) {
        const Vec3 top(b.lo.x + (i + 0.5) / 60 * b.extent().x, b.lo.y + 0.4 * b.extent().y,
                       b.lo.z + (k + 0.5) / 40 * b.extent().z);
        const auto hit = tracer.intersect(Ray{top, Vec3(0, -1, 0), 0.0});
        if (!hit || !hit->frontFace || hit->geometricNormal.y < 0.9) continue;
        const Vec3 p = top + Vec3(0, -hit->t + 0.01, 0);
        if (visibleDeltaArrival(tracer, *lamp, p)) continue;  // the lamp's room
        const auto px = vp->project(p);
        if (!px || !img.rect().contains(px->toPoint())) continue;
        const bool sunlit = visibleDeltaArrival(tracer, *sun, p).has_value();
        const double e = luminance(sampleShGridAt(grid, p).irradiance(Vec3(0, 1, 0)));
        const double l = luma(img.pixel(px->toPoint()));
        (sunlit ? sunGrid : shadeGrid) += e;
        (sunlit ? sunPx : shadePx) += l;
        ++(sunlit ? sunCount : shadeCount);
      }
    QVERIFY2(sunCount >= 10 && shadeCount >= 10,
             qPrintable(QStringLiteral("%1 sunlit, %2 shaded").arg(sunCount).arg(shadeCount)));
    sunGrid /= sunCount, shadeGrid /= shadeCount, sunPx /= sunCount, shadePx /= shadeCount;
    std::printf(
        "two-rooms, sun room floor: irradiance sunlit %.3f, shaded %.3f W/m2; luma "
        "%.1f, %.1f\n",
        sunGrid, shadeGrid, sunPx, shadePx);
    QVERIFY2(sunGrid > 2 * shadeGrid,
             qPrintable(QStringLiteral("%1 %2").arg(sunGrid).arg(shadeGrid)));
    QVERIFY2(sunPx > shadePx + 30, qPrintable(QStringLiteral("%1 %2").arg(sunPx).arg(shadePx)));
    // Flat colours are one toggle away.
    vp->setFlatShading(true);
    QCOMPARE(vp->shading(), Viewport::Shading::Flat);
  }

  void exposureNeitherClipsNorBlackens_data() {
    QTest::addColumn<QString>("scene");
    QTest::addColumn<bool>("rig");
    QTest::addColumn<bool>("probes");
    QTest::newRow("two-rooms, scene lights") << kTwoRooms << false << false;
    QTest::newRow("two-rooms, probes") << kTwoRooms << false << true;
    QTest::newRow("dream-apartment, scene lights") << kApartment << true << false;
    QTest::newRow("dream-apartment, probes") << kApartment << true << true;
  }
  void exposureNeitherClipsNorBlackens() {
    QFETCH(QString, scene);
    QFETCH(bool, rig);
    QFETCH(bool, probes);
    if (!QFile::exists(scene)) QSKIP(qPrintable(scene + " is absent: skipped"));
    Window win;
    QVERIFY(win.w.openPath(scene));
    QVERIFY(QTest::qWaitForWindowExposed(&win.w));
    if (rig) win.doc()->setRig(sunAndSky(), "Sun and sky");
    if (probes) {
      win.doc()->proposeCandidates();
      QCOMPARE(waitForJob(win.doc()), QString());
    }
    Viewport* vp = win.vp();
    if (!probes) {
      // What the view computes on its worker thread after an open or a rig edit, timed here.
      QElapsedTimer clock;
      clock.start();
      const ShGrid g = directLightGrid(*win.doc()->tracer(), win.doc()->probeSet().rig,
                                       win.doc()->scene()->bounds, Viewport::kSceneLightCells);
      std::printf("%s: scene light grid %d x %d x %d in %.2f s\n",
                  qPrintable(QFileInfo(scene).fileName()), g.dims[0], g.dims[1], g.dims[2],
                  double(clock.nsecsElapsed()) * 1e-9);
    }
    const QImage img = frame(vp);
    QCOMPARE(vp->shading(), probes ? Viewport::Shading::Probes : Viewport::Shading::SceneLights);
    const Exposure e = measure(img, rig);
    const QString name = QFileInfo(scene).baseName();
    saveArtifact(img, QStringLiteral("viewport-%1-%2.png")
                          .arg(name, probes ? QStringLiteral("probes") : QStringLiteral("lights")));
    std::printf("%s, %s: exposure %.3g, clipped %.2f %%, luma median %d, p90 %d\n",
                qPrintable(name), probes ? "probes" : "scene lights", double(vp->autoExposure()),
                100 * e.clipped, e.medianLuma, e.p90Luma);
    QVERIFY2(e.clipped <= kMaxClippedFraction, qPrintable(QString::number(e.clipped)));
    QVERIFY2(e.medianLuma >= kMinMedianLuma, qPrintable(QString::number(e.medianLuma)));
    QVERIFY2(e.p90Luma >= kMinP90Luma, qPrintable(QString::number(e.p90Luma)));
    // The artist's offset still works on top: two stops up clips more.
    vp->setExposureStops(2);
    QVERIFY(measure(frame(vp), rig).clipped > e.clipped);
  }

  void aSceneWithoutLightIsFlatAndSaysWhy() {
    if (!QFile::exists(kApartment)) QSKIP(qPrintable(kApartment + " is absent: skipped"));
    Window win;
    QVERIFY(win.w.openPath(kApartment));  // no light of its own, no rig
    Viewport* vp = win.vp();
    (void)frame(vp);
    QCOMPARE(vp->shading(), Viewport::Shading::Flat);
    QVERIFY2(vp->emptyOverlayReason().contains("Lighting tab"),
             qPrintable(vp->emptyOverlayReason()));
    auto* reason = win.w.findChild<QLabel*>("overlayReason");
    QVERIFY(reason);
    QCOMPARE(reason->text(), vp->emptyOverlayReason());
    win.doc()->setRig(sunAndSky(), "Sun and sky");
    (void)frame(vp);
    QCOMPARE(vp->shading(), Viewport::Shading::SceneLights);
    QVERIFY(!vp->emptyOverlayReason().contains("Lighting tab"));
    QCOMPARE(reason->text(), vp->emptyOverlayReason());
  }

  void draggingTheSunTurnsTheRigsSunAndUndoRestoresIt() {
    Window win;
    QVERIFY(win.w.openPath(kTwoRooms));
    QVERIFY(QTest::qWaitForWindowExposed(&win.w));
    Document* doc = win.doc();
    Viewport* vp = win.vp();
    QVERIFY(!vp->sunGizmoPosition());  // the scene's sun is drawn, not edited
    doc->setRig(sunAndSky(), "Sun and sky");
    vp->frameAll();
    const Vec3 before = doc->probeSet().rig.lights.at(0).direction;
    const auto at = vp->sunGizmoPosition();
    QVERIFY(at);
    const auto px = vp->project(*at);
    QVERIFY(px && vp->onScreen(*px));
    const int steps = doc->undoStack()->count();
    drag(vp, *px, *px + QPointF(-120, 60));
    QCOMPARE(doc->undoStack()->count(), steps + 1);
    const Vec3 after = doc->probeSet().rig.lights.at(0).direction;
    const double turnedDeg = std::acos(std::clamp(dot(before, after), -1.0, 1.0)) * 180 / kPi;
    QVERIFY2(turnedDeg > 5, qPrintable(QString::number(turnedDeg)));
    QCOMPARE(length(after), 1.0);
    // The disc follows: it is drawn where the cursor left it.
    const auto moved = vp->project(*vp->sunGizmoPosition());
    QVERIFY(moved && QLineF(*moved, *px + QPointF(-120, 60)).length() < 3);
    doc->undoStack()->undo();
    QCOMPARE(doc->probeSet().rig.lights.at(0).direction, before);
    doc->undoStack()->redo();
    QCOMPARE(doc->probeSet().rig.lights.at(0).direction, after);
  }

  void draggingTheSliceOutlineMovesTheSlice() {
    Window win;
    QVERIFY(win.w.openPath(kTwoRooms));
    QVERIFY(QTest::qWaitForWindowExposed(&win.w));
    Viewport* vp = win.vp();
    vp->setOverlay(Viewport::Overlay::Slice, true);
    vp->setSliceAxis(1);
    vp->setSliceFraction(0.3f);
    vp->frameAll();
    QSignalSpy moved(vp, &Viewport::sliceChanged);
    // Grab the outline at the middle of its edge nearest the camera's side of the frame.
    const auto c = vp->sliceCorners();
    std::optional<QPointF> grip;
    for (int i = 0; i < 4 && !grip; ++i) {
      const auto p = vp->project((c[size_t(i)] + c[size_t((i + 1) % 4)]) * 0.5);
      if (p && vp->onScreen(*p) && vp->onSliceOutline(*p)) grip = *p;
    }
    QVERIFY(grip);
    QVERIFY(!vp->onSliceOutline(*grip + QPointF(0, 40)) ||
            !vp->onSliceOutline(*grip + QPointF(40, 0)));
    // Up on screen raises a horizontal slice.
    drag(vp, *grip, *grip + QPointF(0, -60));
    QVERIFY2(vp->sliceFraction() > 0.35f, qPrintable(QString::number(vp->sliceFraction())));
    QVERIFY(!moved.isEmpty());
    QCOMPARE(moved.last().at(1).toFloat(), vp->sliceFraction());
    // The menu's control moves the same slice the drag moved.
    const float dragged = vp->sliceFraction();
    vp->setSliceFraction(vp->sliceFraction() - 0.05f);
    QCOMPARE(vp->sliceFraction(), std::max(dragged - 0.05f, 0.0f));
    saveArtifact(frame(vp), "viewport-two-rooms-slice.png");
  }

  void theSkyIsTheBackground() {
    Window win;
    QVERIFY(win.w.openPath(kTwoRooms));
    QVERIFY(QTest::qWaitForWindowExposed(&win.w));
    Viewport* vp = win.vp();
    const QImage without = frame(vp);
    QVERIFY(isBackground(without, 2, 2));
    win.doc()->setRig(sunAndSky(), "Sun and sky");
    const QImage with = frame(vp);
    saveArtifact(with, "viewport-two-rooms-sky.png");
    const QRgb corner = with.pixel(2, 2);
    QVERIFY(!isBackground(with, 2, 2));
    // The sky (0.3, 0.4, 0.6) is blue, and lit, not white.
    QVERIFY2(
        qBlue(corner) > qRed(corner) + 20 && qBlue(corner) < 250,
        qPrintable(
            QStringLiteral("%1 %2 %3").arg(qRed(corner)).arg(qGreen(corner)).arg(qBlue(corner))));
    // An environment map instead: red above the horizon, green below; the corner shows the
    // half its view ray points into.
    auto env = std::make_shared<EnvironmentMap>();
    env->width = 8;
    env->height = 4;
    for (int row = 0; row < env->height; ++row)
      for (int col = 0; col < env->width; ++col) {
        const bool up = row < env->height / 2;
        env->rgb.insert(env->rgb.end(), {up ? 0.6f : 0.05f, up ? 0.05f : 0.6f, 0.05f});
      }
    LightingRig rig;
    rig.lights = sunAndSky().lights;
    rig.envMap = env;
    win.doc()->setRig(rig, "Environment map");
    const QImage mapped = frame(vp);
    saveArtifact(mapped, "viewport-two-rooms-env-map.png");
    const bool upward = vp->pickRay(QPointF(2, 2)).direction.y() > 0;
    const QRgb c = mapped.pixel(2, 2);
    QVERIFY2(upward ? qRed(c) > qGreen(c) + 40 : qGreen(c) > qRed(c) + 40,
             qPrintable(QStringLiteral("%1 %2 %3, up %4")
                            .arg(qRed(c))
                            .arg(qGreen(c))
                            .arg(qBlue(c))
                            .arg(upward)));
  }
};

QTEST_MAIN(TestViewportLighting)
#include "test_viewport_lighting.moc"
