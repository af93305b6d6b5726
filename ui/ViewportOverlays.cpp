// The viewport's lighting preview and overlays: the "probe lighting" preview, gradient glyphs
// (Chajdas et al. 2011 Fig. 2), the slice plane coloured by luminance distance to the selected
// probe (their Fig. 11) or by interpolation error, the tetrahedral mesh with leaking edges, and the
// test object. The data comes from LightingField.h; this file only turns it into GL buffers and
// draws it.
#include <QImage>
#include <QLinearGradient>
#include <QPainter>
#include <QtConcurrent/QtConcurrentRun>
#include <QtMath>
#include <algorithm>
#include <cmath>

#include "core/common/Error.h"
#include "core/placement/Uniform.h"
#include "core/scene/Scene.h"
#include "ui/Document.h"
#include "ui/Viewport.h"

namespace ps::ui {

namespace {

// One arrow per instance, drawn as lines: a shaft along +Z of the glyph frame and a head of two
// strokes in the plane facing the eye. Instance: centre + length, direction + magnitude in
// [0, 1] (colour).
const char* kGlyphVs = R"(#version 330 core
layout(location = 0) in vec3 aPos;      // arrow in its frame: shaft from z=-0.5 to z=0.5
layout(location = 1) in vec4 iCentreLen;
layout(location = 2) in vec4 iDirMag;
uniform mat4 uViewProj;
uniform float uClipY;
uniform vec3 uEye;
out float vMag;
out float vClip;
void main() {
  vec3 d = normalize(iDirMag.xyz);
  vec3 toEye = uEye - iCentreLen.xyz;
  vec3 u = cross(d, toEye);
  u = dot(u, u) > 1e-12 ? normalize(u) : normalize(cross(d, abs(d.y) < 0.9 ? vec3(0, 1, 0) : vec3(1, 0, 0)));
  vec3 v = cross(d, u);
  vec3 p = iCentreLen.xyz + (u * aPos.x + v * aPos.y + d * aPos.z) * iCentreLen.w;
  vMag = iDirMag.w;
  vClip = p.y - uClipY;
  gl_Position = uViewProj * vec4(p, 1.0);
})";

// Magnitude colour map: dark blue -> cyan -> yellow -> red (low to high |f|).
const char* kGlyphFs = R"(#version 330 core
in float vMag;
in float vClip;
out vec4 fragColor;
vec3 ramp(float t) {
  t = clamp(t, 0.0, 1.0);
  vec3 a = vec3(0.15, 0.25, 0.9), b = vec3(0.1, 0.85, 0.95), c = vec3(1.0, 0.9, 0.15),
       d = vec3(1.0, 0.2, 0.1);
  return t < 0.33 ? mix(a, b, t / 0.33) : (t < 0.66 ? mix(b, c, (t - 0.33) / 0.33)
                                                       : mix(c, d, (t - 0.66) / 0.34));
}
void main() {
  if (vClip > 0.0) discard;
  fragColor = vec4(ramp(vMag), 1.0);
})";

const char* kSliceVs = R"(#version 330 core
layout(location = 0) in vec3 aPos;
layout(location = 1) in vec4 aUv;  // uv in xy
uniform mat4 uViewProj;
out vec2 vUv;
void main() {
  vUv = aUv.xy;
  gl_Position = uViewProj * vec4(aPos, 1.0);
})";

const char* kSliceFs = R"(#version 330 core
in vec2 vUv;
uniform sampler2D uTex;
out vec4 fragColor;
void main() {
  vec4 c = texture(uTex, vUv);
  if (c.a < 0.01) discard;
  fragColor = c;
})";

/// Neighbouring probes whose brightness differs by more than this (stops) are flagged.
constexpr float kEdgeStopsTooFar = 1.5f;

/// The error slice is red from this error on, in stops (PerceptualError.h: kVisibleStops, a
/// third of a stop, is where an artist sees it).
constexpr double kSliceErrorStopsRed = 1.0;
/// The luminance-distance slice is red from this distance on, in stops (Chajdas Fig. 11).
constexpr double kSliceDistanceStopsRed = 4.0;

/// Slice colour ramp (sRGB): blue (0) -> green -> yellow -> red (1).
QRgb sliceColor(double t) {
  t = std::clamp(t, 0.0, 1.0);
  const double stops[4][3] = {{40, 70, 200}, {40, 190, 90}, {240, 220, 40}, {220, 40, 30}};
  const double x = t * 3.0;
  const int i = std::min(int(x), 2);
  const double f = x - i;
  auto ch = [&](int c) { return int(std::lround(stops[i][c] * (1 - f) + stops[i + 1][c] * f)); };
  return qRgba(ch(0), ch(1), ch(2), 215);
}

}  // namespace

// ---------------------------------------------------------------- state

void Viewport::setPreviewLighting(bool on) {
  previewLighting_ = on;
  overlaysDirty_ = true;
  update();
  emit overlaysToggled();
}

void Viewport::setFlatShading(bool on) {
  flatShading_ = on;
  update();
  emit overlaysToggled();
}

Viewport::Shading Viewport::shading() const {
  if (flatShading_) return Shading::Flat;
  if (previewLighting_ && previewVolume_ && previewGrid_.size() > 0) return Shading::Probes;
  if (sceneGrid_.size() > 0) return Shading::SceneLights;
  return Shading::Flat;
}

const ShGrid* Viewport::shadingGrid() const {
  switch (shading()) {
    case Shading::Probes:
      return &previewGrid_;
    case Shading::SceneLights:
      return &sceneGrid_;
    case Shading::Flat:
      break;
  }
  return nullptr;
}

const ShGrid* Viewport::meteringGrid() const {
  if (const ShGrid* g = shadingGrid()) return g;
  if (previewVolume_ && previewGrid_.size() > 0) return &previewGrid_;
  if (sceneGrid_.size() > 0) return &sceneGrid_;
  return nullptr;
}

namespace {
/// The scene's direct light, on a worker thread: a pure function of its inputs (the tracer is
/// shared and thread-safe for queries). An unreadable environment map gives an empty grid.
std::shared_ptr<ShGrid> computeSceneLight(std::shared_ptr<const Tracer> tracer, LightingRig rig,
                                          Bounds3 bounds, std::shared_ptr<std::atomic<bool>> stop) {
  try {
    return std::make_shared<ShGrid>(directLightGrid(*tracer, rig, bounds,
                                                    Viewport::kSceneLightCells, kDirectSkyRays,
                                                    [stop] { return stop->load(); }));
  } catch (const Error&) {
    return std::make_shared<ShGrid>();
  }
}
}  // namespace

void Viewport::startSceneLightRebuild() {
  if (!sceneGridDirty_ || sceneGridPending_) return;
  sceneGridDirty_ = false;
  const Scene* scene = doc_->scene();
  const auto tracer = doc_->tracerShared();
  if (!scene || !tracer || scene->bounds.empty() || !hasAnyLight(*scene, doc_->probeSet().rig)) {
    sceneGrid_ = {};
    overlaysDirty_ = true;
    return;
  }
  if (!sceneGridWatcher_) {
    sceneGridWatcher_ = new QFutureWatcher<std::shared_ptr<ShGrid>>(this);
    connect(sceneGridWatcher_, &QFutureWatcherBase::finished, this, [this] {
      if (!sceneGridPending_) return;  // already taken by sceneLightGrid()
      sceneGridPending_ = false;
      // A result computed for a scene or a rig that changed since is dropped.
      if (!sceneGridDirty_)
        if (auto r = sceneGridWatcher_->result()) {
          sceneGrid_ = std::move(*r);
          overlaysDirty_ = true;
          emit sceneLightingUpdated();
        }
      update();
    });
  }
  sceneGridPending_ = true;
  sceneGridCancel_ = std::make_shared<std::atomic<bool>>(false);
  sceneGridWatcher_->setFuture(QtConcurrent::run(computeSceneLight, tracer, doc_->probeSet().rig,
                                                 scene->bounds, sceneGridCancel_));
}

const ShGrid& Viewport::sceneLightGrid() {
  if (sceneGridPending_) {
    sceneGridWatcher_->waitForFinished();
    sceneGridPending_ = false;
    if (!sceneGridDirty_)
      if (auto r = sceneGridWatcher_->result()) {
        sceneGrid_ = std::move(*r);
        overlaysDirty_ = true;
        emit sceneLightingUpdated();
      }
  }
  if (sceneGridDirty_) {
    startSceneLightRebuild();
    if (sceneGridPending_) return sceneLightGrid();
  }
  return sceneGrid_;
}

void Viewport::setOverlay(Overlay o, bool on) {
  if (on)
    overlays_ |= 1u << int(o);
  else
    overlays_ &= ~(1u << int(o));
  overlaysDirty_ = true;
  update();
  emit overlaysToggled();
}

void Viewport::setPreviewSource(PreviewSource s) {
  previewSource_ = s;
  fieldsDirty_ = true;
  update();
  emit overlaysToggled();
}

void Viewport::setGlyphResolution(int cells) {
  glyphResolution_ = std::clamp(cells, 1, 256);
  fieldsDirty_ = true;
  update();
}

void Viewport::setSliceMode(SliceMode m) {
  sliceMode_ = m;
  overlaysDirty_ = true;
  update();
  emit overlaysToggled();
}

void Viewport::setSliceAxis(int axis) {
  sliceAxis_ = std::clamp(axis, 0, 2);
  sliceTexDirty_ = true;
  update();
  emit sliceChanged(sliceAxis_, sliceFraction_);
}

void Viewport::setSliceFraction(float f) {
  const float clamped = std::clamp(f, 0.0f, 1.0f);
  if (clamped == sliceFraction_) return;
  sliceFraction_ = clamped;
  sliceTexDirty_ = true;
  update();
  emit sliceChanged(sliceAxis_, sliceFraction_);
}

bool Viewport::onSliceOutline(QPointF pos) const {
  if (!overlay(Overlay::Slice) || !doc_->hasScene()) return false;
  const auto c = sliceCorners();
  for (int i = 0; i < 4; ++i) {
    const auto a = project(c[size_t(i)]), b = project(c[size_t((i + 1) % 4)]);
    if (!a || !b) continue;
    const QPointF ab = *b - *a;
    const double len2 = QPointF::dotProduct(ab, ab);
    const double t =
        len2 > 0 ? std::clamp(QPointF::dotProduct(pos - *a, ab) / len2, 0.0, 1.0) : 0.0;
    const QPointF q = *a + ab * t;
    if (QLineF(q, pos).length() <= kSliceGrabPx) return true;
  }
  return false;
}

std::array<Vec3, 4> Viewport::sliceCorners() const {
  const Scene* scene = doc_->scene();
  Bounds3 b = scene ? scene->bounds : Bounds3();
  if (b.empty()) b = Bounds3(Vec3(-1, -1, -1), Vec3(1, 1, 1));
  const int a = sliceAxis_, u = (a + 1) % 3, v = (a + 2) % 3;
  Vec3 base = b.lo;
  base[a] = b.lo[a] + sliceFraction_ * b.extent()[a];
  std::array<Vec3, 4> c{base, base, base, base};
  c[1][u] = b.hi[u];
  c[2][u] = b.hi[u];
  c[2][v] = b.hi[v];
  c[3][v] = b.hi[v];
  return c;
}

void Viewport::setTestObjectPosition(Vec3 p) {
  testObject_ = p;
  testObjectPlaced_ = true;
  overlaysDirty_ = true;
  update();
}

float Viewport::testObjectRadius() const {
  return baseRadius_ * 2.5f;
}

const std::optional<ProbeVolume>& Viewport::previewVolume() {
  updateFields();
  return previewVolume_;
}

const ShGrid& Viewport::glyphGrid() {
  updateFields();
  return glyphGrid_;
}

const ShGrid& Viewport::previewGrid() {
  updateFields();
  return previewGrid_;
}

void Viewport::setGlyphsAtProbes(bool on) {
  glyphsAtProbes_ = on;
  glyphScale_ = -1;
  overlaysDirty_ = true;
  update();
}

std::vector<Viewport::GlyphSample> Viewport::glyphSamples(double* arrowMeters) {
  updateFields();
  return currentGlyphSamples(arrowMeters);
}

std::vector<Viewport::GlyphSample> Viewport::currentGlyphSamples(double* arrowMeters) {
  std::vector<GlyphSample> out;
  if (glyphsAtProbes_) {
    // Chajdas Fig. 2 over the captured probes themselves.
    for (const Probe& p : doc_->probes())
      if (p.sh && isDrawn(p)) out.push_back({p.position, luminanceDirection(*p.sh)});
    if (arrowMeters) *arrowMeters = baseRadius_ * 5.0;
    return out;
  }
  out.reserve(glyphGrid_.size());
  for (size_t i = 0; i < glyphGrid_.size(); ++i)
    out.push_back({glyphGrid_.centre(i), luminanceDirection(glyphGrid_.sh[i])});
  if (arrowMeters)
    *arrowMeters =
        std::min({glyphGrid_.cellMeters.x, glyphGrid_.cellMeters.y, glyphGrid_.cellMeters.z});
  return out;
}

int32_t Viewport::testObjectTet() {
  updateFields();
  const ProbeVolume* volume = drawnPreviewVolume();
  if (!volume) return -1;
  const VolumeLocation loc = locate(*volume, testObject_, testTetHint_);
  testTetHint_ = loc.tet;
  return loc.tet;
}

void Viewport::renderNow() {
  makeCurrent();
  paintGL();
  glFinish();
  doneCurrent();
}

// ---------------------------------------------------------------- derived data

/// Everything derived from the probes for the preview and the overlays.
struct Viewport::Fields {
  std::optional<ProbeVolume> preview, reference;
  ShGrid glyphGrid, previewGrid;
  std::vector<std::array<int32_t, 2>> edges;
  std::vector<uint8_t> leaks;
  std::vector<float> edgeStops;
};

namespace {
/// A pure function of its inputs, so it runs on a worker thread (the probes are a copy; the
/// tracer is shared and thread-safe for queries).
std::shared_ptr<Viewport::Fields> computeFields(const std::vector<Probe>& probes,
                                                PreviewSource source, Bounds3 bounds,
                                                int glyphResolution, int previewResolution,
                                                std::shared_ptr<const Tracer> tracer,
                                                std::shared_ptr<const ProbeVolume> baked,
                                                std::optional<ProbeVolume> preview);
}  // namespace

namespace {
/// The test object's default place: the scene's centre, at 35 % of its height.
Vec3 defaultTestObjectPosition(const Scene* scene) {
  if (!scene || scene->bounds.empty()) return {};
  Vec3 p = scene->bounds.center();
  p.y = scene->bounds.lo.y + 0.35 * scene->bounds.extent().y;
  return p;
}
}  // namespace

void Viewport::updateFields() {
  const Scene* scene = doc_->scene();
  if (!testObjectPlaced_) testObject_ = defaultTestObjectPosition(scene);
  if (fieldsPending_) {
    // A background rebuild is under way (or done, its signal not yet delivered): take it now.
    fieldsWatcher_->waitForFinished();
    fieldsPending_ = false;
    if (auto r = fieldsWatcher_->result()) applyFields(std::move(*r));
  }
  if (!fieldsDirty_) return;
  fieldsDirty_ = false;
  auto f = computeFields(doc_->probes(), previewSource_, scene ? scene->bounds : Bounds3(),
                         glyphResolution_, previewResolution_, doc_->tracerShared(), doc_->volume(),
                         previewForFields());
  applyFields(std::move(*f));
}

void Viewport::startFieldsRebuild() {
  const Scene* scene = doc_->scene();
  if (!testObjectPlaced_) testObject_ = defaultTestObjectPosition(scene);
  if (!fieldsDirty_ || fieldsPending_) return;
  fieldsDirty_ = false;
  fieldsPending_ = true;
  fieldsRebuildRunning_ = true;
  if (!fieldsWatcher_) {
    fieldsWatcher_ = new QFutureWatcher<std::shared_ptr<Fields>>(this);
    connect(fieldsWatcher_, &QFutureWatcherBase::finished, this, [this] {
      fieldsRebuildRunning_ = false;
      if (!fieldsPending_) return;  // already taken by updateFields()
      fieldsPending_ = false;
      if (auto r = fieldsWatcher_->result()) applyFields(std::move(*r));  // emits fieldsUpdated
      update();  // shows the new fields; starts another rebuild if the probes moved meanwhile
    });
  }
  fieldsWatcher_->setFuture(QtConcurrent::run(computeFields, doc_->probes(), previewSource_,
                                              scene ? scene->bounds : Bounds3(), glyphResolution_,
                                              previewResolution_, doc_->tracerShared(),
                                              doc_->volume(), previewForFields()));
}

void Viewport::applyFields(Fields&& f) {
  mirrorAhead_ = false;
  overlaysDirty_ = true;
  testTetHint_ = -1;
  previewVolume_ = std::move(f.preview);
  referenceVolume_ = std::move(f.reference);
  glyphGrid_ = std::move(f.glyphGrid);
  previewGrid_ = std::move(f.previewGrid);
  edges_ = std::move(f.edges);
  leaks_ = std::move(f.leaks);
  edgeStops_ = std::move(f.edgeStops);
  glyphScale_ = -1;
  emit fieldsUpdated();
}

const ProbeVolume* Viewport::drawnPreviewVolume() const {
  if (mirrorAhead_) return mirror_.volume();
  return previewVolume_ ? &*previewVolume_ : nullptr;
}

void Viewport::syncMirror() {
  const PreviewVolumeMirror::SyncReport r = mirror_.sync(doc_->probes(), previewSource_);
  if (r.changed() && !r.rebuilt) emit previewVolumeEdited(r.seconds, qsizetype(r.tetsRewritten));
}

std::optional<ProbeVolume> Viewport::previewForFields() {
  syncMirror();
  const ProbeVolume* v = mirror_.volume();
  return v ? std::optional<ProbeVolume>(*v) : std::nullopt;
}

namespace {
std::shared_ptr<Viewport::Fields> computeFields(const std::vector<Probe>& probes,
                                                PreviewSource source, Bounds3 bounds,
                                                int glyphResolution, int previewResolution,
                                                std::shared_ptr<const Tracer> tracer,
                                                std::shared_ptr<const ProbeVolume> baked,
                                                std::optional<ProbeVolume> preview) {
  auto f = std::make_shared<Viewport::Fields>();
  if (source == PreviewSource::Baked) {
    if (baked) f->preview = *baked;
  } else {
    f->preview = std::move(preview);  // the mirror's copy, kept up to date by local edits
  }
  if (source == PreviewSource::AllCaptured)
    f->reference = f->preview;
  else
    f->reference = buildPreviewVolume(probes, PreviewSource::AllCaptured);
  if (!f->preview || bounds.empty()) return f;
  f->glyphGrid = sampleGrid(*f->preview, bounds, glyphResolution);
  f->previewGrid = sampleGrid(*f->preview, bounds, previewResolution);
  f->edges = tetEdges(*f->preview);
  f->edgeStops = edgeLuminanceDistances(*f->preview, f->edges);
  if (tracer) f->leaks = leakingEdges(*tracer, *f->preview, f->edges);
  return f;
}
}  // namespace

QImage Viewport::renderSliceImage(int size) {
  QImage img(size, size, QImage::Format_ARGB32);
  img.fill(Qt::transparent);
  if (!previewVolume_) return img;
  const auto c = sliceCorners();
  const Vec3 du = c[1] - c[0], dv = c[3] - c[0];
  Vec3 normal;
  normal[sliceAxis_] = 1.0;
  // Reference for the luminance distance: the selected probe, else the mean of the volume's.
  ShRgb ref;
  bool haveRef = false;
  for (const Probe& p : doc_->probes())
    if (selection_.contains(p.id) && p.sh) {
      ref = *p.sh;
      haveRef = true;
      break;
    }
  if (!haveRef && previewVolume_->probeCount() > 0) {
    for (size_t i = 0; i < previewVolume_->probeCount(); ++i)
      ref += previewVolume_->probeSh(int32_t(i));
    ref = ref * (1.0 / double(previewVolume_->probeCount()));
  }
  // The error's floor (PerceptualError.h): kAdaptationFloorFraction of the reference's typical
  // irradiance, here the mean probe's; darker light counts as the floor.
  double floor = 1e-12;
  if (sliceMode_ == SliceMode::Error && referenceVolume_)
    floor = std::max(kAdaptationFloorFraction * meanLuminance(ref) * kPi, 1e-12);
  int32_t hint = -1, hintRef = -1;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const Vec3 p = c[0] + du * ((x + 0.5) / size) + dv * ((y + 0.5) / size);
      const VolumeLocation loc = locate(*previewVolume_, p, hint);
      hint = loc.tet;
      const ShRgb sh = interpolate(*previewVolume_, loc);
      double t = 0;
      if (sliceMode_ == SliceMode::LuminanceDistance) {
        t = luminanceDistanceStops(sh, ref) / kSliceDistanceStopsRed;
      } else {
        if (!referenceVolume_) continue;
        const VolumeLocation lr = locate(*referenceVolume_, p, hintRef);
        hintRef = lr.tet;
        const double er = luminance(interpolate(*referenceVolume_, lr).irradiance(normal));
        const double et = luminance(sh.irradiance(normal));
        t = errorStops(et, er, floor) / kSliceErrorStopsRed;
      }
      img.setPixel(x, y, sliceColor(t));
    }
  return img;
}

// ---------------------------------------------------------------- GL

void Viewport::initOverlayGL() {
  glyphProgram_ = buildProgram(kGlyphVs, kGlyphFs, false);
  sliceProgram_ = buildProgram(kSliceVs, kSliceFs, false);
  // Arrow mesh (GL_LINES), unit length along +Z, centred.
  const float h = 0.22f, back = 0.22f;
  const std::vector<float> arrow = {0, 0, -0.5f, 0,  0,  0.5f,        0, 0, 0.5f, h, 0, 0.5f - back,
                                    0, 0, 0.5f,  -h, 0,  0.5f - back, 0, 0, 0.5f, 0, h, 0.5f - back,
                                    0, 0, 0.5f,  0,  -h, 0.5f - back};
  glyphMeshCount_ = GLsizei(arrow.size() / 3);
  glGenVertexArrays(1, &glyphVao_);
  glGenBuffers(1, &glyphMeshVbo_);
  glGenBuffers(1, &glyphInstanceVbo_);
  glBindVertexArray(glyphVao_);
  glBindBuffer(GL_ARRAY_BUFFER, glyphMeshVbo_);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(arrow.size() * sizeof(float)), arrow.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  glBindBuffer(GL_ARRAY_BUFFER, glyphInstanceVbo_);
  for (int a = 0; a < 2; ++a) {
    glEnableVertexAttribArray(GLuint(1 + a));
    glVertexAttribPointer(GLuint(1 + a), 4, GL_FLOAT, GL_FALSE, 8 * sizeof(float),
                          reinterpret_cast<const void*>(size_t(a) * 4 * sizeof(float)));
    glVertexAttribDivisor(GLuint(1 + a), 1);
  }
  glBindVertexArray(0);

  glGenTextures(7, previewTex_);
  for (GLuint t : previewTex_) {
    glBindTexture(GL_TEXTURE_3D, t);
    glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
      glTexParameteri(GL_TEXTURE_3D, w, GL_CLAMP_TO_EDGE);
  }
  glBindTexture(GL_TEXTURE_3D, 0);
  glGenTextures(1, &sliceTex_);
  glBindTexture(GL_TEXTURE_2D, sliceTex_);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_2D, 0);
  glGenBuffers(1, &meshVbo_);

  // The test object: the probe sphere mesh with its own one-instance buffer.
  glGenTextures(1, &testInstanceTex_);
  glGenVertexArrays(1, &testVao_);
  glGenBuffers(1, &testInstanceVbo_);
  glBindVertexArray(testVao_);
  glBindBuffer(GL_ARRAY_BUFFER, sphereVbo_);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, sphereIbo_);
  glBindBuffer(GL_ARRAY_BUFFER, testInstanceVbo_);
  for (int a = 0; a < 2; ++a) {
    glEnableVertexAttribArray(GLuint(1 + a));
    glVertexAttribPointer(GLuint(1 + a), 4, GL_FLOAT, GL_FALSE, 36 * sizeof(float),
                          reinterpret_cast<const void*>(size_t(a) * 4 * sizeof(float)));
    glVertexAttribDivisor(GLuint(1 + a), 1);
  }
  glBindVertexArray(0);
}

void Viewport::cleanupOverlayGL() {
  glDeleteProgram(glyphProgram_);
  glDeleteProgram(sliceProgram_);
  glDeleteVertexArrays(1, &glyphVao_);
  glDeleteBuffers(1, &glyphMeshVbo_);
  glDeleteBuffers(1, &glyphInstanceVbo_);
  glDeleteTextures(7, previewTex_);
  glDeleteTextures(1, &sliceTex_);
  glDeleteBuffers(1, &meshVbo_);
  glDeleteVertexArrays(1, &testVao_);
  glDeleteTextures(1, &testInstanceTex_);
  glDeleteBuffers(1, &testInstanceVbo_);
}

void Viewport::uploadOverlays() {
  overlaysDirty_ = false;
  sliceTexDirty_ = true;
  // The light the surfaces are drawn with (the probes' grid or the scene lights'): the SH grid
  // (with the cosine lobes A_l folded in) as seven RGBA textures.
  previewTexValid_ = false;
  uploadedShading_ = shading();
  ++lightingVersion_;  // the exposure is metered again
  if (const ShGrid* grid = shadingGrid(); grid && grid->size() > 0) {
    const size_t n = grid->size();
    std::vector<float> tex[7];
    for (auto& t : tex) t.resize(n * 4, 0.0f);
    for (size_t i = 0; i < n; ++i)
      for (int k = 0; k < 27; ++k) {
        const Rgb c = grid->sh[i].c[size_t(k / 3)] * shCosineLobe(k / 3);
        tex[k / 4][i * 4 + size_t(k % 4)] = float(k % 3 == 0 ? c.r : (k % 3 == 1 ? c.g : c.b));
      }
    for (int t = 0; t < 7; ++t) {
      glBindTexture(GL_TEXTURE_3D, previewTex_[t]);
      glTexImage3D(GL_TEXTURE_3D, 0, GL_RGBA32F, grid->dims[0], grid->dims[1], grid->dims[2], 0,
                   GL_RGBA, GL_FLOAT, tex[t].data());
    }
    glBindTexture(GL_TEXTURE_3D, 0);
    previewTexValid_ = true;
  }

  // Glyphs: one arrow of f per sample, length by |f| (relative to the 95th percentile).
  glyphCount_ = 0;
  if (overlay(Overlay::Glyphs)) {
    double arrowMeters = 0;
    const std::vector<GlyphSample> samples = currentGlyphSamples(&arrowMeters);
    const size_t n = samples.size();
    std::vector<float> inst;
    if (n > 0) {
      std::vector<double> mags(n);
      for (size_t i = 0; i < n; ++i) mags[i] = length(samples[i].f);
      std::vector<double> sorted = mags;
      std::nth_element(sorted.begin(), sorted.begin() + long(n * 95 / 100), sorted.end());
      const double scale = std::max(sorted[n * 95 / 100], 1e-12);
      inst.reserve(n * 8);
      for (size_t i = 0; i < n; ++i) {
        if (mags[i] <= 1e-12) continue;
        const double t = std::min(mags[i] / scale, 1.0);
        const Vec3 c = samples[i].centre, d = samples[i].f / mags[i];
        inst.insert(inst.end(),
                    {float(c.x), float(c.y), float(c.z), float(arrowMeters * (0.35 + 0.5 * t)),
                     float(d.x), float(d.y), float(d.z), float(t)});
      }
    }
    glyphCount_ = GLsizei(inst.size() / 8);
    glBindBuffer(GL_ARRAY_BUFFER, glyphInstanceVbo_);
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(inst.size() * sizeof(float)), inst.data(),
                 GL_STATIC_DRAW);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
  }

  // Tetrahedral mesh: grey edges; red where they cross geometry (leaks); orange where their
  // probes differ by more than kEdgeStopsTooFar stops (Chajdas sec. 4).
  meshVertexCount_ = 0;
  if (overlay(Overlay::TetMesh) && previewVolume_) {
    std::vector<float> v;
    v.reserve(edges_.size() * 14);
    for (size_t i = 0; i < edges_.size(); ++i) {
      const bool leak = i < leaks_.size() && leaks_[i];
      const bool far = !leak && i < edgeStops_.size() && edgeStops_[i] > kEdgeStopsTooFar;
      const float r = leak ? 1.0f : (far ? 1.0f : 0.8f);
      const float g = leak ? 0.15f : (far ? 0.6f : 0.8f);
      const float b = leak ? 0.1f : (far ? 0.1f : 0.85f);
      const float a = leak || far ? 0.95f : 0.45f;
      for (int e = 0; e < 2; ++e) {
        const Vec3 p = previewVolume_->position(edges_[i][size_t(e)]);
        v.insert(v.end(), {float(p.x), float(p.y), float(p.z), r, g, b, a});
      }
    }
    meshVertexCount_ = GLsizei(v.size() / 7);
    glBindBuffer(GL_ARRAY_BUFFER, meshVbo_);
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(v.size() * sizeof(float)), v.data(), GL_STATIC_DRAW);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
  }
}

void Viewport::uploadSliceTexture() {
  sliceTexDirty_ = false;
  const QImage img = renderSliceImage(160).convertToFormat(QImage::Format_RGBA8888);
  glBindTexture(GL_TEXTURE_2D, sliceTex_);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, img.width(), img.height(), 0, GL_RGBA, GL_UNSIGNED_BYTE,
               img.constBits());
  glBindTexture(GL_TEXTURE_2D, 0);
}

void Viewport::drawSliceOutline(const QMatrix4x4& vp) {
  // The plane's outline, where the scene's bounds cut it: solid where visible, faint through
  // geometry, bright while dragged. Drawn with the Slice overlay, with or without a volume.
  const auto c = sliceCorners();
  const bool active = drag_ == Drag::Slice;
  const float r = active ? 1.0f : 0.95f, g = active ? 0.95f : 0.95f, b = active ? 0.3f : 1.0f;
  std::vector<float> v;
  for (int i = 0; i < 4; ++i)
    for (const Vec3& p : {c[size_t(i)], c[size_t((i + 1) % 4)]})
      v.insert(v.end(), {float(p.x), float(p.y), float(p.z), r, g, b, 1.0f});
  drawLines(v, GL_LINES, vp);
  for (size_t i = 6; i < v.size(); i += 7) v[i] = 0.35f;
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  glDisable(GL_DEPTH_TEST);
  drawLines(v, GL_LINES, vp);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
}

void Viewport::drawLines(const std::vector<float>& v, GLenum mode, const QMatrix4x4& vp) {
  if (v.empty()) return;
  glUseProgram(lineProgram_);
  glUniformMatrix4fv(glGetUniformLocation(lineProgram_, "uViewProj"), 1, GL_FALSE, vp.constData());
  glBindVertexArray(lineVao_);
  glBindBuffer(GL_ARRAY_BUFFER, lineVbo_);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(v.size() * sizeof(float)), v.data(), GL_STREAM_DRAW);
  glDrawArrays(mode, 0, GLsizei(v.size() / 7));
}

void Viewport::drawOverlays(const QMatrix4x4& vp) {
  const float clipY = cutaway_ ? cutHeight() : std::numeric_limits<float>::max();
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);

  if (overlay(Overlay::Slice) && previewVolume_) {
    const auto c = sliceCorners();
    const float uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    std::vector<float> v;
    for (int i : {0, 1, 2, 0, 2, 3})
      v.insert(v.end(), {float(c[size_t(i)].x), float(c[size_t(i)].y), float(c[size_t(i)].z),
                         uv[i][0], uv[i][1], 0, 0});
    glEnable(GL_BLEND);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(sliceProgram_);
    glUniformMatrix4fv(glGetUniformLocation(sliceProgram_, "uViewProj"), 1, GL_FALSE,
                       vp.constData());
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, sliceTex_);
    glUniform1i(glGetUniformLocation(sliceProgram_, "uTex"), 0);
    glBindVertexArray(lineVao_);
    glBindBuffer(GL_ARRAY_BUFFER, lineVbo_);
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(v.size() * sizeof(float)), v.data(), GL_STREAM_DRAW);
    glDrawArrays(GL_TRIANGLES, 0, 6);
    glDisable(GL_BLEND);
  }

  if (overlay(Overlay::Slice)) drawSliceOutline(vp);

  if (overlay(Overlay::Glyphs) && glyphCount_ > 0) {
    glUseProgram(glyphProgram_);
    glUniformMatrix4fv(glGetUniformLocation(glyphProgram_, "uViewProj"), 1, GL_FALSE,
                       vp.constData());
    glUniform1f(glGetUniformLocation(glyphProgram_, "uClipY"), clipY);
    const QVector3D eye = camera_.eye();
    glUniform3f(glGetUniformLocation(glyphProgram_, "uEye"), eye.x(), eye.y(), eye.z());
    glBindVertexArray(glyphVao_);
    glDrawArraysInstanced(GL_LINES, 0, glyphMeshCount_, glyphCount_);
  }

  if (overlay(Overlay::TetMesh) && meshVertexCount_ > 0) {
    glEnable(GL_BLEND);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(lineProgram_);
    glUniformMatrix4fv(glGetUniformLocation(lineProgram_, "uViewProj"), 1, GL_FALSE,
                       vp.constData());
    glBindVertexArray(lineVao_);
    glBindBuffer(GL_ARRAY_BUFFER, meshVbo_);
    // The line VAO's attributes point into lineVbo_; rebind them to the mesh buffer.
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 7 * sizeof(float), nullptr);
    glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, 7 * sizeof(float),
                          reinterpret_cast<const void*>(3 * sizeof(float)));
    glDrawArrays(GL_LINES, 0, meshVertexCount_);
    glBindBuffer(GL_ARRAY_BUFFER, lineVbo_);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 7 * sizeof(float), nullptr);
    glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, 7 * sizeof(float),
                          reinterpret_cast<const void*>(3 * sizeof(float)));
    glDisable(GL_BLEND);
  }

  if (const ProbeVolume* volume = drawnPreviewVolume(); overlay(Overlay::TestObject) && volume) {
    const VolumeLocation loc = locate(*volume, testObject_, testTetHint_);
    testTetHint_ = loc.tet;
    const ShRgb sh = interpolate(*volume, loc);
    std::vector<float> inst = {float(testObject_.x),
                               float(testObject_.y),
                               float(testObject_.z),
                               testObjectRadius(),
                               1.0f,
                               0.0f,
                               1.0f,
                               1.0f};
    for (int i = 0; i < kShCoeffCount; ++i) {
      const Rgb c = sh.c[size_t(i)] * shCosineLobe(i);
      inst.insert(inst.end(), {float(c.r), float(c.g), float(c.b)});
    }
    inst.push_back(0.0f);
    glBindBuffer(GL_ARRAY_BUFFER, testInstanceVbo_);
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(inst.size() * sizeof(float)), inst.data(),
                 GL_STREAM_DRAW);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_BUFFER, testInstanceTex_);
    glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA32F, testInstanceVbo_);
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glUseProgram(probeProgram_);
    glUniformMatrix4fv(glGetUniformLocation(probeProgram_, "uViewProj"), 1, GL_FALSE,
                       vp.constData());
    const QVector3D eye = camera_.eye();
    glUniform3f(glGetUniformLocation(probeProgram_, "uEye"), eye.x(), eye.y(), eye.z());
    glUniform1f(glGetUniformLocation(probeProgram_, "uExposure"), exposure());
    glUniform1i(glGetUniformLocation(probeProgram_, "uXray"), 0);
    glUniform1i(glGetUniformLocation(probeProgram_, "uInstances"), 0);
    glBindVertexArray(testVao_);
    glDrawElementsInstanced(GL_TRIANGLES, sphereIndexCount_, GL_UNSIGNED_INT, nullptr, 1);
    glDisable(GL_CULL_FACE);
    // Its tetrahedron, drawn over everything.
    if (loc.tet >= 0) {
      const auto& t = volume->tets[size_t(loc.tet)];
      std::vector<float> v;
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b)
          for (int e : {a, b}) {
            const Vec3 p = volume->position(t[size_t(e)]);
            v.insert(v.end(), {float(p.x), float(p.y), float(p.z), 1.0f, 0.85f, 0.1f, 1.0f});
          }
      glDisable(GL_DEPTH_TEST);
      drawLines(v, GL_LINES, vp);
      glEnable(GL_DEPTH_TEST);
    }
  }

  drawDomain(vp);

  // The importance volumes: box edges, orange where probes are wanted denser (weight >= 1),
  // blue where sparser; solid where visible, faint where behind geometry.
  // The box being drawn (DrawVolume tool) in white.
  auto boxEdges = [](std::vector<float>& v, Vec3 lo, Vec3 hi, float r, float g, float b) {
    auto corner = [&](int i) {
      return Vec3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    };
    for (int i = 0; i < 8; ++i)
      for (int bit : {1, 2, 4})
        if (!(i & bit))
          for (const Vec3 p : {corner(i), corner(i | bit)})
            v.insert(v.end(), {float(p.x), float(p.y), float(p.z), r, g, b, 1.0f});
  };
  const bool drawing = drag_ == Drag::Volume && dragged_;
  if (!doc_->probeSet().importanceVolumes.empty() || drawing) {
    std::vector<float> v;
    for (const ImportanceVolume& box : doc_->probeSet().importanceVolumes) {
      const bool warm = box.weight >= 1;
      boxEdges(v, box.lo, box.hi, warm ? 1.0f : 0.3f, warm ? 0.55f : 0.65f, warm ? 0.1f : 1.0f);
    }
    if (drawing) {
      const Bounds3 box = drawnVolume();
      boxEdges(v, box.lo, box.hi, 1.0f, 1.0f, 1.0f);
    }
    drawLines(v, GL_LINES, vp);
    for (size_t i = 6; i < v.size(); i += 7) v[i] = 0.3f;
    glEnable(GL_BLEND);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glDisable(GL_DEPTH_TEST);
    drawLines(v, GL_LINES, vp);
    glEnable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
  }
}

}  // namespace ps::ui

// ---------------------------------------------------------------- legends

namespace ps::ui {

namespace {
QColor rgbF(double r, double g, double b) {
  return QColor::fromRgbF(float(r), float(g), float(b));
}

/// The slice's ramp at five points from 0 to 1.
std::vector<QColor> sliceRamp() {
  std::vector<QColor> out;
  for (int i = 0; i <= 4; ++i) out.push_back(QColor::fromRgba(sliceColor(i / 4.0)));
  return out;
}

/// Mean irradiance (W/m²) of an SH: pi times its mean radiance (the L00 term's luminance).
double meanIrradiance(const ShRgb& sh) {
  return kPi * luminance(sh.c[0]) * 0.282095;
}

QString number(double x) {
  return QString::number(x, 'g', 3);
}
}  // namespace

QRgb Viewport::legendColor(double value, double red) {
  return sliceColor(red > 0 ? value / red : 0.0);
}

void Viewport::setLegendsVisible(bool on) {
  legendsVisible_ = on;
  update();
}

std::vector<Viewport::Legend> Viewport::legends() {
  std::vector<Legend> out;
  if (!doc_->hasScene()) return out;
  if (const ShGrid* grid = shadingGrid()) {
    double lo = 1e300, hi = 0;
    for (const ShRgb& sh : grid->sh) {
      const double e = meanIrradiance(sh);
      if (e <= 0) continue;
      lo = std::min(lo, e);
      hi = std::max(hi, e);
    }
    if (hi > 0) {
      Legend l;
      const QString stops = QString::number(double(exposureStops_), 'f', 1);
      l.title = shading() == Shading::Probes
                    ? tr("Probe lighting: mean irradiance (exposure %1 stops)").arg(stops)
                    : tr("Scene's lights (direct and one bounce): mean irradiance (exposure %1 "
                         "stops)")
                          .arg(stops);
      l.unit = QStringLiteral("W/m²");
      l.lo = lo;
      l.hi = hi;
      l.clampsAbove = false;
      l.ramp = {rgbF(0.02, 0.02, 0.02), rgbF(0.35, 0.35, 0.35), rgbF(0.95, 0.95, 0.95)};
      out.push_back(l);
    }
  }
  if (overlay(Overlay::Glyphs)) {
    if (glyphScale_ < 0) {
      std::vector<double> mags;
      for (const GlyphSample& g : currentGlyphSamples(nullptr))
        if (const double m = length(g.f); m > 1e-12) mags.push_back(m);
      glyphScale_ = 0;
      if (!mags.empty()) {
        const size_t k = mags.size() * 95 / 100;
        std::nth_element(mags.begin(), mags.begin() + long(k), mags.end());
        glyphScale_ = mags[k];
      }
    }
    if (glyphScale_ > 0) {
      Legend l;
      l.title = glyphsAtProbes_
                    ? tr("Gradient glyphs at the probes: |f| (Chajdas eq. 1), full length at p95")
                    : tr("Gradient glyphs: |f| (Chajdas eq. 1), full length at p95");
      l.unit = QStringLiteral("W/m²");
      l.lo = 0;
      l.hi = glyphScale_;
      l.ramp = {rgbF(0.15, 0.25, 0.9), rgbF(0.1, 0.85, 0.95), rgbF(1.0, 0.9, 0.15),
                rgbF(1.0, 0.2, 0.1)};
      out.push_back(l);
    }
  }
  if (overlay(Overlay::Slice) && previewVolume_) {
    static const char* axes[3] = {"x", "y", "z"};
    const auto c = sliceCorners();
    const QString where =
        tr("%1 = %2 m").arg(QLatin1String(axes[sliceAxis_])).arg(number(c[0][sliceAxis_]));
    Legend l;
    l.unit = tr("stops");
    l.ramp = sliceRamp();
    l.lo = 0;
    if (sliceMode_ == SliceMode::LuminanceDistance) {
      quint64 selected = 0;
      for (const Probe& p : doc_->probes())
        if (selection_.contains(p.id) && p.sh) {
          selected = p.id;
          break;
        }
      l.title = selected
                    ? tr("Slice at %1: luminance distance to probe %2").arg(where).arg(selected)
                    : tr("Slice at %1: luminance distance to the probes' mean").arg(where);
      l.hi = kSliceDistanceStopsRed;
    } else {
      l.title =
          referenceVolume_
              ? tr("Slice at %1: error of the accepted probes against all captured").arg(where)
              : tr("Slice at %1: error (no reference: capture more probes)").arg(where);
      l.hi = kSliceErrorStopsRed;
      l.mark = kVisibleStops;
      l.markLabel = tr("visible from ⅓ stop");
    }
    out.push_back(l);
  }
  if (overlay(Overlay::ErrorPoints) && !doc_->evaluations().empty()) {
    const EvaluationPoint& e = doc_->evaluations().back();
    Legend l;
    l.title = tr("Evaluation errors: %1 queries, %2 probes (%3)")
                  .arg(e.queries.size())
                  .arg(e.probes)
                  .arg(e.source);
    l.unit = tr("stops");
    l.lo = 0;
    l.hi = kSliceErrorStopsRed;
    l.ramp = sliceRamp();
    l.mark = kVisibleStops;
    l.markLabel = tr("visible from ⅓ stop");
    out.push_back(l);
  }
  if (overlay(Overlay::TestObject) && drawnPreviewVolume()) {
    Legend l;
    l.title = tr("Test object: a white sphere lit by the preview volume at (%1, %2, %3) m")
                  .arg(testObject_.x, 0, 'f', 2)
                  .arg(testObject_.y, 0, 'f', 2)
                  .arg(testObject_.z, 0, 'f', 2);
    l.swatches = {{rgbF(1.0, 1.0, 1.0), tr("albedo 1, drag it to move it")}};
    out.push_back(l);
  }
  if (overlay(Overlay::Domain) && doc_->tracer()) {
    Legend l;
    l.title = doc_->probeSet().importanceVolumes.empty()
                  ? tr("Domain of interest: the space a player can reach")
                  : tr("Domain of interest: the importance volumes");
    l.swatches = {{rgbF(0.25, 0.9, 0.55), tr("its shell (cell faces)")}};
    out.push_back(l);
  }
  if (overlay(Overlay::TetMesh) && previewVolume_) {
    Legend l;
    l.title = tr("Tetrahedra of the preview volume: %L1").arg(previewVolume_->tets.size());
    l.swatches = {{rgbF(0.8, 0.8, 0.85), tr("edge")},
                  {rgbF(1.0, 0.15, 0.1), tr("crosses geometry (leak)")},
                  {rgbF(1.0, 0.6, 0.1), tr("probes > %1 stops apart").arg(kEdgeStopsTooFar)}};
    out.push_back(l);
  }
  return out;
}

QString Viewport::emptyOverlayReason() const {
  if (!doc_->hasScene() || (!previewLighting_ && overlays_ == 0)) return {};
  if (overlay(Overlay::ErrorPoints) && doc_->evaluations().empty())
    return tr("The error points have nothing to show: no evaluation yet. Evaluate (Ctrl+E).");
  if (overlays_ == (1u << int(Overlay::ErrorPoints)) && !previewLighting_) return {};
  if (overlays_ == (1u << int(Overlay::TestObject)) && !previewLighting_ && previewVolume_)
    return {};
  if (overlays_ == 0 && flatShading_) return {};
  if (overlays_ == 0 && !previewVolume_ && doc_->scene() &&
      !hasAnyLight(*doc_->scene(), doc_->probeSet().rig))
    return tr(
        "The view shows flat colours: the scene has no light of its own. Add a sun, a sky "
        "or a point light in the Lighting tab.");
  const QString what = previewLighting_ && overlays_ == 0
                           ? tr("The probe lighting (the scene's own light is shown meanwhile)")
                           : tr("The preview and overlays");
  if (previewSource_ == PreviewSource::Baked) {
    if (!doc_->volume())
      return tr("%1 show the baked volume, and there is none: bake (Ctrl+B), open one "
                "(Probes › Open volume) or use the captured probes (View › Preview and overlays "
                "use).")
          .arg(what);
    return {};
  }
  size_t captured = 0, acceptedCaptured = 0, any = 0;
  std::vector<Vec3> points;
  for (const Probe& p : doc_->probes()) {
    if (p.state == ProbeState::Rejected) continue;
    ++any;
    if (!p.sh) continue;
    ++captured;
    const bool accepted = p.state == ProbeState::Accepted;
    acceptedCaptured += accepted ? 1 : 0;
    if (previewSource_ == PreviewSource::AllCaptured || accepted) points.push_back(p.position);
  }
  if (any == 0)
    return tr("%1 have nothing to show: there are no probes. Run placement (Ctrl+R) or add "
              "probes (N).")
        .arg(what);
  if (captured == 0)
    return tr("%1 have nothing to show: the probes carry no captures. Capture them with "
              "Lighting › Recapture probes with this lighting, or open a baked volume (Probes › "
              "Open volume).")
        .arg(what);
  if (previewSource_ == PreviewSource::Accepted && acceptedCaptured < 4)
    return tr("%1 use the accepted probes, and only %2 of them are captured: accept at least 4 "
              "(A), or use all captured probes (View › Preview and overlays use).")
        .arg(what)
        .arg(acceptedCaptured);
  if (points.size() < 4)
    return tr("%1 need at least 4 captured probes, there are %2: capture more with Lighting › "
              "Recapture probes with this lighting.")
        .arg(what)
        .arg(points.size());
  if (!pointsSpan3D(points))
    return tr("%1 have nothing to show: the captured probes lie in one plane. Add a probe above "
              "or below them (Shift+N at the camera).")
        .arg(what);
  return {};
}

std::vector<std::optional<QPointF>> Viewport::errorPointPixels() const {
  std::vector<std::optional<QPointF>> out;
  if (!overlay(Overlay::ErrorPoints) || doc_->evaluations().empty()) return out;
  const float cut = cutHeight();
  for (const QueryError& q : doc_->evaluations().back().queries)
    out.push_back(cutaway_ && q.point.y > cut ? std::nullopt : project(q.point));
  return out;
}

void Viewport::drawErrorPoints(QPainter& p) {
  const std::vector<std::optional<QPointF>> pixels = errorPointPixels();
  if (pixels.empty()) return;
  const std::vector<QueryError>& queries = doc_->evaluations().back().queries;
  const double r = 4.5;
  // The worst drawn last, on top.
  std::vector<size_t> order(queries.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return queries[a].stops < queries[b].stops; });
  for (size_t i : order) {
    if (!pixels[i]) continue;
    p.setPen(QPen(QColor(15, 15, 15, 220), 1.2));
    p.setBrush(QColor::fromRgb(sliceColor(queries[i].stops / kSliceErrorStopsRed)));
    p.drawEllipse(*pixels[i], r, r);
  }
  if (highlightedQuery_ >= 0 && size_t(highlightedQuery_) < pixels.size() &&
      pixels[size_t(highlightedQuery_)]) {
    p.setPen(QPen(QColor(0, 230, 255), 2.5));
    p.setBrush(Qt::NoBrush);
    p.drawEllipse(*pixels[size_t(highlightedQuery_)], r * 2.6, r * 2.6);
  }
}

void Viewport::drawLegends() {
  legendRects_.clear();
  const std::vector<Legend> all = legendsVisible_ ? legends() : std::vector<Legend>();
  if (all.empty() && !overlay(Overlay::ErrorPoints)) return;
  QPainter p(this);
  p.setRenderHint(QPainter::Antialiasing);
  drawErrorPoints(p);
  QFont font = p.font();
  font.setPointSizeF(8.5);
  p.setFont(font);
  const QFontMetrics fm(font);
  const int pad = 6, barH = 10, width = std::min(this->width() - 20, 330);
  int bottom = height() - 10;
  for (auto it = all.rbegin(); it != all.rend(); ++it) {
    const Legend& l = *it;
    // The title wraps to the box's width, never cut; below it the ramp's two lines or a line
    // per swatch.
    const int textWidth = width - 2 * pad;
    const int titleH =
        fm.boundingRect(QRect(0, 0, textWidth, 1 << 16), Qt::TextWordWrap, l.title).height();
    const int lines = l.ramp.empty() ? int(l.swatches.size()) : 2;
    const int h =
        pad * 2 + titleH + lines * fm.height() + (l.ramp.empty() ? 0 : barH - fm.height() + 4);
    const QRect box(10, bottom - h, width, h);
    legendRects_.push_back(box);
    p.setPen(Qt::NoPen);
    p.setBrush(QColor(20, 22, 28, 200));
    p.drawRoundedRect(box, 4, 4);
    p.setPen(QColor(235, 235, 235));
    int y = box.top() + pad;
    p.drawText(QRect(box.left() + pad, y, textWidth, titleH), Qt::AlignLeft | Qt::TextWordWrap,
               l.title);
    y += titleH + 2;
    if (!l.ramp.empty()) {
      const QRect bar(box.left() + pad, y, box.width() - 2 * pad, barH);
      QLinearGradient g(bar.topLeft(), bar.topRight());
      for (size_t i = 0; i < l.ramp.size(); ++i)
        g.setColorAt(l.ramp.size() > 1 ? double(i) / double(l.ramp.size() - 1) : 0.0, l.ramp[i]);
      p.setPen(Qt::NoPen);
      p.setBrush(g);
      p.drawRect(bar);
      if (l.mark && l.hi > l.lo) {
        const int x = bar.left() + int(bar.width() * (*l.mark - l.lo) / (l.hi - l.lo));
        p.setPen(QPen(Qt::white, 2));
        p.drawLine(x, bar.top() - 2, x, bar.bottom() + 2);
      }
      y += barH + 2;
      p.setPen(QColor(235, 235, 235));
      const QRect labels(bar.left(), y, bar.width(), fm.height());
      p.drawText(labels, Qt::AlignLeft | Qt::AlignVCenter, number(l.lo));
      p.drawText(labels, Qt::AlignRight | Qt::AlignVCenter,
                 QStringLiteral("%1%2 %3").arg(
                     number(l.hi), l.clampsAbove ? QStringLiteral("+") : QString(), l.unit));
      if (!l.markLabel.isEmpty())
        p.drawText(labels, Qt::AlignHCenter | Qt::AlignVCenter, l.markLabel);
    } else {
      for (const auto& [colour, text] : l.swatches) {
        p.setPen(Qt::NoPen);
        p.setBrush(colour);
        p.drawRect(box.left() + pad, y + fm.height() / 2 - 3, 14, 6);
        p.setPen(QColor(235, 235, 235));
        p.drawText(QRect(box.left() + pad + 20, y, box.width() - 2 * pad - 20, fm.height()),
                   Qt::AlignLeft | Qt::AlignVCenter, text);
        y += fm.height();
      }
    }
    bottom = box.top() - 6;
  }
}

}  // namespace ps::ui
