#pragma once
// The placement and bake dock (issue 6): method, spacing, budget, quick-capture samples; Run
// places in the background and replaces the unlocked candidates (Document::runPlacement); Bake
// captures the accepted probes at final quality and saves the volume beside the probe set
// (Document::bake). Progress and Cancel are in the main window's status bar and here.
#include <QWidget>

class QCheckBox;
class QComboBox;
class QDoubleSpinBox;
class QLabel;
class QProgressBar;
class QPushButton;
class QSpinBox;

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

  QComboBox* methodBox() const { return method_; }
  QDoubleSpinBox* spacingBox() const { return spacing_; }
  QSpinBox* budgetBox() const { return budget_; }
  QDoubleSpinBox* aggressivenessBox() const { return aggressiveness_; }
  QSpinBox* captureSamplesBox() const { return captureSpp_; }
  QCheckBox* replaceBox() const { return replace_; }
  QSpinBox* bakeSamplesBox() const { return bakeSpp_; }
  QCheckBox* leakRefineBox() const { return leakRefine_; }
  QPushButton* cancelButton() const { return cancel_; }

 signals:
  /// A request was refused (bad numbers, nothing accepted, no saved set): title and reason.
  void failed(const QString& title, const QString& message);

 private:
  void updateState();

  Document* doc_;
  QComboBox* method_;
  QDoubleSpinBox* spacing_;
  QSpinBox* budget_;
  QDoubleSpinBox* aggressiveness_ = nullptr;
  QSpinBox* captureSpp_;
  QCheckBox* replace_;
  QCheckBox* leakRefine_ = nullptr;
  QSpinBox* bakeSpp_;
  QPushButton* run_;
  QPushButton* bake_;
  QPushButton* cancel_;
  QProgressBar* progress_;
  QLabel* status_;
  QLabel* volume_;
};

}  // namespace ps::ui
