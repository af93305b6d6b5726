// Background jobs in the editor as it is shown (run under xvfb-run with Mesa's software GL, as
// ui.test_jobs does): while a job reports progress, the 3D view is not redrawn (a redraw in a
// software GL driver costs the job's own cores); it is redrawn once what it shows changed. Cancel
// ends every step of a job and says so at once.
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QElapsedTimer>
#include <QFile>
#include <QGuiApplication>
#include <QLabel>
#include <QPushButton>
#include <QSignalSpy>
#include <QSpinBox>
#include <QTemporaryDir>
#include <QTimer>
#include <QUndoStack>
#include <QtTest>

#include "ui/Document.h"
#include "ui/EvaluationPanel.h"
#include "ui/MainWindow.h"
#include "ui/PlacementPanel.h"
#include "ui/Viewport.h"

using namespace ps;
using namespace ps::ui;

namespace {
const QString kScene = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");

/// Counts the paint and resize events a widget receives, and the update requests of its window:
/// each of those repaints and flushes the window, which a window holding a QOpenGLWidget
/// composes with OpenGL as a whole.
class PaintCounter : public QObject {
 public:
  explicit PaintCounter(QWidget* w) {
    w->installEventFilter(this);
    w->window()->installEventFilter(this);
    widget_ = w;
  }
  int paints = 0, resizes = 0, windowUpdates = 0;

 protected:
  bool eventFilter(QObject* o, QEvent* e) override {
    if (o == widget_ && e->type() == QEvent::Paint) ++paints;
    if (o == widget_ && e->type() == QEvent::Resize) ++resizes;
    if (o == widget_->window() && e->type() == QEvent::UpdateRequest) ++windowUpdates;
    return QObject::eventFilter(o, e);
  }

 private:
  QWidget* widget_;
};

}  // namespace

class TestJobs : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase() {
    if (!QFile::exists(kScene)) QSKIP("two-rooms.gltf not present");
  }

  void theViewIsNotRedrawnPerProgressTick() {
    if (QGuiApplication::platformName() == QLatin1String("offscreen"))
      QSKIP("needs OpenGL: run under xvfb-run (ui.test_jobs)");
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    Document* doc = w.document();
    Viewport* vp = w.viewport();
    doc->setAutoPropose(false);
    w.resize(1280, 800);
    w.show();
    QVERIFY(QTest::qWaitForWindowExposed(&w));
    QVERIFY(w.openPath(kScene));
    // The view settles: its fields and the scene's light are drawn, no job runs.
    QTRY_VERIFY_WITH_TIMEOUT(!doc->isBusy() && vp->fieldsCurrent() && !vp->isFieldsRebuildRunning(),
                             60000);
    QTest::qWait(500);

    PaintCounter counter(vp);
    int ticks = 0, paintsAtEnd = -1, resizesAtEnd = -1, updatesAtEnd = -1;
    QElapsedTimer clock;
    double seconds = 0;
    connect(doc, &Document::jobProgress, this, [&] { ++ticks; });
    connect(doc, &Document::jobFinished, this, [&] {
      paintsAtEnd = counter.paints;
      resizesAtEnd = counter.resizes;
      updatesAtEnd = counter.windowUpdates;
      seconds = double(clock.nsecsElapsed()) * 1e-9;
    });
    clock.start();
    // A uniform placement at a fine spacing: hundreds of probes captured, a hundred ticks.
    w.placementPanel()->methodBox()->setCurrentText("uniform");
    w.placementPanel()->budgetBox()->setValue(0);
    w.placementPanel()->spacingBox()->setValue(0.5);
    QVERIFY(w.placementPanel()->run());
    QSignalSpy done(doc, &Document::jobFinished);
    QVERIFY(done.wait(300000));
    QCOMPARE(done.first().first().toString(), QString());
    qInfo(
        "%.2f s: %d progress reports shown, %d paints and %d resizes of the view, %d window "
        "updates",
        seconds, ticks, paintsAtEnd, resizesAtEnd, updatesAtEnd);
    // The view drew none of the job's progress and kept its size (the status bar keeps its
    // height). A margin of two paints for frames the window system asks for.
    QVERIFY2(paintsAtEnd <= 2, qPrintable(QString::number(paintsAtEnd)));
    QCOMPARE(resizesAtEnd, 0);
    // The progress shown is throttled in time (Document::kProgressIntervalMs), and so are the
    // window's updates: one per report at most, plus the job's start, its steps and its end.
    const double reportsAllowed = seconds * 1000.0 / Document::kProgressIntervalMs + 8;
    QVERIFY2(ticks <= reportsAllowed,
             qPrintable(QStringLiteral("%1 reports in %2 s").arg(ticks).arg(seconds)));
    QVERIFY2(updatesAtEnd <= 2 * reportsAllowed, qPrintable(QString::number(updatesAtEnd)));
    // What the view shows changed (new probes): it is drawn again.
    QTRY_VERIFY_WITH_TIMEOUT(counter.paints > paintsAtEnd, 10000);
  }

  void cancelEndsEveryStepAndSaysSo() {
    // Cancel clicked in the middle of each step of a greedy placement, a bake and an
    // evaluation (kIntoStep after the step's first report): the job ends cancelled, the status
    // bar says "Cancelling…" at once, and nothing changes. The latency of each is printed (the
    // figures of BENCHMARKS.md); the document holds no timing assertion.
    constexpr int kIntoStep = 500;  // ms
    struct Case {
      QString job, step;
    };
    const Case cases[] = {
        {"place", "field"}, {"place", "greedy"}, {"bake", "Baking"}, {"eval", "Evaluating"}};
    for (const Case& c : cases) {
      MainWindow w;
      w.setQuiet(true);
      w.setPromptOnClose(false);
      Document* doc = w.document();
      doc->setAutoPropose(false);
      QVERIFY(w.openPath(kScene));
      if (c.job != QLatin1String("place")) {
        // A set of 64 accepted probes to bake and evaluate, saved beside a scratch folder.
        w.placementPanel()->budgetBox()->setValue(64);
        w.placementPanel()->methodBox()->setCurrentText("uniform");
        QVERIFY(w.placementPanel()->run());
        QSignalSpy placed(doc, &Document::jobFinished);
        QVERIFY(placed.wait(120000));
        std::vector<uint64_t> ids;
        for (const Probe& p : doc->probes()) ids.push_back(p.id);
        doc->setStates(ids, ProbeState::Accepted);
        QVERIFY(w.saveAs(scratch_.filePath(c.job + ".probes.json")));
      }
      const int steps = doc->undoStack()->count();
      const QLabel* jobLabel = w.findChild<QLabel*>(QStringLiteral("jobLabel"));
      QElapsedTimer clock;
      QString shownAtCancel, cancelledIn;
      QTimer timer;
      timer.setSingleShot(true);
      connect(&timer, &QTimer::timeout, this, [&] {
        cancelledIn = jobLabel->text();
        clock.start();
        w.cancelButton()->click();
        shownAtCancel = jobLabel->text();
      });
      connect(doc, &Document::jobProgress, this, [&](const QString& message) {
        if (!timer.isActive() && !clock.isValid() && message.contains(c.step))
          timer.start(kIntoStep);
      });
      QSignalSpy done(doc, &Document::jobFinished);
      if (c.job == QLatin1String("place")) {
        w.placementPanel()->methodBox()->setCurrentText("greedy");
        w.placementPanel()->budgetBox()->setValue(64);
        QVERIFY(w.placementPanel()->run());
      } else if (c.job == QLatin1String("bake")) {
        w.placementPanel()->bakeSamplesBox()->setValue(1 << 16);  // long enough to cancel in
        QVERIFY(w.placementPanel()->bake());
      } else {
        w.evaluationPanel()->queriesBox()->setValue(4096);
        w.evaluationPanel()->referenceSamplesBox()->setValue(4096);
        QVERIFY(w.evaluationPanel()->evaluate());
      }
      QVERIFY(done.wait(300000));
      QVERIFY2(clock.isValid(), qPrintable(c.job + ": ended before the cancel"));
      qInfo("Cancel %d ms into %s (\"%s\"): the job ended %.3f s later", kIntoStep,
            qPrintable(c.job), qPrintable(cancelledIn), double(clock.nsecsElapsed()) * 1e-9);
      QCOMPARE(done.first().first().toString(), QStringLiteral("cancelled"));
      QCOMPARE(shownAtCancel, QStringLiteral("Cancelling…"));
      QCOMPARE(doc->undoStack()->count(), steps);
    }
  }

 private:
  QTemporaryDir scratch_;
};

QTEST_MAIN(TestJobs)
#include "test_jobs.moc"
