#pragma once
// The lighting dock. It lists the scene's own lights (glTF KHR_lights_punctual) and edits the
// one picked in the list: a point or spot light's position, colour and intensity, a sun's
// direction, colour and irradiance, one undoable step per change (Document::setSceneLights; the
// edit lasts for the session, the scene file keeps its own). Below, it edits the rig's sun, sky
// and point lights: the probe set's LightingRig, one undoable step per change
// (Document::setRig). Every capture, bake and
// evaluation lights the scene with both, the scene's lights and the rig's (allLights), and a
// line under the list says which those are. Conventions as the command line's --sun / --env /
// --point (README):
//   sun: azimuth and elevation of the direction from the scene towards the sun, irradiance E
//        (W/m^2) on a surface facing it, and a colour; stored as a Directional light named "sun"
//        whose direction is the one the light travels (the negation);
//   sky: a constant radiance per channel;
//   point lights: position, radiant intensity (W/sr) and colour.
#include <QWidget>

#include "core/scene/LightingRig.h"

class QDoubleSpinBox;
class QFormLayout;
class QGroupBox;
class QListWidget;
class QLabel;
class QPushButton;
class QTableWidget;

namespace ps::ui {

class Document;

class LightingPanel : public QWidget {
  Q_OBJECT
 public:
  explicit LightingPanel(Document* doc, QWidget* parent = nullptr);

  /// The rig the widgets describe.
  LightingRig rigFromWidgets() const;

  /// The direction from the scene towards a sun at azimuth / elevation (degrees): azimuth 0 is
  /// +Z, 90 is +X; elevation 90 is straight up (+Y).
  static Vec3 towardsSun(double azimuthDeg, double elevationDeg);

  // Widgets, for tests.
  /// The scene's lights, one row each: type, name, direction or position, intensity.
  QTableWidget* sceneLightsTable() const { return sceneLights_; }
  /// Which lights the captures use: the scene's and the rig's, in one or two lines.
  QLabel* capturesUseLabel() const { return capturesUse_; }
  /// The editor of the scene light picked in the list (hidden while none is): position (point,
  /// spot), azimuth and elevation of the direction towards it (sun), intensity (W/sr, or W/m²
  /// for a sun) and colour.
  QGroupBox* sceneLightGroup() const { return sceneLightBox_; }
  QDoubleSpinBox* sceneLightPosition(int axis) const { return sceneLightPos_[axis]; }
  QDoubleSpinBox* sceneLightAzimuth() const { return sceneLightAz_; }
  QDoubleSpinBox* sceneLightElevation() const { return sceneLightEl_; }
  QDoubleSpinBox* sceneLightIntensity() const { return sceneLightI_; }
  QDoubleSpinBox* sceneLightColour(int channel) const { return sceneLightColor_[channel]; }
  QGroupBox* sunGroup() const { return sunBox_; }
  QDoubleSpinBox* sunAzimuth() const { return sunAz_; }
  QDoubleSpinBox* sunElevation() const { return sunEl_; }
  QDoubleSpinBox* sunIrradiance() const { return sunE_; }
  QGroupBox* skyGroup() const { return skyBox_; }
  QDoubleSpinBox* skyRadiance(int channel) const { return sky_[channel]; }
  QListWidget* pointList() const { return points_; }
  QPushButton* addPointButton() const { return addPoint_; }
  QPushButton* removePointButton() const { return removePoint_; }
  QDoubleSpinBox* pointPosition(int axis) const { return pointPos_[axis]; }
  QDoubleSpinBox* pointIntensity() const { return pointI_; }
  QPushButton* recaptureButton() const { return recapture_; }

 private:
  void refresh();
  void refreshSceneLights();
  void refreshCapturesUse();
  void apply(const QString& text);
  void showPoint(int row);
  /// Shows the scene light of this row of the list in its editor (hides it for -1).
  void showSceneLight(int row);
  /// Which of a scene light's values an editor row sets.
  enum class SceneLightPart { Position, Direction, Intensity };
  /// Applies the editor's `part` (only it: the others keep the file's precision) to the list's
  /// current light; one undo step.
  void applySceneLight(SceneLightPart part);

  Document* doc_;
  QTableWidget* sceneLights_;
  QLabel* capturesUse_;
  QGroupBox* sceneLightBox_;
  QFormLayout* sceneLightForm_;
  QDoubleSpinBox *sceneLightPos_[3], *sceneLightAz_, *sceneLightEl_, *sceneLightI_,
      *sceneLightColor_[3];
  QWidget* sceneLightPosRow_;
  QGroupBox* sunBox_;
  QDoubleSpinBox *sunAz_, *sunEl_, *sunE_, *sunColor_[3];
  QGroupBox* skyBox_;
  QDoubleSpinBox* sky_[3];
  QListWidget* points_;
  QPushButton *addPoint_, *removePoint_, *recapture_;
  QDoubleSpinBox *pointPos_[3], *pointI_, *pointColor_[3];
  std::vector<Light> pointLights_;  ///< the rig's point lights, as shown in the list
  std::vector<Light> otherLights_;  ///< rig lights the panel does not edit (kept as they are)
  bool refreshing_ = false;
};

}  // namespace ps::ui
