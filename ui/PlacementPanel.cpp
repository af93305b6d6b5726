#include "ui/PlacementPanel.h"

#include <QCheckBox>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QFileInfo>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QPushButton>
#include <QSpinBox>
#include <QTableWidget>
#include <QVBoxLayout>

#include <map>

#include "core/common/Error.h"
#include "core/placement/Place.h"
#include "core/scene/Scene.h"
#include "ui/Document.h"
#include "ui/MainWindow.h"

namespace ps::ui {

PlacementPanel::PlacementPanel(Document* doc, QWidget* parent) : QWidget(parent), doc_(doc) {
  auto* layout = new QVBoxLayout(this);
  auto* placeBox = new QGroupBox(tr("Placement"));
  auto* form = new QFormLayout(placeBox);
  form->setRowWrapPolicy(QFormLayout::WrapLongRows);  // narrow docks: fields under labels
  const PlacementRequest defaults;                    // the panel's first values
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
  method_->setCurrentText(QString::fromStdString(defaults.method));
  spacing_ = new QDoubleSpinBox;
  spacing_->setRange(0.01, 1000);
  spacing_->setDecimals(2);
  spacing_->setValue(defaults.spacingMeters);
  spacing_->setSuffix(QStringLiteral(" m"));
  budget_ = new QSpinBox;
  budget_->setRange(0, 1000000);
  budget_->setValue(defaults.budget);
  captureSpp_ = new QSpinBox;
  captureSpp_->setRange(1, 1 << 16);
  captureSpp_->setValue(defaults.samplesPerProbe);
  form->addRow(tr("Method"), method_);
  form->addRow(tr("Spacing"), spacing_);
  form->addRow(tr("Budget"), budget_);
  aggressiveness_ = new QDoubleSpinBox;
  aggressiveness_->setRange(0.05, 20);
  aggressiveness_->setSingleStep(0.25);
  aggressiveness_->setValue(defaults.aggressiveness);
  aggressiveness_->setToolTip(
      tr("chajdas without a budget: how readily clusters of similar lighting merge (higher: "
         "fewer probes)"));
  form->addRow(tr("Aggressiveness"), aggressiveness_);
  swapPasses_ = new QSpinBox;
  swapPasses_->setRange(0, 64);
  swapPasses_->setValue(defaults.swapPasses);
  swapPasses_->setSpecialValueText(tr("none"));
  swapPasses_->setToolTip(
      tr("greedy: after the additions, passes that move each probe to where it lowers the error "
         "most, far away or to a nearby sample; they stop early once a pass gains less than 1 %. "
         "Each pass can take several times as long as the additions (none: the additions "
         "alone)"));
  form->addRow(tr("Swap passes"), swapPasses_);
  // greedy's objective (core/placement/GreedyMethod.h), `place --objective`.
  objective_ = new QComboBox;
  const QString perceptualTip =
      tr("Lowers the error in stops (|log2| of the interpolated over the true irradiance): a dim "
         "room counts as much as a bright one");
  const QString energyTip =
      tr("Lowers rel_rmse (the irradiance error relative to its mean): the bright places "
         "dominate, dim rooms get few probes");
  objective_->addItem(QStringLiteral("perceptual"));
  objective_->setItemData(0, perceptualTip, Qt::ToolTipRole);
  objective_->addItem(QStringLiteral("energy"));
  objective_->setItemData(1, energyTip, Qt::ToolTipRole);
  objective_->setCurrentText(QString::fromStdString(defaults.objective));
  objective_->setToolTip(tr("greedy: the error it lowers.\nperceptual: %1.\nenergy: %2.")
                             .arg(perceptualTip, energyTip));
  form->addRow(tr("Objective"), objective_);
  form->addRow(tr("Preview samples"), captureSpp_);
  replace_ = new QCheckBox(tr("Replace unlocked candidates"));
  replace_->setChecked(defaults.replaceCandidates);
  replace_->setToolTip(tr("Off: keep the current candidates and only add new ones"));
  form->addRow(replace_);
  domain_ = new QComboBox;
  domain_->addItem(tr("reachable"));
  domain_->setItemData(0,
                       tr("Free space within 3 m above walkable ground; in an interior only the "
                          "enclosed part (View > Domain of interest shows it)"),
                       Qt::ToolTipRole);
  domain_->addItem(tr("bounds"));
  domain_->setItemData(1, tr("The scene's bounding box"), Qt::ToolTipRole);
  domain_->setCurrentIndex(defaults.domain == DomainRule::Bounds ? 1 : 0);
  domain_->setToolTip(
      tr("Where probes go without importance volumes (probestudio place --domain)"));
  form->addRow(tr("Domain"), domain_);
  // The proposal made when a scene opens places in this domain too, as Run placement does.
  connect(domain_, &QComboBox::currentIndexChanged, this, [this](int index) {
    doc_->proposalSettings().domain = index == 1 ? DomainRule::Bounds : DomainRule::Reachable;
  });
  doc_->proposalSettings().domain = defaults.domain;
  run_ = new QPushButton(tr("Run placement"));
  run_->setToolTip(
      tr("Replaces the unlocked candidates; accepted, rejected and locked probes "
         "stay"));
  form->addRow(run_);
  layout->addWidget(placeBox);

  auto* volumeBox = new QGroupBox(tr("Importance volumes"));
  auto* volumeLayout = new QVBoxLayout(volumeBox);
  volumes_ = new QTableWidget(0, 8);
  volumes_->setHorizontalHeaderLabels({tr("Name"), tr("Weight"), tr("Min x"), tr("Min y"),
                                       tr("Min z"), tr("Max x"), tr("Max y"), tr("Max z")});
  volumes_->verticalHeader()->setVisible(false);
  volumes_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  volumes_->setSelectionBehavior(QAbstractItemView::SelectRows);
  volumes_->setSelectionMode(QAbstractItemView::SingleSelection);
  volumes_->setMinimumHeight(90);
  volumes_->setToolTip(
      tr("Boxes in metres. With volumes, greedy and chajdas sample the lighting only inside them; "
         "a weight above 1 makes chajdas merge less there (more probes), below 1 more"));
  volumeLayout->addWidget(volumes_);
  auto* volumeButtons = new QHBoxLayout;
  addVolume_ = new QPushButton(tr("Add around selection"));
  addVolume_->setToolTip(
      tr("A box around the selected probes (or the whole scene when none is selected)"));
  removeVolume_ = new QPushButton(tr("Remove"));
  volumeButtons->addWidget(addVolume_);
  volumeButtons->addWidget(removeVolume_);
  volumeLayout->addLayout(volumeButtons);
  layout->addWidget(volumeBox);

  auto* bakeBox = new QGroupBox(tr("Bake"));
  auto* bakeForm = new QFormLayout(bakeBox);
  bakeForm->setRowWrapPolicy(QFormLayout::WrapLongRows);  // narrow docks: fields under labels
  bakeSpp_ = new QSpinBox;
  bakeSpp_->setRange(1, 1 << 20);
  bakeSpp_->setValue(1024);
  bakeForm->addRow(tr("Samples per probe"), bakeSpp_);
  // An edited probe's live capture ends at the bake's count (LiveCaptureSettings).
  connect(bakeSpp_, &QSpinBox::valueChanged, this,
          [this](int n) { doc_->liveCaptureSettings().finalSamples = n; });
  doc_->liveCaptureSettings().finalSamples = bakeSpp_->value();
  fit_ = new QCheckBox(tr("Least-squares values"));
  fit_->setToolTip(
      tr("Fit the probes' values so that the volume's interpolation comes closest to captures at "
         "random points of the domain, instead of keeping each probe's own capture: lower error "
         "overall, at the capture work of about eight 1024-spp bakes; beside a sharp bright patch "
         "the dark "
         "side can come out brighter"));
  bakeForm->addRow(fit_);
  bake_ = new QPushButton(tr("Bake accepted probes"));
  bakeForm->addRow(bake_);
  volume_ = new QLabel;
  volume_->setObjectName("volumeState");
  volume_->setWordWrap(true);
  bakeForm->addRow(volume_);
  layout->addWidget(bakeBox);

  // What the last job did (its notes) or why it failed; the job's progress and Cancel are the
  // status bar's.
  status_ = new QLabel;
  status_->setObjectName("placementStatus");
  status_->setWordWrap(true);
  layout->addWidget(status_);
  layout->addStretch(1);

  // Each method's fields; greedy always has a budget (it needs one, and the panel offers no
  // error target).
  connect(method_, &QComboBox::currentTextChanged, this, &PlacementPanel::updateMethodFields);
  connect(budget_, &QSpinBox::valueChanged, this, &PlacementPanel::updateMethodFields);
  updateMethodFields();
  // A reopened set places again as it was placed.
  connect(doc_, &Document::probeSetOpened, this, &PlacementPanel::restorePlacement);

  connect(run_, &QPushButton::clicked, this, [this] { run(); });
  connect(bake_, &QPushButton::clicked, this, [this] { bake(); });
  // Enabled states follow the job; the message of each report is the status bar's alone (a
  // label changed at every report would repaint the dock).
  connect(doc_, &Document::jobProgress, this, [this] {
    if (doc_->isBusy() && !status_->text().isEmpty()) status_->clear();
    updateState();
  });
  connect(doc_, &Document::jobFinished, this, [this](const QString& error) {
    // A core error names the command line's flags; here, the editor's controls.
    status_->setText(error == QLatin1String("cancelled") ? tr("Cancelled")
                     : error.isEmpty()                   ? doc_->lastJobNotes().join('\n')
                                                         : MainWindow::editorMessage(error));
    updateState();
  });
  connect(addVolume_, &QPushButton::clicked, this, [this] { addVolumeAroundSelection(); });
  connect(removeVolume_, &QPushButton::clicked, this, [this] { removeCurrentVolume(); });
  connect(volumes_, &QTableWidget::itemChanged, this, &PlacementPanel::onVolumeEdited);
  connect(volumes_, &QTableWidget::itemSelectionChanged, this, &PlacementPanel::updateState);
  connect(doc_, &Document::importanceVolumesChanged, this, &PlacementPanel::refreshVolumes);
  connect(doc_, &Document::volumeChanged, this, &PlacementPanel::updateState);
  connect(doc_, &Document::volumeStateChanged, this, &PlacementPanel::updateState);
  connect(doc_, &Document::sceneChanged, this, &PlacementPanel::updateState);
  connect(doc_, &Document::pathsChanged, this, &PlacementPanel::updateState);
  refreshVolumes();
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
  r.swapPasses = swapPasses_->value();
  r.objective = objective_->currentText().toStdString();
  r.domain = domain_->currentIndex() == 1 ? DomainRule::Bounds : DomainRule::Reachable;
  return r;
}

BakeRequest PlacementPanel::bakeRequest() const {
  BakeRequest r;
  r.samplesPerProbe = bakeSpp_->value();
  r.fit = fit_->isChecked();
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
  if (doc_->hasScene() && !doc_->isBusy() && doc_->probeSetPath().isEmpty() && saveBeforeBake_ &&
      !saveBeforeBake_())
    return false;  // the artist declined to save: nothing to report
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

bool PlacementPanel::addVolumeAroundSelection() {
  const std::vector<uint64_t> ids = selection_ ? selection_() : std::vector<uint64_t>();
  Bounds3 box;
  for (uint64_t id : ids)
    if (const Probe* p = doc_->probe(id)) box.extend(p->position);
  if (!box.empty()) {
    const Vec3 pad(0.5, 0.5, 0.5);
    box = Bounds3{box.lo - pad, box.hi + pad};
  } else if (doc_->hasScene()) {
    box = doc_->scene()->bounds;
  } else {
    emit failed(tr("Importance volume"), tr("Select probes or open a scene first."));
    return false;
  }
  return addVolume(box);
}

bool PlacementPanel::addVolume(const Bounds3& box) {
  std::vector<ImportanceVolume> volumes = doc_->probeSet().importanceVolumes;
  ImportanceVolume v;
  v.name = "Volume " + std::to_string(volumes.size() + 1);
  v.lo = box.lo;
  v.hi = box.hi;
  v.weight = 2.0;
  volumes.push_back(v);
  try {
    doc_->setImportanceVolumes(volumes, tr("Add importance volume"));
  } catch (const Error& e) {
    emit failed(tr("Importance volume"), QString::fromStdString(e.what()));
    return false;
  }
  volumes_->selectRow(int(volumes.size()) - 1);
  return true;
}

bool PlacementPanel::removeCurrentVolume() {
  std::vector<ImportanceVolume> volumes = doc_->probeSet().importanceVolumes;
  const int row = volumes_->currentRow();
  if (row < 0 || size_t(row) >= volumes.size()) return false;
  volumes.erase(volumes.begin() + row);
  doc_->setImportanceVolumes(volumes, tr("Remove importance volume"));
  return true;
}

void PlacementPanel::refreshVolumes() {
  syncingVolumes_ = true;
  const std::vector<ImportanceVolume>& volumes = doc_->probeSet().importanceVolumes;
  const int current = volumes_->currentRow();
  volumes_->setRowCount(int(volumes.size()));
  for (size_t i = 0; i < volumes.size(); ++i) {
    const ImportanceVolume& v = volumes[i];
    const QString cells[8] = {QString::fromStdString(v.name), QString::number(v.weight),
                              QString::number(v.lo.x),        QString::number(v.lo.y),
                              QString::number(v.lo.z),        QString::number(v.hi.x),
                              QString::number(v.hi.y),        QString::number(v.hi.z)};
    for (int c = 0; c < 8; ++c) {
      QTableWidgetItem* item = volumes_->item(int(i), c);
      if (!item) {
        item = new QTableWidgetItem;
        volumes_->setItem(int(i), c, item);
      }
      item->setText(cells[c]);
    }
  }
  if (current >= 0 && current < volumes_->rowCount()) volumes_->selectRow(current);
  syncingVolumes_ = false;
  updateState();
}

void PlacementPanel::onVolumeEdited(QTableWidgetItem* item) {
  if (syncingVolumes_) return;
  std::vector<ImportanceVolume> volumes = doc_->probeSet().importanceVolumes;
  const int row = item->row(), col = item->column();
  if (row < 0 || size_t(row) >= volumes.size()) return;
  ImportanceVolume& v = volumes[size_t(row)];
  const QString header = volumes_->horizontalHeaderItem(col)->text();
  auto refuse = [&](const QString& why) {
    refreshVolumes();  // back to the document's values
    emit failed(tr("Importance volume"), why);
  };
  if (col == 0) {
    v.name = item->text().trimmed().toStdString();
  } else {
    bool ok = false;
    const double x = item->text().trimmed().toDouble(&ok);
    if (!ok) {
      refuse(tr("importance volume %1, %2: expected a number, got \"%3\"")
                 .arg(row + 1)
                 .arg(header.toLower(), item->text()));
      return;
    }
    if (col == 1)
      v.weight = x;
    else if (col <= 4)
      v.lo[col - 2] = x;
    else
      v.hi[col - 5] = x;
  }
  try {
    doc_->setImportanceVolumes(volumes, tr("Edit importance volume %1").arg(row + 1));
  } catch (const Error& e) {
    refuse(QString::fromStdString(e.what()));
  }
}

void PlacementPanel::restorePlacement() {
  const PlacementSettings& placed = doc_->probeSet().placement;
  const QString method = QString::fromStdString(placed.method);
  if (method_->findText(method) < 0) return;  // not a method of the panel ("manual", ...)
  method_->setCurrentText(method);            // greedy: the budget's minimum is 4
  if (placed.spacingMeters > 0) spacing_->setValue(placed.spacingMeters);
  if (placed.budget >= budget_->minimum()) budget_->setValue(placed.budget);
}

void PlacementPanel::updateMethodFields() {
  const std::string method = method_->currentText().toStdString();
  const bool greedy = method == "greedy";
  if (greedy && budget_->minimum() != kMinGreedyBudget) {
    const bool none = budget_->value() < kMinGreedyBudget;
    budget_->setSpecialValueText(QString());  // shown at the minimum: not "none" for 4
    budget_->setMinimum(kMinGreedyBudget);
    if (none) budget_->setValue(PlacementRequest::kDefaultBudget);
  } else if (!greedy && budget_->minimum() != 0) {
    budget_->setMinimum(0);
    budget_->setSpecialValueText(tr("none (use spacing)"));
  }
  budget_->setToolTip(greedy ? tr("greedy: the probe count it places, the kept probes included")
                             : tr("The probe count; none: the spacing decides"));
  // The fields the method reads (PlacementMethod::parameters); the spacing only without a
  // budget.
  auto takes = [&](std::string_view name) { return PlacementRequest::methodReads(method, name); };
  spacing_->setEnabled(takes("spacingMeters") && budget_->value() == 0);
  aggressiveness_->setEnabled(takes("aggressiveness"));
  swapPasses_->setEnabled(takes("swapPasses"));
  objective_->setEnabled(takes("objective"));
}

void PlacementPanel::updateState() {
  const bool busy = doc_->isBusy();
  run_->setEnabled(!busy && doc_->hasScene());
  bake_->setEnabled(!busy && doc_->hasScene());
  removeVolume_->setEnabled(volumes_->currentRow() >= 0 && volumes_->rowCount() > 0);
  const bool stale = doc_->volumeState() == Document::VolumeState::Stale;
  volume_->setText(tr("Volume: %1").arg(doc_->volumeStatusText()) +
                   (stale ? tr(". Bake again (Ctrl+B).") : QString()));
  volume_->setStyleSheet(stale ? QStringLiteral("color: #b35c00") : QString());
}

}  // namespace ps::ui
