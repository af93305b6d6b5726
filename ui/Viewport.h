#pragma once
// The 3D viewport: the scene shaded (albedo x headlight + key light, plus a little emission) and
// the probes as instanced spheres shaded by their own SH irradiance, tone mapped (exposure,
// ACES, sRGB). Turns document data into GL buffers and nothing more (STYLE.md rule 10).
// OpenGL 3.3 core; GL resources are made in initializeGL and freed on aboutToBeDestroyed.
#include <QOpenGLFunctions_3_3_Core>
#include <QOpenGLWidget>
#include <QSet>
#include <QSurfaceFormat>
#include <optional>
#include <vector>

#include "core/io/ProbeSet.h"
#include "ui/OrbitCamera.h"

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

  /// Widget pixel (logical, origin top-left) of a world point, or nothing behind the camera.
  std::optional<QPointF> project(Vec3 world) const;
  /// True when the projected point lies inside the widget.
  bool onScreen(QPointF p) const { return rect().contains(p.toPoint()); }
  /// The probe whose sphere the ray under the pixel hits first, if any.
  std::optional<quint64> pickProbe(QPointF widgetPos) const;
  /// The drawn radius of a probe in metres (depends on its state and on the selection).
  float drawnRadius(const Probe& p) const;

  void setProbesVisible(bool on);
  bool probesVisible() const { return probesVisible_; }
  void setCutaway(bool on);
  bool cutaway() const { return cutaway_; }
  /// Height of the cut-away as a fraction of the scene's height (default 0.75).
  void setCutFraction(float f);
  float cutFraction() const { return cutFraction_; }
  /// World height above which the cut-away hides the scene.
  float cutHeight() const;
  /// Exposure offset in stops on top of the automatic exposure (from the probes' mean light).
  void setExposureStops(float stops);
  float exposureStops() const { return exposureStops_; }
  /// The linear scale applied to probe radiance before tone mapping.
  float exposure() const;
  /// Background gradient (top and bottom of the viewport, sRGB).
  static QColor backgroundTop();
  static QColor backgroundBottom();

 signals:
  /// The user clicked in the viewport: the probe under the cursor (nothing = empty space).
  void probeClicked(std::optional<quint64> id, Qt::KeyboardModifiers modifiers);

 protected:
  void initializeGL() override;
  void resizeGL(int w, int h) override;
  void paintGL() override;
  void mousePressEvent(QMouseEvent* e) override;
  void mouseMoveEvent(QMouseEvent* e) override;
  void mouseReleaseEvent(QMouseEvent* e) override;
  void wheelEvent(QWheelEvent* e) override;

 private:
  void cleanup();
  void uploadScene();
  void uploadProbes();
  QMatrix4x4 viewProjection() const;
  void clipPlanes(float& nearDist, float& farDist) const;
  float baseRadius() const;
  void updateBaseRadius();
  void updateAutoExposure();
  void onProbesChanged();

  Document* doc_;
  OrbitCamera camera_;
  QSet<quint64> selection_;
  bool probesVisible_ = true;
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

  // Mouse interaction.
  QPointF pressPos_, lastPos_;
  Qt::MouseButton pressButton_ = Qt::NoButton;
  bool dragged_ = false;
};

}  // namespace ps::ui
