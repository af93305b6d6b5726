#pragma once
// The 3D viewport: the scene lit by the probes' interpolated light, or before any capture by the
// scene's own lights (SceneLighting.h), or in flat colours (albedo x headlight + key light), and
// the probes as instanced spheres shaded by their own SH irradiance, tone mapped (exposure
// metered from the lit surfaces in view, ACES, sRGB); the sun's direction gizmo; the sky as the
// background. Turns document data into GL buffers and nothing more (STYLE.md rule 10).
// OpenGL 3.3 core; GL resources are made in initializeGL and freed on aboutToBeDestroyed.
// Viewport.cpp: the widget, its camera and picking; ViewportGL.cpp: the drawing;
// ViewportInput.cpp: mouse and keys; ViewportOverlays.cpp: the lighting preview and overlays.
#include <QFutureWatcher>
#include <QOpenGLFunctions_3_3_Core>
#include <QOpenGLWidget>
#include <QSet>
#include <QSurfaceFormat>
#include <atomic>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "core/io/ProbeSet.h"
#include "ui/DragHandle.h"
#include "ui/LightingField.h"
#include "ui/OrbitCamera.h"
#include "ui/SceneLighting.h"

class QRubberBand;
class QTimer;

class QPainter;

namespace ps::ui {

class Document;

class Viewport : public QOpenGLWidget, protected QOpenGLFunctions_3_3_Core {
  Q_OBJECT
 public:
  /// OpenGL 3.3 core, 24-bit depth, 4x MSAA: set it as the default before QApplication.
  static QSurfaceFormat surfaceFormat();

  explicit Viewport(Document* doc, QWidget* parent = nullptr);
  ~Viewport() override;

  QSize sizeHint() const override { return {1024, 768}; }

  const QSet<quint64>& selection() const { return selection_; }
  void setSelection(const QSet<quint64>& ids);

  OrbitCamera& camera() { return camera_; }
  /// Frames the scene bounds from the current angles (the default 3/4 view from above at load).
  void frameAll();
  /// Frames the selected probes, or everything when nothing is selected.
  void frameSelection();
  /// Frames a ball of `radius` metres around `centre` (a query of the evaluation).
  void framePoint(Vec3 centre, double radius);
  /// Where the ErrorPoints overlay draws each query of the last evaluation (widget pixels; none
  /// for a query behind the camera or above the cut-away), in eval's order.
  std::vector<std::optional<QPointF>> errorPointPixels() const;
  /// The colour the slice and the error points give `value` on a ramp that is red from `red` on.
  static QRgb legendColor(double value, double red);
  /// The query the artist picked (ringed in the ErrorPoints overlay); -1 for none.
  void setHighlightedQuery(int index);

  /// World to clip space for the current camera and widget size (project() divides by w).
  QMatrix4x4 viewProjection() const;
  /// Widget pixel (logical, origin top-left) of a world point, or nothing behind the camera.
  std::optional<QPointF> project(Vec3 world) const;
  /// True when the projected point lies inside the widget.
  bool onScreen(QPointF p) const { return rect().contains(p.toPoint()); }
  /// The probe whose sphere the ray under the pixel hits first, if any.
  std::optional<quint64> pickProbe(QPointF widgetPos) const;
  /// The drawn radius of a probe in metres, as this view draws it: its radius in the scene
  /// (worldRadius), enlarged where that would show less than kMinProbeRadiusPx pixels (times
  /// the state's and the selection's factor) so that probes stay visible when the view is far,
  /// as at Frame all, or small.
  float drawnRadius(const Probe& p) const;
  /// A probe's radius in the scene, metres: baseRadius() times 1 (accepted) or 0.7, times 1.25
  /// when selected.
  float worldRadius(const Probe& p) const;
  /// The smallest drawn radius of an accepted, unselected probe, in logical pixels.
  static constexpr float kMinProbeRadiusPx = 9.0f;

  /// What a left click does: select (and drag the move handle), add a probe on the surface, or
  /// (DrawVolume) drag out an importance volume's footprint from the surface point pressed.
  enum class Tool { Select, AddProbe, DrawVolume };
  void setTool(Tool t);
  Tool tool() const { return tool_; }

  /// The world ray through a widget pixel (origin on the near plane, unit direction).
  PickRay pickRay(QPointF widgetPos) const;
  /// pickRay() starting where the artist can see: with the cut-away on, a ray from above the
  /// cut height starts at the cut plane, so clicks go through the removed ceiling to the floor.
  PickRay surfaceRay(QPointF widgetPos) const;
  /// Probes whose centres project inside the widget rectangle (hidden probes excluded).
  QSet<quint64> probesInRect(const QRectF& widgetRect) const;

  /// The move handle: at the centre of the selected, unlocked probes; nothing when there are
  /// none. Its arm length in metres makes it about 90 pixels long on screen.
  std::optional<QVector3D> handleOrigin() const;
  float handleArmMeters() const;
  /// The handle part under a widget pixel (None without a handle).
  HandlePart handlePartAt(QPointF widgetPos) const;

  /// The arrow keys, while the view has the focus, move the selected unlocked probes by
  /// kNudgeMeters: Left and Right along the camera's right, Up and Down away from and towards
  /// the camera along the floor, with Shift up and down; one undo step per press. False when
  /// the key is no arrow or nothing selected can move.
  bool nudgeSelection(int key, Qt::KeyboardModifiers modifiers);
  static constexpr double kNudgeMeters = 0.1;

  /// Fly (WASD, Q/E down/up, Shift faster) while the right mouse button is held. Advances the
  /// camera by `seconds` for the keys held; returns true when it moved.
  bool flyStep(float seconds);
  /// Fly speed in metres per second (a third of the scene diagonal per second by default).
  float flySpeed() const;
  void setFlyKey(int key, bool down);

  // ---- lighting preview and overlays (ViewportOverlays.cpp) ----
  /// "Probe lighting" (on by default): surfaces shaded by the preview volume's interpolated
  /// irradiance (albedo x E(n) / pi + emission, tone mapped), sampled on a grid of
  /// previewResolution() cells along the longest side and filtered trilinearly on the GPU.
  /// Without a preview volume (before any capture), or with it off, the surfaces are lit by the
  /// scene's lights instead (Shading::SceneLights).
  void setPreviewLighting(bool on);
  bool previewLighting() const { return previewLighting_; }
  /// How the surfaces are drawn now: by the probes (Probe lighting with a preview volume), by
  /// the scene's and the rig's lights, direct and one bounce (sceneLightGrid(): the same
  /// shader and trilinear grid as the probes), or in flat colours (the flat toggle, or a scene
  /// without any light, or while its light grid is first computed).
  enum class Shading { Probes, SceneLights, Flat };
  Shading shading() const;
  /// Flat colours (albedo under a headlight and a fixed key light, no exposure) instead of light.
  void setFlatShading(bool on);
  bool flatShading() const { return flatShading_; }
  /// The scene's own light on a grid of kSceneLightCells cells along the longest side
  /// (directLightGrid, SceneLighting.h), brought up to date now: computed on a worker thread when
  /// the scene or the rig changes, and waited for here. Empty without a tracer or any light.
  const ShGrid& sceneLightGrid();
  static constexpr int kSceneLightCells = 64;
  /// ErrorPoints: the last evaluation's queries (Document::evaluations()), a dot each, coloured
  /// by their error in stops (blue at 0, red from 1 stop).
  enum class Overlay { Glyphs, Slice, TetMesh, TestObject, ErrorPoints, Domain };
  void setOverlay(Overlay o, bool on);
  bool overlay(Overlay o) const { return overlays_ & (1u << int(o)); }
  /// Which probes the preview volume uses (accepted only, or all captured).
  void setPreviewSource(PreviewSource s);
  PreviewSource previewSource() const { return previewSource_; }
  /// Cells along the longest side of the glyph grid (one glyph per cell).
  void setGlyphResolution(int cells);
  int glyphResolution() const { return glyphResolution_; }
  /// Slice: axis (0 x, 1 y, 2 z) and position as a fraction of the scene's extent on that axis.
  enum class SliceMode { LuminanceDistance, Error };
  void setSliceMode(SliceMode m);
  SliceMode sliceMode() const { return sliceMode_; }
  void setSliceAxis(int axis);
  int sliceAxis() const { return sliceAxis_; }
  void setSliceFraction(float f);
  float sliceFraction() const { return sliceFraction_; }
  /// The slice's four corners in world space (scene bounds on the other two axes).
  std::array<Vec3, 4> sliceCorners() const;
  /// The test object (a sphere lit by the preview volume): centre and radius in metres.
  void setTestObjectPosition(Vec3 p);
  Vec3 testObjectPosition() const { return testObject_; }
  float testObjectRadius() const;
  /// The preview volume (nothing when fewer than 4 probes span 3D) and the derived data, brought
  /// up to date with the document first.
  const std::optional<ProbeVolume>& previewVolume();
  /// Glyph centres and f vectors (for the screenshot's sidecar and tests).
  const ShGrid& glyphGrid();
  /// The lit preview's grid (the preview volume sampled, Probe lighting), now.
  const ShGrid& previewGrid();
  /// Glyphs over the dense grid (default) or over the captured probes themselves.
  void setGlyphsAtProbes(bool on);
  bool glyphsAtProbes() const { return glyphsAtProbes_; }
  struct GlyphSample {
    Vec3 centre;
    Vec3 f;  ///< luminanceDirection of the SH there
  };
  /// Where the glyphs are drawn and their f; `arrowMeters` (optional) receives the arrow length
  /// at full magnitude.
  std::vector<GlyphSample> glyphSamples(double* arrowMeters = nullptr);
  /// The tetrahedron around the test object (-1 without a volume).
  int32_t testObjectTet();
  /// The data behind the preview and the overlays (ViewportOverlays.cpp).
  struct Fields;
  /// Starts rebuilding the fields on a worker thread when they are out of date (paintGL calls
  /// it: the frame keeps the previous fields until fieldsUpdated()).
  void startFieldsRebuild();
  /// The fields drawn are those of the document as it is now: nothing changed since they were
  /// computed and no background rebuild's result waits to be applied. Brings nothing up to date.
  bool fieldsCurrent() const { return !fieldsDirty_ && !fieldsPending_; }
  /// A background rebuild was started and the end of it has not been handled yet: true from
  /// startFieldsRebuild() until its finished signal reaches the view, also when updateFields()
  /// took its result before (the handler then drops it).
  bool isFieldsRebuildRunning() const { return fieldsRebuildRunning_; }
  /// The view computes nothing in the background: no fields rebuild and no scene light grid
  /// under way, the fields current.
  bool isSettled() const { return fieldsCurrent() && !fieldsRebuildRunning_ && !sceneGridPending_; }
  /// The preview volume as it is now, without bringing it up to date.
  bool hasPreviewVolume() const { return previewVolume_.has_value(); }
  /// The preview volume the test object is lit by now, without bringing it up to date: during
  /// and after a handle drag, until the next fields, the volume edited in place at each step;
  /// else the last fields' (nullptr when there is none).
  const ProbeVolume* drawnPreviewVolume() const;

  /// The slice's texture (size x size, u along sliceCorners()[0] -> [1], v along [0] -> [3]):
  /// luminance distance to the selected probe (or the volume's mean when none is selected), blue
  /// at 0 to red at 4 stops; or the error in stops (errorStops, PerceptualError.h) of the preview
  /// volume's irradiance for the slice's normal against the all-captured one's, blue at 0 to red
  /// at 1 stop. Transparent without a volume.
  QImage renderSliceImage(int size);

  /// One overlay's legend, drawn in the view's lower left corner: a title, a colour ramp from
  /// `lo` to `hi` in `unit` (with `mark` flagged on it), or named colour swatches.
  struct Legend {
    QString title;
    QString unit;
    double lo = 0, hi = 0;
    bool clampsAbove = true;   ///< values above `hi` take its colour ("hi+")
    std::vector<QColor> ramp;  ///< colours evenly from lo to hi; empty: swatches only
    std::optional<double> mark;
    QString markLabel;
    std::vector<std::pair<QColor, QString>> swatches;
  };
  /// The legends of the preview and the overlays shown now, from the last fields.
  std::vector<Legend> legends();
  /// Draw the legends (on by default).
  void setLegendsVisible(bool on);
  bool legendsVisible() const { return legendsVisible_; }
  /// Where the last frame drew its legends (widget pixels).
  const std::vector<QRect>& legendRects() const { return legendRects_; }
  /// Why the preview and the overlays shown have nothing to draw, in one line with the action
  /// that fixes it; empty when they have something (or none is shown).
  QString emptyOverlayReason() const;

  /// Renders one frame into the widget's framebuffer now (makeCurrent, paintGL, glFinish);
  /// for the frame-time benchmark.
  void renderNow();

  void setProbesVisible(bool on);
  void setRejectedVisible(bool on);
  bool rejectedVisible() const { return rejectedVisible_; }
  /// True when the probe is inside geometry: more than tol::kDefaultInvalidBackfaceFraction of
  /// 32 rays from it hit back faces (Kontkanen & Laine sec. 5). Cached per probe and position;
  /// false without a tracer. Invalid probes are drawn with a magenta ring and cross.
  bool isInvalid(const Probe& p) const;
  /// True when the probe is drawn (and pickable) with the current toggles.
  bool isDrawn(const Probe& p) const;
  bool probesVisible() const { return probesVisible_; }
  void setCutaway(bool on);
  bool cutaway() const { return cutaway_; }
  /// Height of the cut-away as a fraction of the scene's height (default 0.75).
  void setCutFraction(float f);
  float cutFraction() const { return cutFraction_; }
  /// World height above which the cut-away hides the scene.
  float cutHeight() const;
  /// Exposure offset in stops on top of the automatic exposure.
  void setExposureStops(float stops);
  float exposureStops() const { return exposureStops_; }
  /// The linear scale applied to radiance before tone mapping: the automatic exposure times
  /// 2^exposureStops().
  float exposure() const;
  /// The automatic exposure, metered from what the view shows: meterExposure (SceneLighting.h)
  /// over the lit surfaces seen through a grid of kMeterColumns x kMeterRows pixels (through the
  /// cut-away as clicks go), lit by the grid the surfaces are drawn with (the probes', else the
  /// scene lights'). Metered again when the view or the light changes; 1 before any light.
  float autoExposure() const { return autoExposure_; }
  /// Meters the exposure now for the current view and light (paintGL does it when needed).
  void meterExposureNow();
  static constexpr int kMeterColumns = 48, kMeterRows = 36;

  // ---- the sun gizmo ----
  /// A sun drawn in the view: a disc where the sun is seen from the scene's centre (at
  /// sunGizmoDistance() from it) with an arrow along the light's path. The rig's sun (the first
  /// directional light of the rig, which the Lighting tab edits) can be dragged: the disc
  /// follows the cursor over the sphere of that radius, and the release sets the rig's sun
  /// direction as one undo step ("Move sun"). The scene's own suns are drawn dimmer and do not
  /// move (a glTF's lights are read-only).
  struct SunGizmo {
    Vec3 towardsSun;  ///< unit, from the scene towards the sun
    bool editable = false;
  };
  std::vector<SunGizmo> sunGizmos() const;
  /// Where the rig's sun's disc is drawn (world), or nothing when the rig has no sun.
  std::optional<Vec3> sunGizmoPosition() const;
  Vec3 sunGizmoCentre() const;
  double sunGizmoDistance() const;
  /// The disc's radius on screen (logical pixels); a press within it plus 4 px grabs it.
  static constexpr float kSunDiscPx = 13.0f;

  // ---- the slice plane ----
  /// True when the widget pixel lies within kSliceGrabPx of the slice's outline (drawn while
  /// the Slice overlay is on); a drag from there moves the slice along its axis.
  bool onSliceOutline(QPointF widgetPos) const;
  static constexpr float kSliceGrabPx = 6.0f;
  /// Background gradient (top and bottom of the viewport, sRGB).
  static QColor backgroundTop();
  static QColor backgroundBottom();

 signals:
  /// The user clicked in the viewport: the probe under the cursor (nothing = empty space).
  void probeClicked(std::optional<quint64> id, Qt::KeyboardModifiers modifiers);
  /// Ctrl + drag drew a box: the probes inside it (Shift as well: add to the selection).
  void boxSelected(const QSet<quint64>& ids, Qt::KeyboardModifiers modifiers);
  /// In the AddProbe tool, the user clicked: the ray through the cursor.
  void addProbeRequested(const ps::ui::PickRay& ray);
  /// In the DrawVolume tool, a drag ended: the box whose footprint the drag spanned on the
  /// horizontal plane through the surface point pressed, from that point up to the scene's top.
  void volumeDrawn(const ps::Bounds3& box);
  /// New lighting fields were applied (applyFields): a background rebuild arrived, or
  /// updateFields() took or computed them.
  void fieldsUpdated();
  /// The preview, an overlay, the slice's mode or the preview's source was switched.
  void overlaysToggled();
  /// The slice moved (a drag of its outline, setSliceFraction or setSliceAxis): its axis and its
  /// position as a fraction of the scene's extent on that axis.
  void sliceChanged(int axis, float fraction);
  /// The scene's direct light grid was recomputed (sceneLightGrid()).
  void sceneLightingUpdated();
  /// The preview volume was brought up to date with the document by local edits
  /// (EditableProbeVolume) rather than rebuilt: the wall time of the edits and the tet slots
  /// they rewrote.
  void previewVolumeEdited(double seconds, qsizetype tetsRewritten);

 protected:
  void initializeGL() override;
  void resizeGL(int w, int h) override;
  void paintGL() override;
  void mousePressEvent(QMouseEvent* e) override;
  void mouseMoveEvent(QMouseEvent* e) override;
  void mouseReleaseEvent(QMouseEvent* e) override;
  void wheelEvent(QWheelEvent* e) override;
  void keyPressEvent(QKeyEvent* e) override;
  void keyReleaseEvent(QKeyEvent* e) override;
  bool event(QEvent* e) override;
  void focusOutEvent(QFocusEvent* e) override;

 private:
  static QVector3D toQ(Vec3 v) { return QVector3D(float(v.x), float(v.y), float(v.z)); }
  void cleanup();
  void uploadScene();
  void uploadProbes();
  void clipPlanes(float& nearDist, float& farDist) const;
  float baseRadius() const;
  void updateBaseRadius();
  /// Metres per logical pixel at unit distance along the view direction (perspective).
  float metresPerPixelPerMetre() const;
  /// Starts computing the scene's direct light grid on a worker thread when it is out of date.
  void startSceneLightRebuild();
  /// The grid the surfaces are lit by (Probes, SceneLights), else nullptr.
  const ShGrid* shadingGrid() const;
  /// The grid the exposure is metered with: shadingGrid(), or in flat colours the probes' or the
  /// scene lights' grid, whichever exists.
  const ShGrid* meteringGrid() const;
  void drawSunGizmos(const QMatrix4x4& vp);
  void drawSliceOutline(const QMatrix4x4& vp);
  void uploadSliceTexture();
  /// The point on the sun sphere under the cursor nearest to `near` (the silhouette when the ray
  /// misses the sphere).
  Vec3 sunSpherePoint(const PickRay& ray, Vec3 near) const;
  void uploadEnvironment();
  void onProbesChanged();
  void drawHandle(const QMatrix4x4& vp);
  /// Brings the lighting fields up to date now (waits for a background rebuild).
  void updateFields();

  void applyFields(Fields&& f);
  /// glyphSamples() from the fields as they are (the frame does not wait for a rebuild).
  std::vector<GlyphSample> currentGlyphSamples(double* arrowMeters);
  /// Brings mirror_ up to date with the document (local edits); emits previewVolumeEdited.
  void syncMirror();
  /// syncMirror(), then a copy of its volume for the fields (nothing when there is none); the
  /// fields take it by move, so this is the only copy.
  std::optional<ProbeVolume> previewForFields();
  void uploadOverlays();
  void drawOverlays(const QMatrix4x4& vp);
  /// The legends and the error points, with QPainter over the frame.
  void drawLegends();
  void drawErrorPoints(QPainter& p);
  void drawLines(const std::vector<float>& xyzrgba, GLenum mode, const QMatrix4x4& vp);
  /// The domain of interest's shell (ui/DomainOverlay.cpp).
  void drawDomain(const QMatrix4x4& vp);
  void initOverlayGL();
  /// Compiles and links a program; `common` prepends the version line and kCommonGlsl to the
  /// fragment shader. A shader that fails is a bug (qFatal with the log).
  GLuint buildProgram(const char* vs, const char* fsBody, bool common);
  void cleanupOverlayGL();
  bool isFlyKey(int key) const;

  Document* doc_;
  const Tracer* domainTracer_ = nullptr;  ///< the scene domainLines_ were made for
  size_t domainVolumes_ = 0;              ///< and its importance volumes' count
  std::vector<float> domainLines_;        ///< drawLines vertices of the domain's shell
  OrbitCamera camera_;
  QSet<quint64> selection_;
  bool probesVisible_ = true;
  bool previewLighting_ = true;
  bool flatShading_ = false;
  // The scene's direct light (sceneLightGrid), rebuilt on a worker thread when dirty.
  ShGrid sceneGrid_;
  bool sceneGridDirty_ = true, sceneGridPending_ = false;
  QFutureWatcher<std::shared_ptr<ShGrid>>* sceneGridWatcher_ = nullptr;
  std::shared_ptr<std::atomic<bool>> sceneGridCancel_;
  /// What the lighting textures hold (uploadOverlays), and the view they were metered in.
  Shading uploadedShading_ = Shading::Flat;
  quint64 lightingVersion_ = 0, meteredVersion_ = ~quint64(0);
  QMatrix4x4 meteredView_;
  QSize meteredSize_;
  unsigned overlays_ = 0;
  PreviewSource previewSource_ = PreviewSource::AllCaptured;
  int glyphResolution_ = 20;
  bool glyphsAtProbes_ = false;
  int previewResolution_ = 40;
  SliceMode sliceMode_ = SliceMode::LuminanceDistance;
  int sliceAxis_ = 1;
  float sliceFraction_ = 0.35f;
  Vec3 testObject_;
  bool testObjectPlaced_ = false;
  // Derived lighting data (LightingField.h), rebuilt when fieldsDirty_.
  bool fieldsDirty_ = true, overlaysDirty_ = true;
  std::optional<ProbeVolume> previewVolume_, referenceVolume_;
  // The preview volume kept in step with the document by local edits; the fields take a copy
  // of it instead of rebuilding it. A handle drag syncs it at every step (the fields are
  // rebuilt only when the drag ends), and it is drawn for the test object until the next
  // fields arrive (mirrorAhead_).
  PreviewVolumeMirror mirror_;
  bool mirrorAhead_ = false;
  ShGrid glyphGrid_, previewGrid_;
  bool legendsVisible_ = true;
  std::vector<QRect> legendRects_;
  int highlightedQuery_ = -1;
  /// The glyphs' full-length magnitude (95th percentile of |f|), for their legend; recomputed
  /// when negative.
  double glyphScale_ = -1;
  std::vector<std::array<int32_t, 2>> edges_;
  std::vector<uint8_t> leaks_;
  std::vector<float> edgeStops_;
  int32_t testTetHint_ = -1;
  mutable std::unordered_map<uint64_t, std::pair<Vec3, bool>> validity_;
  QFutureWatcher<std::shared_ptr<Fields>>* fieldsWatcher_ = nullptr;
  bool fieldsPending_ = false;         ///< a background rebuild's result is not applied yet
  bool fieldsRebuildRunning_ = false;  ///< isFieldsRebuildRunning()
  bool rejectedVisible_ = true;
  Tool tool_ = Tool::Select;
  bool cutaway_ = true;
  float cutFraction_ = 0.75f;
  bool sceneClosed_ = false;
  float exposureStops_ = 0.0f;
  float autoExposure_ = 1.0f;
  float baseRadius_ = 0.1f;
  bool framePending_ = true;
  bool sceneDirty_ = true;
  bool probesDirty_ = true;

  // GL objects (0 = none); owned, freed in cleanup().
  bool glReady_ = false;
  GLuint sceneProgram_ = 0, probeProgram_ = 0, backgroundProgram_ = 0;
  GLuint sceneVao_ = 0, sceneVbo_[3] = {0, 0, 0};  // positions, normals, indices
  GLuint materialTbo_ = 0, materialTex_ = 0, triMaterialTbo_ = 0, triMaterialTex_ = 0;
  GLsizei sceneIndexCount_ = 0;
  GLuint sphereVao_ = 0, sphereVbo_ = 0, sphereIbo_ = 0, instanceVbo_ = 0;
  GLsizei sphereIndexCount_ = 0, instanceCount_ = 0;
  GLuint emptyVao_ = 0;
  GLuint impostorVao_ = 0, quadVbo_ = 0, instanceTex_ = 0;
  GLuint lineProgram_ = 0, lineVao_ = 0, lineVbo_ = 0;  // coloured lines and triangles
  GLuint glyphProgram_ = 0, glyphVao_ = 0, glyphMeshVbo_ = 0, glyphInstanceVbo_ = 0;
  GLsizei glyphCount_ = 0, glyphMeshCount_ = 0;
  GLuint previewTex_[7] = {0, 0, 0, 0, 0, 0, 0};  // 3D RGBA32F: 27 SH floats + 1 per cell
  bool previewTexValid_ = false;
  GLuint envTex_ = 0;  // the rig's environment map, RGB32F equirectangular
  std::shared_ptr<const EnvironmentMap> env_;
  std::string envKey_;  ///< the rig's map path and pointer env_ was taken for
  double envMeanLuminance_ = 0;
  GLuint sliceProgram_ = 0, sliceTex_ = 0;
  bool sliceTexDirty_ = true;
  GLuint meshVbo_ = 0;  // tet mesh lines
  GLsizei meshVertexCount_ = 0;
  GLuint testVao_ = 0, testInstanceVbo_ = 0, testInstanceTex_ = 0;

  // Mouse interaction.
  QPointF pressPos_, lastPos_;
  Qt::MouseButton pressButton_ = Qt::NoButton;
  bool dragged_ = false;
  enum class Drag {
    None,
    Camera,
    Handle,
    Box,
    Look,
    TestObject,
    Volume,
    Sun,
    Slice
  } drag_ = Drag::None;
  // Sun drag: where the rig's sun is shown while dragged (towards the sun, unit).
  std::optional<Vec3> sunDragTowards_;
  // Slice drag: the fraction and the point of the outline where it started.
  float sliceDragStart_ = 0;
  // Volume drag: the surface point pressed and the point under the cursor on its level.
  Vec3 volumeStart_, volumeEnd_;
  Bounds3 drawnVolume() const;
  Vec3 testDragStart_;
  // Handle drag: the part, where it started, the probes moved and their start positions.
  HandlePart dragPart_ = HandlePart::None;
  QVector3D dragOrigin_;
  PickRay dragStartRay_;
  std::vector<std::pair<uint64_t, Vec3>> dragStart_;
  int dragKey_ = -1;
  QRubberBand* rubberBand_ = nullptr;
  // Fly keys held (bit per key) and the timer that moves the camera while any is held.
  unsigned flyKeys_ = 0;
  QTimer* flyTimer_ = nullptr;
};

}  // namespace ps::ui
