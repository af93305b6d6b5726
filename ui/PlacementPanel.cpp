#include "ui/PlacementPanel.h"

#include <QCheckBox>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QFileInfo>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QLabel>
#include <QProgressBar>
#include <QPushButton>
#include <QSpinBox>
#include <QVBoxLayout>

#include <map>

#include "core/common/Error.h"
#include "core/placement/Place.h"
#include "ui/Document.h"

namespace ps::ui {

PlacementPanel::PlacementPanel(Document* doc, QWidget* parent) : QWidget(parent), doc_(doc) {
  auto* layout = new QVBoxLayout(this);
  auto* placeBox = new QGroupBox(tr("Placement"));
  auto* form = new QFormLayout(placeBox);
  method_ = new QComboBox;
  // The core's placement methods (core/placement/Place.h), the same as `probestudio place`.
  const std::map<std::string, QString> help = {
      {"uniform", tr("A grid at the spacing (or the budget), minus the points inside geometry")},
      {"greedy", tr("Error-driven: adds the dense-field sample where the interpolation is worst, "
                    "until the budget")},
      {"ascent", tr("A grid whose probes climb towards the light of their indirect captures "
                    "(Sukys 3.1.2)")},
      {"spawn-merge", tr("A grid of half the budget; similar neighbours merge, probes spawn "
                         "between differing ones (Sukys 3.1.1)")},
      {"chajdas", tr("Dense-field particles traced to the sinks of the light; one probe per "
                     "cluster of matching samples (Chajdas et al.); the budget sets the merging")},
  };
  for (const std::string& name : placementMethods()) {
    method_->addItem(QString::fromStdString(name));
    const auto h = help.find(name);
    if (h != help.end()) method_->setItemData(method_->count() - 1, h->second, Qt::ToolTipRole);
  }
  method_->setCurrentText(QStringLiteral("uniform"));
  spacing_ = new QDoubleSpinBox;
  spacing_->setRange(0.01, 1000);
  spacing_->setDecimals(2);
  spacing_->setValue(1.0);
  spacing_->setSuffix(QStringLiteral(" m"));
  budget_ = new QSpinBox;
  budget_->setRange(0, 1000000);
  budget_->setSpecialValueText(tr("none (use spacing)"));
  captureSpp_ = new QSpinBox;
  captureSpp_->setRange(1, 1 << 16);
  captureSpp_->setValue(64);
  form->addRow(tr("Method"), method_);
  form->addRow(tr("Spacing"), spacing_);
  form->addRow(tr("Budget"), budget_);
  aggressiveness_ = new QDoubleSpinBox;
  aggressiveness_->setRange(0.05, 20);
  aggressiveness_->setSingleStep(0.25);
  aggressiveness_->setValue(1.0);
  aggressiveness_->setToolTip(
      tr("chajdas without a budget: how readily clusters of similar lighting merge (higher: "
         "fewer probes)"));
  form->addRow(tr("Aggressiveness"), aggressiveness_);
  form->addRow(tr("Preview samples"), captureSpp_);
  replace_ = new QCheckBox(tr("Replace unlocked candidates"));
  replace_->setChecked(true);
  replace_->setToolTip(tr("Off: keep the current candidates and only add new ones"));
  form->addRow(replace_);
  run_ = new QPushButton(tr("Run placement"));
  run_->setToolTip(
      tr("Replaces the unlocked candidates; accepted, rejected and locked probes "
         "stay"));
  form->addRow(run_);
  layout->addWidget(placeBox);

  auto* bakeBox = new QGroupBox(tr("Bake"));
  auto* bakeForm = new QFormLayout(bakeBox);
  bakeSpp_ = new QSpinBox;
  bakeSpp_->setRange(1, 1 << 20);
  bakeSpp_->setValue(1024);
  bakeForm->addRow(tr("Samples per probe"), bakeSpp_);
  leakRefine_ = new QCheckBox(tr("Refine leaks"));
  leakRefine_->setChecked(true);
  leakRefine_->setToolTip(
      tr("Add probes on both sides of the walls that tetrahedron edges cross (Sukys 3.2.2); they "
         "go into the volume, not into the probe set"));
  bakeForm->addRow(leakRefine_);
  bake_ = new QPushButton(tr("Bake accepted probes"));
  bakeForm->addRow(bake_);
  volume_ = new QLabel;
  volume_->setWordWrap(true);
  bakeForm->addRow(volume_);
  layout->addWidget(bakeBox);

  auto* jobRow = new QHBoxLayout;
  progress_ = new QProgressBar;
  progress_->setRange(0, 100);
  cancel_ = new QPushButton(tr("Cancel"));
  jobRow->addWidget(progress_, 1);
  jobRow->addWidget(cancel_);
  layout->addLayout(jobRow);
  status_ = new QLabel;
  status_->setWordWrap(true);
  layout->addWidget(status_);
  layout->addStretch(1);

  connect(run_, &QPushButton::clicked, this, [this] { run(); });
  connect(bake_, &QPushButton::clicked, this, [this] { bake(); });
  connect(cancel_, &QPushButton::clicked, doc_, &Document::requestCancel);
  connect(doc_, &Document::jobProgress, this, [this](const QString& what, double f) {
    status_->setText(what);
    progress_->setValue(int(f * 100));
    updateState();
  });
  connect(doc_, &Document::jobFinished, this, [this](const QString& error) {
    status_->setText(error == QLatin1String("cancelled") ? tr("Cancelled")
                     : error.isEmpty()                   ? doc_->lastJobNotes().join('\n')
                                                         : error);
    progress_->setValue(0);
    updateState();
  });
  connect(doc_, &Document::volumeChanged, this, &PlacementPanel::updateState);
  connect(doc_, &Document::sceneChanged, this, &PlacementPanel::updateState);
  connect(doc_, &Document::pathsChanged, this, &PlacementPanel::updateState);
  updateState();
}

PlacementRequest PlacementPanel::placementRequest() const {
  PlacementRequest r;
  r.method = method_->currentText().toStdString();
  r.spacingMeters = spacing_->value();
  r.budget = budget_->value();
  r.samplesPerProbe = captureSpp_->value();
  r.replaceCandidates = replace_->isChecked();
  r.aggressiveness = aggressiveness_->value();
  return r;
}

BakeRequest PlacementPanel::bakeRequest() const {
  BakeRequest r;
  r.samplesPerProbe = bakeSpp_->value();
  r.refineLeaks = leakRefine_->isChecked();
  return r;
}

bool PlacementPanel::run() {
  try {
    if (doc_->runPlacement(placementRequest())) {
      updateState();
      return true;
    }
  } catch (const Error& e) {
    emit failed(tr("Placement"), QString::fromStdString(e.what()));
    return false;
  }
  emit failed(tr("Placement"),
              doc_->isBusy() ? tr("Another job is running.") : tr("Open a scene first."));
  return false;
}

bool PlacementPanel::bake() {
  try {
    if (doc_->bake(bakeRequest())) {
      updateState();
      return true;
    }
  } catch (const Error& e) {
    emit failed(tr("Bake"), QString::fromStdString(e.what()));
    return false;
  }
  emit failed(tr("Bake"),
              doc_->isBusy() ? tr("Another job is running.") : tr("Open a scene first."));
  return false;
}

void PlacementPanel::updateState() {
  const bool busy = doc_->isBusy();
  run_->setEnabled(!busy && doc_->hasScene());
  bake_->setEnabled(!busy && doc_->hasScene());
  cancel_->setEnabled(busy);
  progress_->setVisible(busy);
  volume_->setText(doc_->volume() ? tr("Volume: %1").arg(QFileInfo(doc_->volumePath()).fileName())
                                  : tr("Not baked yet"));
}

}  // namespace ps::ui
