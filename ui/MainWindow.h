#pragma once
// The editor's main window: viewport in the centre, probe table in a dock, menus, status bar.
// Every action that can fail catches ps::Error and shows it; the document then stays as it was.
#include <QMainWindow>
#include <QSet>
#include <optional>

class QLabel;
class QProgressBar;
class QSortFilterProxyModel;
class QTableView;

namespace ps::ui {

class Document;
class ProbeTableModel;
class Viewport;

class MainWindow : public QMainWindow {
  Q_OBJECT
 public:
  explicit MainWindow(QWidget* parent = nullptr);

  Document* document() const { return doc_; }
  Viewport* viewport() const { return viewport_; }
  QTableView* probeTable() const { return table_; }

  /// No prompts on close (screenshot and test runs).
  void setPromptOnClose(bool on) { promptOnClose_ = on; }

  // Actions, public so that main() and tests can drive them. They return false (after showing
  // the error, unless quiet) when the operation failed; the document is then unchanged.
  bool openScene(const QString& path);
  bool openProbeSet(const QString& path);
  bool save();
  bool saveAs(const QString& path = {});

  /// Last error shown (or suppressed), for the command line and tests.
  QString lastError() const { return lastError_; }
  /// When quiet, errors are recorded in lastError() instead of shown in a message box.
  void setQuiet(bool on) { quiet_ = on; }

 protected:
  void closeEvent(QCloseEvent* e) override;

 private:
  void createActions();
  void showError(const QString& title, const QString& message);
  bool maybeSave();
  void updateTitle();
  void updateStatus();
  std::vector<uint64_t> selectedIds() const;
  void onTableSelectionChanged();
  void onProbeClicked(std::optional<quint64> id, Qt::KeyboardModifiers mods);
  void selectIds(const QSet<quint64>& ids);

  Document* doc_;
  Viewport* viewport_;
  ProbeTableModel* model_;
  QSortFilterProxyModel* proxy_;
  QTableView* table_;
  QLabel* sceneLabel_;
  QLabel* trianglesLabel_;
  QLabel* probesLabel_;
  QLabel* jobLabel_;
  QProgressBar* progress_;
  bool promptOnClose_ = true;
  bool quiet_ = false;
  bool syncingSelection_ = false;
  QString lastError_;
};

}  // namespace ps::ui
