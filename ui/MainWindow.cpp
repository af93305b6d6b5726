#include "ui/MainWindow.h"

#include <QAction>
#include <QActionGroup>
#include <QApplication>
#include <QCloseEvent>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QFrame>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QItemSelectionModel>
#include <QLabel>
#include <QMenuBar>
#include <QMessageBox>
#include <QProgressBar>
#include <QPushButton>
#include <QRegularExpression>
#include <QScreen>
#include <QScrollArea>
#include <QSettings>
#include <QSortFilterProxyModel>
#include <QStatusBar>
#include <QStyle>
#include <QTableView>
#include <QToolBar>
#include <QUndoStack>
#include <algorithm>
#include <cmath>

#include "core/common/Error.h"
#include "ui/Autosave.h"
#include "ui/Document.h"
#include "ui/EvaluationPanel.h"
#include "ui/InspectorPanel.h"
#include "ui/LightingPanel.h"
#include "ui/PlacementPanel.h"
#include "ui/ProbeTableModel.h"
#include "ui/SceneLighting.h"
#include "ui/SurfacePlacement.h"
#include "ui/Viewport.h"

namespace ps::ui {

namespace {
/// A dock's panel in a scroll area: a dock shorter than the panel scrolls it instead of
/// squashing its rows below their height.
QScrollArea* scrollable(QWidget* panel) {
  auto* area = new QScrollArea;
  area->setWidget(panel);
  area->setWidgetResizable(true);
  area->setFrameShape(QFrame::NoFrame);
  area->setHorizontalScrollBarPolicy(Qt::ScrollBarAsNeeded);
  return area;
}
}  // namespace

MainWindow::MainWindow(QWidget* parent) : QMainWindow(parent) {
  doc_ = new Document(this);
  viewport_ = new Viewport(doc_, this);
  setCentralWidget(viewport_);

  model_ = new ProbeTableModel(doc_, this);
  proxy_ = new QSortFilterProxyModel(this);
  proxy_->setSourceModel(model_);
  proxy_->setSortRole(ProbeTableModel::SortRole);
  table_ = new QTableView;
  table_->setModel(proxy_);
  table_->setSortingEnabled(true);
  table_->sortByColumn(ProbeTableModel::Id, Qt::AscendingOrder);
  table_->setSelectionBehavior(QAbstractItemView::SelectRows);
  table_->setSelectionMode(QAbstractItemView::ExtendedSelection);
  table_->verticalHeader()->hide();
  table_->verticalHeader()->setDefaultSectionSize(20);
  table_->horizontalHeader()->setStretchLastSection(true);
  table_->setAlternatingRowColors(true);
  for (int c = 0; c < ProbeTableModel::ColumnCount; ++c)
    table_->setColumnWidth(c,
                           c == ProbeTableModel::State || c == ProbeTableModel::Method ? 72 : 52);
  auto* dock = new QDockWidget(tr("Probes"), this);
  dock->setObjectName("probesDock");
  dock->setWidget(table_);
  addDockWidget(Qt::RightDockWidgetArea, dock);

  inspector_ = new InspectorPanel(doc_);
  auto* inspectorDock = new QDockWidget(tr("Inspector"), this);
  inspectorDock->setObjectName("inspectorDock");
  inspectorDock->setWidget(scrollable(inspector_));
  addDockWidget(Qt::RightDockWidgetArea, inspectorDock);

  placement_ = new PlacementPanel(doc_);
  auto* placementDock = new QDockWidget(tr("Placement"), this);
  placementDock->setObjectName("placementDock");
  placementDock->setWidget(scrollable(placement_));
  addDockWidget(Qt::LeftDockWidgetArea, placementDock);
  leftDock_ = placementDock;
  rightDock_ = dock;
  connect(placement_, &PlacementPanel::failed, this, &MainWindow::showError);
  placement_->setSelectionProvider([this] { return selectedIds(); });
  placement_->setSaveBeforeBake([this] { return offerSaveBeforeBake(); });

  lighting_ = new LightingPanel(doc_);
  auto* lightingDock = new QDockWidget(tr("Lighting"), this);
  lightingDock->setObjectName("lightingDock");
  lightingDock->setWidget(scrollable(lighting_));
  addDockWidget(Qt::LeftDockWidgetArea, lightingDock);
  tabifyDockWidget(placementDock, lightingDock);

  evaluation_ = new EvaluationPanel(doc_);
  auto* evaluationDock = new QDockWidget(tr("Evaluation"), this);
  evaluationDock->setObjectName("evaluationDock");
  evaluationDock->setWidget(scrollable(evaluation_));
  addDockWidget(Qt::LeftDockWidgetArea, evaluationDock);
  tabifyDockWidget(lightingDock, evaluationDock);
  connect(evaluation_, &EvaluationPanel::failed, this, &MainWindow::showError);
  evaluation_->setPlacementSettings([this] { return placement_->placementRequest(); });
  // A saved set keeps the panel's method, spacing and budget; reopening it shows them again.
  doc_->setPlacementSource([this] {
    const PlacementRequest r = placement_->placementRequest();
    return PlacementSettings{r.method, r.spacingMeters, r.budget};
  });
  evaluation_->setBakeSettings([this] { return placement_->bakeRequest(); });
  evaluation_->setSaveBeforeBake([this] { return offerSaveBeforeBake(); });
  // The error where it is: a picked query is framed and ringed; a probe added there is selected.
  connect(evaluation_, &EvaluationPanel::queryPicked, this, [this](int index) {
    if (doc_->evaluations().empty()) return;
    const auto& queries = doc_->evaluations().back().queries;
    if (index < 0 || size_t(index) >= queries.size()) return;
    viewport_->setHighlightedQuery(index);
    const Scene* scene = doc_->scene();
    viewport_->framePoint(queries[size_t(index)].point,
                          std::clamp(scene ? scene->bounds.diagonal() * 0.08 : 1.0, 0.5, 3.0));
  });
  connect(evaluation_, &EvaluationPanel::probeAdded, this, [this](quint64 id) { selectIds({id}); });
  connect(evaluation_, &EvaluationPanel::probesAdded, this, &MainWindow::selectIds);
  placementDock->raise();

  sceneLabel_ = new QLabel(tr("No scene"));
  trianglesLabel_ = new QLabel;
  probesLabel_ = new QLabel;
  // Why the view shows nothing (or flat colours), with what fixes it: a banner over the top of
  // the view, wrapped to its width, never a dialog. A scene without any light offers a sky.
  banner_ = new QFrame(this);
  banner_->setObjectName("viewBanner");
  banner_->setAutoFillBackground(true);
  banner_->setFrameShape(QFrame::StyledPanel);
  banner_->setStyleSheet(
      "#viewBanner { background: rgba(255, 244, 229, 235); border: 1px solid #b35c00; }");
  overlayReason_ = new QLabel;
  overlayReason_->setObjectName("overlayReason");
  overlayReason_->setStyleSheet("color: #7a3e00");
  overlayReason_->setWordWrap(true);
  bannerAction_ = new QPushButton(tr("Add a default sky"));
  bannerAction_->setObjectName("addDefaultSky");
  bannerAction_->setToolTip(
      tr("Light the scene with a uniform sky (one undo step; edit it in the Lighting tab)"));
  connect(bannerAction_, &QPushButton::clicked, this, &MainWindow::addDefaultSky);
  auto* bannerLayout = new QHBoxLayout(banner_);
  bannerLayout->setContentsMargins(8, 4, 8, 4);
  bannerLayout->addWidget(overlayReason_, 1);
  bannerLayout->addWidget(bannerAction_);
  banner_->hide();
  viewport_->installEventFilter(this);
  volumeState_ = new QLabel;
  volumeState_->setObjectName("volumeStateStatus");
  volumeState_->setStyleSheet("color: #b35c00");
  jobLabel_ = new QLabel;
  jobLabel_->setObjectName("jobLabel");
  progress_ = new QProgressBar;
  progress_->setRange(0, 100);
  progress_->setMaximumWidth(160);
  progress_->hide();
  cancelJob_ = new QPushButton(tr("Cancel"));
  cancelJob_->setObjectName("cancelJob");
  cancelJob_->setToolTip(tr("Stop the running job (Esc); it changes nothing"));
  cancelJob_->hide();
  // The bar and its Cancel keep their room while hidden: the status bar's height never changes
  // with a job, so the 3D view is not resized (and redrawn) when a job starts or ends.
  for (QWidget* jobWidget : {static_cast<QWidget*>(progress_), static_cast<QWidget*>(cancelJob_)}) {
    QSizePolicy policy = jobWidget->sizePolicy();
    policy.setRetainSizeWhenHidden(true);
    jobWidget->setSizePolicy(policy);
  }
  connect(cancelJob_, &QPushButton::clicked, doc_, &Document::requestCancel);
  statusBar()->addWidget(sceneLabel_);
  statusBar()->addWidget(trianglesLabel_);
  statusBar()->addWidget(probesLabel_);
  statusBar()->addWidget(volumeState_);
  statusBar()->addPermanentWidget(jobLabel_);
  statusBar()->addPermanentWidget(progress_);
  statusBar()->addPermanentWidget(cancelJob_);

  createActions();
  confineKeyShortcutsToViewport();
  viewport_->setFocus();  // the keys' shortcuts act from the start

  connect(table_->selectionModel(), &QItemSelectionModel::selectionChanged, this,
          &MainWindow::onTableSelectionChanged);
  connect(model_, &QAbstractItemModel::modelReset, this, &MainWindow::onTableSelectionChanged);
  connect(model_, &QAbstractItemModel::rowsRemoved, this, &MainWindow::onTableSelectionChanged);
  connect(viewport_, &Viewport::probeClicked, this, &MainWindow::onProbeClicked);
  connect(viewport_, &Viewport::boxSelected, this, &MainWindow::onBoxSelected);
  connect(viewport_, &Viewport::addProbeRequested, this,
          [this](const PickRay& ray) { addProbeOnSurface(ray); });
  // While a probe is dragged, the test object's volume is edited in place: say how long it took.
  connect(viewport_, &Viewport::previewVolumeEdited, this, [this](double seconds, qsizetype tets) {
    statusBar()->showMessage(tr("Preview volume updated in place: %1 tetrahedra in %2 µs")
                                 .arg(tets)
                                 .arg(seconds * 1e6, 0, 'f', 0),
                             3000);
  });
  // Why a shown overlay is empty, and what fixes it.
  connect(viewport_, &Viewport::fieldsUpdated, this, &MainWindow::updateOverlayReason);
  connect(viewport_, &Viewport::overlaysToggled, this, &MainWindow::updateOverlayReason);
  connect(viewport_, &Viewport::sceneLightingUpdated, this, &MainWindow::updateOverlayReason);
  for (auto signal : {&Document::probesReset, &Document::volumeChanged, &Document::rigChanged})
    connect(doc_, signal, this, &MainWindow::updateOverlayReason);
  for (auto signal : {&Document::probeInserted, &Document::probeRemoved, &Document::probeChanged})
    connect(doc_, signal, this, &MainWindow::updateOverlayReason);
  connect(doc_, &Document::volumeStateChanged, this, &MainWindow::updateVolumeState);
  connect(doc_, &Document::modifiedChanged, this, &MainWindow::updateTitle);
  connect(doc_, &Document::pathsChanged, this, &MainWindow::updateTitle);
  connect(doc_, &Document::pathsChanged, this, &MainWindow::updateStatus);
  connect(doc_, &Document::probesReset, this, &MainWindow::updateStatus);
  connect(doc_, &Document::probeInserted, this, &MainWindow::updateStatus);
  connect(doc_, &Document::probeRemoved, this, &MainWindow::updateStatus);
  connect(doc_, &Document::probeChanged, this, &MainWindow::updateStatus);
  connect(doc_, &Document::jobProgress, this, &MainWindow::onJobProgress);
  connect(doc_, &Document::jobFinished, this, [this](const QString& error) {
    progress_->hide();
    cancelJob_->hide();
    jobLabel_->clear();
    jobTimer_.invalidate();
    const QString kind = jobKind_;
    jobKind_.clear();
    // The proposal in a scene without any light places its candidates but cannot capture them:
    // the banner over the view says so and offers a sky; no dialog stands in front of the scene.
    const Scene* scene = doc_->scene();
    if (kind == QLatin1String("propose") && scene && !hasAnyLight(*scene, doc_->probeSet().rig))
      return updateOverlayReason();
    if (!error.isEmpty() && error != QLatin1String("cancelled")) showError(jobTitle(kind), error);
  });
  updateTitle();
  updateStatus();
  // The first window: 1600 x 1000, or 90 % of a smaller screen.
  if (const QScreen* screen = QGuiApplication::primaryScreen())
    resize(QSize(1600, 1000).boundedTo(screen->availableSize() * 0.9));
}

void MainWindow::createActions() {
  QMenu* file = menuBar()->addMenu(tr("&File"));
  QAction* a = file->addAction(tr("Open &scene…"), this, [this] {
    const QString path =
        QFileDialog::getOpenFileName(this, tr("Open scene"), {}, tr("glTF scenes (*.gltf *.glb)"));
    if (!path.isEmpty()) openScene(path);
  });
  a->setShortcut(QKeySequence::Open);
  a = file->addAction(tr("Open &probe set…"), this, [this] {
    const QString path =
        QFileDialog::getOpenFileName(this, tr("Open probe set"), {}, tr("Probe sets (*.json)"));
    if (!path.isEmpty()) openProbeSet(path);
  });
  a->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_O));
  recentMenu_ = file->addMenu(tr("Open &recent"));
  connect(recentMenu_, &QMenu::aboutToShow, this, &MainWindow::rebuildRecentMenu);
  rebuildRecentMenu();
  file->addSeparator();
  a = file->addAction(tr("&Save probe set"), this, [this] { save(); });
  a->setShortcut(QKeySequence::Save);
  a = file->addAction(tr("Save probe set &as…"), this, [this] { saveAs(); });
  a->setObjectName("saveAsAction");
  // Spelled out: QKeySequence::SaveAs and ::Quit are empty on some platforms (offscreen, X11
  // without a desktop's theme).
  a->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_S));
  file->addSeparator();
  a = file->addAction(tr("&Quit"), this, &QWidget::close);
  a->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_Q));

  QMenu* edit = menuBar()->addMenu(tr("&Edit"));
  a = doc_->undoStack()->createUndoAction(this, tr("&Undo"));
  a->setShortcut(QKeySequence::Undo);
  edit->addAction(a);
  a = doc_->undoStack()->createRedoAction(this, tr("&Redo"));
  a->setObjectName("redoAction");
  // Both conventions: Ctrl+Shift+Z (KDE, macOS) and Ctrl+Y (Windows, the README).
  a->setShortcuts(
      {QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_Z), QKeySequence(Qt::CTRL | Qt::Key_Y)});
  edit->addAction(a);
  edit->addSeparator();
  a = edit->addAction(tr("&Accept selected"), this,
                      [this] { doc_->setStates(selectedIds(), ProbeState::Accepted); });
  a->setShortcut(Qt::Key_A);
  a = edit->addAction(tr("&Reject selected"), this,
                      [this] { doc_->setStates(selectedIds(), ProbeState::Rejected); });
  a->setShortcut(Qt::Key_R);
  a = edit->addAction(tr("Make &candidate"), this,
                      [this] { doc_->setStates(selectedIds(), ProbeState::Candidate); });
  a->setShortcut(Qt::Key_C);
  a = edit->addAction(tr("&Delete selected"), this, [this] { doc_->deleteProbes(selectedIds()); });
  a->setShortcut(QKeySequence::Delete);
  a = edit->addAction(tr("&Lock selected"), this, [this] { doc_->setLocked(selectedIds(), true); });
  a->setShortcut(Qt::Key_L);
  a = edit->addAction(tr("&Unlock selected"), this,
                      [this] { doc_->setLocked(selectedIds(), false); });
  a->setShortcut(QKeySequence(Qt::SHIFT | Qt::Key_L));
  edit->addSeparator();
  QAction* addTool = edit->addAction(tr("Add probes by clicking &surfaces"));
  addTool->setCheckable(true);
  addTool->setShortcut(Qt::Key_N);
  connect(addTool, &QAction::toggled, this, [this](bool on) {
    viewport_->setTool(on ? Viewport::Tool::AddProbe : Viewport::Tool::Select);
    statusBar()->showMessage(on ? tr("Click a surface to add a probe (N to stop)") : QString());
  });
  QAction* volumeTool = edit->addAction(tr("Draw importance &volume"));
  volumeTool->setCheckable(true);
  volumeTool->setShortcut(Qt::Key_B);
  volumeTool->setToolTip(
      tr("Drag on a floor to draw a box from it up to the top of the scene; edit it in the "
         "placement panel"));
  connect(volumeTool, &QAction::toggled, this, [this, addTool](bool on) {
    if (on) addTool->setChecked(false);
    viewport_->setTool(
        on ? Viewport::Tool::DrawVolume
           : (addTool->isChecked() ? Viewport::Tool::AddProbe : Viewport::Tool::Select));
    statusBar()->showMessage(on ? tr("Drag on a surface to draw an importance volume (B to stop)")
                                : QString());
  });
  connect(addTool, &QAction::toggled, this, [volumeTool](bool on) {
    if (on) volumeTool->setChecked(false);
  });
  connect(viewport_, &Viewport::volumeDrawn, this,
          [this](const Bounds3& box) { placement_->addVolume(box); });
  a = edit->addAction(tr("Add probe at the &camera"), this, &MainWindow::addProbeAtCamera);
  a->setShortcut(QKeySequence(Qt::SHIFT | Qt::Key_N));
  edit->addSeparator();
  a = edit->addAction(tr("Select a&ll"), table_, &QTableView::selectAll);
  a->setShortcut(QKeySequence::SelectAll);
  a = edit->addAction(tr("Propose &candidates"), this, [this] {
    try {
      doc_->proposeCandidates();
    } catch (const Error& e) {
      showError(jobTitle(QStringLiteral("propose")), QString::fromStdString(e.what()));
    }
  });

  QMenu* probes = menuBar()->addMenu(tr("&Probes"));
  a = probes->addAction(tr("&Run placement"), this, [this] { placement_->run(); });
  a->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_R));
  a = probes->addAction(tr("&Bake accepted probes"), this, [this] {
    if (doc_->probeSetPath().isEmpty() && !saveAs()) return;
    placement_->bake();
  });
  a->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_B));
  a = probes->addAction(tr("&Evaluate"), this, [this] { evaluation_->evaluate(); });
  a->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_E));
  a = probes->addAction(tr("&Cancel background job"), doc_, &Document::requestCancel);
  a->setShortcut(Qt::Key_Escape);
  a = probes->addAction(tr("Open &volume…"), this, [this] {
    const QString path =
        QFileDialog::getOpenFileName(this, tr("Open volume"), {}, tr("Probe volumes (*.psv)"));
    if (path.isEmpty()) return;
    try {
      doc_->openVolume(path);
    } catch (const Error& e) {
      showError(tr("Open volume"), QString::fromStdString(e.what()));
    }
  });

  QMenu* view = menuBar()->addMenu(tr("&View"));
  a = view->addAction(tr("&Frame all"), viewport_, &Viewport::frameAll);
  a->setShortcut(Qt::Key_F);
  a = view->addAction(tr("Frame &selection"), viewport_, &Viewport::frameSelection);
  a->setShortcut(QKeySequence(Qt::SHIFT | Qt::Key_F));
  view->addSeparator();
  a = view->addAction(tr("Show &probes"), viewport_, &Viewport::setProbesVisible);
  a->setCheckable(true);
  a->setChecked(true);
  a->setShortcut(Qt::Key_P);
  a = view->addAction(tr("Show re&jected probes"), viewport_, &Viewport::setRejectedVisible);
  a->setCheckable(true);
  a->setChecked(true);
  a->setShortcut(Qt::Key_H);
  a = view->addAction(tr("C&ut-away"), viewport_, &Viewport::setCutaway);
  a->setCheckable(true);
  a->setChecked(true);
  a->setShortcut(Qt::Key_X);
  a = view->addAction(tr("Raise cut"), this,
                      [this] { viewport_->setCutFraction(viewport_->cutFraction() + 0.05f); });
  a->setShortcut(Qt::Key_PageUp);
  a = view->addAction(tr("Lower cut"), this,
                      [this] { viewport_->setCutFraction(viewport_->cutFraction() - 0.05f); });
  a->setShortcut(Qt::Key_PageDown);
  view->addSeparator();
  a = view->addAction(tr("&Brighter (+1/2 stop)"), this,
                      [this] { viewport_->setExposureStops(viewport_->exposureStops() + 0.5f); });
  a->setShortcut(Qt::Key_BracketRight);
  a = view->addAction(tr("&Darker (-1/2 stop)"), this,
                      [this] { viewport_->setExposureStops(viewport_->exposureStops() - 0.5f); });
  a->setShortcut(Qt::Key_BracketLeft);
  a = view->addAction(tr("&Auto exposure"), this, [this] { viewport_->setExposureStops(0); });
  view->addSeparator();
  QToolBar* overlayBar = addToolBar(tr("Overlays"));
  overlayBar->setObjectName("overlayToolBar");
  a = view->addAction(tr("Probe &lighting preview"), viewport_, &Viewport::setPreviewLighting);
  a->setCheckable(true);
  a->setChecked(viewport_->previewLighting());
  a->setShortcut(Qt::Key_I);
  a->setToolTip(
      tr("Shade surfaces with the probes' interpolated irradiance (off, or before "
         "any capture: the scene's own lights)"));
  overlayBar->addAction(a);
  a = view->addAction(tr("&Flat colours"), viewport_, &Viewport::setFlatShading);
  a->setObjectName("flatShadingAction");
  a->setCheckable(true);
  a->setShortcut(QKeySequence(Qt::SHIFT | Qt::Key_I));
  a->setToolTip(tr("Draw the surfaces in their flat colours instead of lit"));
  const struct {
    Viewport::Overlay overlay;
    const char* text;
    QKeySequence key;
  } overlays[] = {
      {Viewport::Overlay::Glyphs, "&Gradient glyphs", QKeySequence(Qt::Key_G)},
      {Viewport::Overlay::Slice, "&Slice plane", QKeySequence(Qt::Key_V)},
      {Viewport::Overlay::TetMesh, "&Tetrahedral mesh", QKeySequence(Qt::Key_T)},
      {Viewport::Overlay::TestObject, "Test &object", QKeySequence(Qt::Key_O)},
      {Viewport::Overlay::ErrorPoints, "Evaluation &error points", QKeySequence(Qt::Key_U)},
      {Viewport::Overlay::Domain, "&Domain of interest", QKeySequence(Qt::Key_M)},
  };
  for (const auto& o : overlays) {
    const Viewport::Overlay which = o.overlay;
    a = view->addAction(tr(o.text), this,
                        [this, which](bool on) { viewport_->setOverlay(which, on); });
    a->setCheckable(true);
    a->setShortcut(o.key);
    overlayBar->addAction(a);
    if (which == Viewport::Overlay::ErrorPoints) {
      a->setObjectName("errorPointsAction");
      a->setToolTip(tr("The last evaluation's queries, coloured by their error in stops"));
      // A finished evaluation shows where its error is.
      connect(doc_, &Document::evaluationsChanged, a, [this, a] {
        if (!doc_->evaluations().empty() && !a->isChecked()) a->trigger();
      });
    }
  }
  a = view->addAction(tr("Glyphs at the probes (not the grid)"), viewport_,
                      &Viewport::setGlyphsAtProbes);
  a->setCheckable(true);
  QMenu* slice = view->addMenu(tr("Slice"));
  auto* sliceModes = new QActionGroup(this);
  a = slice->addAction(tr("Luminance distance to the selected probe"), this,
                       [this] { viewport_->setSliceMode(Viewport::SliceMode::LuminanceDistance); });
  a->setCheckable(true);
  a->setChecked(true);
  sliceModes->addAction(a);
  a = slice->addAction(tr("Interpolation error (accepted vs all captured)"), this,
                       [this] { viewport_->setSliceMode(Viewport::SliceMode::Error); });
  a->setCheckable(true);
  sliceModes->addAction(a);
  slice->addSeparator();
  for (int axis = 0; axis < 3; ++axis) {
    a = slice->addAction(tr("Across %1").arg(QChar('X' + axis)), this,
                         [this, axis] { viewport_->setSliceAxis(axis); });
  }
  a = slice->addAction(tr("Move slice up"), this,
                       [this] { viewport_->setSliceFraction(viewport_->sliceFraction() + 0.05f); });
  a->setShortcut(QKeySequence(Qt::ALT | Qt::Key_Up));
  a = slice->addAction(tr("Move slice down"), this,
                       [this] { viewport_->setSliceFraction(viewport_->sliceFraction() - 0.05f); });
  a->setShortcut(QKeySequence(Qt::ALT | Qt::Key_Down));
  QMenu* source = view->addMenu(tr("Preview and overlays &use"));
  auto* sources = new QActionGroup(this);
  const struct {
    PreviewSource source;
    const char* text;
  } sourceItems[] = {{PreviewSource::AllCaptured, "All captured probes (candidates too)"},
                     {PreviewSource::Accepted, "Accepted probes"},
                     {PreviewSource::Baked, "The baked volume"}};
  for (const auto& item : sourceItems) {
    const PreviewSource which = item.source;
    a = source->addAction(tr(item.text), this,
                          [this, which] { viewport_->setPreviewSource(which); });
    a->setCheckable(true);
    a->setChecked(which == viewport_->previewSource());
    sources->addAction(a);
  }
  view->addSeparator();
  view->addAction(findChild<QDockWidget*>("probesDock")->toggleViewAction());
  view->addAction(findChild<QDockWidget*>("inspectorDock")->toggleViewAction());
  view->addAction(findChild<QDockWidget*>("placementDock")->toggleViewAction());
  view->addAction(findChild<QDockWidget*>("lightingDock")->toggleViewAction());
  view->addAction(findChild<QDockWidget*>("evaluationDock")->toggleViewAction());

  QToolBar* tools = addToolBar(tr("Edit"));
  tools->setObjectName("editToolBar");
  tools->addAction(addTool);
  tools->addAction(volumeTool);
}

void MainWindow::confineKeyShortcutsToViewport() {
  for (QAction* a : findChildren<QAction*>()) {
    bool typed = false;  // a key that types text in a field (Shift allowed: "R" is Shift+R)
    for (const QKeySequence& k : a->shortcuts()) {
      if (k.count() != 1) continue;
      const QKeyCombination c = k[0];
      const Qt::KeyboardModifiers mods =
          c.keyboardModifiers() & ~(Qt::ShiftModifier | Qt::KeypadModifier);
      typed = typed || (mods == Qt::NoModifier && c.key() != Qt::Key_Escape);
    }
    if (!typed) continue;
    a->setShortcutContext(Qt::WidgetShortcut);
    viewport_->addAction(a);
  }
}

QStringList MainWindow::recentFiles() const {
  return QSettings().value("recentFiles").toStringList();
}

void MainWindow::addRecentFile(const QString& path) {
  const QString abs = QFileInfo(path).absoluteFilePath();
  QStringList list = recentFiles();
  list.removeAll(abs);
  list.prepend(abs);
  while (list.size() > kMaxRecent) list.removeLast();
  QSettings().setValue("recentFiles", list);
}

void MainWindow::rebuildRecentMenu() {
  recentMenu_->clear();
  const QStringList list = recentFiles();
  for (int i = 0; i < list.size(); ++i) {
    const QString path = list[i];
    QAction* a =
        recentMenu_->addAction(QStringLiteral("&%1 %2").arg(i + 1).arg(QFileInfo(path).fileName()),
                               this, [this, path] { openRecent(path); });
    a->setToolTip(path);
    a->setStatusTip(path);
  }
  recentMenu_->setEnabled(!list.isEmpty());
  if (!list.isEmpty()) {
    recentMenu_->addSeparator();
    recentMenu_->addAction(tr("Clear list"), this, [this] {
      QSettings().remove("recentFiles");
      rebuildRecentMenu();
    });
  }
}

bool MainWindow::openRecent(const QString& path) {
  return openPath(path);
}

bool MainWindow::openPath(const QString& path) {
  return path.endsWith(QLatin1String(".json"), Qt::CaseInsensitive) ? openProbeSet(path)
                                                                    : openScene(path);
}

QString MainWindow::jobTitle(const QString& kind) {
  if (kind == QLatin1String("propose")) return tr("Probe proposal");
  if (kind == QLatin1String("place")) return tr("Run placement");
  if (kind == QLatin1String("bake")) return tr("Bake");
  if (kind == QLatin1String("recapture")) return tr("Recapture probes");
  if (kind == QLatin1String("eval")) return tr("Evaluate");
  return tr("Background job");
}

QString MainWindow::editorMessage(const QString& message) {
  // The core names the command line's flags; in the editor the same settings are the Lighting
  // tab's controls.
  QString m = message;
  static const QRegularExpression flag(QStringLiteral(R"( \(--[a-z-]+[^)]*\))"));
  const bool hadFlags = m.contains(flag);
  m.remove(flag);
  if (hadFlags)
    m.replace(QLatin1String("add a sun, a sky or an environment map"),
              QLatin1String("add a sun, a sky or a point light in the Lighting tab"));
  return m;
}

void MainWindow::setJobBarValue(int percent) {
  // QProgressBar::setValue repaints at once (a synchronous flush of the whole window, which
  // software GL composes on the job's cores); with updates off it only schedules the repaint.
  if (progress_->value() == percent) return;
  progress_->setUpdatesEnabled(false);
  progress_->setValue(percent);
  progress_->setUpdatesEnabled(true);  // update(): repainted with the next frame
}

void MainWindow::onJobProgress(const QString& what, double fraction) {
  const bool busy = doc_->isBusy();
  if (busy && !jobTimer_.isValid()) {
    jobTimer_.start();
    jobKind_ = doc_->jobKind();
    setJobBarValue(0);
  }
  // One bar for the whole job: the document reports the overall fraction across its phases;
  // the bar never goes back within a job.
  const int percent = std::max(progress_->value(), int(fraction * 100));
  setJobBarValue(percent);
  QString text = what;
  const double elapsed = jobTimer_.isValid() ? jobTimer_.elapsed() * 1e-3 : 0.0;
  if (busy && !doc_->isCancelling() && percent >= 3 && elapsed >= 2.0) {
    const double left = elapsed * (100 - percent) / percent;
    text += left < 60 ? tr(" (about %1 s left)").arg(std::max(1, int(std::lround(left))))
                      : tr(" (about %1 min left)").arg(int(std::lround(left / 60)));
  }
  jobLabel_->setText(text);
  progress_->setVisible(busy);
  cancelJob_->setVisible(busy);
}

bool MainWindow::offerSaveBeforeBake(std::optional<int> answer) {
  QString suggestion = doc_->scenePath().isEmpty()
                           ? QString()
                           : QFileInfo(doc_->scenePath()).absolutePath() + "/" +
                                 QFileInfo(doc_->scenePath()).completeBaseName() + ".probes.json";
  if (QFileInfo::exists(suggestion)) suggestion.clear();  // never overwrite without a dialog
  int choice = answer.value_or(0);
  if (!answer) {
    QMessageBox box(QMessageBox::Question, tr("Bake"),
                    suggestion.isEmpty()
                        ? tr("The bake saves its volume beside the probe set, which has no file "
                             "yet. Save the probe set first?")
                        : tr("The bake saves its volume beside the probe set, which has no file "
                             "yet. Save the probe set as %1 and bake?")
                              .arg(QFileInfo(suggestion).fileName()),
                    QMessageBox::Save | QMessageBox::Cancel, this);
    box.setObjectName("saveBeforeBakeBox");
    box.setInformativeText(suggestion.isEmpty() ? QString() : QFileInfo(suggestion).absolutePath());
    QPushButton* other = box.addButton(tr("Save as…"), QMessageBox::ActionRole);
    if (suggestion.isEmpty()) other->hide();
    choice = box.exec();
    if (box.clickedButton() == other) choice = QMessageBox::SaveAll;
  }
  if (choice == QMessageBox::Save) return suggestion.isEmpty() ? saveAs() : saveAs(suggestion);
  if (choice == QMessageBox::SaveAll) return saveAs();
  return false;
}

void MainWindow::startAutosave(const QString& folder, int intervalMs) {
  delete autosave_;
  autosaveFolder_ = folder;
  autosave_ = new Autosave(doc_, folder, intervalMs, this);
}

bool MainWindow::offerRecovery(std::optional<int> answer) {
  if (autosaveFolder_.isEmpty()) return false;
  const auto orphans = Autosave::findOrphans(autosaveFolder_);
  if (orphans.empty()) return false;
  const Autosave::Orphan& o = orphans.front();
  const QString what = o.originalSetPath.isEmpty() ? tr("an unsaved probe set")
                                                   : QFileInfo(o.originalSetPath).fileName();
  int choice = answer.value_or(0);
  if (!answer) {
    QMessageBox box(QMessageBox::Question, tr("Recover unsaved work"),
                    tr("ProbeStudio did not close properly. Recover the changes to %1 (scene %2) "
                       "autosaved at %3?")
                        .arg(what, QFileInfo(o.scenePath).fileName(),
                             o.savedAt.toLocalTime().toString(Qt::TextDate)),
                    QMessageBox::Yes | QMessageBox::Discard | QMessageBox::Ignore, this);
    box.button(QMessageBox::Yes)->setText(tr("Recover"));
    box.button(QMessageBox::Ignore)->setText(tr("Not now"));
    choice = box.exec();
  }
  if (choice == QMessageBox::Discard) {
    Autosave::discard(o);
    return false;
  }
  if (choice != QMessageBox::Yes) return false;
  try {
    doc_->recover(o.recoveryPath, o.originalSetPath);
  } catch (const Error& e) {
    showError(tr("Recover"), QString::fromStdString(e.what()));
    return false;
  }
  Autosave::discard(o);  // this session's autosave owns the work now
  if (autosave_) autosave_->saveNow();
  viewport_->frameAll();
  return true;
}

double MainWindow::surfaceOffsetMeters() const {
  const Scene* scene = doc_->scene();
  const double diag = scene ? scene->bounds.diagonal() : 10.0;
  return std::clamp(diag * 0.03, 0.05, 1.0);
}

bool MainWindow::addProbeOnSurface(const PickRay& ray) {
  const Tracer* tracer = doc_->tracer();
  if (!tracer) return false;
  const Vec3 o(ray.origin.x(), ray.origin.y(), ray.origin.z());
  const Vec3 d(ray.direction.x(), ray.direction.y(), ray.direction.z());
  const auto placed = placeOnSurface(*tracer, o, d, surfaceOffsetMeters());
  if (!placed) {
    statusBar()->showMessage(tr("No surface under the cursor"), 3000);
    return false;
  }
  const uint64_t id = doc_->addManualProbe(placed->position, tr("Add probe on surface"));
  selectIds({quint64(id)});
  return true;
}

void MainWindow::addProbeAtCamera() {
  if (!doc_->hasScene()) return;
  const QVector3D e = viewport_->camera().eye();
  const uint64_t id = doc_->addManualProbe(Vec3(e.x(), e.y(), e.z()), tr("Add probe at camera"));
  selectIds({quint64(id)});
}

void MainWindow::onBoxSelected(const QSet<quint64>& ids, Qt::KeyboardModifiers mods) {
  QSet<quint64> sel = (mods & Qt::ShiftModifier) ? viewport_->selection() : QSet<quint64>();
  sel.unite(ids);
  selectIds(sel);
}

void MainWindow::showError(const QString& title, const QString& given) {
  const QString message = editorMessage(given);
  lastError_ = message;
  if (quiet_) return;
  QMessageBox::warning(this, title, message);
}

bool MainWindow::openScene(const QString& path, double metresPerUnit) {
  if (promptOnClose_ && !maybeSave()) return false;
  try {
    doc_->openScene(path, metresPerUnit);
  } catch (const Error& e) {
    showError(tr("Open scene"), QString::fromStdString(e.what()));
    return false;
  }
  addRecentFile(path);
  if (!doc_->unitHint().isEmpty())
    statusBar()->showMessage(tr("Warning: %1 (probestudio-editor --units)").arg(doc_->unitHint()));
  viewport_->frameAll();
  return true;
}

bool MainWindow::openProbeSet(const QString& path) {
  if (promptOnClose_ && !maybeSave()) return false;
  try {
    doc_->openProbeSet(path);
  } catch (const Error& e) {
    showError(tr("Open probe set"), QString::fromStdString(e.what()));
    return false;
  }
  addRecentFile(path);
  if (!doc_->unitHint().isEmpty())
    statusBar()->showMessage(tr("Warning: %1 (probestudio-editor --units)").arg(doc_->unitHint()));
  const std::string stale = doc_->staleCapturesText();
  if (!stale.empty())
    statusBar()->showMessage(
        QString::fromStdString(stale) +
            tr(". Lighting › Recapture probes with this lighting captures them again."),
        15000);
  viewport_->frameAll();
  return true;
}

bool MainWindow::save() {
  if (doc_->probeSetPath().isEmpty()) return saveAs();
  try {
    doc_->saveProbeSet(doc_->probeSetPath());
  } catch (const Error& e) {
    showError(tr("Save probe set"), QString::fromStdString(e.what()));
    return false;
  }
  addRecentFile(doc_->probeSetPath());
  statusBar()->showMessage(tr("Saved %1").arg(doc_->probeSetPath()), 3000);
  return true;
}

bool MainWindow::saveAs(const QString& given) {
  QString path = given;
  if (path.isEmpty()) {
    QString suggestion = doc_->probeSetPath();
    if (suggestion.isEmpty() && !doc_->scenePath().isEmpty()) {
      const QFileInfo fi(doc_->scenePath());
      suggestion = fi.absolutePath() + "/" + fi.completeBaseName() + ".probes.json";
    }
    path = QFileDialog::getSaveFileName(this, tr("Save probe set"), suggestion,
                                        tr("Probe sets (*.json)"));
    if (path.isEmpty()) return false;
  }
  try {
    doc_->saveProbeSet(path);
  } catch (const Error& e) {
    showError(tr("Save probe set"), QString::fromStdString(e.what()));
    return false;
  }
  addRecentFile(path);
  return true;
}

bool MainWindow::maybeSave() {
  if (!doc_->isModified()) return true;
  const auto answer = QMessageBox::warning(
      this, tr("Unsaved changes"), tr("The probe set has unsaved changes. Save them?"),
      QMessageBox::Save | QMessageBox::Discard | QMessageBox::Cancel);
  if (answer == QMessageBox::Save) return save();
  return answer == QMessageBox::Discard;
}

int MainWindow::docksWidth(Qt::DockWidgetArea side) const {
  // The tabs of the side's docks, each its title and the style's padding (QTabBar::tabSizeHint),
  // side by side, and the widest panel without a horizontal scroll bar.
  int tabs = 0, panels = 0;
  const int tabPadding = style()->pixelMetric(QStyle::PM_TabBarTabHSpace, nullptr, this);
  const int scrollBar = style()->pixelMetric(QStyle::PM_ScrollBarExtent, nullptr, this);
  for (const QDockWidget* d : findChildren<QDockWidget*>()) {
    if (dockWidgetArea(const_cast<QDockWidget*>(d)) != side) continue;
    tabs += fontMetrics().size(Qt::TextShowMnemonic, d->windowTitle()).width() + tabPadding;
    if (const auto* area = qobject_cast<const QScrollArea*>(d->widget()))
      panels = std::max(panels, area->widget()->minimumSizeHint().width() + scrollBar);
  }
  return std::max(tabs, panels) + kDockFrame;
}

void MainWindow::resizeEvent(QResizeEvent* e) {
  if (!dockSizesSet_ && e->size().width() > 0) {
    const int w = e->size().width();
    resizeDocks({leftDock_, rightDock_},
                {std::max(int(kLeftDockShare * w), docksWidth(Qt::LeftDockWidgetArea)),
                 std::max(int(kRightDockShare * w), docksWidth(Qt::RightDockWidgetArea))},
                Qt::Horizontal);  // the layout keeps each dock at least at its minimum
  }
  QMainWindow::resizeEvent(e);
}

void MainWindow::showEvent(QShowEvent* e) {
  dockSizesSet_ = true;  // the size it is shown at came in a resize event before this
  QMainWindow::showEvent(e);
}

void MainWindow::closeEvent(QCloseEvent* e) {
  if (promptOnClose_ && !maybeSave()) {
    e->ignore();
    return;
  }
  e->accept();
}

void MainWindow::updateTitle() {
  QString name =
      doc_->probeSetPath().isEmpty() ? tr("untitled") : QFileInfo(doc_->probeSetPath()).fileName();
  if (!doc_->scenePath().isEmpty()) name += " (" + QFileInfo(doc_->scenePath()).fileName() + ")";
  setWindowTitle(name + "[*] — ProbeStudio");
  setWindowModified(doc_->isModified());
}

void MainWindow::updateStatus() {
  const Scene* scene = doc_->scene();
  sceneLabel_->setText(scene ? QFileInfo(doc_->scenePath()).fileName() : tr("No scene"));
  trianglesLabel_->setText(scene ? tr("%L1 triangles").arg(scene->triangleCount()) : QString());
  int counts[3] = {0, 0, 0};
  for (const Probe& p : doc_->probes()) ++counts[int(p.state)];
  probesLabel_->setText(tr("%1 probes (%2 accepted, %3 candidates, %4 rejected)")
                            .arg(doc_->probes().size())
                            .arg(counts[int(ProbeState::Accepted)])
                            .arg(counts[int(ProbeState::Candidate)])
                            .arg(counts[int(ProbeState::Rejected)]));
}

void MainWindow::updateVolumeState() {
  const bool stale = doc_->volumeState() == Document::VolumeState::Stale;
  volumeState_->setText(stale ? tr("Volume %1; bake again (Ctrl+B)").arg(doc_->volumeStatusText())
                              : QString());
  volumeState_->setToolTip(volumeState_->text());
}

void MainWindow::updateOverlayReason() {
  const QString reason = viewport_->emptyOverlayReason();
  overlayReason_->setText(reason);
  const Scene* scene = doc_->scene();
  bannerAction_->setVisible(scene && !hasAnyLight(*scene, doc_->probeSet().rig));
  banner_->setVisible(!reason.isEmpty() && centralWidget() == viewport_);
  placeBanner();
}

void MainWindow::placeBanner() {
  if (!banner_->isVisible() || centralWidget() != viewport_) return;
  constexpr int kMargin = 8;
  const QRect view = viewport_->geometry();
  const int width = std::max(view.width() - 2 * kMargin, 1);
  const int height = banner_->layout()->hasHeightForWidth()
                         ? banner_->layout()->totalHeightForWidth(width)
                         : banner_->sizeHint().height();
  banner_->setGeometry(view.x() + kMargin, view.y() + kMargin, width, height);
  banner_->raise();
}

bool MainWindow::eventFilter(QObject* watched, QEvent* e) {
  if (watched == viewport_ && (e->type() == QEvent::Resize || e->type() == QEvent::Move))
    placeBanner();
  return QMainWindow::eventFilter(watched, e);
}

void MainWindow::addDefaultSky() {
  LightingRig rig = doc_->probeSet().rig;
  rig.skyRadiance = kDefaultSkyRadiance;
  doc_->setRig(rig, tr("Add a default sky"));
}

std::vector<uint64_t> MainWindow::selectedIds() const {
  std::vector<uint64_t> ids;
  for (const QModelIndex& i : table_->selectionModel()->selectedRows())
    ids.push_back(i.data(ProbeTableModel::ProbeIdRole).toULongLong());
  return ids;
}

void MainWindow::onTableSelectionChanged() {
  if (syncingSelection_) return;
  QSet<quint64> ids;
  for (uint64_t id : selectedIds()) ids.insert(id);
  viewport_->setSelection(ids);
  inspector_->setSelection(ids);
}

void MainWindow::selectIds(const QSet<quint64>& ids) {
  QItemSelection sel;
  for (quint64 id : ids) {
    const int row = doc_->indexOf(id);
    if (row < 0) continue;
    const QModelIndex proxyIndex = proxy_->mapFromSource(model_->index(row, 0));
    sel.select(proxyIndex, proxyIndex);
  }
  table_->selectionModel()->select(sel,
                                   QItemSelectionModel::ClearAndSelect | QItemSelectionModel::Rows);
  if (!sel.isEmpty()) table_->scrollTo(sel.indexes().first());
}

void MainWindow::onProbeClicked(std::optional<quint64> id, Qt::KeyboardModifiers mods) {
  QSet<quint64> ids =
      (mods & (Qt::ControlModifier | Qt::ShiftModifier)) ? viewport_->selection() : QSet<quint64>();
  if (id) {
    if ((mods & Qt::ControlModifier) && ids.contains(*id))
      ids.remove(*id);
    else
      ids.insert(*id);
  }
  selectIds(ids);
}

}  // namespace ps::ui
