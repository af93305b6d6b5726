#pragma once
// Table model over the document's probes: one row per probe, in the document's order.
// Columns: id, state, x, y, z, method, score, locked. SortRole gives raw values for sorting.
#include <QAbstractTableModel>

namespace ps::ui {

class Document;

class ProbeTableModel : public QAbstractTableModel {
  Q_OBJECT
 public:
  enum Column { Id, State, X, Y, Z, Method, Score, Locked, ColumnCount };
  /// Raw value for sorting (numbers as numbers); ProbeIdRole gives the probe id of any cell.
  static constexpr int SortRole = Qt::UserRole;
  static constexpr int ProbeIdRole = Qt::UserRole + 1;

  explicit ProbeTableModel(Document* doc, QObject* parent = nullptr);

  int rowCount(const QModelIndex& parent = {}) const override;
  int columnCount(const QModelIndex& parent = {}) const override;
  QVariant data(const QModelIndex& index, int role = Qt::DisplayRole) const override;
  QVariant headerData(int section, Qt::Orientation orientation,
                      int role = Qt::DisplayRole) const override;

 private:
  Document* doc_;
};

}  // namespace ps::ui
