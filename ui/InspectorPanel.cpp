#include "ui/InspectorPanel.h"

#include <QCheckBox>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QPixmap>
#include <QVBoxLayout>

#include "ui/Document.h"
#include "ui/IrradianceSphere.h"

namespace ps::ui {

InspectorPanel::InspectorPanel(Document* doc, QWidget* parent) : QWidget(parent), doc_(doc) {
  auto* layout = new QVBoxLayout(this);
  title_ = new QLabel;
  QFont bold = title_->font();
  bold.setBold(true);
  title_->setFont(bold);
  layout->addWidget(title_);
  auto* form = new QFormLayout;
  form->setRowWrapPolicy(QFormLayout::WrapLongRows);  // narrow docks: fields under labels
  state_ = new QLabel;
  method_ = new QLabel;
  score_ = new QLabel;
  shInfo_ = new QLabel;
  locked_ = new QCheckBox(tr("Locked"));
  locked_->setToolTip(tr("Placement keeps it where it is; it does not drag"));
  shInfo_->setWordWrap(true);
  locked_->setTristate(false);
  form->addRow(tr("State"), state_);
  form->addRow(tr("Provenance"), method_);
  form->addRow(tr("Score"), score_);
  const char* names[3] = {"X", "Y", "Z"};
  for (int i = 0; i < 3; ++i) {
    pos_[i] = new QDoubleSpinBox;
    pos_[i]->setRange(-1e6, 1e6);
    pos_[i]->setDecimals(3);
    pos_[i]->setSingleStep(0.05);
    pos_[i]->setSuffix(QStringLiteral(" m"));
    pos_[i]->setKeyboardTracking(false);  // one edit per Enter / focus change / arrow step
    form->addRow(tr(names[i]), pos_[i]);
    connect(pos_[i], &QDoubleSpinBox::valueChanged, this, &InspectorPanel::onPositionEdited);
  }
  form->addRow(QString(), locked_);
  layout->addLayout(form);
  sphere_ = new QLabel;
  sphere_->setAlignment(Qt::AlignCenter);
  sphere_->setMinimumSize(136, 136);
  layout->addWidget(sphere_);
  layout->addWidget(shInfo_);
  layout->addStretch(1);

  connect(locked_, &QCheckBox::clicked, this, [this](bool on) {
    doc_->setLocked(std::vector<uint64_t>(ids_.begin(), ids_.end()), on);
  });
  connect(doc_, &Document::probeChanged, this, [this](int row) {
    if (row >= 0 && row < int(doc_->probes().size()) &&
        ids_.contains(doc_->probes()[size_t(row)].id))
      refresh();
  });
  connect(doc_, &Document::probesReset, this, [this] { setSelection({}); });
  connect(doc_, &Document::probeRemoved, this, &InspectorPanel::refresh);
  refresh();
}

void InspectorPanel::setSelection(const QSet<quint64>& ids) {
  ids_ = ids;
  refresh();
}

void InspectorPanel::onPositionEdited() {
  if (refreshing_ || ids_.isEmpty()) return;
  // One probe: its position. Several: their centre; an edit moves the unlocked ones together.
  std::vector<const Probe*> movable;
  Vec3 centre;
  for (quint64 id : ids_)
    if (const Probe* p = doc_->probe(id); p && !p->locked) {
      movable.push_back(p);
      centre += p->position;
    }
  if (movable.empty()) return;
  centre = centre / double(movable.size());
  const Vec3 to(pos_[0]->value(), pos_[1]->value(), pos_[2]->value());
  const Vec3 delta = movable.size() == 1 ? to - movable[0]->position : to - centre;
  if (delta == Vec3()) return;
  std::vector<std::pair<uint64_t, Vec3>> targets;
  for (const Probe* p : movable)
    targets.emplace_back(p->id, movable.size() == 1 ? to : p->position + delta);
  doc_->moveProbes(targets, doc_->newMergeKey());  // each numeric edit is its own undo step
}

void InspectorPanel::refresh() {
  refreshing_ = true;
  std::vector<const Probe*> sel;
  for (quint64 id : ids_)
    if (const Probe* p = doc_->probe(id)) sel.push_back(p);
  const Probe* one = sel.size() == 1 ? sel[0] : nullptr;
  title_->setText(sel.empty() ? tr("No probe selected")
                  : one       ? tr("Probe %1").arg(one->id)
                              : tr("%1 probes selected").arg(sel.size()));
  state_->setText(one ? QString::fromLatin1(toString(one->state)) : QString());
  method_->setText(one ? QString::fromStdString(one->method.empty() ? "unknown" : one->method)
                       : QString());
  score_->setText(one ? QString::number(one->score, 'g', 5) : QString());
  Vec3 centre;
  int movable = 0;
  for (const Probe* p : sel)
    if (!p->locked) {
      centre += p->position;
      ++movable;
    }
  if (movable > 0) centre = centre / double(movable);
  for (int i = 0; i < 3; ++i) {
    pos_[i]->setEnabled(movable > 0);
    pos_[i]->setValue(one ? one->position[i] : centre[i]);
    pos_[i]->setToolTip(one ? QString() : tr("Centre of the selected, unlocked probes"));
  }
  int lockedCount = 0;
  for (const Probe* p : sel) lockedCount += p->locked ? 1 : 0;
  locked_->setEnabled(!sel.empty());
  locked_->setChecked(!sel.empty() && lockedCount == int(sel.size()));
  if (one && one->sh) {
    const double exposure = autoExposureFor(*one->sh);
    sphere_->setPixmap(QPixmap::fromImage(renderIrradianceSphere(*one->sh, 128, exposure)));
    const Rgb e = one->sh->irradiance(Vec3(0, 1, 0));
    shInfo_->setText(tr("Irradiance facing up: %1, %2, %3 W/m²")
                         .arg(e.r, 0, 'g', 3)
                         .arg(e.g, 0, 'g', 3)
                         .arg(e.b, 0, 'g', 3));
  } else {
    sphere_->clear();
    sphere_->setText(!one                                   ? QString()
                     : doc_->isQuickCapturePending(one->id) ? tr("capturing at this position…")
                                                            : tr("not captured at this position"));
    shInfo_->clear();
  }
  refreshing_ = false;
}

}  // namespace ps::ui
