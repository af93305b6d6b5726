// Editing in the editor, headless (QT_QPA_PLATFORM=offscreen): the move handle's constraints,
// drags through real mouse events (one undo step each), box select, probes added on a surface
// through the Embree tracer, the inspector, locks, fly keys, undo of a move restoring the SH.
#include <QAction>
#include <QCheckBox>
#include <QDoubleSpinBox>
#include <QLabel>
#include <QMouseEvent>
#include <QSignalSpy>
#include <QStandardPaths>
#include <QTableView>
#include <QtTest>
#include <random>

#include "core/trace/Tracer.h"
#include "ui/Document.h"
#include "ui/DragHandle.h"
#include "ui/InspectorPanel.h"
#include "ui/IrradianceSphere.h"
#include "ui/MainWindow.h"
#include "ui/ProbeTableModel.h"
#include "ui/SurfacePlacement.h"
#include "ui/Viewport.h"

using namespace ps;
using namespace ps::ui;

namespace {
const QString kScene = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");

/// Radiance arriving from straight above only (a small cap around +Y), as SH.
ShRgb lightFromAbove() {
  ShRgb sh;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    // Uniform sphere directions, radiance 1 where y > 0.8.
    const double z = 2 * u(rng) - 1, phi = 2 * kPi * u(rng), r = std::sqrt(1 - z * z);
    const Vec3 d(r * std::cos(phi), z, r * std::sin(phi));
    if (d.y > 0.8) sh.addSample(d, Rgb(1, 1, 1), 4 * kPi / n);
  }
  return sh;
}

void send(QWidget* w, QEvent::Type type, QPointF pos, Qt::MouseButton button,
          Qt::MouseButtons buttons, Qt::KeyboardModifiers mods = Qt::NoModifier) {
  QMouseEvent e(type, pos, w->mapToGlobal(pos), button, buttons, mods);
  QCoreApplication::sendEvent(w, &e);
}

/// No dialogs, no prompt on close, no automatic proposal: the test drives everything.
void quiet(MainWindow& w) {
  w.setQuiet(true);
  w.setPromptOnClose(false);
  w.document()->setAutoPropose(false);
}

/// A press at `from`, moves in `steps` to `to`, a release: what a user's drag sends.
void drag(QWidget* w, QPointF from, QPointF to, Qt::MouseButton button = Qt::LeftButton,
          Qt::KeyboardModifiers mods = Qt::NoModifier, int steps = 8) {
  send(w, QEvent::MouseButtonPress, from, button, button, mods);
  for (int i = 1; i <= steps; ++i)
    send(w, QEvent::MouseMove, from + (to - from) * (double(i) / steps), Qt::NoButton, button,
         mods);
  send(w, QEvent::MouseButtonRelease, to, button, Qt::NoButton, mods);
}

/// Captured probes on a jittered nx x ny x nz grid through the box; `sh(i, j, k)` gives each
/// one's SH.
template <class ShOf>
std::vector<Probe> jitteredGrid(const Bounds3& b, int nx, int ny, int nz, unsigned seed, ShOf sh) {
  std::vector<Probe> ps;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.05, 0.05);
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) {
        Probe p;
        p.position = b.lo + Vec3((i + 0.5 + jitter(rng)) * b.extent().x / nx,
                                 (j + 0.5 + jitter(rng)) * b.extent().y / ny,
                                 (k + 0.5 + jitter(rng)) * b.extent().z / nz);
        p.sh = sh(i, j, k);
        ps.push_back(p);
      }
  return ps;
}

QPointF toPoint(std::optional<QPointF> p) {
  return p ? *p : QPointF(-1, -1);
}
Vec3 toV(QVector3D v) {
  return Vec3(v.x(), v.y(), v.z());
}
}  // namespace

class TestEditing : public QObject {
  Q_OBJECT
 private slots:
  void initTestCase() {
    QStandardPaths::setTestModeEnabled(true);  // recent files go to a test config, not the user's
    if (!QFile::exists(kScene)) QSKIP("two-rooms.gltf not present");
  }

  void axisAndPlaneConstraintsKeepTheOtherComponents() {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1, 1);
    const HandlePart parts[] = {HandlePart::AxisX,   HandlePart::AxisY,   HandlePart::AxisZ,
                                HandlePart::PlaneYZ, HandlePart::PlaneXZ, HandlePart::PlaneXY};
    int checked = 0;
    for (int trial = 0; trial < 2000; ++trial) {
      const QVector3D origin(u(rng) * 5, u(rng) * 5, u(rng) * 5);
      const QVector3D eye = origin + QVector3D(u(rng), u(rng), u(rng)).normalized() * 6;
      auto rayTo = [&](QVector3D p) { return PickRay{eye, (p - eye).normalized()}; };
      const PickRay a = rayTo(origin + QVector3D(u(rng), u(rng), u(rng)) * 0.5f);
      const PickRay b = rayTo(origin + QVector3D(u(rng), u(rng), u(rng)) * 0.5f);
      for (HandlePart part : parts) {
        const auto d = dragDelta(part, origin, a, b);
        if (!d) continue;
        ++checked;
        const QVector3D axis = handleAxis(part);
        if (isPlane(part)) {
          QCOMPARE(QVector3D::dotProduct(*d, axis), 0.0f);
        } else {
          QCOMPARE((*d - axis * QVector3D::dotProduct(*d, axis)).length(), 0.0f);
        }
      }
    }
    QVERIFY(checked > 10000);
    // An axis drag follows the cursor: the ray through a point of the axis gives that point.
    const QVector3D o(1, 2, 3), eye(4, 6, 9);
    const QVector3D target = o + QVector3D(0.7f, 0, 0);
    const auto p = constrainedPoint(HandlePart::AxisX, o, {eye, (target - eye).normalized()});
    QVERIFY(p && (*p - target).length() < 1e-4f);
    // A ray parallel to the axis designates no point.
    QVERIFY(!constrainedPoint(HandlePart::AxisX, o, {QVector3D(0, 2, 3), QVector3D(1, 0, 0)}));
  }

  void moveUndoRestoresPositionAndSh() {
    Document doc;
    doc.setAutoPropose(false);
    doc.openScene(kScene);
    Probe p;
    p.position = Vec3(1, 1, 1);
    p.sh = lightFromAbove();
    const uint64_t id = doc.addProbes({p}, "Add").at(0);
    const int before = doc.undoStack()->count();
    const int key = doc.newMergeKey();
    doc.moveProbes({{id, Vec3(1.5, 1, 1)}}, key);
    QVERIFY(!doc.probe(id)->sh);  // the SH belonged to the old position
    doc.moveProbes({{id, Vec3(2, 1, 1)}}, key);
    QCOMPARE(doc.undoStack()->count(), before + 1);
    // A new key is a new step.
    doc.moveProbes({{id, Vec3(3, 1, 1)}}, doc.newMergeKey());
    QCOMPARE(doc.undoStack()->count(), before + 2);
    doc.undoStack()->undo();
    QCOMPARE(doc.probe(id)->position, Vec3(2, 1, 1));
    doc.undoStack()->undo();
    QCOMPARE(doc.probe(id)->position, Vec3(1, 1, 1));
    QVERIFY(doc.probe(id)->sh && *doc.probe(id)->sh == *p.sh);
  }

  void handleDragIsOneUndoStepAlongTheAxis() {
    MainWindow w;
    quiet(w);
    Document* doc = w.document();
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    vp->resize(900, 700);
    vp->frameAll();
    const Vec3 c = doc->scene()->bounds.center();
    Probe p;
    p.position = c;
    const uint64_t id = doc->addProbes({p, p}, "Add").at(0);
    const uint64_t other = doc->probes().back().id;
    doc->moveProbe(other, c + Vec3(0.5, 0.3, 0.2));
    vp->setSelection({id});
    const auto origin = vp->handleOrigin();
    QVERIFY(origin);
    QVERIFY((toV(*origin) - c).x == 0.0);
    const float arm = vp->handleArmMeters();
    QVERIFY(arm > 0);

    for (HandlePart part : {HandlePart::AxisX, HandlePart::PlaneXZ}) {
      const Vec3 start = doc->probe(id)->position;
      const QVector3D o = *vp->handleOrigin();
      const QVector3D grab = part == HandlePart::AxisX ? o + QVector3D(arm * 0.6f, 0, 0)
                                                       : o + QVector3D(arm * 0.32f, 0, arm * 0.32f);
      const QPointF from = toPoint(vp->project(toV(grab)));
      QCOMPARE(vp->handlePartAt(from), part);
      const int steps = doc->undoStack()->count();
      drag(vp, from, from + QPointF(60, 25));
      QCOMPARE(doc->undoStack()->count(), steps + 1);  // the whole drag: one undo step
      const Vec3 moved = doc->probe(id)->position;
      QVERIFY(length(moved - start) > 0.01);
      if (part == HandlePart::AxisX) {
        QCOMPARE(moved.y, start.y);
        QCOMPARE(moved.z, start.z);
      } else {
        QCOMPARE(moved.y, start.y);
      }
      QCOMPARE(doc->probe(other)->position, c + Vec3(0.5, 0.3, 0.2));  // not selected
      doc->undoStack()->undo();
      QCOMPARE(doc->probe(id)->position, start);
      doc->undoStack()->redo();
      QCOMPARE(doc->probe(id)->position, moved);
    }

    // A locked probe has no handle and does not move.
    doc->setLocked({id}, true);
    QVERIFY(!vp->handleOrigin());
    doc->undoStack()->undo();
    QVERIFY(vp->handleOrigin());
  }

  void aDraggedProbeStopsWhereItIsReleased() {
    // With the probes captured and lit: once the button is up the probe stays where it was
    // released, whatever arrives after (its live captures, the rebuilt fields, moves still
    // queued with the button state they were sent with, moves with the button up).
    MainWindow w;
    quiet(w);
    Document* doc = w.document();
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    vp->resize(900, 700);
    const std::vector<Probe> ps = jitteredGrid(doc->scene()->bounds, 4, 2, 3, 9,
                                               [](int, int, int) { return lightFromAbove(); });
    const std::vector<uint64_t> ids = doc->addProbes(ps, "Add");
    vp->frameAll();
    const uint64_t id = ids.at(8);
    vp->setSelection({id});
    const QVector3D o = *vp->handleOrigin();
    const QPointF from =
        toPoint(vp->project(toV(o + QVector3D(vp->handleArmMeters() * 0.6f, 0, 0))));
    QCOMPARE(vp->handlePartAt(from), HandlePart::AxisX);
    const Vec3 start = doc->probe(id)->position;
    send(vp, QEvent::MouseButtonPress, from, Qt::LeftButton, Qt::LeftButton);
    for (int i = 1; i <= 12; ++i) {
      send(vp, QEvent::MouseMove, from + QPointF(8.0 * i, 0), Qt::NoButton, Qt::LeftButton);
      QCoreApplication::processEvents();
    }
    // Moves queued before the release, delivered after it.
    const QPointF further = from + QPointF(160, 0);
    for (int i = 0; i < 4; ++i) {
      const QPointF p = further + QPointF(10.0 * i, 0);
      QCoreApplication::postEvent(
          vp, new QMouseEvent(QEvent::MouseMove, p, vp->mapToGlobal(p), Qt::NoButton,
                              Qt::LeftButton, Qt::NoModifier));
    }
    send(vp, QEvent::MouseButtonRelease, from + QPointF(96, 0), Qt::LeftButton, Qt::NoButton);
    const Vec3 released = doc->probe(id)->position;
    QVERIFY(length(released - start) > 0.05);
    const int steps = doc->undoStack()->count();
    // The captures and fields of the new place land while the cursor moves on, button up.
    for (int i = 0; i < 10; ++i) {
      send(vp, QEvent::MouseMove, further + QPointF(0, 5.0 * i), Qt::NoButton, Qt::NoButton);
      QTest::qWait(150);
      QCOMPARE(doc->probe(id)->position, released);
    }
    QTRY_VERIFY_WITH_TIMEOUT(!doc->isCapturingLive(), 30000);
    QTest::qWait(200);
    QCOMPARE(doc->probe(id)->position, released);
    QCOMPARE(doc->undoStack()->count(), steps);
  }

  void boxSelectPicksTheProbesInside() {
    MainWindow w;
    quiet(w);
    Document* doc = w.document();
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    vp->resize(800, 600);
    const Bounds3 b = doc->scene()->bounds;
    std::vector<Probe> ps;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 3; ++j) {
        Probe p;
        p.position = Vec3(b.lo.x + (i + 0.5) * b.extent().x / 4, b.lo.y + 1.0,
                          b.lo.z + (j + 0.5) * b.extent().z / 3);
        ps.push_back(p);
      }
    const auto ids = doc->addProbes(ps, "Add");
    vp->frameAll();
    // Box around the left half of the probes (by projected x).
    std::vector<double> xs;
    for (uint64_t id : ids) xs.push_back(toPoint(vp->project(doc->probe(id)->position)).x());
    std::vector<double> sorted = xs;
    std::sort(sorted.begin(), sorted.end());
    const double split = 0.5 * (sorted[5] + sorted[6]);
    QSignalSpy box(vp, &Viewport::boxSelected);
    drag(vp, QPointF(1, 1), QPointF(split, 599), Qt::LeftButton, Qt::ControlModifier);
    QCOMPARE(box.count(), 1);
    QSet<quint64> expected;
    for (size_t i = 0; i < ids.size(); ++i)
      if (xs[i] < split) expected.insert(ids[i]);
    QCOMPARE(vp->selection(), expected);
    QCOMPARE(w.inspector()->findChild<QLabel*>() != nullptr, true);
    // Ctrl+Shift adds the rest; a Ctrl drag does not orbit the camera.
    const QVector3D eye = vp->camera().eye();
    drag(vp, QPointF(split, 1), QPointF(799, 599), Qt::LeftButton,
         Qt::ControlModifier | Qt::ShiftModifier);
    QCOMPARE(vp->selection().size(), qsizetype(ids.size()));
    QCOMPARE(vp->camera().eye(), eye);
  }

  void surfaceClickPlacesAProbeOffsetAlongTheNormal() {
    const Scene scene = loadScene(kScene.toStdString());
    const Tracer tracer(scene);
    const Bounds3 b = scene.bounds;
    const Vec3 e = b.extent();
    // Straight down inside room A: the floor (or the top of something standing on it).
    const Vec3 origin(b.lo.x + 0.2 * e.x, b.lo.y + 0.7 * e.y, b.lo.z + 0.5 * e.z);
    const auto s = placeOnSurface(tracer, origin, Vec3(0, -1, 0), 0.3);
    QVERIFY(s);
    QVERIFY(s->normal.y > 0.99);
    QVERIFY(std::abs(length(s->position - s->hitPoint) - 0.3) < 1e-9);
    QVERIFY(s->position.y > s->hitPoint.y);
    // Looking up at the ceiling: the normal faces the viewer (downwards).
    const auto up = placeOnSurface(tracer, origin, Vec3(0, 1, 0), 0.3);
    QVERIFY(up && up->normal.y < -0.99 && up->position.y < up->hitPoint.y);
    // An offset larger than the room: halfway to the opposite surface, inside the bounds.
    const auto big = placeOnSurface(tracer, origin, Vec3(0, -1, 0), 50.0);
    QVERIFY(big);
    const auto across = tracer.intersect(Ray{big->hitPoint, big->normal, tracer.rayEpsilon()});
    QVERIFY(across);
    QVERIFY(std::abs(length(big->position - big->hitPoint) - 0.5 * across->t) < 1e-9);
    QVERIFY(b.contains(big->position));
    // A ray into the sky.
    QVERIFY(!placeOnSurface(tracer, b.hi + Vec3(1, 1, 1), Vec3(0, 1, 0), 0.3));

    // The AddProbe tool: a click adds one accepted, captured manual probe (one undo step).
    MainWindow w;
    quiet(w);
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    vp->resize(800, 600);
    vp->frameAll();
    vp->setTool(Viewport::Tool::AddProbe);
    const QPointF centre(400, 300);
    // The ray starts at the cut plane: what the cut-away removed is not clicked.
    const PickRay ray = vp->surfaceRay(centre);
    QVERIFY(vp->cutaway());
    QCOMPARE(ray.origin.y(), vp->cutHeight());
    {
      // Here the whole ray meets geometry the cut-away hides (y 3.2 above the 2.35 m cut):
      // a probe there is one the artist cannot see, so the click must not put it there.
      const PickRay full = vp->pickRay(centre);
      const auto above = placeOnSurface(*w.document()->tracer(), toV(full.origin),
                                        toV(full.direction), w.surfaceOffsetMeters());
      QVERIFY(above && above->hitPoint.y > vp->cutHeight());
    }
    const auto expected = placeOnSurface(*w.document()->tracer(), toV(ray.origin),
                                         toV(ray.direction), w.surfaceOffsetMeters());
    QVERIFY(expected);
    QVERIFY(expected->hitPoint.y < vp->cutHeight());
    send(vp, QEvent::MouseButtonPress, centre, Qt::LeftButton, Qt::LeftButton);
    send(vp, QEvent::MouseButtonRelease, centre, Qt::LeftButton, Qt::NoButton);
    QCOMPARE(w.document()->probes().size(), size_t(1));
    const Probe& added = w.document()->probes()[0];
    QVERIFY(length(added.position - expected->position) < 1e-4);
    QCOMPARE(added.state, ProbeState::Accepted);
    QCOMPARE(added.method, std::string("manual"));
    QVERIFY(added.sh.has_value());
    QCOMPARE(vp->selection(), QSet<quint64>{added.id});
    QCOMPARE(w.document()->undoStack()->count(), 1);

    // At the camera.
    w.addProbeAtCamera();
    QCOMPARE(w.document()->probes().size(), size_t(2));
    QVERIFY(length(w.document()->probes()[1].position - toV(vp->camera().eye())) < 1e-5);
  }

  void drawingInTheViewportAddsAnImportanceVolume() {
    // The DrawVolume tool (Edit > Draw importance volume, B): a drag on the floor spans the
    // box's footprint on the level of the point pressed, up to the top of the scene.
    MainWindow w;
    quiet(w);
    Document* doc = w.document();
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    vp->resize(800, 600);
    vp->frameAll();
    QAction* tool = nullptr;
    for (QAction* a : w.findChildren<QAction*>())
      if (a->text() == QStringLiteral("Draw importance &volume")) tool = a;
    QVERIFY(tool);
    tool->setChecked(true);
    QCOMPARE(vp->tool(), Viewport::Tool::DrawVolume);

    // A floor point: the first pixel along the middle row whose ray (from the cut plane, as
    // the artist sees it) meets an upward-facing surface in the lowest half metre of the scene.
    const Bounds3 bounds = doc->scene()->bounds;
    QPointF from;
    std::optional<Hit> hit;
    PickRay r0;
    for (int x = 100; x < 700 && !hit; x += 10) {
      from = QPointF(x, 330);
      r0 = vp->surfaceRay(from);
      hit = doc->tracer()->intersect(Ray{toV(r0.origin), toV(r0.direction), 0.0});
      if (hit && !(hit->geometricNormal.y > 0.9 &&
                   toV(r0.origin).y + toV(r0.direction).y * hit->t < bounds.lo.y + 0.5))
        hit.reset();
    }
    QVERIFY(hit);
    const QPointF to = from + QPointF(70, 40);
    const PickRay r1 = vp->pickRay(to);
    const Vec3 a = toV(r0.origin) + toV(r0.direction) * hit->t;
    const double t1 = (a.y - r1.origin.y()) / r1.direction.y();
    QVERIFY(t1 > 0);
    const Vec3 b = toV(r1.origin) + toV(r1.direction) * t1;

    // A click draws nothing.
    send(vp, QEvent::MouseButtonPress, from, Qt::LeftButton, Qt::LeftButton);
    send(vp, QEvent::MouseButtonRelease, from, Qt::LeftButton, Qt::NoButton);
    QVERIFY(doc->probeSet().importanceVolumes.empty());

    drag(vp, from, to);
    QCOMPARE(doc->probeSet().importanceVolumes.size(), size_t(1));
    const ImportanceVolume& v = doc->probeSet().importanceVolumes[0];
    QVERIFY(std::abs(v.lo.x - std::min(a.x, b.x)) < 1e-3 &&
            std::abs(v.hi.x - std::max(a.x, b.x)) < 1e-3);
    QVERIFY(std::abs(v.lo.z - std::min(a.z, b.z)) < 1e-3 &&
            std::abs(v.hi.z - std::max(a.z, b.z)) < 1e-3);
    QVERIFY(std::abs(v.lo.y - a.y) < 1e-3);
    QCOMPARE(v.hi.y, doc->scene()->bounds.hi.y);
    QCOMPARE(v.weight, 2.0);
    QCOMPARE(doc->undoStack()->count(), 1);
    doc->undoStack()->undo();
    QVERIFY(doc->probeSet().importanceVolumes.empty());

    // Leaving the tool selects again.
    tool->setChecked(false);
    QCOMPARE(vp->tool(), Viewport::Tool::Select);
  }

  void inspectorEditsThePositionAndShowsTheSh() {
    MainWindow w;
    quiet(w);
    Document* doc = w.document();
    QVERIFY(w.openScene(kScene));
    Probe p;
    p.position = Vec3(0.25, 1.5, -0.5);
    p.method = "uniform";
    p.score = 2.5;
    p.sh = lightFromAbove();
    const uint64_t id = doc->addProbes({p}, "Add").at(0);
    InspectorPanel* in = w.inspector();
    in->setSelection({id});
    QCOMPARE(in->positionField(1)->value(), 1.5);
    QCOMPARE(in->provenanceLabel()->text(), QStringLiteral("uniform"));
    QCOMPARE(in->scoreLabel()->text(), QStringLiteral("2.5"));
    // The irradiance sphere: lit from above, its top is brighter than its bottom.
    const QImage img = in->sphereLabel()->pixmap().toImage();
    QVERIFY(!img.isNull());
    const int s = img.width();
    QVERIFY(qGray(img.pixel(s / 2, s / 8)) > qGray(img.pixel(s / 2, s - s / 8)) + 40);
    QCOMPARE(qAlpha(img.pixel(0, 0)), 0);  // outside the disc

    const int steps = doc->undoStack()->count();
    in->positionField(0)->setValue(1.0);
    in->positionField(2)->setValue(2.0);
    QCOMPARE(doc->probe(id)->position, Vec3(1.0, 1.5, 2.0));
    QCOMPARE(doc->undoStack()->count(), steps + 2);  // each numeric edit is a step
    doc->undoStack()->undo();
    QCOMPARE(in->positionField(2)->value(), -0.5);  // the inspector follows undo

    // Several probes: the fields show their centre; an edit moves them together, one step.
    {
      Probe q;
      q.position = Vec3(1.0, 0.5, 0.0);
      const uint64_t id2 = doc->addProbes({q}, "Add").at(0);
      const Vec3 a = doc->probe(id)->position, b = doc->probe(id2)->position;
      in->setSelection({id, id2});
      QCOMPARE(in->positionField(1)->value(), 0.5 * (a.y + b.y));
      const int n = doc->undoStack()->index();
      in->positionField(1)->setValue(0.5 * (a.y + b.y) + 1.0);
      QCOMPARE(doc->undoStack()->index(), n + 1);
      QVERIFY(length(doc->probe(id)->position - (a + Vec3(0, 1, 0))) < 1e-9);
      QVERIFY(length(doc->probe(id2)->position - (b + Vec3(0, 1, 0))) < 1e-9);
      doc->undoStack()->undo();
      doc->undoStack()->undo();
      in->setSelection({id});
    }

    // Lock from the inspector: fields disabled, undoable, shown in the probe list.
    in->lockBox()->click();
    QVERIFY(doc->probe(id)->locked);
    {
      QAbstractItemModel* m = w.probeTable()->model();
      bool shown = false;
      for (int r = 0; r < m->rowCount(); ++r)
        if (m->index(r, ProbeTableModel::Id).data(ProbeTableModel::ProbeIdRole).toULongLong() == id)
          shown = m->index(r, ProbeTableModel::Locked).data().toString() == "locked";
      QVERIFY(shown);
    }
    QVERIFY(!in->positionField(0)->isEnabled());
    doc->undoStack()->undo();
    QVERIFY(!doc->probe(id)->locked);
    QVERIFY(in->positionField(0)->isEnabled());
  }

  void irradianceSphereOfAConstantEnvironmentIsUniform() {
    // Constant radiance L: E(n) = pi L for every normal, so every disc pixel is the same.
    ShRgb sh;
    sh.c[0] = Rgb(1, 1, 1) * (1.0 / 0.282095);  // L = 1
    const QImage img = renderIrradianceSphere(sh, 32, 0.5);
    QRgb first = 0;
    bool any = false;
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 32; ++x) {
        const QRgb c = img.pixel(x, y);
        if (qAlpha(c) == 0) continue;
        if (!any) first = c, any = true;
        QCOMPARE(c, first);
      }
    QVERIFY(any);
  }

  void previewVolumeFollowsEditsInPlace() {
    // The preview volume follows the document by local edits (EditableProbeVolume), not
    // rebuilds: a drag step (the moved probe loses its capture, so it leaves the preview), a
    // rejection, and each reports its time; the result is always the volume a rebuild gives.
    MainWindow w;
    quiet(w);
    Document* doc = w.document();
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    vp->resize(900, 700);
    const std::vector<Probe> ps =
        jitteredGrid(doc->scene()->bounds, 5, 3, 4, 5, [](int i, int, int k) {
          ShRgb sh;
          sh.c[0] = Rgb(1, 1, 1) * (1 + i + 2 * k);
          return sh;
        });
    const std::vector<uint64_t> ids = doc->addProbes(ps, "Add");
    vp->frameAll();
    vp->setOverlay(Viewport::Overlay::TestObject, true);
    QVERIFY(vp->previewVolume().has_value());

    // The same tets (by vertex positions) and the same light at the test object as a rebuild.
    auto tetKeys = [](const ProbeVolume& v) {
      std::vector<std::array<std::array<float, 3>, 4>> keys;
      for (const auto& t : v.tets) {
        std::array<std::array<float, 3>, 4> k;
        for (size_t i = 0; i < 4; ++i)
          for (size_t a = 0; a < 3; ++a) k[i][a] = v.positions[3 * size_t(t[i]) + a];
        std::sort(k.begin(), k.end());
        keys.push_back(k);
      }
      std::sort(keys.begin(), keys.end());
      return keys;
    };
    auto sameAsRebuild = [&](const ProbeVolume& live) {
      const auto rebuilt = buildPreviewVolume(doc->probes(), vp->previewSource());
      if (!rebuilt || live.probeCount() != rebuilt->probeCount()) return false;
      if (tetKeys(live) != tetKeys(*rebuilt)) return false;
      const Vec3 q = vp->testObjectPosition();
      const ShRgb x = interpolate(live, locate(live, q));
      const ShRgb y = interpolate(*rebuilt, locate(*rebuilt, q));
      return std::abs(x.c[0].r - y.c[0].r) < 1e-5;
    };
    QSignalSpy edited(vp, &Viewport::previewVolumeEdited);
    auto editsSince = [&](int from, double& seconds, qsizetype& tets) {
      seconds = 0;
      tets = 0;
      for (int i = from; i < edited.count(); ++i) {
        seconds += edited.at(i).at(0).toDouble();
        tets += edited.at(i).at(1).value<qsizetype>();
      }
      return edited.count() - from;
    };

    // A drag: the first step takes the probe out of the preview, in place.
    const uint64_t id = ids.at(27);  // an inner probe (i = 2, j = 0, k = 3)
    vp->setSelection({id});
    const QVector3D o = *vp->handleOrigin();
    const QPointF from =
        toPoint(vp->project(toV(o + QVector3D(vp->handleArmMeters() * 0.6f, 0, 0))));
    QCOMPARE(vp->handlePartAt(from), HandlePart::AxisX);
    const Vec3 start = doc->probe(id)->position;
    drag(vp, from, from + QPointF(90, 0));
    QVERIFY(length(doc->probe(id)->position - start) > 0.05);
    QVERIFY(!doc->probe(id)->sh);  // its capture is stale now
    double seconds = 0;
    qsizetype tets = 0;
    QCOMPARE(editsSince(0, seconds, tets), 1);
    QVERIFY(seconds > 0);
    QVERIFY(tets > 0);
    const ProbeVolume* live = vp->drawnPreviewVolume();
    QVERIFY(live);
    QCOMPARE(live->probeCount(), size_t(59));
    QVERIFY(sameAsRebuild(*live));
    // The next fields take the edited volume (no further edit), and replace it as drawn.
    const auto& fresh = vp->previewVolume();
    QVERIFY(fresh.has_value());
    QCOMPARE(vp->drawnPreviewVolume(), &*fresh);
    QCOMPARE(edited.count(), 1);
    QVERIFY(sameAsRebuild(*fresh));

    // Rejecting two probes removes them in place; undo puts them back in place.
    doc->setStates({ids.at(5), ids.at(40)}, ProbeState::Rejected);
    QVERIFY(vp->previewVolume().has_value());
    QCOMPARE(editsSince(1, seconds, tets), 1);
    QVERIFY(tets > 0);
    QCOMPARE(vp->previewVolume()->probeCount(), size_t(57));
    QVERIFY(sameAsRebuild(*vp->previewVolume()));
    doc->undoStack()->undo();
    QCOMPARE(vp->previewVolume()->probeCount(), size_t(59));
    QCOMPARE(editsSince(2, seconds, tets), 1);
    QVERIFY(sameAsRebuild(*vp->previewVolume()));
  }

  void overlaysToggleFromTheMenuAndTheTestObjectDrags() {
    MainWindow w;
    quiet(w);
    Document* doc = w.document();
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    vp->resize(800, 600);
    // Captured probes on a jittered grid through both rooms.
    const Bounds3 b = doc->scene()->bounds;
    const std::vector<Probe> ps = jitteredGrid(b, 6, 3, 4, 4, [](int i, int, int) {
      ShRgb sh;
      sh.c[0] = Rgb(1, 1, 1) * (1 + i);  // brighter towards +X
      sh.c[3] = Rgb(1, 1, 1) * 0.5;      // light from +X
      return sh;
    });
    doc->addProbes(ps, "Add");
    vp->frameAll();
    // Each overlay has a checkable action in the View menu (and the toolbar).
    const struct {
      const char* text;
      Viewport::Overlay overlay;
    } toggles[] = {{"&Gradient glyphs", Viewport::Overlay::Glyphs},
                   {"&Slice plane", Viewport::Overlay::Slice},
                   {"&Tetrahedral mesh", Viewport::Overlay::TetMesh},
                   {"Test &object", Viewport::Overlay::TestObject}};
    for (const auto& t : toggles) {
      QAction* action = nullptr;
      for (QAction* a : w.findChildren<QAction*>())
        if (a->text() == QLatin1String(t.text)) action = a;
      QVERIFY2(action, t.text);
      QVERIFY(!vp->overlay(t.overlay));
      action->trigger();
      QVERIFY(vp->overlay(t.overlay));
    }
    // The glyphs point along f: towards +X here.
    const ShGrid& g = vp->glyphGrid();
    QVERIFY(g.size() > 100);
    for (size_t i = 0; i < g.size(); i += 13) QVERIFY(luminanceDirection(g.sh[i]).x > 0);
    QVERIFY(vp->previewVolume().has_value());
    QCOMPARE(vp->glyphSamples().size(), g.size());
    // Over the probes instead: one per captured probe, f of its own SH.
    vp->setGlyphsAtProbes(true);
    const auto atProbes = vp->glyphSamples();
    QCOMPARE(atProbes.size(), doc->probes().size());
    for (size_t i = 0; i < atProbes.size(); ++i) {
      QCOMPARE(atProbes[i].centre, doc->probes()[i].position);
      QCOMPARE(atProbes[i].f, luminanceDirection(*doc->probes()[i].sh));
    }
    vp->setGlyphsAtProbes(false);

    // The slice across Y: luminance distance to a selected probe on the dark (-X) side is ~0
    // there and grows towards +X (brightness rises 6x across the scene); the error slice is
    // zero when the preview is the reference itself (all captured probes).
    {
      uint64_t darkest = 0;
      double darkX = 1e30;
      for (const Probe& p : doc->probes())
        if (p.position.x < darkX) darkX = p.position.x, darkest = p.id;
      vp->setSelection({darkest});
      vp->setSliceAxis(1);
      vp->setSliceFraction(0.5f);
      const QImage lum = vp->renderSliceImage(64);
      auto blueness = [](QRgb c) { return qBlue(c) - qRed(c); };
      // Across Y the slice's u runs along Z and v (image rows) along X.
      QVERIFY(blueness(lum.pixel(32, 1)) > 100);    // v = 0: the -X side
      QVERIFY(blueness(lum.pixel(32, 62)) < -100);  // v = 1: the +X side, > 2.5 stops brighter
      QVERIFY(qAlpha(lum.pixel(32, 32)) > 0);
      vp->setSliceMode(Viewport::SliceMode::Error);
      const QImage err = vp->renderSliceImage(32);
      for (int y = 0; y < 32; y += 5)
        for (int x = 0; x < 32; x += 5) {
          QCOMPARE(err.pixel(x, y), err.pixel(0, 0));
          QVERIFY(blueness(err.pixel(x, y)) > 100);  // zero error
        }
      vp->setSliceMode(Viewport::SliceMode::LuminanceDistance);
      vp->setSelection({});
    }

    // A background rebuild after an edit: the old fields stay until the new ones arrive.
    QSignalSpy updated(vp, &Viewport::fieldsUpdated);
    const size_t before = vp->previewVolume()->probeCount();
    Probe extra;
    extra.position = b.center() + Vec3(0.1, 0.05, 0.02);
    extra.sh = ShRgb();
    doc->addProbes({extra}, "Add");
    vp->startFieldsRebuild();
    QVERIFY(vp->hasPreviewVolume());  // still the previous one
    QVERIFY(updated.wait(20000));
    QCOMPARE(vp->previewVolume()->probeCount(), before + 1);
    // Taken synchronously while the signal is still queued: applied once, not emptied later.
    doc->undoStack()->undo();
    vp->startFieldsRebuild();
    QVERIFY(vp->isFieldsRebuildRunning());
    QCOMPARE(vp->previewVolume()->probeCount(), before);
    const size_t cells = vp->glyphGrid().size();
    QVERIFY(cells > 100);
    updated.clear();
    // Once the rebuild's finished signal has reached the view, nothing more was applied.
    QTRY_VERIFY_WITH_TIMEOUT(!vp->isFieldsRebuildRunning(), 60000);
    QCOMPARE(updated.count(), 0);
    QCOMPARE(vp->glyphGrid().size(), cells);
    QCOMPARE(vp->previewVolume()->probeCount(), before);
    doc->undoStack()->redo();
    doc->undoStack()->undo();

    // Drag the test object; its tetrahedron contains it.
    const Vec3 start = vp->testObjectPosition();
    const QPointF at = toPoint(vp->project(start));
    drag(vp, at, at + QPointF(80, 0));
    const Vec3 moved = vp->testObjectPosition();
    QVERIFY(length(moved - start) > 0.05);
    QVERIFY(std::abs(dot(moved - start, toV(vp->camera().backward()))) < 1e-4);  // in view plane
    const int32_t tet = vp->testObjectTet();
    QVERIFY(tet >= 0);
    const VolumeLocation loc = locate(*vp->previewVolume(), moved, tet);
    QCOMPARE(loc.tet, tet);
    QVERIFY(!loc.outside);
    QCOMPARE(doc->undoStack()->index(), 1);  // a view gadget, not an edit
  }

  void probesInsideGeometryAreMarkedInvalid() {
    MainWindow w;
    quiet(w);
    QVERIFY(w.openScene(kScene));
    const Bounds3 b = w.document()->scene()->bounds;
    Probe inside, below;
    // In room A, mid-height: sees only front faces.
    inside.position = Vec3(b.lo.x + 0.2 * b.extent().x, b.lo.y + 0.5 * b.extent().y, b.center().z);
    // Inside the floor slab (a closed box 0.2 m thick from the bounds' bottom): every ray
    // meets its inner, back faces.
    below.position = Vec3(inside.position.x, b.lo.y + 0.1, inside.position.z + 1.0);
    w.document()->addProbes({inside, below}, "Add");
    const auto& ps = w.document()->probes();
    QVERIFY(!w.viewport()->isInvalid(ps[0]));
    QVERIFY(w.viewport()->isInvalid(ps[1]));
    // Moving it into the room makes it valid (the cache follows the position).
    w.document()->moveProbe(ps[1].id, inside.position + Vec3(0.3, 0, 0));
    QVERIFY(!w.viewport()->isInvalid(w.document()->probes()[1]));
  }

  void everyShortcutIsUnique() {
    MainWindow w;
    QMap<QString, QString> seen;
    for (QAction* a : w.findChildren<QAction*>())
      for (const QKeySequence& k : a->shortcuts()) {
        const QString key = k.toString();
        QVERIFY2(!seen.contains(key),
                 qPrintable(key + ": " + seen.value(key) + " and " + a->text()));
        seen.insert(key, a->text());
      }
    QVERIFY(seen.size() > 30);
  }

  void arrowKeysNudgeTheSelectionInTheView() {
    MainWindow w;
    quiet(w);
    Document* doc = w.document();
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    vp->resize(800, 600);
    vp->frameAll();
    Probe p;
    p.position = doc->scene()->bounds.center();
    const std::vector<uint64_t> ids = doc->addProbes({p, p}, "Add");
    doc->setLocked({ids[1]}, true);
    vp->setSelection({ids[0], ids[1]});
    const Vec3 start = doc->probe(ids[0])->position;
    const QVector3D right = vp->camera().right();
    const Vec3 level = normalize(Vec3(right.x(), 0, right.z()));
    auto press = [&](int key, Qt::KeyboardModifiers mods = Qt::NoModifier) {
      QKeyEvent e(QEvent::KeyPress, key, mods);
      QCoreApplication::sendEvent(vp, &e);
    };
    // Right: along the camera's right on the floor, one undo step; the locked probe stays.
    const int steps = doc->undoStack()->count();
    press(Qt::Key_Right);
    QCOMPARE(doc->undoStack()->count(), steps + 1);
    const Vec3 moved = doc->probe(ids[0])->position - start;
    QVERIFY(length(moved - level * Viewport::kNudgeMeters) < 1e-6);  // float steps
    QCOMPARE(doc->probe(ids[1])->position, start);
    // Up is level too (away from the camera); Shift+Up raises it.
    press(Qt::Key_Up);
    QCOMPARE(doc->probe(ids[0])->position.y, start.y);
    press(Qt::Key_Up, Qt::ShiftModifier);
    QVERIFY(std::abs(doc->probe(ids[0])->position.y - (start.y + Viewport::kNudgeMeters)) < 1e-6);
    QCOMPARE(doc->undoStack()->count(), steps + 3);
    for (int i = 0; i < 3; ++i) doc->undoStack()->undo();
    QCOMPARE(doc->probe(ids[0])->position, start);
    // Nothing movable selected: the keys move nothing.
    vp->setSelection({ids[1]});
    press(Qt::Key_Left);
    QCOMPARE(doc->undoStack()->index(), steps);
    QCOMPARE(doc->undoStack()->count(), steps + 3);
  }

  void testObjectAndDomainOverlaysHaveLegends() {
    MainWindow w;
    quiet(w);
    Document* doc = w.document();
    doc->setAutoPropose(false);
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    auto titles = [&] {
      QStringList out;
      for (const Viewport::Legend& l : vp->legends()) out << l.title;
      return out.join(" | ");
    };
    vp->setOverlay(Viewport::Overlay::Domain, true);
    QVERIFY2(titles().contains("Domain of interest: the space a player can reach"),
             qPrintable(titles()));
    // The test object needs a preview volume: captured probes that span the scene.
    std::vector<Probe> probes;
    const Bounds3 b = doc->scene()->bounds;
    for (int i = 0; i < 8; ++i) {
      Probe p;
      const Vec3 e = b.hi - b.lo;
      p.position = b.lo + Vec3(e.x * (i & 1 ? 0.7 : 0.3), e.y * (i & 2 ? 0.7 : 0.3),
                               e.z * (i & 4 ? 0.7 : 0.3));
      p.state = ProbeState::Accepted;
      probes.push_back(p);
    }
    doc->addProbes(probes, "Add");
    QVERIFY(doc->recapture(8));
    QSignalSpy done(doc, &Document::jobFinished);
    QVERIFY(done.wait(60000));
    vp->setOverlay(Viewport::Overlay::TestObject, true);
    (void)vp->previewVolume();
    QVERIFY2(titles().contains("Test object"), qPrintable(titles()));
  }

  void wasdFliesWhileTheRightButtonIsHeld() {
    MainWindow w;
    quiet(w);
    QVERIFY(w.openScene(kScene));
    Viewport* vp = w.viewport();
    vp->resize(800, 600);
    vp->frameAll();
    const QVector3D eye0 = vp->camera().eye(), fwd = -vp->camera().backward();
    // Without the right button W is not a fly key (A, R are the window's shortcuts).
    QKeyEvent w0(QEvent::KeyPress, Qt::Key_W, Qt::NoModifier, "w");
    QCoreApplication::sendEvent(vp, &w0);
    QVERIFY(!vp->flyStep(0.5f));
    send(vp, QEvent::MouseButtonPress, QPointF(400, 300), Qt::RightButton, Qt::RightButton);
    QKeyEvent over(QEvent::ShortcutOverride, Qt::Key_A, Qt::NoModifier, "a");
    QCoreApplication::sendEvent(vp, &over);
    QVERIFY(over.isAccepted());  // A flies instead of accepting probes
    QKeyEvent press(QEvent::KeyPress, Qt::Key_W, Qt::NoModifier, "w");
    QCoreApplication::sendEvent(vp, &press);
    QVERIFY(vp->flyStep(0.5f));
    const QVector3D moved = vp->camera().eye() - eye0;
    QVERIFY(std::abs(moved.length() - vp->flySpeed() * 0.5f) < 1e-3f * vp->flySpeed());
    QVERIFY(QVector3D::dotProduct(moved.normalized(), fwd) > 0.9999f);
    // Releasing the button stops flying.
    send(vp, QEvent::MouseButtonRelease, QPointF(400, 300), Qt::RightButton, Qt::NoButton);
    QVERIFY(!vp->flyStep(0.5f));
  }
};

QTEST_MAIN(TestEditing)
#include "test_editing.moc"
