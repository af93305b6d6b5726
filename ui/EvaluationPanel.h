#pragma once
// The evaluation dock, a plot (Qt Charts) of error against probe count: Evaluate runs core/eval in
// the background on the baked volume (or the accepted probes' preview volume); each run adds a
// point to the plot of relative RMS and 95th-percentile irradiance error (in %), and of the RMS
// error in stops (right-hand axis), against the
// volume's probe count, and a row to the table below it. Below that, the last evaluation's
// queries worst first: picking one frames it in the view, and "Add a probe here" puts an accepted
// probe at it; "Let greedy add K probes" runs greedy around the probes there are
// (Document::addProbesWhereErrorIsWorst), and "Bake and evaluate" measures the volume that will
// be baked with them.
#include <QSet>
#include <QWidget>

#include <functional>

class QChart;
class QChartView;
class QLineSeries;
class QScatterSeries;
class QValueAxis;
class QLogValueAxis;
class QLabel;
class QSpinBox;
class QPushButton;
class QTableWidget;

namespace ps::ui {

class Document;
struct BakeRequest;
struct PlacementRequest;

class EvaluationPanel : public QWidget {
  Q_OBJECT
 public:
  explicit EvaluationPanel(Document* doc, QWidget* parent = nullptr);

  /// Starts an evaluation; false (after emitting failed) when it could not start.
  bool evaluate();

  QChart* chart() const { return chart_; }
  /// The plot's least height, pixels.
  static constexpr int kPlotMinHeight = 280;
  /// The plotted series: relative RMS error (%) and 95th percentile (%) against probe count.
  QScatterSeries* rmseSeries() const { return rmse_; }
  QScatterSeries* p95Series() const { return p95_; }
  /// The RMS error in stops (EvalStops::rms) against probe count, on the right-hand axis.
  QScatterSeries* stopsSeries() const { return stops_; }
  QSpinBox* queriesBox() const { return queries_; }
  /// What Evaluate measures now, named with its state (Document::evaluationSource): the baked
  /// volume, or the preview with a stale volume named stale.
  QLabel* evaluatedLabel() const { return evaluated_; }
  QSpinBox* referenceSamplesBox() const { return refSpp_; }
  QTableWidget* table() const { return table_; }
  /// The last evaluation's queries, worst first: error (stops), reference and volume (W/m²),
  /// position. A row's Qt::UserRole holds the query's index in eval's order.
  QTableWidget* worstTable() const { return worst_; }
  QPushButton* addProbeButton() const { return addProbe_; }
  /// Adds an accepted probe at the query of the worst table's current row (one undo step);
  /// false when no row is current.
  bool addProbeAtCurrentQuery();

  /// "Let greedy add K probes where the error is worst" and its K.
  QPushButton* greedyAddButton() const { return greedyAdd_; }
  QSpinBox* greedyAddCountBox() const { return greedyAddCount_; }
  /// Where greedy's options (objective, swap passes, preview samples) come from: the placement
  /// panel's request. Without one, PlacementRequest's defaults.
  void setPlacementSettings(std::function<PlacementRequest()> settings) {
    placementSettings_ = std::move(settings);
  }
  /// Starts greedy adding greedyAddCountBox() probes (Document::addProbesWhereErrorIsWorst);
  /// false (after emitting failed) when it could not start. Once they landed, nextStepLabel()
  /// says that the figures shown are of the volume without them and names Bake and evaluate.
  bool addProbesWhereErrorIsWorst();
  /// "Bake and evaluate": bakes the accepted probes (Document::bake with the bake settings),
  /// then, when the bake succeeded, evaluates the baked volume; the evaluation's figure is the
  /// volume that will ship. A set without a file is offered to be saved first (the volume is
  /// saved beside it). False (after emitting failed, unless the artist declined to save) when
  /// the bake could not start.
  bool bakeAndEvaluate();
  QPushButton* bakeAndEvaluateButton() const { return bakeAndEvaluate_; }
  /// What to do next after greedy added probes (hidden otherwise).
  QLabel* nextStepLabel() const { return next_; }
  /// Where the bake's settings come from (the placement panel's); without one, BakeRequest's
  /// defaults.
  void setBakeSettings(std::function<BakeRequest()> settings) {
    bakeSettings_ = std::move(settings);
  }
  /// Asked before a bake when the probe set has no file (MainWindow::offerSaveBeforeBake): true
  /// once it is saved.
  void setSaveBeforeBake(std::function<bool()> offer) { saveBeforeBake_ = std::move(offer); }

 signals:
  void failed(const QString& title, const QString& message);
  /// The artist picked a query in the worst-first list (its index in eval's order).
  void queryPicked(int index);
  /// A probe was added at a query.
  void probeAdded(quint64 id);
  /// Greedy's probes landed (addProbesWhereErrorIsWorst), in one undo step.
  void probesAdded(const QSet<quint64>& ids);

 private:
  void refresh();
  void refreshWorst();
  void refreshEvaluated();

  Document* doc_;
  QChart* chart_;
  QChartView* view_;
  QScatterSeries *rmse_, *p95_, *stops_;
  QLineSeries *rmseLine_, *p95Line_;
  QValueAxis *xAxis_, *yAxis_, *stopsAxis_;
  QSpinBox *queries_, *refSpp_;
  QPushButton* run_;
  QPushButton* bakeAndEvaluate_;
  QLabel* evaluated_;
  QLabel* next_;
  QTableWidget* table_;
  QTableWidget* worst_;
  QPushButton* addProbe_;
  QPushButton* greedyAdd_;
  QSpinBox* greedyAddCount_;
  std::function<PlacementRequest()> placementSettings_;
  std::function<BakeRequest()> bakeSettings_;
  std::function<bool()> saveBeforeBake_;
};

}  // namespace ps::ui
