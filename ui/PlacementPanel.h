#pragma once
// The placement and bake dock: method, spacing, budget, quick-capture samples; Run
// places in the background and replaces the unlocked candidates (Document::runPlacement); Bake
// captures the accepted probes at final quality and saves the volume beside the probe set
// (Document::bake). The importance volumes (boxes the artist adds around a selection and edits in
// a table) restrict greedy's and chajdas' dense field to them and weight chajdas' merging. A job's
// progress and Cancel are in the main window's status bar; the panel says what the last job did.
#include <QWidget>

#include <cstdint>
#include <functional>
#include <vector>

#include "core/math/Vec3.h"

class QCheckBox;
class QComboBox;
class QDoubleSpinBox;
class QLabel;
class QPushButton;
class QSpinBox;
class QTableWidget;
class QTableWidgetItem;

namespace ps::ui {

class Document;
struct PlacementRequest;
struct BakeRequest;

class PlacementPanel : public QWidget {
  Q_OBJECT
 public:
  explicit PlacementPanel(Document* doc, QWidget* parent = nullptr);

  PlacementRequest placementRequest() const;
  BakeRequest bakeRequest() const;
  /// Starts the placement / the bake; false (after emitting failed) when it could not start.
  bool run();
  bool bake();

  /// Where "Add around selection" takes the selected probes from (the main window's table).
  void setSelectionProvider(std::function<std::vector<uint64_t>()> provider) {
    selection_ = std::move(provider);
  }
  /// Asked by bake() when the probe set has no file yet (the volume is saved beside it): true
  /// once the set is saved, false when the artist declined (the bake then does not start).
  void setSaveBeforeBake(std::function<bool()> offer) { saveBeforeBake_ = std::move(offer); }
  /// Adds an importance volume around the selected probes (padded by half a metre), or around
  /// the whole scene when none is selected; one undo step. False (after emitting failed) when
  /// there is neither a selection nor a scene.
  bool addVolumeAroundSelection();
  /// Adds this box as an importance volume ("Volume N", weight 2) and selects its row; one undo
  /// step. False (after emitting failed) when the box is refused.
  bool addVolume(const Bounds3& box);
  /// Removes the volume of the table's current row; one undo step.
  bool removeCurrentVolume();

  QComboBox* methodBox() const { return method_; }
  QDoubleSpinBox* spacingBox() const { return spacing_; }
  QSpinBox* budgetBox() const { return budget_; }
  QDoubleSpinBox* aggressivenessBox() const { return aggressiveness_; }
  QSpinBox* swapPassesBox() const { return swapPasses_; }
  /// greedy's objective: "perceptual" (the default) or "energy".
  QComboBox* objectiveBox() const { return objective_; }
  QSpinBox* captureSamplesBox() const { return captureSpp_; }
  QCheckBox* replaceBox() const { return replace_; }
  QSpinBox* bakeSamplesBox() const { return bakeSpp_; }
  QCheckBox* fitBox() const { return fit_; }
  /// The volume named with its state (Document::volumeStatusText).
  QLabel* volumeLabel() const { return volume_; }
  /// One row per importance volume: name, weight, min x/y/z, max x/y/z (metres), editable.
  QTableWidget* volumeTable() const { return volumes_; }

 signals:
  /// A request was refused (bad numbers, nothing accepted, no saved set): title and reason.
  void failed(const QString& title, const QString& message);

 private:
  void updateState();
  /// The budget's range for the method (greedy: at least kMinGreedyBudget, never "none"; a
  /// budget of none becomes PlacementRequest::kDefaultBudget) and the fields it reads enabled.
  void updateMethodFields();
  /// Shows the opened set's placement settings (method, budget, spacing) when the panel offers
  /// its method; greedy keeps the panel's budget when the set has none.
  void restorePlacement();
  void refreshVolumes();
  static constexpr int kMinGreedyBudget = 4;
  void onVolumeEdited(QTableWidgetItem* item);

  Document* doc_;
  QComboBox* method_;
  QDoubleSpinBox* spacing_;
  QSpinBox* budget_;
  QDoubleSpinBox* aggressiveness_ = nullptr;
  QSpinBox* swapPasses_ = nullptr;
  QComboBox* objective_ = nullptr;
  QSpinBox* captureSpp_;
  QCheckBox* replace_;
  QComboBox* domain_ = nullptr;
  QCheckBox* fit_ = nullptr;
  QSpinBox* bakeSpp_;
  QPushButton* run_;
  QPushButton* bake_;
  QLabel* status_;
  QLabel* volume_;
  QTableWidget* volumes_ = nullptr;
  QPushButton* addVolume_ = nullptr;
  QPushButton* removeVolume_ = nullptr;
  bool syncingVolumes_ = false;
  std::function<std::vector<uint64_t>()> selection_;
  std::function<bool()> saveBeforeBake_;
};

}  // namespace ps::ui
