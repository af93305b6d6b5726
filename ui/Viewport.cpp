#include "ui/Viewport.h"

// The viewport as a widget: its state, the camera, framing, projection and picking. Drawing
// is in ViewportGL.cpp, mouse and keys in ViewportInput.cpp, the lighting preview and the
// overlays in ViewportOverlays.cpp.

#include <QOpenGLContext>
#include <QTimer>
#include <algorithm>
#include <cmath>

#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"
#include "ui/Document.h"

namespace ps::ui {

QSurfaceFormat Viewport::surfaceFormat() {
  QSurfaceFormat f;
  f.setRenderableType(QSurfaceFormat::OpenGL);
  f.setVersion(3, 3);
  f.setProfile(QSurfaceFormat::CoreProfile);
  f.setDepthBufferSize(24);
  // 4x MSAA; PS_VIEWPORT_MSAA overrides (0 turns it off, e.g. for software OpenGL).
  bool ok = false;
  const int samples = qEnvironmentVariableIntValue("PS_VIEWPORT_MSAA", &ok);
  f.setSamples(ok ? std::clamp(samples, 0, 16) : 4);
  return f;
}

QColor Viewport::backgroundTop() {
  return QColor(72, 78, 88);
}
QColor Viewport::backgroundBottom() {
  return QColor(30, 32, 36);
}

Viewport::Viewport(Document* doc, QWidget* parent) : QOpenGLWidget(parent), doc_(doc) {
  setFormat(surfaceFormat());
  setFocusPolicy(Qt::StrongFocus);
  setMinimumSize(160, 120);
  flyTimer_ = new QTimer(this);
  flyTimer_->setInterval(16);
  connect(flyTimer_, &QTimer::timeout, this, [this] {
    if (flyStep(0.016f)) update();
  });
  connect(doc, &Document::sceneChanged, this, [this] {
    // Default 3/4 view from above, looking across the scene's longer horizontal side so it
    // spans the (landscape) frame.
    if (const Scene* scene = doc_->scene()) {
      const Vec3 e = scene->bounds.extent();
      camera_.yawDeg = e.x >= e.z ? 22.0f : 68.0f;
      camera_.pitchDeg = 52.0f;
    }
    sceneDirty_ = true;
    framePending_ = true;
    update();
  });
  connect(doc, &Document::probesReset, this, &Viewport::onProbesChanged);
  connect(doc, &Document::evaluationsChanged, this, [this] {
    highlightedQuery_ = -1;
    update();
  });
  connect(doc, &Document::volumeChanged, this, [this] {
    fieldsDirty_ = true;
    update();
  });
  connect(doc, &Document::importanceVolumesChanged, this, [this] {
    fieldsDirty_ = true;
    update();
  });
  connect(doc, &Document::probeInserted, this, &Viewport::onProbesChanged);
  connect(doc, &Document::probeRemoved, this, &Viewport::onProbesChanged);
  // A changed probe (moved, accepted, ...) keeps the drawn size: no O(n^2) radius update.
  connect(doc, &Document::probeChanged, this, [this] {
    probesDirty_ = true;
    fieldsDirty_ = true;
    update();
  });
  // The scene's direct light follows the scene and the rig (a sun edit, a sky).
  connect(doc, &Document::sceneChanged, this, [this] {
    sceneGridDirty_ = true;
    sceneGrid_ = {};
    overlaysDirty_ = true;
    if (sceneGridCancel_) sceneGridCancel_->store(true);
  });
  connect(doc, &Document::rigChanged, this, [this] {
    sceneGridDirty_ = true;
    if (sceneGridCancel_) sceneGridCancel_->store(true);
    update();
  });
}

Viewport::~Viewport() {
  if (fieldsWatcher_) fieldsWatcher_->waitForFinished();
  if (sceneGridCancel_) sceneGridCancel_->store(true);
  if (sceneGridWatcher_) sceneGridWatcher_->waitForFinished();
  cleanup();
  // ~QOpenGLWidget destroys the context, whose aboutToBeDestroyed must not reach this half
  // destroyed object (UBSan).
  if (QOpenGLContext* c = context()) disconnect(c, nullptr, this, nullptr);
}

void Viewport::onProbesChanged() {
  probesDirty_ = true;
  fieldsDirty_ = true;
  updateBaseRadius();
  update();
}

void Viewport::setSelection(const QSet<quint64>& ids) {
  if (ids == selection_) return;
  selection_ = ids;
  probesDirty_ = true;
  // The slice measures the distance to the selected probe; glyphs at probes follow visibility.
  if (overlays_) overlaysDirty_ = true;
  sliceTexDirty_ = true;
  update();
}

void Viewport::setProbesVisible(bool on) {
  probesVisible_ = on;
  update();
}

void Viewport::setRejectedVisible(bool on) {
  rejectedVisible_ = on;
  probesDirty_ = true;
  update();
}

bool Viewport::isDrawn(const Probe& p) const {
  return probesVisible_ &&
         (rejectedVisible_ || p.state != ProbeState::Rejected || selection_.contains(p.id));
}

void Viewport::setTool(Tool t) {
  tool_ = t;
  setCursor(t == Tool::Select ? Qt::ArrowCursor : Qt::CrossCursor);
}

void Viewport::setCutaway(bool on) {
  cutaway_ = on;
  update();
}

void Viewport::setExposureStops(float stops) {
  exposureStops_ = stops;
  update();
}

float Viewport::cutHeight() const {
  const Scene* scene = doc_->scene();
  if (!scene || scene->bounds.empty()) return std::numeric_limits<float>::max();
  return float(scene->bounds.lo.y + cutFraction_ * scene->bounds.extent().y);
}

PickRay Viewport::surfaceRay(QPointF widgetPos) const {
  PickRay r = pickRay(widgetPos);
  const float cut = cutHeight();
  if (cutaway_ && r.origin.y() > cut && r.direction.y() < 0)
    r.origin += r.direction * ((cut - r.origin.y()) / r.direction.y());
  return r;
}

void Viewport::setCutFraction(float f) {
  cutFraction_ = std::clamp(f, 0.05f, 1.0f);
  update();
}

float Viewport::exposure() const {
  return autoExposure_ * std::exp2(exposureStops_);
}

void Viewport::meterExposureNow() {
  const QMatrix4x4 vp = viewProjection();
  meteredView_ = vp;
  meteredSize_ = size();
  meteredVersion_ = lightingVersion_;
  const Tracer* tracer = doc_->tracer();
  const ShGrid* grid = meteringGrid();
  if (!tracer || !grid || width() < 1 || height() < 1) return;
  // One ray through the centre of each cell of a kMeterColumns x kMeterRows grid of the view,
  // starting at the cut plane above it as surfaceRay() does (the artist sees the rooms below).
  const QMatrix4x4 inv = vp.inverted();
  const float cut = cutHeight();
  std::vector<Ray> rays;
  rays.reserve(size_t(kMeterColumns) * kMeterRows);
  for (int j = 0; j < kMeterRows; ++j)
    for (int i = 0; i < kMeterColumns; ++i) {
      const float x = (2.0f * (float(i) + 0.5f) / kMeterColumns) - 1.0f;
      const float y = 1.0f - (2.0f * (float(j) + 0.5f) / kMeterRows);
      QVector3D a = inv.map(QVector3D(x, y, -1.0f));
      const QVector3D d = (inv.map(QVector3D(x, y, 1.0f)) - a).normalized();
      if (cutaway_ && a.y() > cut && d.y() < 0) a += d * ((cut - a.y()) / d.y());
      rays.push_back(Ray{Vec3(a.x(), a.y(), a.z()), Vec3(d.x(), d.y(), d.z()), 0.0});
    }
  if (const auto e = meterExposure(litSurfaceLuminances(*tracer, *grid, rays)))
    autoExposure_ = float(*e);
}

void Viewport::updateBaseRadius() {
  const Scene* scene = doc_->scene();
  const double diag = scene ? scene->bounds.diagonal() : 10.0;
  const auto& probes = doc_->probes();
  const size_t n = std::min<size_t>(probes.size(), 1500);
  if (n < 2) {
    baseRadius_ = float(diag * 0.012);
    return;
  }
  std::vector<double> nn(n, std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j)
      if (i != j) nn[i] = std::min(nn[i], length(probes[i].position - probes[j].position));
  std::nth_element(nn.begin(), nn.begin() + n / 2, nn.end());
  baseRadius_ = float(std::clamp(nn[n / 2] * 0.18, diag * 0.002, diag * 0.03));
}

float Viewport::baseRadius() const {
  return baseRadius_;
}

float Viewport::worldRadius(const Probe& p) const {
  float r = baseRadius_ * (p.state == ProbeState::Accepted ? 1.0f : 0.7f);
  if (selection_.contains(p.id)) r *= 1.25f;
  return r;
}

float Viewport::metresPerPixelPerMetre() const {
  return 2.0f * std::tan(qDegreesToRadians(camera_.fovYDeg) * 0.5f) / float(std::max(height(), 1));
}

float Viewport::drawnRadius(const Probe& p) const {
  // As the probe vertex shader computes it (uMinRadiusScale): the depth along the view
  // direction gives the metres per pixel.
  const float r = worldRadius(p);
  const float depth = QVector3D::dotProduct(toQ(p.position) - camera_.eye(), -camera_.backward());
  const float atLeast =
      kMinProbeRadiusPx * std::max(depth, 0.0f) * metresPerPixelPerMetre() / baseRadius_;
  return r * std::max(1.0f, atLeast);
}

void Viewport::frameAll() {
  const Scene* scene = doc_->scene();
  Bounds3 b;
  if (scene) b = scene->bounds;
  for (const Probe& p : doc_->probes()) b.extend(p.position);
  if (b.empty()) return;
  camera_.frame(b, float(std::max(width(), 1)) / float(std::max(height(), 1)));
  framePending_ = false;
  update();
}

void Viewport::frameSelection() {
  Bounds3 b;
  for (const Probe& p : doc_->probes())
    if (selection_.contains(p.id)) {
      const double r = worldRadius(p) * 4.0;
      b.extend(p.position - Vec3(r, r, r));
      b.extend(p.position + Vec3(r, r, r));
    }
  if (b.empty()) return frameAll();
  camera_.frame(b, float(std::max(width(), 1)) / float(std::max(height(), 1)), 0.6f);
  update();
}

void Viewport::framePoint(Vec3 centre, double radius) {
  const Vec3 r(radius, radius, radius);
  camera_.frame(Bounds3{centre - r, centre + r},
                float(std::max(width(), 1)) / float(std::max(height(), 1)), 0.6f);
  update();
}

void Viewport::setHighlightedQuery(int index) {
  highlightedQuery_ = index;
  update();
}

void Viewport::clipPlanes(float& nearDist, float& farDist) const {
  const Scene* scene = doc_->scene();
  Bounds3 b;
  if (scene) b = scene->bounds;
  for (const Probe& p : doc_->probes()) b.extend(p.position);
  const QVector3D centre = b.empty() ? camera_.target : toQ(b.center());
  const float radius = b.empty() ? 10.0f : float(b.diagonal() * 0.5) * 1.1f + baseRadius_ * 2;
  const float dist = (camera_.eye() - centre).length();
  farDist = dist + radius;
  nearDist = std::max(farDist * 2e-4f, (dist - radius) * 0.9f);
}

QMatrix4x4 Viewport::viewProjection() const {
  float n = 0, f = 0;
  clipPlanes(n, f);
  const float aspect = float(std::max(width(), 1)) / float(std::max(height(), 1));
  return camera_.projection(aspect, n, f) * camera_.view();
}

std::optional<QPointF> Viewport::project(Vec3 world) const {
  const QVector4D clip = viewProjection() * QVector4D(toQ(world), 1.0f);
  if (clip.w() <= 0) return std::nullopt;
  const float x = clip.x() / clip.w(), y = clip.y() / clip.w();
  return QPointF((x * 0.5 + 0.5) * width(), (0.5 - y * 0.5) * height());
}

PickRay Viewport::pickRay(QPointF pos) const {
  const QMatrix4x4 inv = viewProjection().inverted();
  const float x = float(2.0 * pos.x() / std::max(width(), 1) - 1.0);
  const float y = float(1.0 - 2.0 * pos.y() / std::max(height(), 1));
  const QVector3D a = inv.map(QVector3D(x, y, -1.0f)), b = inv.map(QVector3D(x, y, 1.0f));
  return {a, (b - a).normalized()};
}

QSet<quint64> Viewport::probesInRect(const QRectF& r) const {
  QSet<quint64> ids;
  for (const Probe& p : doc_->probes()) {
    if (!isDrawn(p)) continue;
    const auto px = project(p.position);
    if (px && r.contains(*px)) ids.insert(p.id);
  }
  return ids;
}

std::optional<QVector3D> Viewport::handleOrigin() const {
  QVector3D sum;
  int n = 0;
  for (const Probe& p : doc_->probes())
    if (selection_.contains(p.id) && !p.locked) {
      sum += toQ(p.position);
      ++n;
    }
  if (n == 0) return std::nullopt;
  return sum / float(n);
}

float Viewport::handleArmMeters() const {
  const auto o = handleOrigin();
  if (!o) return 0.0f;
  const float depth =
      std::max(QVector3D::dotProduct(*o - camera_.eye(), -camera_.backward()), 1e-3f);
  const float metresPerPixel = 2.0f * depth * std::tan(qDegreesToRadians(camera_.fovYDeg) * 0.5f) /
                               float(std::max(height(), 1));
  return 90.0f * metresPerPixel;
}

HandlePart Viewport::handlePartAt(QPointF pos) const {
  const auto o = handleOrigin();
  if (!o || tool_ != Tool::Select) return HandlePart::None;
  return pickHandle(pos, *o, handleArmMeters(),
                    [this](QVector3D w) { return project(Vec3(w.x(), w.y(), w.z())); });
}

std::optional<quint64> Viewport::pickProbe(QPointF pos) const {
  const PickRay ray = pickRay(pos);
  const QVector3D a = ray.origin, dir = ray.direction;
  std::optional<quint64> best;
  float bestT = std::numeric_limits<float>::infinity();
  for (const Probe& p : doc_->probes()) {
    if (!isDrawn(p)) continue;
    // Ray-sphere with a little slack so small spheres are easy to hit.
    const float r = drawnRadius(p) * 1.3f;
    const QVector3D oc = a - toQ(p.position);
    const float bq = QVector3D::dotProduct(oc, dir);
    const float c = QVector3D::dotProduct(oc, oc) - r * r;
    const float disc = bq * bq - c;
    if (disc < 0) continue;
    const float t = -bq - std::sqrt(disc);
    if (t > 0 && t < bestT) {
      bestT = t;
      best = p.id;
    }
  }
  return best;
}

// ---------------------------------------------------------------- GL

}  // namespace ps::ui
