#pragma once
// The editor's main window: viewport in the centre, probe table in a dock, menus, status bar.
// Every action that can fail catches ps::Error and shows it; the document then stays as it was.
#include <QElapsedTimer>
#include <QMainWindow>
#include <QSet>
#include <QStringList>
#include <optional>

#include "core/math/Vec3.h"

class QActionGroup;
class QDockWidget;
class QFrame;
class QLabel;
class QMenu;
class QPushButton;
class QProgressBar;
class QSortFilterProxyModel;
class QTableView;

namespace ps::ui {

class Autosave;
class Document;
class EvaluationPanel;
class InspectorPanel;
class LightingPanel;
class PlacementPanel;
class ProbeTableModel;
class Viewport;
struct PickRay;

class MainWindow : public QMainWindow {
  Q_OBJECT
 public:
  explicit MainWindow(QWidget* parent = nullptr);

  Document* document() const { return doc_; }
  Viewport* viewport() const { return viewport_; }
  QTableView* probeTable() const { return table_; }
  InspectorPanel* inspector() const { return inspector_; }
  PlacementPanel* placementPanel() const { return placement_; }
  LightingPanel* lightingPanel() const { return lighting_; }
  EvaluationPanel* evaluationPanel() const { return evaluation_; }
  Autosave* autosave() const { return autosave_; }
  /// The job's progress bar and its Cancel, in the status bar: the only ones (every job's).
  QProgressBar* jobProgressBar() const { return progress_; }
  QPushButton* cancelButton() const { return cancelJob_; }

  /// The sky "Add a default sky" gives a scene without any light: uniform, W/(m² sr) per channel.
  static constexpr Rgb kDefaultSkyRadiance{0.3, 0.4, 0.6};
  /// The banner over the view saying why it shows nothing or flat colours (hidden otherwise).
  QFrame* viewBanner() const { return banner_; }

  /// No prompts on close (screenshot and test runs).
  void setPromptOnClose(bool on) { promptOnClose_ = on; }

  // Actions, public so that main() and tests can drive them. They return false (after showing
  // the error, unless quiet) when the operation failed; the document is then unchanged.
  /// Opens a scene in its unit (metres per unit); shows the unit hint in the status bar.
  bool openScene(const QString& path, double metresPerUnit = 1.0);
  bool openProbeSet(const QString& path);
  bool save();
  bool saveAs(const QString& path = {});

  /// Recent files (probe sets and scenes, newest first, at most kMaxRecent), kept in QSettings
  /// under "recentFiles". Successful opens and saves add to it.
  static constexpr int kMaxRecent = 8;
  QStringList recentFiles() const;
  /// Opens a recent file: a .json as a probe set, anything else as a scene.
  bool openRecent(const QString& path);
  /// Opens a file by its kind: a .json probe set with its scene (and the volume beside it),
  /// anything else as a glTF scene. The command line's argument goes here.
  bool openPath(const QString& path);

  /// Bake asks this when the probe set has no file: offers to save it beside the scene
  /// (X.gltf -> X.probes.json) or elsewhere. True once saved. With `answer` (tests) no dialog
  /// is shown: QMessageBox::Save saves at the suggestion, anything else declines.
  bool offerSaveBeforeBake(std::optional<int> answer = std::nullopt);

  /// A core message as the editor shows it: the command line's flags ("(--sun DX,DY,DZ,E)")
  /// left out and the Lighting tab named instead.
  static QString editorMessage(const QString& message);
  /// The title of a background job's error box ("Run placement", "Bake", ...).
  static QString jobTitle(const QString& kind);

  /// Starts autosaving into `folder` (Autosave.h) every `intervalMs`.
  void startAutosave(const QString& folder, int intervalMs = 30000);
  /// Looks for recovery files left by a crashed session in the autosave folder and offers the
  /// newest (Recover / Discard / Not now). Returns true when one was recovered. With
  /// `answer` set (tests, scripts) no dialog is shown: QMessageBox::Yes recovers, ::Discard
  /// deletes the files, anything else keeps them.
  bool offerRecovery(std::optional<int> answer = std::nullopt);

  /// Selects these probes in the table, the viewport and the inspector.
  void selectProbes(const QSet<quint64>& ids) { selectIds(ids); }

  /// Adds a probe where the ray meets a surface (offset along the normal): the AddProbe tool.
  bool addProbeOnSurface(const PickRay& ray);
  /// Adds a probe at the camera's eye.
  void addProbeAtCamera();
  /// Offset of surface-placed probes from the surface, metres.
  double surfaceOffsetMeters() const;

  /// Last error shown (or suppressed), for the command line and tests.
  QString lastError() const { return lastError_; }
  /// When quiet, errors are recorded in lastError() instead of shown in a message box.
  void setQuiet(bool on) { quiet_ = on; }

 protected:
  void closeEvent(QCloseEvent* e) override;
  /// Until the window has been shown at a size, gives the docks their default share of the
  /// width (kLeftDockShare, kRightDockShare; at least docksWidth()), the viewport the rest.
  void resizeEvent(QResizeEvent* e) override;
  void showEvent(QShowEvent* e) override;

 private:
  void createActions();
  /// Shortcuts of keys without Ctrl, Alt or Meta (A, R, Shift+L, Delete, ], ...; Esc excepted)
  /// act only while the viewport has the focus: typed into a field, a table or a list they
  /// are text, never an edit of the probes.
  void confineKeyShortcutsToViewport();
  /// The left docks' and the right docks' default share of the window's width: the viewport
  /// keeps about 60 % of it.
  static constexpr double kLeftDockShare = 0.2, kRightDockShare = 0.16;
  /// The least width of one side's docks that cuts nothing: their tabs side by side with whole
  /// titles (as tabs need them; stacked docks need less), and the widest of their panels
  /// without a horizontal scroll bar (pixels).
  int docksWidth(Qt::DockWidgetArea side) const;
  static constexpr int kDockFrame = 8;  ///< a dock's frame and separator, pixels
  void showError(const QString& title, const QString& message);
  bool maybeSave();
  void updateTitle();
  void updateStatus();
  /// The banner over the view: why the preview or a shown overlay is empty
  /// (Viewport::emptyOverlayReason), and for a scene without any light "Add a default sky".
  void updateOverlayReason();
  /// Puts the banner across the top of the view, as high as its text wraps to.
  void placeBanner();
  bool eventFilter(QObject* watched, QEvent* e) override;
  /// Sets the rig's sky to kDefaultSkyRadiance (one undo step).
  void addDefaultSky();
  /// The status bar's volume label: shown while the volume is stale.
  void updateVolumeState();
  std::vector<uint64_t> selectedIds() const;
  void onTableSelectionChanged();
  void onProbeClicked(std::optional<quint64> id, Qt::KeyboardModifiers mods);
  void selectIds(const QSet<quint64>& ids);
  void onBoxSelected(const QSet<quint64>& ids, Qt::KeyboardModifiers mods);
  void addRecentFile(const QString& path);
  void onJobProgress(const QString& what, double fraction);
  /// Sets the job bar's percentage; its repaint waits for the next frame.
  void setJobBarValue(int percent);
  void rebuildRecentMenu();

  Document* doc_;
  Viewport* viewport_;
  ProbeTableModel* model_;
  QSortFilterProxyModel* proxy_;
  QTableView* table_;
  QLabel* sceneLabel_;
  QLabel* trianglesLabel_;
  QLabel* probesLabel_;
  QFrame* banner_;             ///< over the view's top; hidden when there is nothing to say
  QLabel* overlayReason_;      ///< why a shown overlay is empty, with the fixing action
  QPushButton* bannerAction_;  ///< "Add a default sky", for a scene without any light
  QLabel* volumeState_;        ///< a stale volume, named with why (Document::volumeStatusText)
  QLabel* jobLabel_;
  QProgressBar* progress_;
  InspectorPanel* inspector_;
  PlacementPanel* placement_;
  LightingPanel* lighting_;
  EvaluationPanel* evaluation_;
  QPushButton* cancelJob_;
  QDockWidget *leftDock_ = nullptr, *rightDock_ = nullptr;  ///< placement; probes
  bool dockSizesSet_ = false;  ///< shown once: the docks keep the widths the artist gives them
  Autosave* autosave_ = nullptr;
  QString autosaveFolder_;
  QMenu* recentMenu_ = nullptr;
  bool promptOnClose_ = true;
  bool quiet_ = false;
  bool syncingSelection_ = false;
  QString lastError_;
  QElapsedTimer jobTimer_;  ///< since the running job started; invalid when idle
  QString jobKind_;         ///< the running job's kind, kept for its error's title
};

}  // namespace ps::ui
