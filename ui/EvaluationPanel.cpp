#include "ui/EvaluationPanel.h"

#include <QChart>
#include <QChartView>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLegendMarker>
#include <QLineSeries>
#include <QPushButton>
#include <QScatterSeries>
#include <QSpinBox>
#include <QTableWidget>
#include <QTimer>
#include <QVBoxLayout>
#include <QValueAxis>
#include <algorithm>
#include <map>

#include "core/common/Error.h"
#include "ui/Document.h"

namespace ps::ui {

EvaluationPanel::EvaluationPanel(Document* doc, QWidget* parent) : QWidget(parent), doc_(doc) {
  auto* layout = new QVBoxLayout(this);
  auto* form = new QFormLayout;
  queries_ = new QSpinBox;
  queries_->setRange(8, 1 << 20);
  queries_->setValue(128);
  refSpp_ = new QSpinBox;
  refSpp_->setRange(16, 1 << 20);
  refSpp_->setValue(256);
  form->addRow(tr("Query points"), queries_);
  form->addRow(tr("Reference samples"), refSpp_);
  layout->addLayout(form);
  run_ = new QPushButton(tr("Evaluate"));
  run_->setToolTip(
      tr("Error of the baked volume (or the accepted probes' preview) against a "
         "path-traced reference at random points"));
  bakeAndEvaluate_ = new QPushButton(tr("Bake and evaluate"));
  bakeAndEvaluate_->setObjectName("bakeAndEvaluate");
  bakeAndEvaluate_->setToolTip(
      tr("Bake the accepted probes (the Placement tab's bake settings), then evaluate the baked "
         "volume: the figure of what the game will show"));
  auto* runRow = new QHBoxLayout;
  runRow->addWidget(run_);
  runRow->addWidget(bakeAndEvaluate_);
  layout->addLayout(runRow);
  evaluated_ = new QLabel;
  evaluated_->setObjectName("evaluatedVolume");
  evaluated_->setWordWrap(true);
  layout->addWidget(evaluated_);

  chart_ = new QChart;
  chart_->setTitle(tr("Irradiance error against probe count"));
  rmse_ = new QScatterSeries;
  rmse_->setName(tr("RMS %"));
  rmse_->setMarkerSize(9);
  p95_ = new QScatterSeries;
  p95_->setName(tr("p95 %"));
  p95_->setMarkerSize(9);
  p95_->setMarkerShape(QScatterSeries::MarkerShapeRectangle);
  stops_ = new QScatterSeries;
  stops_->setName(tr("stops"));
  stops_->setMarkerSize(9);
  stops_->setMarkerShape(QScatterSeries::MarkerShapeTriangle);
  rmseLine_ = new QLineSeries;
  p95Line_ = new QLineSeries;
  for (QXYSeries* s : {static_cast<QXYSeries*>(rmseLine_), static_cast<QXYSeries*>(p95Line_),
                       static_cast<QXYSeries*>(rmse_), static_cast<QXYSeries*>(p95_)})
    chart_->addSeries(s);
  xAxis_ = new QValueAxis;
  xAxis_->setTitleText(tr("probes"));
  xAxis_->setLabelFormat("%d");
  yAxis_ = new QValueAxis;
  yAxis_->setTitleText(tr("error (%)"));
  chart_->addAxis(xAxis_, Qt::AlignBottom);
  chart_->addAxis(yAxis_, Qt::AlignLeft);
  for (QAbstractSeries* s : chart_->series()) {
    s->attachAxis(xAxis_);
    s->attachAxis(yAxis_);
  }
  // The error as the eye sees it, in stops (core/eval/PerceptualError.h), on its own axis.
  chart_->addSeries(stops_);
  stopsAxis_ = new QValueAxis;
  stopsAxis_->setTitleText(tr("RMS (stops)"));
  chart_->addAxis(stopsAxis_, Qt::AlignRight);
  stops_->attachAxis(xAxis_);
  stops_->attachAxis(stopsAxis_);
  // A label cut to fit ("3.5" for 36.6) misreads: the plot gives the axes their room instead.
  for (QAbstractAxis* axis :
       {static_cast<QAbstractAxis*>(xAxis_), static_cast<QAbstractAxis*>(yAxis_),
        static_cast<QAbstractAxis*>(stopsAxis_)})
    axis->setTruncateLabels(false);
  // The connecting lines share the markers' colours and stay out of the legend.
  rmseLine_->setColor(rmse_->color());
  p95Line_->setColor(p95_->color());
  for (auto* m : chart_->legend()->markers(rmseLine_)) m->setVisible(false);
  for (auto* m : chart_->legend()->markers(p95Line_)) m->setVisible(false);
  view_ = new QChartView(chart_);
  view_->setRenderHint(QPainter::Antialiasing);
  // Tall enough for the axes' titles and labels whole beside a dock's narrow width; the legend
  // names are short for the same reason (QChart cuts what does not fit, and never wraps).
  view_->setMinimumHeight(kPlotMinHeight);
  chart_->legend()->setAlignment(Qt::AlignBottom);  // the plot's whole width for the names
  chart_->setMargins(QMargins(4, 4, 4, 4));
  layout->addWidget(view_, 1);

  table_ = new QTableWidget(0, 7);
  table_->setHorizontalHeaderLabels({tr("probes"), tr("rel. RMS"), tr("stops (RMS / p90)"),
                                     tr("p95"), tr("leaking"), tr("reference"), tr("source")});
  table_->verticalHeader()->hide();
  table_->horizontalHeader()->setStretchLastSection(true);
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_->setMaximumHeight(140);
  layout->addWidget(table_);

  worst_ = new QTableWidget(0, 4);
  worst_->setObjectName("worstQueries");
  worst_->setHorizontalHeaderLabels(
      {tr("error (stops)"), tr("reference W/m²"), tr("volume W/m²"), tr("position (m)")});
  worst_->setToolTip(tr("The last evaluation's queries, worst first; pick one to frame it"));
  worst_->verticalHeader()->hide();
  worst_->horizontalHeader()->setStretchLastSection(true);
  worst_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  worst_->setSelectionBehavior(QAbstractItemView::SelectRows);
  worst_->setSelectionMode(QAbstractItemView::SingleSelection);
  worst_->setMaximumHeight(180);
  layout->addWidget(worst_);
  addProbe_ = new QPushButton(tr("Add a probe here"));
  addProbe_->setObjectName("addProbeAtQuery");
  addProbe_->setToolTip(tr("An accepted probe at the picked query (one undo step)"));
  addProbe_->setEnabled(false);
  layout->addWidget(addProbe_);
  connect(worst_, &QTableWidget::currentCellChanged, this, [this](int row) {
    addProbe_->setEnabled(row >= 0);
    if (row >= 0) emit queryPicked(worst_->item(row, 0)->data(Qt::UserRole).toInt());
  });
  connect(addProbe_, &QPushButton::clicked, this, [this] { addProbeAtCurrentQuery(); });
  // Greedy, where the list says the error is: K more probes around the ones there are.
  auto* greedyRow = new QHBoxLayout;
  greedyAdd_ = new QPushButton(tr("Let greedy add"));
  greedyAdd_->setObjectName("greedyAddProbes");
  greedyAddCount_ = new QSpinBox;
  // The placement refuses a budget that leaves fewer than 4 new probes beside the kept ones.
  greedyAddCount_->setRange(4, 999);
  greedyAddCount_->setValue(8);
  greedyAddCount_->setSuffix(tr(" probes"));
  const QString greedyTip =
      tr("Greedy, with the Placement tab's objective and swap passes, adds this many accepted "
         "probes where its measured error is worst, keeping every probe where it is (one undo "
         "step; fewer when it reaches its noise floor first). Bake and evaluate then measures "
         "the volume with them");
  greedyAdd_->setToolTip(greedyTip);
  greedyAddCount_->setToolTip(greedyTip);
  greedyRow->addWidget(greedyAdd_);
  greedyRow->addWidget(greedyAddCount_);
  auto* where = new QLabel(tr("where the error is worst"));
  where->setToolTip(greedyTip);
  where->setWordWrap(true);
  greedyRow->addWidget(where, 1);
  layout->addLayout(greedyRow);
  next_ = new QLabel;
  next_->setObjectName("evaluationNext");
  next_->setWordWrap(true);
  next_->hide();
  layout->addWidget(next_);
  connect(greedyAdd_, &QPushButton::clicked, this, [this] { addProbesWhereErrorIsWorst(); });
  connect(bakeAndEvaluate_, &QPushButton::clicked, this, [this] { bakeAndEvaluate(); });

  connect(run_, &QPushButton::clicked, this, [this] { evaluate(); });
  connect(doc_, &Document::evaluationsChanged, this, &EvaluationPanel::refresh);
  auto updateState = [this] {
    run_->setEnabled(!doc_->isBusy());
    greedyAdd_->setEnabled(!doc_->isBusy() && doc_->hasScene());
    bakeAndEvaluate_->setEnabled(!doc_->isBusy() && doc_->hasScene());
  };
  connect(doc_, &Document::jobFinished, this, updateState);
  connect(doc_, &Document::jobProgress, this, updateState);
  connect(doc_, &Document::sceneChanged, this, updateState);
  connect(doc_, &Document::volumeStateChanged, this, &EvaluationPanel::refreshEvaluated);
  updateState();
  refresh();
  refreshEvaluated();
}

void EvaluationPanel::refreshEvaluated() {
  const bool stale = doc_->volumeState() == Document::VolumeState::Stale;
  evaluated_->setText(
      tr("Evaluates: %1").arg(doc_->evaluationSource()) +
      (stale ? tr(". Bake again (Ctrl+B) to evaluate the volume itself.") : QString()));
  evaluated_->setStyleSheet(stale ? QStringLiteral("color: #b35c00") : QString());
}

bool EvaluationPanel::addProbesWhereErrorIsWorst() {
  const PlacementRequest settings = placementSettings_ ? placementSettings_() : PlacementRequest{};
  try {
    const uint64_t firstNewId = doc_->probeSet().nextId;
    if (doc_->addProbesWhereErrorIsWorst(greedyAddCount_->value(), settings)) {
      greedyAdd_->setEnabled(false);
      // The job's undo step is pushed before jobFinished: its probes are there.
      connect(
          doc_, &Document::jobFinished, this,
          [this, firstNewId](const QString& error) {
            QSet<quint64> ids;
            for (const Probe& p : doc_->probes())
              if (p.id >= firstNewId && p.method == "greedy") ids.insert(quint64(p.id));
            if (!error.isEmpty() || ids.isEmpty()) return;
            // The figures so far are of the volume without them: say what measures it now.
            next_->setText(
                tr("Greedy added %n probe(s). The figures above are of the volume "
                   "without them: Bake and evaluate measures what will be baked.",
                   nullptr, int(ids.size())));
            next_->show();
            bakeAndEvaluate_->setDefault(true);
            emit probesAdded(ids);
          },
          Qt::SingleShotConnection);
      return true;
    }
  } catch (const Error& e) {
    emit failed(tr("Let greedy add probes"), QString::fromStdString(e.what()));
    return false;
  }
  emit failed(tr("Let greedy add probes"),
              doc_->isBusy() ? tr("Another job is running.") : tr("Open a scene first."));
  return false;
}

bool EvaluationPanel::bakeAndEvaluate() {
  if (doc_->hasScene() && !doc_->isBusy() && doc_->probeSetPath().isEmpty() && saveBeforeBake_ &&
      !saveBeforeBake_())
    return false;  // the artist declined to save: nothing to report
  const BakeRequest request = bakeSettings_ ? bakeSettings_() : BakeRequest{};
  try {
    if (doc_->bake(request)) {
      next_->hide();
      bakeAndEvaluate_->setDefault(false);
      // The evaluation starts once the bake's end has reached every listener.
      connect(
          doc_, &Document::jobFinished, this,
          [this](const QString& error) {
            if (error.isEmpty()) QTimer::singleShot(0, this, [this] { evaluate(); });
          },
          Qt::SingleShotConnection);
      return true;
    }
  } catch (const Error& e) {
    emit failed(tr("Bake and evaluate"), QString::fromStdString(e.what()));
    return false;
  }
  emit failed(tr("Bake and evaluate"),
              doc_->isBusy() ? tr("Another job is running.") : tr("Open a scene first."));
  return false;
}

bool EvaluationPanel::evaluate() {
  EvalRequest r;
  r.queries = queries_->value();
  r.referenceSpp = refSpp_->value();
  try {
    if (doc_->evaluate(r)) return true;
  } catch (const Error& e) {
    emit failed(tr("Evaluate"), QString::fromStdString(e.what()));
    return false;
  }
  emit failed(tr("Evaluate"),
              doc_->isBusy() ? tr("Another job is running.") : tr("Open a scene first."));
  return false;
}

bool EvaluationPanel::addProbeAtCurrentQuery() {
  const int row = worst_->currentRow();
  if (row < 0 || doc_->evaluations().empty() || !doc_->hasScene()) return false;
  const int index = worst_->item(row, 0)->data(Qt::UserRole).toInt();
  const auto& queries = doc_->evaluations().back().queries;
  if (index < 0 || size_t(index) >= queries.size()) return false;
  // Queries are free-space points of the domain (core/eval), so the probe goes right there.
  const uint64_t id = doc_->addManualProbe(queries[size_t(index)].point,
                                           tr("Add probe at query %1 (%2 stops)")
                                               .arg(index)
                                               .arg(queries[size_t(index)].stops, 0, 'f', 2));
  emit probeAdded(quint64(id));
  return true;
}

void EvaluationPanel::refreshWorst() {
  worst_->setRowCount(0);
  addProbe_->setEnabled(false);
  if (doc_->evaluations().empty()) return;
  const auto& queries = doc_->evaluations().back().queries;
  std::vector<int> order(queries.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = int(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return queries[size_t(a)].stops > queries[size_t(b)].stops;
  });
  worst_->setRowCount(int(order.size()));
  for (int row = 0; row < int(order.size()); ++row) {
    const QueryError& q = queries[size_t(order[size_t(row)])];
    auto* stops = new QTableWidgetItem(QString::number(q.stops, 'f', 2));
    stops->setData(Qt::UserRole, order[size_t(row)]);
    if (q.leaking) stops->setToolTip(tr("Its tetrahedron has a probe it cannot see (a leak)"));
    worst_->setItem(row, 0, stops);
    worst_->setItem(row, 1, new QTableWidgetItem(QString::number(q.reference, 'g', 3)));
    worst_->setItem(row, 2, new QTableWidgetItem(QString::number(q.interpolated, 'g', 3)));
    worst_->setItem(row, 3,
                    new QTableWidgetItem(QStringLiteral("%1, %2, %3")
                                             .arg(q.point.x, 0, 'f', 2)
                                             .arg(q.point.y, 0, 'f', 2)
                                             .arg(q.point.z, 0, 'f', 2)));
  }
}

void EvaluationPanel::refresh() {
  refreshWorst();
  const auto& evals = doc_->evaluations();
  rmse_->clear();
  p95_->clear();
  stops_->clear();
  double maxStops = kVisibleStops;
  rmseLine_->clear();
  p95Line_->clear();
  table_->setRowCount(int(evals.size()));
  double maxX = 1, maxY = 1;
  // Lines through the best result at each count, in order of count.
  std::map<size_t, std::pair<double, double>> best;
  for (size_t i = 0; i < evals.size(); ++i) {
    const EvaluationPoint& e = evals[i];
    const double x = double(e.probes), a = 100 * e.relRmse, b = 100 * e.p95RelError;
    rmse_->append(x, a);
    p95_->append(x, b);
    stops_->append(x, e.stops.rms);
    maxStops = std::max(maxStops, e.stops.rms);
    auto it = best.find(e.probes);
    if (it == best.end())
      best[e.probes] = {a, b};
    else
      it->second = {std::min(it->second.first, a), std::min(it->second.second, b)};
    maxX = std::max(maxX, x);
    maxY = std::max({maxY, a, b});
    table_->setItem(int(i), 0, new QTableWidgetItem(QString::number(e.probes)));
    // The error with its uncertainty: the spread of another draw of queries, and the
    // reference's own noise (what a perfect volume would show).
    auto* rmseItem = new QTableWidgetItem(QString::number(a, 'f', 2) + QStringLiteral(" ± ") +
                                          QString::number(100 * e.relRmseStdError, 'f', 2) + " %");
    rmseItem->setToolTip(
        tr("± %1 %: how far another draw of as many queries would move it.\n"
           "The reference's own noise: %2 % (a perfect volume would show this; more reference "
           "samples lower it).")
            .arg(100 * e.relRmseStdError, 0, 'f', 2)
            .arg(100 * e.referenceRelNoise, 0, 'f', 2));
    table_->setItem(int(i), 1, rmseItem);
    // The error as the eye sees it: ratios, so that a dim room counts as much as a bright one.
    auto* stopsItem =
        new QTableWidgetItem(QString::number(e.stops.rms, 'f', 2) + QStringLiteral(" / ") +
                             QString::number(e.stops.p90, 'f', 2));
    stopsItem->setToolTip(
        tr("Error in stops: |log2| of the interpolated over the reference irradiance, both "
           "floored at %1 W/m² (%6 % of the median reference).\n"
           "RMS %2, median %3, 90th percentile %4; %5 % of the queries are off by a third of a "
           "stop or more (visible).")
            .arg(e.stopsFloor, 0, 'g', 3)
            .arg(e.stops.rms, 0, 'f', 3)
            .arg(e.stops.median, 0, 'f', 3)
            .arg(e.stops.p90, 0, 'f', 3)
            .arg(100 * e.stops.beyondThirdStop, 0, 'f', 1)
            .arg(100 * kAdaptationFloorFraction, 0, 'f', 0));
    table_->setItem(int(i), 2, stopsItem);
    table_->setItem(int(i), 3, new QTableWidgetItem(QString::number(b, 'f', 2) + " %"));
    // Light leaking through walls, and where: outside the probes' hull a probe placed near the
    // leaking queries ends it; inside, a tetrahedron spans a wall.
    auto* leakItem = new QTableWidgetItem(QString::number(100 * e.leakingFraction, 'f', 2) + " %");
    leakItem->setToolTip(
        tr("Queries that interpolate a probe they cannot see (light through a wall): %1 %.\n"
           "Outside the probes' hull: %2 % (%3 % of all queries are outside it, where the "
           "volume extrapolates; probes near them end those leaks).\n"
           "Inside: %4 % (tetrahedra across walls where no probe that sees the query takes "
           "the weight).")
            .arg(100 * e.leakingFraction, 0, 'f', 2)
            .arg(100 * e.leakingOutsideHullFraction, 0, 'f', 2)
            .arg(100 * e.outsideHullFraction, 0, 'f', 2)
            .arg(100 * (e.leakingFraction - e.leakingOutsideHullFraction), 0, 'f', 2));
    table_->setItem(int(i), 4, leakItem);
    table_->setItem(
        int(i), 5,
        new QTableWidgetItem((e.referenceCached ? tr("cached, %1 s") : tr("traced, %1 s"))
                                 .arg(e.seconds, 0, 'f', 2)));
    table_->setItem(int(i), 6, new QTableWidgetItem(e.source));
  }
  for (const auto& [n, errs] : best) {
    rmseLine_->append(double(n), errs.first);
    p95Line_->append(double(n), errs.second);
  }
  xAxis_->setRange(0, maxX * 1.1);
  yAxis_->setRange(0, maxY * 1.15);
  stopsAxis_->setRange(0, maxStops * 1.15);
}

}  // namespace ps::ui
