#include "ui/MainWindow.h"

#include <QAction>
#include <QApplication>
#include <QCloseEvent>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QHeaderView>
#include <QItemSelectionModel>
#include <QLabel>
#include <QMenuBar>
#include <QMessageBox>
#include <QProgressBar>
#include <QSortFilterProxyModel>
#include <QStatusBar>
#include <QTableView>
#include <QUndoStack>

#include "core/common/Error.h"
#include "ui/Document.h"
#include "ui/ProbeTableModel.h"
#include "ui/Viewport.h"

namespace ps::ui {

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

  sceneLabel_ = new QLabel(tr("No scene"));
  trianglesLabel_ = new QLabel;
  probesLabel_ = new QLabel;
  jobLabel_ = new QLabel;
  progress_ = new QProgressBar;
  progress_->setRange(0, 100);
  progress_->setMaximumWidth(160);
  progress_->hide();
  statusBar()->addWidget(sceneLabel_);
  statusBar()->addWidget(trianglesLabel_);
  statusBar()->addWidget(probesLabel_);
  statusBar()->addPermanentWidget(jobLabel_);
  statusBar()->addPermanentWidget(progress_);

  createActions();

  connect(table_->selectionModel(), &QItemSelectionModel::selectionChanged, this,
          &MainWindow::onTableSelectionChanged);
  connect(model_, &QAbstractItemModel::modelReset, this, &MainWindow::onTableSelectionChanged);
  connect(model_, &QAbstractItemModel::rowsRemoved, this, &MainWindow::onTableSelectionChanged);
  connect(viewport_, &Viewport::probeClicked, this, &MainWindow::onProbeClicked);
  connect(doc_, &Document::modifiedChanged, this, &MainWindow::updateTitle);
  connect(doc_, &Document::pathsChanged, this, &MainWindow::updateTitle);
  connect(doc_, &Document::pathsChanged, this, &MainWindow::updateStatus);
  connect(doc_, &Document::probesReset, this, &MainWindow::updateStatus);
  connect(doc_, &Document::probeInserted, this, &MainWindow::updateStatus);
  connect(doc_, &Document::probeRemoved, this, &MainWindow::updateStatus);
  connect(doc_, &Document::probeChanged, this, &MainWindow::updateStatus);
  connect(doc_, &Document::jobProgress, this, [this](const QString& what, double f) {
    jobLabel_->setText(what);
    progress_->setValue(int(f * 100));
    progress_->setVisible(doc_->isBusy());
  });
  connect(doc_, &Document::jobFinished, this, [this](const QString& error) {
    progress_->hide();
    jobLabel_->clear();
    if (!error.isEmpty() && error != QLatin1String("cancelled"))
      showError(tr("Probe proposal"), error);
  });
  updateTitle();
  updateStatus();
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
  file->addSeparator();
  a = file->addAction(tr("&Save probe set"), this, [this] { save(); });
  a->setShortcut(QKeySequence::Save);
  a = file->addAction(tr("Save probe set &as…"), this, [this] { saveAs(); });
  a->setShortcut(QKeySequence::SaveAs);
  file->addSeparator();
  a = file->addAction(tr("&Quit"), this, &QWidget::close);
  a->setShortcut(QKeySequence::Quit);

  QMenu* edit = menuBar()->addMenu(tr("&Edit"));
  a = doc_->undoStack()->createUndoAction(this, tr("&Undo"));
  a->setShortcut(QKeySequence::Undo);
  edit->addAction(a);
  a = doc_->undoStack()->createRedoAction(this, tr("&Redo"));
  a->setShortcut(QKeySequence::Redo);
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
  edit->addSeparator();
  a = edit->addAction(tr("Select a&ll"), table_, &QTableView::selectAll);
  a->setShortcut(QKeySequence::SelectAll);
  a = edit->addAction(tr("Propose &candidates"), this, [this] { doc_->proposeCandidates(); });

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
  a = view->addAction(tr("&Brighter probes (+1/2 stop)"), this,
                      [this] { viewport_->setExposureStops(viewport_->exposureStops() + 0.5f); });
  a->setShortcut(Qt::Key_BracketRight);
  a = view->addAction(tr("&Darker probes (-1/2 stop)"), this,
                      [this] { viewport_->setExposureStops(viewport_->exposureStops() - 0.5f); });
  a->setShortcut(Qt::Key_BracketLeft);
  a = view->addAction(tr("&Auto exposure"), this, [this] { viewport_->setExposureStops(0); });
  view->addSeparator();
  view->addAction(findChild<QDockWidget*>("probesDock")->toggleViewAction());
}

void MainWindow::showError(const QString& title, const QString& message) {
  lastError_ = message;
  if (quiet_) return;
  QMessageBox::warning(this, title, message);
}

bool MainWindow::openScene(const QString& path) {
  if (promptOnClose_ && !maybeSave()) return false;
  try {
    doc_->openScene(path);
  } catch (const Error& e) {
    showError(tr("Open scene"), QString::fromStdString(e.what()));
    return false;
  }
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
  const std::string stale = doc_->staleCapturesText();
  if (!stale.empty()) statusBar()->showMessage(QString::fromStdString(stale), 15000);
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
