#include "ui/Viewport.h"

// The viewport's input: mouse (orbit, pan, select, box select, drag the move handle, the test
// object, the sun, the slice, draw a volume, add a probe), wheel, and keys (fly).

#include <QGuiApplication>
#include <QKeyEvent>
#include <QMouseEvent>
#include <QRubberBand>
#include <QTimer>
#include <QWheelEvent>
#include <algorithm>
#include <cmath>

#include "core/scene/Scene.h"
#include "ui/Document.h"

namespace ps::ui {

// ---------------------------------------------------------------- mouse

void Viewport::mousePressEvent(QMouseEvent* e) {
  pressPos_ = lastPos_ = e->position();
  pressButton_ = e->button();
  dragged_ = false;
  drag_ = Drag::None;
  if (e->button() == Qt::RightButton) {
    drag_ = Drag::Look;
    return;
  }
  if (e->button() != Qt::LeftButton) {
    drag_ = Drag::Camera;
    return;
  }
  if (tool_ == Tool::Select) {
    const HandlePart part = handlePartAt(e->position());
    if (part != HandlePart::None) {
      drag_ = Drag::Handle;
      dragPart_ = part;
      dragOrigin_ = *handleOrigin();
      dragStartRay_ = pickRay(e->position());
      dragStart_.clear();
      for (const Probe& p : doc_->probes())
        if (selection_.contains(p.id) && !p.locked) dragStart_.emplace_back(p.id, p.position);
      dragKey_ = doc_->newMergeKey();
      update();
      return;
    }
  }
  if (tool_ == Tool::Select) {
    // The rig's sun: drag it over its sphere around the scene.
    if (const auto sun = sunGizmoPosition()) {
      const auto px = project(*sun);
      if (px && QLineF(*px, e->position()).length() <= kSunDiscPx + 4) {
        drag_ = Drag::Sun;
        sunDragTowards_ = normalize(*sun - sunGizmoCentre());
        update();
        return;
      }
    }
    // The slice's outline: drag the plane along its axis.
    if (onSliceOutline(e->position())) {
      drag_ = Drag::Slice;
      sliceDragStart_ = sliceFraction_;
      dragStartRay_ = pickRay(e->position());
      const auto c = sliceCorners();
      // The axis line through the plane's centre: the drag follows the point of it nearest
      // the cursor's ray.
      const Vec3 mid = (c[0] + c[2]) * 0.5;
      dragOrigin_ = toQ(mid);
      update();
      return;
    }
  }
  if (tool_ == Tool::Select && overlay(Overlay::TestObject) && drawnPreviewVolume()) {
    // Press on the test object: drag it in the plane facing the camera.
    const PickRay ray = pickRay(e->position());
    const QVector3D oc = ray.origin - toQ(testObject_);
    const float b = QVector3D::dotProduct(oc, ray.direction);
    const float c = QVector3D::dotProduct(oc, oc) - testObjectRadius() * testObjectRadius();
    if (b * b - c >= 0 && -b > 0) {
      drag_ = Drag::TestObject;
      testDragStart_ = testObject_;
      dragStartRay_ = ray;
      return;
    }
  }
  if (tool_ == Tool::DrawVolume && doc_->tracer()) {
    const PickRay ray = surfaceRay(e->position());
    const Vec3 o(ray.origin.x(), ray.origin.y(), ray.origin.z());
    const Vec3 d(ray.direction.x(), ray.direction.y(), ray.direction.z());
    if (const auto hit = doc_->tracer()->intersect(Ray{o, d, 0.0})) {
      drag_ = Drag::Volume;
      volumeStart_ = volumeEnd_ = o + d * hit->t;
      return;
    }
  }
  drag_ = (e->modifiers() & Qt::ControlModifier) ? Drag::Box : Drag::Camera;
}

Bounds3 Viewport::drawnVolume() const {
  Bounds3 box;
  box.extend(volumeStart_);
  box.extend(Vec3(volumeEnd_.x, volumeStart_.y, volumeEnd_.z));
  const double top = doc_->scene() ? doc_->scene()->bounds.hi.y : volumeStart_.y;
  box.hi.y = std::max(top, volumeStart_.y + 0.5);
  return box;
}

void Viewport::mouseMoveEvent(QMouseEvent* e) {
  const QPointF d = e->position() - lastPos_;
  lastPos_ = e->position();
  if ((e->position() - pressPos_).manhattanLength() > 3) dragged_ = true;
  if (!dragged_ || e->buttons() == Qt::NoButton) return;
  switch (drag_) {
    case Drag::Handle: {
      const auto delta = dragDelta(dragPart_, dragOrigin_, dragStartRay_, pickRay(e->position()));
      if (!delta) return;
      const Vec3 dv(delta->x(), delta->y(), delta->z());
      std::vector<std::pair<uint64_t, Vec3>> targets;
      targets.reserve(dragStart_.size());
      for (const auto& [id, from] : dragStart_) targets.emplace_back(id, from + dv);
      doc_->moveProbes(targets, dragKey_);  // merges: the whole drag is one undo step
      // The test object follows the drag in the preview volume, edited in place.
      if (overlay(Overlay::TestObject)) {
        syncMirror();
        mirrorAhead_ = true;
      }
      return;
    }
    case Drag::Sun: {
      const Vec3 c = sunGizmoCentre();
      const Vec3 near = c + *sunDragTowards_ * sunGizmoDistance();
      sunDragTowards_ = normalize(sunSpherePoint(pickRay(e->position()), near) - c);
      update();
      return;
    }
    case Drag::Slice: {
      const HandlePart axis = sliceAxis_ == 0   ? HandlePart::AxisX
                              : sliceAxis_ == 1 ? HandlePart::AxisY
                                                : HandlePart::AxisZ;
      const auto delta = dragDelta(axis, dragOrigin_, dragStartRay_, pickRay(e->position()));
      const Scene* scene = doc_->scene();
      if (!delta || !scene || scene->bounds.empty()) return;
      const double extent = std::max(scene->bounds.extent()[sliceAxis_], 1e-9);
      setSliceFraction(sliceDragStart_ + float((*delta)[sliceAxis_] / extent));
      return;
    }
    case Drag::Box: {
      if (!rubberBand_) rubberBand_ = new QRubberBand(QRubberBand::Rectangle, this);
      rubberBand_->setGeometry(QRectF(pressPos_, e->position()).normalized().toRect());
      rubberBand_->show();
      return;
    }
    case Drag::TestObject: {
      // Both rays meet the plane through the start position facing the camera.
      const QVector3D n = camera_.backward(), o = toQ(testDragStart_);
      auto hit = [&](const PickRay& r) -> std::optional<QVector3D> {
        const float dn = QVector3D::dotProduct(r.direction, n);
        if (std::abs(dn) < 1e-6f) return std::nullopt;
        return r.origin + r.direction * (QVector3D::dotProduct(o - r.origin, n) / dn);
      };
      const auto a = hit(dragStartRay_), b = hit(pickRay(e->position()));
      if (a && b) {
        const QVector3D moved = *b - *a;
        setTestObjectPosition(testDragStart_ + Vec3(moved.x(), moved.y(), moved.z()));
      }
      return;
    }
    case Drag::Volume: {
      // The cursor's ray meets the horizontal plane through the point pressed.
      const PickRay r = pickRay(e->position());
      if (std::abs(r.direction.y()) < 1e-6f) return;
      const float t = (float(volumeStart_.y) - r.origin.y()) / r.direction.y();
      if (t <= 0) return;
      const QVector3D p = r.origin + r.direction * t;
      volumeEnd_ = Vec3(p.x(), volumeStart_.y, p.z());
      update();
      return;
    }
    case Drag::Look:
      camera_.lookAround(float(d.x()), float(d.y()));
      update();
      return;
    case Drag::Camera: {
      const bool panning =
          (e->buttons() & Qt::MiddleButton) ||
          ((e->buttons() & Qt::LeftButton) && (e->modifiers() & Qt::ShiftModifier));
      if (panning)
        camera_.pan(float(d.x()), float(d.y()), float(height()));
      else if (e->buttons() & Qt::LeftButton)
        camera_.orbit(float(d.x()), float(d.y()));
      else
        return;
      update();
      return;
    }
    case Drag::None:
      return;
  }
}

void Viewport::mouseReleaseEvent(QMouseEvent* e) {
  const Drag drag = drag_;
  if (e->button() == pressButton_) drag_ = Drag::None;
  if (drag == Drag::Look) {
    flyKeys_ = 0;
    flyTimer_->stop();
  }
  if (drag == Drag::Box) {
    if (rubberBand_) rubberBand_->hide();
    if (dragged_) {
      emit boxSelected(probesInRect(QRectF(pressPos_, e->position()).normalized()), e->modifiers());
      pressButton_ = Qt::NoButton;
      return;
    }
  }
  if (drag == Drag::Volume) {
    pressButton_ = Qt::NoButton;
    const Bounds3 box = drawnVolume();
    update();
    // A click or a sliver (under 5 cm across) draws nothing.
    if (dragged_ && box.extent().x >= 0.05 && box.extent().z >= 0.05) emit volumeDrawn(box);
    return;
  }
  if (drag == Drag::Handle) {
    dragKey_ = -1;
    update();
  }
  if (drag == Drag::Sun) {
    const std::optional<Vec3> towards = sunDragTowards_;
    sunDragTowards_.reset();
    pressButton_ = Qt::NoButton;
    update();
    if (!dragged_ || !towards) return;
    // One undo step, as the Lighting tab's sun edit: the rig's first directional light turns.
    LightingRig rig = doc_->probeSet().rig;
    for (Light& l : rig.lights)
      if (l.type == LightType::Directional && length(l.direction) > 0) {
        l.direction = -*towards;
        break;
      }
    doc_->setRig(rig, tr("Move sun"));
    return;
  }
  if (drag == Drag::Slice) {
    pressButton_ = Qt::NoButton;
    update();
    return;
  }
  if (e->button() == Qt::LeftButton && pressButton_ == Qt::LeftButton && !dragged_ &&
      drag != Drag::Handle) {
    if (tool_ == Tool::AddProbe)
      emit addProbeRequested(surfaceRay(e->position()));
    else
      emit probeClicked(pickProbe(e->position()), e->modifiers());
  }
  pressButton_ = Qt::NoButton;
}

void Viewport::wheelEvent(QWheelEvent* e) {
  camera_.zoom(float(e->angleDelta().y()) / 120.0f);
  update();
}

// ---------------------------------------------------------------- fly (WASD)

namespace {
constexpr int kFlyKeys[] = {Qt::Key_W, Qt::Key_A, Qt::Key_S, Qt::Key_D, Qt::Key_Q, Qt::Key_E};
int flyBit(int key) {
  for (int i = 0; i < 6; ++i)
    if (kFlyKeys[i] == key) return 1 << i;
  return 0;
}
}  // namespace

bool Viewport::isFlyKey(int key) const {
  return drag_ == Drag::Look && flyBit(key) != 0;
}

float Viewport::flySpeed() const {
  const Scene* scene = doc_->scene();
  return scene && !scene->bounds.empty() ? float(scene->bounds.diagonal()) / 3.0f : 2.0f;
}

void Viewport::setFlyKey(int key, bool down) {
  const int bit = flyBit(key);
  if (down)
    flyKeys_ |= unsigned(bit);
  else
    flyKeys_ &= ~unsigned(bit);
  if (flyKeys_ && !flyTimer_->isActive()) flyTimer_->start();
  if (!flyKeys_) flyTimer_->stop();
}

bool Viewport::flyStep(float seconds) {
  const auto held = [this](int key) { return (flyKeys_ & unsigned(flyBit(key))) ? 1.0f : 0.0f; };
  const float forward = held(Qt::Key_W) - held(Qt::Key_S);
  const float right = held(Qt::Key_D) - held(Qt::Key_A);
  const float up = held(Qt::Key_E) - held(Qt::Key_Q);
  if (forward == 0 && right == 0 && up == 0) return false;
  const float boost = (QGuiApplication::queryKeyboardModifiers() & Qt::ShiftModifier) ? 3.0f : 1.0f;
  const float step = flySpeed() * boost * seconds;
  camera_.fly(right * step, up * step, forward * step);
  return true;
}

bool Viewport::event(QEvent* e) {
  // While flying, W A S D Q E belong to the viewport, not to the window's shortcuts (A accepts).
  if (e->type() == QEvent::ShortcutOverride) {
    auto* k = static_cast<QKeyEvent*>(e);
    if (isFlyKey(k->key())) {
      e->accept();
      return true;
    }
  }
  return QOpenGLWidget::event(e);
}

bool Viewport::nudgeSelection(int key, Qt::KeyboardModifiers modifiers) {
  // Up and Down move away from and towards the camera along the floor (Shift: up and down),
  // Left and Right along the camera's right, both level whatever the camera's pitch.
  QVector3D away(-camera_.backward().x(), 0, -camera_.backward().z());
  if (away.lengthSquared() < 1e-6f) away = QVector3D(camera_.up().x(), 0, camera_.up().z());
  const QVector3D right = QVector3D(camera_.right().x(), 0, camera_.right().z()).normalized();
  const bool vertical = modifiers & Qt::ShiftModifier;
  QVector3D step;
  if (key == Qt::Key_Left) step = -right;
  if (key == Qt::Key_Right) step = right;
  if (key == Qt::Key_Up) step = vertical ? QVector3D(0, 1, 0) : away.normalized();
  if (key == Qt::Key_Down) step = vertical ? QVector3D(0, -1, 0) : -away.normalized();
  if (step.isNull()) return false;
  step *= float(kNudgeMeters);
  std::vector<std::pair<uint64_t, Vec3>> targets;
  for (quint64 id : selection_)
    if (const Probe* p = doc_->probe(id); p && !p->locked)
      targets.emplace_back(id, p->position + Vec3(step.x(), step.y(), step.z()));
  if (targets.empty()) return false;
  doc_->moveProbes(targets, doc_->newMergeKey());  // one undo step per press
  return true;
}

void Viewport::keyPressEvent(QKeyEvent* e) {
  if (isFlyKey(e->key())) {
    if (!e->isAutoRepeat()) setFlyKey(e->key(), true);
    return;
  }
  if (!(e->modifiers() & (Qt::ControlModifier | Qt::AltModifier)) &&
      nudgeSelection(e->key(), e->modifiers()))
    return;
  QOpenGLWidget::keyPressEvent(e);
}

void Viewport::keyReleaseEvent(QKeyEvent* e) {
  if (flyBit(e->key())) {
    if (!e->isAutoRepeat()) setFlyKey(e->key(), false);
    return;
  }
  QOpenGLWidget::keyReleaseEvent(e);
}

void Viewport::focusOutEvent(QFocusEvent* e) {
  flyKeys_ = 0;
  flyTimer_->stop();
  QOpenGLWidget::focusOutEvent(e);
}

}  // namespace ps::ui
