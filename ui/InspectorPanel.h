#pragma once
// The inspector dock: the selected probe's provenance (placement method), score, state, lock,
// its position as numbers the artist can edit (each edit one undo step) and its SH as an
// irradiance sphere (IrradianceSphere.h). With several probes selected it shows their count, lock
// state and the centre of the unlocked ones, whose edit moves them together.
#include <QSet>
#include <QWidget>

class QCheckBox;
class QDoubleSpinBox;
class QLabel;

namespace ps::ui {

class Document;

class InspectorPanel : public QWidget {
  Q_OBJECT
 public:
  explicit InspectorPanel(Document* doc, QWidget* parent = nullptr);

  void setSelection(const QSet<quint64>& ids);
  /// The position fields (x, y, z), for tests.
  QDoubleSpinBox* positionField(int axis) const { return pos_[axis]; }
  QCheckBox* lockBox() const { return locked_; }
  QLabel* sphereLabel() const { return sphere_; }
  QLabel* provenanceLabel() const { return method_; }
  QLabel* scoreLabel() const { return score_; }

 private:
  void refresh();
  void onPositionEdited();

  Document* doc_;
  QSet<quint64> ids_;
  QLabel* title_;
  QLabel* state_;
  QLabel* method_;
  QLabel* score_;
  QLabel* shInfo_;
  QLabel* sphere_;
  QCheckBox* locked_;
  QDoubleSpinBox* pos_[3];
  bool refreshing_ = false;
};

}  // namespace ps::ui
