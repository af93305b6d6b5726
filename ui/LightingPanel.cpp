#include "ui/LightingPanel.h"

#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QListWidget>
#include <QPushButton>
#include <QSignalBlocker>
#include <QTableWidget>
#include <QVBoxLayout>
#include <QtMath>
#include <cmath>

#include "ui/Document.h"

namespace ps::ui {

namespace {
QDoubleSpinBox* spin(double lo, double hi, double value, int decimals, const QString& suffix = {}) {
  auto* s = new QDoubleSpinBox;
  s->setRange(lo, hi);
  s->setDecimals(decimals);
  s->setValue(value);
  s->setSuffix(suffix);
  s->setKeyboardTracking(false);  // one change per Enter / focus change / arrow step
  // Three to a row in a dock a quarter of the window wide: narrower than their range's text.
  s->setMinimumWidth(56);
  return s;
}
QWidget* row(QDoubleSpinBox* const (&boxes)[3]) {
  auto* w = new QWidget;
  auto* h = new QHBoxLayout(w);
  h->setContentsMargins(0, 0, 0, 0);
  for (QDoubleSpinBox* b : boxes) h->addWidget(b);
  return w;
}
QString vec(Vec3 v, int decimals) {
  return QStringLiteral("(%1, %2, %3)")
      .arg(v.x, 0, 'f', decimals)
      .arg(v.y, 0, 'f', decimals)
      .arg(v.z, 0, 'f', decimals);
}
QString lightName(const Light& l) {
  return QString::fromStdString(l.name.empty() ? std::string("unnamed") : l.name);
}
QString typeName(LightType t) {
  switch (t) {
    case LightType::Directional:
      return QObject::tr("sun");
    case LightType::Point:
      return QObject::tr("point");
    case LightType::Spot:
      return QObject::tr("spot");
  }
  return {};
}
/// Azimuth (0 = +Z, 90 = +X) and elevation, in degrees, of the direction towards a directional
/// light that travels along `travels` (LightingPanel::towardsSun inverted).
std::pair<double, double> sourceAzimuthElevation(Vec3 travels) {
  const Vec3 t = -travels / std::max(length(travels), 1e-12);
  return {qRadiansToDegrees(std::atan2(t.x, t.z)),
          qRadiansToDegrees(std::asin(std::clamp(t.y, -1.0, 1.0)))};
}
/// A directional light's source as the sun group gives it.
QString sourceAngles(Vec3 travels) {
  const auto [az, el] = sourceAzimuthElevation(travels);
  return QObject::tr("from azimuth %1°, elevation %2°").arg(az, 0, 'f', 1).arg(el, 0, 'f', 1);
}
/// The strongest channel (the intensity the panel shows) and the colour it scales (white for
/// black).
std::pair<double, Rgb> intensityAndColour(Rgb intensity) {
  const double e = std::max({intensity.r, intensity.g, intensity.b});
  return {e, e > 0 ? intensity / e : Rgb(1, 1, 1)};
}
bool sameLight(const Light& a, const Light& b) {
  return a.type == b.type && a.position == b.position && a.direction == b.direction &&
         a.intensity == b.intensity;
}
}  // namespace

Vec3 LightingPanel::towardsSun(double azimuthDeg, double elevationDeg) {
  const double az = qDegreesToRadians(azimuthDeg), el = qDegreesToRadians(elevationDeg);
  return {std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az)};
}

LightingPanel::LightingPanel(Document* doc, QWidget* parent) : QWidget(parent), doc_(doc) {
  auto* layout = new QVBoxLayout(this);

  auto* sceneBox = new QGroupBox(tr("Scene lights"));
  sceneBox->setToolTip(tr("The scene file's lights; pick one to edit it"));
  auto* sceneLayout = new QVBoxLayout(sceneBox);
  sceneLights_ = new QTableWidget(0, 4);
  sceneLights_->setHorizontalHeaderLabels(
      {tr("Type"), tr("Name"), tr("Direction / position (m)"), tr("Intensity")});
  sceneLights_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  sceneLights_->setSelectionMode(QAbstractItemView::SingleSelection);
  sceneLights_->setSelectionBehavior(QAbstractItemView::SelectRows);
  sceneLights_->verticalHeader()->hide();
  sceneLights_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  sceneLights_->horizontalHeader()->setStretchLastSection(true);
  sceneLights_->setMaximumHeight(110);
  sceneLayout->addWidget(sceneLights_);
  // The picked scene light's editor: the rows its type has.
  sceneLightBox_ = new QGroupBox;
  sceneLightBox_->setToolTip(
      tr("Edits last for this session: captures, placement, bake and evaluation here use them; "
         "the scene file keeps its own lights. Each change is one undo step"));
  sceneLightForm_ = new QFormLayout(sceneLightBox_);
  sceneLightForm_->setRowWrapPolicy(
      QFormLayout::WrapLongRows);  // narrow docks: fields under labels
  for (int i = 0; i < 3; ++i) sceneLightPos_[i] = spin(-1e6, 1e6, 0, 3);
  sceneLightAz_ = spin(-360, 360, 0, 1, QStringLiteral("°"));
  sceneLightEl_ = spin(-90, 90, 45, 1, QStringLiteral("°"));
  sceneLightI_ = spin(0, 1e9, 1, 3);
  for (int i = 0; i < 3; ++i) sceneLightColor_[i] = spin(0, 100, 1, 3);
  sceneLightPosRow_ = row(sceneLightPos_);
  sceneLightForm_->addRow(tr("Position"), sceneLightPosRow_);
  sceneLightForm_->addRow(tr("Azimuth"), sceneLightAz_);
  sceneLightForm_->addRow(tr("Elevation"), sceneLightEl_);
  sceneLightForm_->addRow(tr("Intensity"), sceneLightI_);
  sceneLightForm_->addRow(tr("Colour (RGB)"), row(sceneLightColor_));
  sceneLightBox_->setVisible(false);
  sceneLayout->addWidget(sceneLightBox_);
  capturesUse_ = new QLabel;
  capturesUse_->setWordWrap(true);
  sceneLayout->addWidget(capturesUse_);
  layout->addWidget(sceneBox);

  sunBox_ = new QGroupBox(tr("Sun (rig)"));
  sunBox_->setCheckable(true);
  auto* sunForm = new QFormLayout(sunBox_);
  sunForm->setRowWrapPolicy(QFormLayout::WrapLongRows);  // narrow docks: fields under labels
  sunAz_ = spin(-360, 360, 30, 1, QStringLiteral("°"));
  sunEl_ = spin(-90, 90, 45, 1, QStringLiteral("°"));
  sunE_ = spin(0, 1e6, 5, 3, QStringLiteral(" W/m²"));
  for (int i = 0; i < 3; ++i) sunColor_[i] = spin(0, 100, 1, 3);
  sunForm->addRow(tr("Azimuth"), sunAz_);
  sunForm->addRow(tr("Elevation"), sunEl_);
  sunForm->addRow(tr("Irradiance"), sunE_);
  sunForm->addRow(tr("Colour (RGB)"), row(sunColor_));
  layout->addWidget(sunBox_);

  skyBox_ = new QGroupBox(tr("Sky (rig)"));
  skyBox_->setToolTip(tr("A constant radiance, W/m²/sr per channel"));
  skyBox_->setCheckable(true);
  auto* skyForm = new QFormLayout(skyBox_);
  skyForm->setRowWrapPolicy(QFormLayout::WrapLongRows);  // narrow docks: fields under labels
  for (int i = 0; i < 3; ++i) sky_[i] = spin(0, 1e6, 0.5, 3);
  skyForm->addRow(tr("RGB"), row(sky_));
  layout->addWidget(skyBox_);

  auto* pointBox = new QGroupBox(tr("Point lights (rig)"));
  auto* pointLayout = new QVBoxLayout(pointBox);
  points_ = new QListWidget;
  points_->setMaximumHeight(90);
  pointLayout->addWidget(points_);
  auto* buttons = new QHBoxLayout;
  addPoint_ = new QPushButton(tr("Add"));
  removePoint_ = new QPushButton(tr("Remove"));
  buttons->addWidget(addPoint_);
  buttons->addWidget(removePoint_);
  pointLayout->addLayout(buttons);
  auto* pointForm = new QFormLayout;
  pointForm->setRowWrapPolicy(QFormLayout::WrapLongRows);  // narrow docks: fields under labels
  for (int i = 0; i < 3; ++i) pointPos_[i] = spin(-1e6, 1e6, 0, 3);
  pointI_ = spin(0, 1e9, 10, 3, QStringLiteral(" W/sr"));
  for (int i = 0; i < 3; ++i) pointColor_[i] = spin(0, 100, 1, 3);
  pointForm->addRow(tr("Position"), row(pointPos_));
  pointForm->addRow(tr("Intensity"), pointI_);
  pointForm->addRow(tr("Colour (RGB)"), row(pointColor_));
  pointLayout->addLayout(pointForm);
  layout->addWidget(pointBox);
  recapture_ = new QPushButton(tr("Recapture probes with this lighting"));
  recapture_->setToolTip(
      tr("Quick capture (64 samples) of every non-rejected probe; one undo "
         "step"));
  layout->addWidget(recapture_);
  layout->addStretch(1);
  connect(recapture_, &QPushButton::clicked, this, [this] { doc_->recapture(64); });

  connect(sunBox_, &QGroupBox::toggled, this, [this] { apply(tr("Edit sun")); });
  for (QDoubleSpinBox* s : {sunAz_, sunEl_, sunE_, sunColor_[0], sunColor_[1], sunColor_[2]})
    connect(s, &QDoubleSpinBox::valueChanged, this, [this] { apply(tr("Edit sun")); });
  connect(skyBox_, &QGroupBox::toggled, this, [this] { apply(tr("Edit sky")); });
  for (QDoubleSpinBox* s : sky_)
    connect(s, &QDoubleSpinBox::valueChanged, this, [this] { apply(tr("Edit sky")); });
  for (QDoubleSpinBox* s : {pointPos_[0], pointPos_[1], pointPos_[2], pointI_, pointColor_[0],
                            pointColor_[1], pointColor_[2]})
    connect(s, &QDoubleSpinBox::valueChanged, this, [this] {
      const int r = points_->currentRow();
      if (refreshing_ || r < 0 || r >= int(pointLights_.size())) return;
      Light& l = pointLights_[size_t(r)];
      l.position = Vec3(pointPos_[0]->value(), pointPos_[1]->value(), pointPos_[2]->value());
      l.intensity = Rgb(pointColor_[0]->value(), pointColor_[1]->value(), pointColor_[2]->value()) *
                    pointI_->value();
      apply(tr("Edit point light"));
    });
  connect(points_, &QListWidget::currentRowChanged, this, &LightingPanel::showPoint);
  connect(sceneLights_, &QTableWidget::currentCellChanged, this,
          [this](int r) { showSceneLight(r); });
  const std::pair<QDoubleSpinBox*, SceneLightPart> sceneLightParts[] = {
      {sceneLightPos_[0], SceneLightPart::Position},
      {sceneLightPos_[1], SceneLightPart::Position},
      {sceneLightPos_[2], SceneLightPart::Position},
      {sceneLightAz_, SceneLightPart::Direction},
      {sceneLightEl_, SceneLightPart::Direction},
      {sceneLightI_, SceneLightPart::Intensity},
      {sceneLightColor_[0], SceneLightPart::Intensity},
      {sceneLightColor_[1], SceneLightPart::Intensity},
      {sceneLightColor_[2], SceneLightPart::Intensity}};
  for (const auto& [box, part] : sceneLightParts)
    connect(box, &QDoubleSpinBox::valueChanged, this, [this, p = part] { applySceneLight(p); });
  connect(doc_, &Document::sceneLightsChanged, this, [this] {
    refreshSceneLights();
    refreshCapturesUse();
  });
  connect(addPoint_, &QPushButton::clicked, this, [this] {
    Light l;
    l.type = LightType::Point;
    l.name = "point";
    const Scene* scene = doc_->scene();
    if (scene && !scene->bounds.empty()) l.position = scene->bounds.center();
    l.intensity = Rgb(10, 10, 10);
    pointLights_.push_back(l);
    apply(tr("Add point light"));
    points_->setCurrentRow(int(pointLights_.size()) - 1);
  });
  connect(removePoint_, &QPushButton::clicked, this, [this] {
    const int r = points_->currentRow();
    if (r < 0 || r >= int(pointLights_.size())) return;
    pointLights_.erase(pointLights_.begin() + r);
    apply(tr("Remove point light"));
  });
  connect(doc_, &Document::rigChanged, this, &LightingPanel::refresh);
  connect(doc_, &Document::sceneChanged, this, [this] {
    sceneLights_->setRowCount(0);  // a new scene: nothing picked
    refreshSceneLights();
    refreshCapturesUse();
  });
  refreshSceneLights();
  refresh();
}

void LightingPanel::refreshSceneLights() {
  const Scene* scene = doc_->scene();
  const std::vector<Light> none;
  const std::vector<Light>& lights = scene ? scene->lights : none;
  const std::vector<Light>& fromFile = doc_->sceneFileLights();
  const int current = sceneLights_->currentRow();
  const QSignalBlocker block(sceneLights_);
  sceneLights_->setRowCount(int(lights.size()));
  for (size_t i = 0; i < lights.size(); ++i) {
    const Light& l = lights[i];
    const int r = int(i);
    QString where, intensity;
    const double e = std::max({l.intensity.r, l.intensity.g, l.intensity.b});
    const Rgb c = e > 0 ? l.intensity / e : Rgb(1, 1, 1);
    if (l.type == LightType::Directional) {
      where = sourceAngles(l.direction);
      intensity = tr("%1 W/m²").arg(e, 0, 'g', 4);
    } else {
      where = tr("at %1").arg(vec(l.position, 2));
      if (l.type == LightType::Spot) where += tr(", along %1").arg(vec(l.direction, 2));
      intensity = tr("%1 W/sr").arg(e, 0, 'g', 4);
    }
    QString tip =
        l.type == LightType::Directional
            ? tr("Travels along %1; irradiance on a surface facing it").arg(vec(l.direction, 3))
            : tr("Radiant intensity, inverse-square falloff");
    tip += tr("; colour (RGB) %1").arg(vec(Vec3(c.r, c.g, c.b), 3));
    if (l.rangeMeters > 0) tip += tr("; range %1 m").arg(l.rangeMeters, 0, 'g', 4);
    const bool edited = i >= fromFile.size() || !sameLight(l, fromFile[i]);
    if (edited) tip += tr("; edited in this session (the scene file keeps its own)");
    const QString cells[] = {
        typeName(l.type), lightName(l) + (edited ? tr(" (edited)") : QString()), where, intensity};
    for (int col = 0; col < 4; ++col) {
      auto* item = new QTableWidgetItem(cells[col]);
      item->setToolTip(tip);
      sceneLights_->setItem(r, col, item);
    }
  }
  sceneLights_->setVisible(!lights.empty());
  const int keep = current < int(lights.size()) ? current : -1;
  sceneLights_->setCurrentCell(keep, keep < 0 ? -1 : 0);
  showSceneLight(keep);
}

void LightingPanel::showSceneLight(int r) {
  const Scene* scene = doc_->scene();
  const bool valid = scene && r >= 0 && r < int(scene->lights.size());
  sceneLightBox_->setVisible(valid);
  if (!valid) return;
  const Light& l = scene->lights[size_t(r)];
  const bool sun = l.type == LightType::Directional;
  sceneLightBox_->setTitle(tr("%1 \"%2\"").arg(typeName(l.type), lightName(l)));
  sceneLightForm_->setRowVisible(sceneLightPosRow_, !sun);
  sceneLightForm_->setRowVisible(sceneLightAz_, sun);
  sceneLightForm_->setRowVisible(sceneLightEl_, sun);
  const bool was = refreshing_;
  refreshing_ = true;
  for (int i = 0; i < 3; ++i) sceneLightPos_[i]->setValue(l.position[i]);
  if (sun) {
    const auto [az, el] = sourceAzimuthElevation(l.direction);
    sceneLightAz_->setValue(az);
    sceneLightEl_->setValue(el);
  }
  const auto [e, c] = intensityAndColour(l.intensity);
  sceneLightI_->setSuffix(sun ? QStringLiteral(" W/m²") : QStringLiteral(" W/sr"));
  sceneLightI_->setToolTip(sun ? tr("Irradiance on a surface facing the sun")
                               : tr("Radiant intensity, inverse-square falloff"));
  sceneLightI_->setValue(e);
  sceneLightColor_[0]->setValue(c.r), sceneLightColor_[1]->setValue(c.g),
      sceneLightColor_[2]->setValue(c.b);
  refreshing_ = was;
}

void LightingPanel::applySceneLight(SceneLightPart part) {
  const Scene* scene = doc_->scene();
  const int r = sceneLights_->currentRow();
  if (refreshing_ || !scene || r < 0 || r >= int(scene->lights.size())) return;
  std::vector<Light> lights = scene->lights;
  Light& l = lights[size_t(r)];
  if (part == SceneLightPart::Direction)
    l.direction = -towardsSun(sceneLightAz_->value(), sceneLightEl_->value());
  else if (part == SceneLightPart::Position)
    l.position =
        Vec3(sceneLightPos_[0]->value(), sceneLightPos_[1]->value(), sceneLightPos_[2]->value());
  else
    l.intensity = Rgb(sceneLightColor_[0]->value(), sceneLightColor_[1]->value(),
                      sceneLightColor_[2]->value()) *
                  sceneLightI_->value();
  doc_->setSceneLights(lights, tr("Edit scene light \"%1\"").arg(lightName(l)));
}

void LightingPanel::refreshCapturesUse() {
  const Scene* scene = doc_->scene();
  const LightingRig& rig = doc_->probeSet().rig;
  QStringList sceneNames, rigNames;
  int sceneSuns = 0, rigSuns = 0;
  if (scene)
    for (const Light& l : scene->lights) {
      sceneNames << QStringLiteral("%1 \"%2\"").arg(typeName(l.type), lightName(l));
      sceneSuns += l.type == LightType::Directional ? 1 : 0;
    }
  if (scene && scene->hasEmissiveSurfaces()) sceneNames << tr("emissive surfaces");
  for (const Light& l : rig.lights) {
    rigNames << (l.type == LightType::Directional
                     ? typeName(l.type)
                     : QStringLiteral("%1 \"%2\"").arg(typeName(l.type), lightName(l)));
    rigSuns += l.type == LightType::Directional ? 1 : 0;
  }
  if (!rig.skyRadiance.isBlack()) rigNames << tr("sky");
  if (!rig.envMapPath.empty() || rig.envMap) rigNames << tr("environment map");
  QString text;
  if (sceneNames.isEmpty() && rigNames.isEmpty())
    text = tr("No light: the scene brings none. Add a sun, a sky or a point light below.");
  else if (rigNames.isEmpty())
    text = tr("Captures use the scene's lights: %1. The rig below adds none.")
               .arg(sceneNames.join(QStringLiteral(", ")));
  else if (sceneNames.isEmpty())
    text = tr("The scene brings no light. Captures use the rig's: %1.")
               .arg(rigNames.join(QStringLiteral(", ")));
  else
    text = tr("Captures use both the scene's lights (%1) and the rig's (%2).")
               .arg(sceneNames.join(QStringLiteral(", ")), rigNames.join(QStringLiteral(", ")));
  if (sceneSuns > 0 && rigSuns > 0)
    text += QLatin1Char(' ') + tr("The scene's sun and the rig's sun both light the captures.");
  capturesUse_->setText(text);
}

LightingRig LightingPanel::rigFromWidgets() const {
  LightingRig rig;
  rig.lights = otherLights_;
  if (sunBox_->isChecked()) {
    Light sun;
    sun.type = LightType::Directional;
    sun.name = "sun";
    sun.direction = -towardsSun(sunAz_->value(), sunEl_->value());
    sun.intensity =
        Rgb(sunColor_[0]->value(), sunColor_[1]->value(), sunColor_[2]->value()) * sunE_->value();
    rig.lights.push_back(sun);
  }
  rig.lights.insert(rig.lights.end(), pointLights_.begin(), pointLights_.end());
  if (skyBox_->isChecked())
    rig.skyRadiance = Rgb(sky_[0]->value(), sky_[1]->value(), sky_[2]->value());
  // The panel does not edit the environment map (--env-map): keep the set's.
  rig.envMapPath = doc_->probeSet().rig.envMapPath;
  rig.envMap = doc_->probeSet().rig.envMap;
  return rig;
}

void LightingPanel::apply(const QString& text) {
  if (refreshing_) return;
  doc_->setRig(rigFromWidgets(), text);
}

void LightingPanel::refresh() {
  refreshCapturesUse();
  refreshing_ = true;
  const LightingRig& rig = doc_->probeSet().rig;
  const Light* sun = nullptr;
  pointLights_.clear();
  otherLights_.clear();
  for (const Light& l : rig.lights) {
    if (l.type == LightType::Directional && !sun)
      sun = &l;
    else if (l.type == LightType::Point)
      pointLights_.push_back(l);
    else
      otherLights_.push_back(l);
  }
  sunBox_->setChecked(sun != nullptr);
  if (sun) {
    const Vec3 t = -sun->direction / std::max(length(sun->direction), 1e-12);
    sunEl_->setValue(qRadiansToDegrees(std::asin(std::clamp(t.y, -1.0, 1.0))));
    sunAz_->setValue(qRadiansToDegrees(std::atan2(t.x, t.z)));
    const double e = std::max({sun->intensity.r, sun->intensity.g, sun->intensity.b});
    sunE_->setValue(e);
    const Rgb c = e > 0 ? sun->intensity / e : Rgb(1, 1, 1);
    sunColor_[0]->setValue(c.r), sunColor_[1]->setValue(c.g), sunColor_[2]->setValue(c.b);
  }
  skyBox_->setChecked(!rig.skyRadiance.isBlack());
  if (!rig.skyRadiance.isBlack()) {
    sky_[0]->setValue(rig.skyRadiance.r);
    sky_[1]->setValue(rig.skyRadiance.g);
    sky_[2]->setValue(rig.skyRadiance.b);
  }
  const int current = points_->currentRow();
  points_->clear();
  for (size_t i = 0; i < pointLights_.size(); ++i) {
    const Light& l = pointLights_[i];
    points_->addItem(tr("%1 %2 at (%3, %4, %5)")
                         .arg(QString::fromStdString(l.name.empty() ? "point" : l.name))
                         .arg(i + 1)
                         .arg(l.position.x, 0, 'f', 2)
                         .arg(l.position.y, 0, 'f', 2)
                         .arg(l.position.z, 0, 'f', 2));
  }
  refreshing_ = false;
  points_->setCurrentRow(std::min(current, int(pointLights_.size()) - 1));
  showPoint(points_->currentRow());
}

void LightingPanel::showPoint(int r) {
  const bool valid = r >= 0 && r < int(pointLights_.size());
  for (QDoubleSpinBox* s : {pointPos_[0], pointPos_[1], pointPos_[2], pointI_, pointColor_[0],
                            pointColor_[1], pointColor_[2]})
    s->setEnabled(valid);
  removePoint_->setEnabled(valid);
  if (!valid) return;
  const bool was = refreshing_;
  refreshing_ = true;
  const Light& l = pointLights_[size_t(r)];
  for (int i = 0; i < 3; ++i) pointPos_[i]->setValue(l.position[i]);
  const double e = std::max({l.intensity.r, l.intensity.g, l.intensity.b});
  pointI_->setValue(e);
  const Rgb c = e > 0 ? l.intensity / e : Rgb(1, 1, 1);
  pointColor_[0]->setValue(c.r), pointColor_[1]->setValue(c.g), pointColor_[2]->setValue(c.b);
  refreshing_ = was;
}

}  // namespace ps::ui
