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
const QString kApartment =
    QStringLiteral(PS_SHARED_SCENES_DIR "/dream-apartment/dream-apartment.glb");

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

/// What a Cancel clicked in the middle of a job's step gave.
struct CancelOutcome {
  QString cancelledIn;    ///< the status text when Cancel was clicked
  QString shownAtCancel;  ///< the status text right after the click
  QString error;          ///< jobFinished's argument ("cancelled" when it stopped)
  double seconds = -1;    ///< from the click to the job's end; -1: it ended before the click
};

/// Starts a job with `start` (false: it did not start) and clicks Cancel `intoMs` after the
/// first progress report whose message contains `step`; waits up to 5 minutes for the job's end.
template <class Start>
CancelOutcome cancelInStep(MainWindow& w, const QString& step, int intoMs, Start start) {
  Document* doc = w.document();
  const QLabel* jobLabel = w.findChild<QLabel*>(QStringLiteral("jobLabel"));
  CancelOutcome out;
  QElapsedTimer clock;
  QTimer timer;
  timer.setSingleShot(true);
  QObject::connect(&timer, &QTimer::timeout, [&] {
    out.cancelledIn = jobLabel->text();
    clock.start();
    w.cancelButton()->click();
    out.shownAtCancel = jobLabel->text();
  });
  const QMetaObject::Connection watch =
      QObject::connect(doc, &Document::jobProgress, [&](const QString& message) {
        if (!timer.isActive() && !clock.isValid() && message.contains(step)) timer.start(intoMs);
      });
  QSignalSpy done(doc, &Document::jobFinished);
  if (start() && done.wait(300000)) {
    out.error = done.first().first().toString();
    if (clock.isValid()) out.seconds = double(clock.nsecsElapsed()) * 1e-9;
  }
  QObject::disconnect(watch);
  return out;
}

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
      const CancelOutcome out = cancelInStep(w, c.step, kIntoStep, [&] {
        if (c.job == QLatin1String("place")) {
          w.placementPanel()->methodBox()->setCurrentText("greedy");
          w.placementPanel()->budgetBox()->setValue(64);
          return w.placementPanel()->run();
        }
        if (c.job == QLatin1String("bake")) {
          w.placementPanel()->bakeSamplesBox()->setValue(1 << 16);  // long enough to cancel in
          return w.placementPanel()->bake();
        }
        w.evaluationPanel()->queriesBox()->setValue(4096);
        w.evaluationPanel()->referenceSamplesBox()->setValue(4096);
        return w.evaluationPanel()->evaluate();
      });
      QVERIFY2(out.seconds >= 0, qPrintable(c.job + ": ended before the cancel"));
      qInfo("Cancel %d ms into %s (\"%s\"): the job ended %.3f s later", kIntoStep,
            qPrintable(c.job), qPrintable(out.cancelledIn), out.seconds);
      QCOMPARE(out.error, QStringLiteral("cancelled"));
      QCOMPARE(out.shownAtCancel, QStringLiteral("Cancelling…"));
      QCOMPARE(doc->undoStack()->count(), steps);
    }
  }

  void cancelStopsEveryGreedyStepOfALargeSceneInHalfASecond() {
    // Greedy 64 on dream-apartment under the rig of the placement benchmark (a sun from
    // (0.4, 0.8, 0.3) at 3 W/m², a sky of (0.3, 0.4, 0.6)): Cancel in the middle of each of its
    // steps ends the job within kLatency, and says so at once.
    if (!QFile::exists(kApartment)) QSKIP("the shared scene dream-apartment is not present");
    constexpr double kLatency = 0.5;  // s, the bound for every step
    const QString steps[] = {"field", "held-out", "greedy"};
    for (const QString& step : steps) {
      MainWindow w;
      w.setQuiet(true);
      w.setPromptOnClose(false);
      Document* doc = w.document();
      doc->setAutoPropose(false);
      QVERIFY(w.openPath(kApartment));
      LightingRig rig;
      Light sun;
      sun.type = LightType::Directional;
      sun.direction = -normalize(Vec3(0.4, 0.8, 0.3));
      sun.intensity = Rgb(3, 3, 3);
      rig.lights.push_back(sun);
      rig.skyRadiance = Rgb(0.3, 0.4, 0.6);
      doc->setRig(rig, "Rig");
      // The held-out step is short (4 % of the job): cancel soon after it starts.
      const int intoMs = step == QLatin1String("held-out") ? 100 : 500;
      const CancelOutcome out = cancelInStep(w, step, intoMs, [&] {
        w.placementPanel()->methodBox()->setCurrentText("greedy");
        w.placementPanel()->budgetBox()->setValue(64);
        return w.placementPanel()->run();
      });
      QVERIFY2(out.seconds >= 0, qPrintable(step + ": ended before the cancel"));
      qInfo("dream-apartment: Cancel %d ms into \"%s\": the job ended %.3f s later", intoMs,
            qPrintable(out.cancelledIn), out.seconds);
      QCOMPARE(out.error, QStringLiteral("cancelled"));
      QCOMPARE(out.shownAtCancel, QStringLiteral("Cancelling…"));
      QVERIFY2(out.seconds < kLatency, qPrintable(QStringLiteral("%1 s").arg(out.seconds)));
    }
  }

 private:
  QTemporaryDir scratch_;
};

QTEST_MAIN(TestJobs)
#include "test_jobs.moc"
