#include "ui/ProbeTableModel.h"

#include <QBrush>
#include <QColor>

#include "ui/Document.h"

namespace ps::ui {

ProbeTableModel::ProbeTableModel(Document* doc, QObject* parent)
    : QAbstractTableModel(parent), doc_(doc) {
  connect(doc, &Document::probesAboutToBeReset, this, [this] { beginResetModel(); });
  connect(doc, &Document::probesReset, this, [this] { endResetModel(); });
  connect(doc, &Document::probeAboutToBeInserted, this,
          [this](int row) { beginInsertRows({}, row, row); });
  connect(doc, &Document::probeInserted, this, [this] { endInsertRows(); });
  connect(doc, &Document::probeAboutToBeRemoved, this,
          [this](int row) { beginRemoveRows({}, row, row); });
  connect(doc, &Document::probeRemoved, this, [this] { endRemoveRows(); });
  connect(doc, &Document::probeChanged, this,
          [this](int row) { emit dataChanged(index(row, 0), index(row, ColumnCount - 1)); });
}

int ProbeTableModel::rowCount(const QModelIndex& parent) const {
  return parent.isValid() ? 0 : int(doc_->probes().size());
}

int ProbeTableModel::columnCount(const QModelIndex& parent) const {
  return parent.isValid() ? 0 : ColumnCount;
}

QVariant ProbeTableModel::data(const QModelIndex& index, int role) const {
  if (!index.isValid() || index.row() >= rowCount()) return {};
  const Probe& p = doc_->probes()[size_t(index.row())];
  if (role == ProbeIdRole) return QVariant::fromValue<qulonglong>(p.id);
  if (role == Qt::TextAlignmentRole)
    return index.column() == State || index.column() == Method
               ? QVariant(Qt::AlignLeft | Qt::AlignVCenter)
               : QVariant(Qt::AlignRight | Qt::AlignVCenter);
  if (role == Qt::ForegroundRole && p.state == ProbeState::Rejected)
    return QBrush(QColor(128, 128, 128));
  if (role != Qt::DisplayRole && role != SortRole) return {};
  const bool display = role == Qt::DisplayRole;
  switch (index.column()) {
    case Id:
      return QVariant::fromValue<qulonglong>(p.id);
    case State:
      return display ? QVariant(QString::fromLatin1(toString(p.state))) : QVariant(int(p.state));
    case X:
      return display ? QVariant(QString::number(p.position.x, 'f', 2)) : QVariant(p.position.x);
    case Y:
      return display ? QVariant(QString::number(p.position.y, 'f', 2)) : QVariant(p.position.y);
    case Z:
      return display ? QVariant(QString::number(p.position.z, 'f', 2)) : QVariant(p.position.z);
    case Method:
      return QString::fromStdString(p.method);
    case Score:
      return display ? QVariant(QString::number(p.score, 'g', 4)) : QVariant(p.score);
    case Locked:
      return display ? QVariant(p.locked ? QStringLiteral("locked") : QString())
                     : QVariant(int(p.locked));
    default:
      return {};
  }
}

QVariant ProbeTableModel::headerData(int section, Qt::Orientation orientation, int role) const {
  if (orientation != Qt::Horizontal || role != Qt::DisplayRole) return {};
  static const char* names[] = {"id", "state", "x", "y", "z", "method", "score", "locked"};
  return section >= 0 && section < ColumnCount ? QString::fromLatin1(names[section]) : QVariant();
}

}  // namespace ps::ui
