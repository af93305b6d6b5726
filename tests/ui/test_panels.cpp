// The placement / bake and lighting panels, headless (QT_QPA_PLATFORM=offscreen): placement in
// the background keeps accepted, rejected and locked probes and is one undo step; cancel; bake
// writes the volume beside the probe set; importance volumes are added, edited, refused, undone,
// saved and restrict greedy; greedy adds K probes around the set's in one undo step; the
// lighting panel edits the scene's lights and the rig (undoable).
#include <QAction>
#include <QCheckBox>
#include <QComboBox>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QFileInfo>
#include <QGroupBox>
#include <QItemSelectionModel>
#include <QLabel>
#include <QLayout>
#include <QLineEdit>
#include <QListWidget>
#include <QMessageBox>
#include <QProcess>
#include <QPushButton>
#include <QScatterSeries>
#include <QSignalSpy>
#include <QSpinBox>
#include <QStandardPaths>
#include <QTableView>
#include <QTableWidget>
#include <QTemporaryDir>
#include <QTimer>
#include <QtTest>
#include <cstring>
#include <map>
#include <memory>

#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/VolumeFile.h"
#include "core/placement/Place.h"
#include "core/traversal/ProbeVolume.h"
#include "ui/Document.h"
#include "ui/EvaluationPanel.h"
#include "ui/LightingField.h"
#include "ui/LightingPanel.h"
#include "ui/MainWindow.h"
#include "ui/PlacementPanel.h"
#include "ui/Viewport.h"

using namespace ps;
using namespace ps::ui;

namespace {
/// Clicks Cancel on the next modal message box as soon as it shows.
void cancelNextMessageBox() {
  QTimer::singleShot(0, [] {
    auto* box = qobject_cast<QMessageBox*>(QApplication::activeModalWidget());
    if (!box) return cancelNextMessageBox();  // not up yet: try again
    box->button(QMessageBox::Cancel)->click();
  });
}
const QString kScene = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");

struct Window {
  MainWindow w;
  Document* doc;
  Window() : doc(w.document()) {
    w.setQuiet(true);
    w.setPromptOnClose(false);
    doc->setAutoPropose(false);
  }
};

QString waitForJob(Document* doc) {
  QSignalSpy done(doc, &Document::jobFinished);
  if (!done.wait(240000)) return QStringLiteral("timeout");
  return done.at(0).at(0).toString();
}
}  // namespace

class TestPanels : public QObject {
  Q_OBJECT
 private slots:
  void initTestCase() {
    QStandardPaths::setTestModeEnabled(true);  // recent files go to a test config, not the user's
    if (!QFile::exists(kScene)) QSKIP("two-rooms.gltf not present");
  }

  void placementMatchesTheCommandLineByteForByte() {
    // The panel and `probestudio place` build the same core request (core/placement/Place.h):
    // the same probes, ids, states, methods and scores, and positions to the last bit.
    QTemporaryDir dir;
    QVERIFY(dir.isValid());
    struct Case {
      QString method, objective;
      int budget, swapPasses;
      QStringList flags;
    };
    const Case cases[] = {
        {QStringLiteral("uniform"), QString(), 32, 0, {}},
        {QStringLiteral("greedy"),
         QStringLiteral("perceptual"),
         16,
         1,
         {QStringLiteral("--swap-passes"), QStringLiteral("1")}},
        {QStringLiteral("greedy"),
         QStringLiteral("energy"),
         16,
         1,
         {QStringLiteral("--swap-passes"), QStringLiteral("1"), QStringLiteral("--objective"),
          QStringLiteral("energy")}},
    };
    std::map<QString, std::vector<Vec3>> greedyPositions;  // by objective
    for (const Case& c : cases) {
      Window win;
      QVERIFY(win.w.openScene(kScene));
      Document* doc = win.doc;
      PlacementPanel* panel = win.w.placementPanel();
      panel->methodBox()->setCurrentText(c.method);
      panel->budgetBox()->setValue(c.budget);
      panel->swapPassesBox()->setValue(c.swapPasses);
      panel->captureSamplesBox()->setValue(4);
      // greedy's objective: perceptual unless the artist picks energy.
      QCOMPARE(panel->objectiveBox()->currentText(), QStringLiteral("perceptual"));
      if (!c.objective.isEmpty()) {
        panel->objectiveBox()->setCurrentText(c.objective);
        QCOMPARE(panel->objectiveBox()->currentText(), c.objective);
        QCOMPARE(panel->placementRequest().toPlaceRequest().parameters.texts().at("objective"),
                 c.objective.toStdString());
      }
      QVERIFY(panel->run());
      QCOMPARE(waitForJob(doc), QString());
      if (!c.objective.isEmpty())
        for (const Probe& p : doc->probes())
          if (p.method == "greedy") greedyPositions[c.objective].push_back(p.position);

      const QString out = dir.filePath(c.method + c.objective + QStringLiteral(".json"));
      QProcess cli;
      cli.start(QStringLiteral(PS_CLI_PATH),
                QStringList{QStringLiteral("place"), kScene, QStringLiteral("--method"), c.method,
                            QStringLiteral("--budget"), QString::number(c.budget),
                            QStringLiteral("-o"), out} +
                    c.flags);
      QVERIFY(cli.waitForFinished(240000));
      QVERIFY2(cli.exitCode() == 0, cli.readAllStandardError().constData());
      const ProbeSet fromCli = loadProbeSet(out.toStdString());
      const std::vector<Probe>& fromEditor = doc->probes();
      QCOMPARE(fromEditor.size(), fromCli.probes.size());
      for (size_t i = 0; i < fromEditor.size(); ++i) {
        const Probe &a = fromEditor[i], &b = fromCli.probes[i];
        QCOMPARE(a.id, b.id);
        QCOMPARE(a.method, b.method);
        QCOMPARE(a.state, b.state);
        QCOMPARE(a.locked, b.locked);
        QVERIFY(std::memcmp(&a.score, &b.score, sizeof a.score) == 0);
        QVERIFY2(std::memcmp(&a.position, &b.position, sizeof a.position) == 0,
                 qPrintable(QStringLiteral("%1 probe %2").arg(c.method).arg(i)));
      }
      QCOMPARE(doc->probeSet().placement.method, fromCli.placement.method);
      QCOMPARE(doc->probeSet().placement.spacingMeters, fromCli.placement.spacingMeters);
    }
    // The two objectives put the probes in different places (the same as the command line's,
    // above): the choice reached greedy.
    QVERIFY(!greedyPositions["energy"].empty());
    QVERIFY(greedyPositions["energy"] != greedyPositions["perceptual"]);
  }

  void objectiveTooltipSaysWhatEachLowers() {
    Window win;
    QComboBox* box = win.w.placementPanel()->objectiveBox();
    QStringList items;
    for (int i = 0; i < box->count(); ++i) items << box->itemText(i);
    QCOMPARE(items, QStringList({QStringLiteral("perceptual"), QStringLiteral("energy")}));
    QVERIFY(box->itemData(0, Qt::ToolTipRole).toString().contains(QStringLiteral("stops")));
    QVERIFY(box->itemData(0, Qt::ToolTipRole).toString().contains(QStringLiteral("dim room")));
    QVERIFY(box->itemData(1, Qt::ToolTipRole).toString().contains(QStringLiteral("rel_rmse")));
    QVERIFY(box->itemData(1, Qt::ToolTipRole).toString().contains(QStringLiteral("bright")));
    QVERIFY(box->toolTip().contains(QStringLiteral("perceptual")) &&
            box->toolTip().contains(QStringLiteral("energy")));
  }

  void placementReplacesOnlyUnlockedCandidates() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    const Vec3 c = doc->scene()->bounds.center();
    std::vector<Probe> mine(5);
    for (size_t i = 0; i < mine.size(); ++i) {
      mine[i].position = c + Vec3(0.37 * double(i), 0.11, 0.23);
      mine[i].method = "manual";
    }
    const auto ids = doc->addProbes(mine, "Add");
    doc->setStates({ids[0]}, ProbeState::Accepted);
    doc->setStates({ids[1]}, ProbeState::Rejected);
    doc->setLocked({ids[2]}, true);  // a locked candidate
    // ids[3], ids[4]: unlocked candidates, replaced by the run.
    std::vector<Probe> kept;
    for (uint64_t id : {ids[0], ids[1], ids[2]}) kept.push_back(*doc->probe(id));
    const size_t before = doc->probes().size();
    const int steps = doc->undoStack()->count();

    PlacementPanel* panel = win.w.placementPanel();
    panel->methodBox()->setCurrentText(QStringLiteral("uniform"));
    panel->spacingBox()->setValue(1.0);
    panel->budgetBox()->setValue(0);
    panel->captureSamplesBox()->setValue(16);
    QVERIFY(panel->run());
    QVERIFY(doc->isBusy());
    QVERIFY(!panel->run());  // one job at a time
    QCOMPARE(waitForJob(doc), QString());
    QCOMPARE(doc->undoStack()->count(), steps + 1);
    for (const Probe& k : kept) {
      const Probe* p = doc->probe(k.id);
      QVERIFY(p);
      QCOMPARE(p->position, k.position);
      QCOMPARE(p->state, k.state);
      QCOMPARE(p->locked, k.locked);
    }
    QVERIFY(!doc->probe(ids[3]) && !doc->probe(ids[4]));
    size_t added = 0;
    for (const Probe& p : doc->probes()) {
      if (p.method != "uniform") continue;
      ++added;
      QCOMPARE(p.state, ProbeState::Candidate);
      QVERIFY(p.sh.has_value());
      for (const Probe& k : kept) QVERIFY(length(p.position - k.position) >= 0.5);
    }
    QVERIFY(added >= 10);
    QCOMPARE(doc->probeSet().placement.spacingMeters, 1.0);
    // One undo step brings back exactly what was there.
    doc->undoStack()->undo();
    QCOMPARE(doc->probes().size(), before);
    QVERIFY(doc->probe(ids[3]) && doc->probe(ids[4]));

    // Keeping the candidates: the old ones stay and the new ones keep half a spacing away.
    panel->replaceBox()->setChecked(false);
    panel->spacingBox()->setValue(0.8);
    QVERIFY(panel->run());
    QCOMPARE(waitForJob(doc), QString());
    QVERIFY(doc->probe(ids[3]) && doc->probe(ids[4]));
    QVERIFY(doc->probes().size() > before);
    for (const Probe& p : doc->probes())
      if (p.method == "uniform")
        for (uint64_t k : {ids[3], ids[4]})
          QVERIFY(length(p.position - doc->probe(k)->position) >= 0.4);
    doc->undoStack()->undo();
    QCOMPARE(doc->probes().size(), before);
    panel->replaceBox()->setChecked(true);
    panel->spacingBox()->setValue(1.0);

    // A budget: the count is near it (placeUniformBudget: within 10 % when reachable).
    panel->budgetBox()->setValue(40);
    doc->deleteProbes({ids[0], ids[1], ids[2], ids[3], ids[4]});
    QVERIFY(panel->run());
    QCOMPARE(waitForJob(doc), QString());
    // The grid's probes.
    double n = 0;
    for (const Probe& p : doc->probes()) n += p.method == "uniform" ? 1 : 0;
    QVERIFY2(n >= 30 && n <= 50, qPrintable(QString::number(n)));
    QCOMPARE(doc->probeSet().placement.budget, 40);
  }

  void everyCoreMethodRunsFromThePanelAndBuildsAroundLockedProbes() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    PlacementPanel* panel = win.w.placementPanel();
    // The panel offers exactly the core's methods, greedy first selected with a budget of 64
    // (scripts/run --headless's).
    QStringList offered;
    for (int i = 0; i < panel->methodBox()->count(); ++i)
      offered << panel->methodBox()->itemText(i);
    QStringList core;
    for (const std::string& m : placementMethods()) core << QString::fromStdString(m);
    QCOMPARE(offered, core);
    QCOMPARE(panel->methodBox()->currentText(), QStringLiteral("greedy"));
    QCOMPARE(panel->budgetBox()->value(), 64);
    QCOMPARE(panel->placementRequest().budget, 64);

    const Vec3 c = doc->scene()->bounds.center();
    Probe locked;
    locked.position = c + Vec3(0.1, 0.2, 0.3);
    locked.method = "manual";
    const uint64_t lockedId = doc->addProbes({locked}, "Add").at(0);
    doc->setLocked({lockedId}, true);

    // greedy needs a budget: choosing it never leaves the budget at "none" (uniform's spacing),
    // and the budget cannot be set to none while it is chosen.
    panel->methodBox()->setCurrentText(QStringLiteral("uniform"));
    panel->budgetBox()->setValue(0);
    QCOMPARE(panel->budgetBox()->text(), QStringLiteral("none (use spacing)"));
    QVERIFY(panel->spacingBox()->isEnabled());
    panel->methodBox()->setCurrentText(QStringLiteral("greedy"));
    QCOMPARE(panel->budgetBox()->value(), 64);
    QVERIFY(!panel->spacingBox()->isEnabled());
    panel->budgetBox()->setValue(0);
    QCOMPARE(panel->budgetBox()->value(), 4);
    QCOMPARE(panel->budgetBox()->text(), QStringLiteral("4"));
    // A library caller's bad request: an error naming the panel's field; nothing starts.
    auto refusal = [&](const PlacementRequest& request) {
      try {
        doc->runPlacement(request);
      } catch (const ParameterError& e) {
        return QString::fromUtf8(e.what());
      }
      return QStringLiteral("accepted");
    };
    PlacementRequest noBudget = panel->placementRequest();
    noBudget.budget = 0;
    const QString noBudgetError = refusal(noBudget);
    QVERIFY2(noBudgetError.contains(QStringLiteral("Budget: expected a probe count")),
             qPrintable(noBudgetError));
    QVERIFY(!doc->isBusy());

    panel->budgetBox()->setValue(24);
    panel->captureSamplesBox()->setValue(16);
    QVERIFY(panel->run());
    QCOMPARE(waitForJob(doc), QString());
    size_t greedy = 0, scored = 0, covering = 0;
    for (const Probe& p : doc->probes()) {
      covering += p.method == "coverage" ? 1 : 0;
      if (p.method != "greedy") continue;
      ++greedy;
      QVERIFY(p.score >= 0);  // the error the probe had when added (0 for the start corners)
      if (p.score > 0) ++scored;
      QVERIFY(p.sh.has_value());
      QCOMPARE(p.state, ProbeState::Candidate);
    }
    // The budget counts the locked probe and the covering (a probe in each room, the hull's
    // corners); greedy may stop early only below its noise floor.
    QVERIFY2(
        covering >= 8 && greedy >= 4 && 1 + covering + greedy <= 24 && 1 + covering + greedy >= 21,
        qPrintable(QStringLiteral("%1 covering, %2 greedy").arg(covering).arg(greedy)));
    QVERIFY(scored >= 1);
    QCOMPARE(doc->probe(lockedId)->position, locked.position);
    QVERIFY(!doc->lastJobNotes().isEmpty());  // "dense field: ...", "greedy: field error ..."
    QCOMPARE(doc->probeSet().placement.method, std::string("greedy"));
    // The swap passes (on by default) say what they did; with none, there is no such note.
    auto swapNote = [&] {
      for (const QString& n : doc->lastJobNotes())
        if (n.contains(QStringLiteral("swap pass"))) return true;
      return false;
    };
    QCOMPARE(panel->swapPassesBox()->value(), kGreedySwapPasses);
    QVERIFY(swapNote());
    panel->swapPassesBox()->setValue(0);
    QVERIFY(panel->run());
    QCOMPARE(waitForJob(doc), QString());
    QVERIFY(!swapNote());
    size_t unswapped = 0;
    for (const Probe& p : doc->probes()) unswapped += p.method == "greedy";
    QVERIFY2(unswapped >= 4 && 1 + covering + unswapped <= 24,
             qPrintable(QString::number(unswapped)));
    panel->swapPassesBox()->setValue(kGreedySwapPasses);
    // A negative count from a library caller: a clear error, nothing started or changed.
    PlacementRequest negative = panel->placementRequest();
    negative.swapPasses = -1;
    const size_t before = doc->probes().size();
    const QString negativeError = refusal(negative);
    QVERIFY2(negativeError.contains(QStringLiteral("Swap passes: expected 0 or more")),
             qPrintable(negativeError));
    QVERIFY(!doc->isBusy());
    QCOMPARE(doc->probes().size(), before);

    // chajdas without a budget: the aggressiveness decides the count (more merges, fewer).
    panel->methodBox()->setCurrentText(QStringLiteral("chajdas"));
    panel->budgetBox()->setValue(0);
    auto chajdasCount = [&](double aggressiveness) {
      panel->aggressivenessBox()->setValue(aggressiveness);
      if (!panel->run()) return size_t(0);
      if (!waitForJob(doc).isEmpty()) return size_t(0);
      size_t n = 0;
      for (const Probe& p : doc->probes()) n += p.method == "chajdas";
      return n;
    };
    const size_t gentle = chajdasCount(1.0), aggressive = chajdasCount(2.0);
    QVERIFY2(aggressive > 0 && gentle > aggressive,
             qPrintable(QStringLiteral("%1 vs %2").arg(gentle).arg(aggressive)));
  }

  void importanceVolumesAreAddedEditedUndoneSavedAndSteerPlacement() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    PlacementPanel* panel = win.w.placementPanel();
    QSignalSpy failed(panel, &PlacementPanel::failed);
    const Vec3 c = doc->scene()->bounds.center();
    std::vector<Probe> two(2);
    two[0].position = c + Vec3(-1.0, -0.3, -0.8);
    two[1].position = c + Vec3(0.6, 0.4, 0.9);
    const auto ids = doc->addProbes(two, "Add");
    win.w.selectProbes({ids[0], ids[1]});

    // A box around the selection, padded by half a metre, weight 2, one undo step.
    const int steps = doc->undoStack()->count();
    QVERIFY(panel->addVolumeAroundSelection());
    QCOMPARE(doc->undoStack()->count(), steps + 1);
    QCOMPARE(doc->probeSet().importanceVolumes.size(), size_t(1));
    const ImportanceVolume v = doc->probeSet().importanceVolumes[0];
    QCOMPARE(v.lo.x, two[0].position.x - 0.5);
    QCOMPARE(v.hi.z, two[1].position.z + 0.5);
    QCOMPARE(v.weight, 2.0);
    QTableWidget* table = panel->volumeTable();
    QCOMPARE(table->rowCount(), 1);
    QCOMPARE(table->item(0, 0)->text(), QStringLiteral("Volume 1"));

    // Edits in the table: a number is taken (undoable), a word or an inverted box is refused
    // with the row and the field named, and the document keeps its values.
    table->item(0, 1)->setText(QStringLiteral("3"));
    QCOMPARE(doc->probeSet().importanceVolumes[0].weight, 3.0);
    table->item(0, 2)->setText(QStringLiteral("wide"));
    QCOMPARE(failed.count(), 1);
    QVERIFY2(
        failed.at(0).at(1).toString().contains("importance volume 1, min x: expected a number"),
        qPrintable(failed.at(0).at(1).toString()));
    QCOMPARE(doc->probeSet().importanceVolumes[0].lo.x, v.lo.x);
    QCOMPARE(table->item(0, 2)->text(), QString::number(v.lo.x));
    table->item(0, 2)->setText(QString::number(v.hi.x + 1));
    QCOMPARE(failed.count(), 2);
    QVERIFY2(failed.at(1).at(1).toString().contains("expected min x <= max x"),
             qPrintable(failed.at(1).at(1).toString()));
    QCOMPARE(doc->probeSet().importanceVolumes[0].lo.x, v.lo.x);
    table->item(0, 1)->setText(QStringLiteral("0"));
    QCOMPARE(failed.count(), 3);
    QVERIFY(failed.at(2).at(1).toString().contains("expected a positive weight"));
    QCOMPARE(doc->probeSet().importanceVolumes[0].weight, 3.0);
    doc->undoStack()->undo();
    QCOMPARE(doc->probeSet().importanceVolumes[0].weight, 2.0);
    QCOMPARE(table->item(0, 1)->text(), QStringLiteral("2"));
    doc->undoStack()->undo();
    QVERIFY(doc->probeSet().importanceVolumes.empty());
    QCOMPARE(table->rowCount(), 0);
    doc->undoStack()->redo();
    QCOMPARE(doc->probeSet().importanceVolumes.size(), size_t(1));

    // Greedy and the covering keep to the volume: every probe they place is in the box.
    panel->methodBox()->setCurrentText(QStringLiteral("greedy"));
    panel->budgetBox()->setValue(24);
    panel->captureSamplesBox()->setValue(16);
    QVERIFY(panel->run());
    QCOMPARE(waitForJob(doc), QString());
    size_t greedy = 0;
    for (const Probe& p : doc->probes()) {
      if (p.method != "greedy" && p.method != "coverage") continue;
      greedy += p.method == "greedy" ? 1 : 0;
      for (int a = 0; a < 3; ++a)
        QVERIFY2(p.position[a] >= v.lo[a] - 1e-9 && p.position[a] <= v.hi[a] + 1e-9,
                 qPrintable(QStringLiteral("axis %1: %2 outside [%3, %4]")
                                .arg(a)
                                .arg(p.position[a])
                                .arg(v.lo[a])
                                .arg(v.hi[a])));
    }
    QVERIFY(greedy >= 4);

    // Saved with the probe set and read back.
    QTemporaryDir dir;
    const QString set = dir.filePath("volumes.probes.json");
    QVERIFY(win.w.saveAs(set));
    Window other;
    QVERIFY(other.w.openProbeSet(set));
    QCOMPARE(other.doc->probeSet().importanceVolumes.size(), size_t(1));
    QCOMPARE(other.doc->probeSet().importanceVolumes[0].name, std::string("Volume 1"));
    QCOMPARE(other.doc->probeSet().importanceVolumes[0].hi.z, v.hi.z);
    QCOMPARE(other.w.placementPanel()->volumeTable()->rowCount(), 1);

    // Remove: the current row goes, one undo step.
    table->selectRow(0);
    QVERIFY(panel->removeCurrentVolume());
    QVERIFY(doc->probeSet().importanceVolumes.empty());
    doc->undoStack()->undo();
    QCOMPARE(doc->probeSet().importanceVolumes.size(), size_t(1));
  }

  void cancelStopsTheJobAndChangesNothing() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    PlacementPanel* panel = win.w.placementPanel();
    panel->spacingBox()->setValue(0.25);
    panel->captureSamplesBox()->setValue(4096);  // long enough to cancel
    QVERIFY(panel->run());
    QVERIFY(!win.w.cancelButton()->isHidden());
    QSignalSpy done(doc, &Document::jobFinished);
    win.w.cancelButton()->click();
    QVERIFY(done.wait(60000));
    QCOMPARE(done.at(0).at(0).toString(), QStringLiteral("cancelled"));
    QVERIFY(!doc->isBusy());
    QCOMPARE(doc->probes().size(), size_t(0));
    QCOMPARE(doc->undoStack()->count(), 0);
    QVERIFY(win.w.cancelButton()->isHidden());
  }

  void cancelOfAGreedyPlacementIsQuick() {
    // Greedy 64 on two-rooms (about 20 s on two cores): Cancel, clicked in each of its stages,
    // ends the job within a second and leaves the document as it was.
    const QString stages[] = {QStringLiteral("field"), QStringLiteral("greedy"),
                              QStringLiteral("last step")};
    for (const QString& stage : stages) {
      Window win;
      QVERIFY(win.w.openScene(kScene));
      Document* doc = win.doc;
      PlacementPanel* panel = win.w.placementPanel();
      panel->methodBox()->setCurrentText(QStringLiteral("greedy"));
      panel->budgetBox()->setValue(64);
      panel->captureSamplesBox()->setValue(4096);  // a last step long enough to cancel in
      QSignalSpy done(doc, &Document::jobFinished);
      QElapsedTimer clock;
      // Clicked at the first progress report of the stage, as an artist reading the bar would;
      // the status bar says at once that the job is being cancelled.
      const QLabel* jobLabel = win.w.findChild<QLabel*>(QStringLiteral("jobLabel"));
      QVERIFY(jobLabel);
      QString shownAtCancel;
      connect(doc, &Document::jobProgress, panel, [&](const QString& message) {
        if (clock.isValid() || !message.contains(stage)) return;
        clock.start();
        win.w.cancelButton()->click();
        shownAtCancel = jobLabel->text();
      });
      QVERIFY(panel->run());
      QVERIFY(done.wait(120000));
      QVERIFY2(clock.isValid(), qPrintable(stage + QStringLiteral(": never reported")));
      const double seconds = double(clock.nsecsElapsed()) * 1e-9;
      qInfo("Cancel in %s: the job ended %.3f s later", qPrintable(stage), seconds);
      QCOMPARE(done.at(0).at(0).toString(), QStringLiteral("cancelled"));
      QCOMPARE(shownAtCancel, QStringLiteral("Cancelling…"));
      QVERIFY2(seconds < 1.0, qPrintable(QString::number(seconds)));
      QVERIFY(!doc->isBusy());
      QCOMPARE(doc->probes().size(), size_t(0));
      QCOMPARE(doc->undoStack()->count(), 0);
      QVERIFY(!doc->isModified());
    }
  }

  void bakeSavesTheVolumeBesideTheProbeSet() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    PlacementPanel* panel = win.w.placementPanel();
    QSignalSpy failed(panel, &PlacementPanel::failed);
    // Nothing saved yet: the editor offers to save; declined, nothing starts and nothing fails.
    cancelNextMessageBox();
    QVERIFY(!panel->bake());
    QCOMPARE(failed.count(), 0);
    QVERIFY(!doc->isBusy());

    panel->budgetBox()->setValue(12);
    panel->captureSamplesBox()->setValue(8);
    QVERIFY(panel->run());
    QCOMPARE(waitForJob(doc), QString());
    QTemporaryDir dir;
    const QString set = dir.filePath("rooms.probes.json");
    QVERIFY(win.w.saveAs(set));
    QVERIFY(!panel->bake());  // nothing accepted
    QVERIFY(failed.at(0).at(1).toString().contains("accepted"));

    // Accept all but one, plus a manual (accepted) probe above the first so the set is 3D.
    std::vector<uint64_t> accepted;
    for (const Probe& p : doc->probes()) accepted.push_back(p.id);
    accepted.pop_back();
    doc->setStates(accepted, ProbeState::Accepted);
    accepted.push_back(
        doc->addManualProbe(doc->probes()[0].position + Vec3(0.1, 0.6, 0.05), "Add"));
    panel->bakeSamplesBox()->setValue(16);
    QSignalSpy volumeChanged(doc, &Document::volumeChanged);
    QVERIFY(panel->bake());
    QCOMPARE(waitForJob(doc), QString());
    const QString psv = dir.filePath("rooms.psv");
    QCOMPARE(doc->volumePath(), psv);
    QCOMPARE(volumeChanged.count(), 1);
    QVERIFY(doc->volume());
    QCOMPARE(doc->volume()->probeCount(), accepted.size());  // the accepted probes only
    const VolumeFile f = loadVolume(psv.toStdString());
    QCOMPARE(f.volume.probeCount(), accepted.size());
    QCOMPARE(f.volume.tets.size(), doc->volume()->tets.size());
    QCOMPARE(Document::volumePathFor("/a/b.json"), QStringLiteral("/a/b.psv"));
    // The preview can show the baked volume itself.
    Viewport* vp = win.w.viewport();
    vp->setPreviewSource(PreviewSource::Baked);
    QVERIFY(vp->previewVolume().has_value());
    QCOMPARE(vp->previewVolume()->probeCount(), accepted.size());
    const QString note = doc->lastJobNotes().join(' ');
    QVERIFY2(note.contains(QStringLiteral("Baked %1 accepted probes").arg(accepted.size())),
             qPrintable(note));
    // Least-squares values: the same mesh, other values, and the notes and the file say so.
    QVERIFY(!panel->fitBox()->isChecked());
    const ProbeVolume captured = *doc->volume();
    panel->fitBox()->setChecked(true);
    QVERIFY(panel->bake());
    QCOMPARE(waitForJob(doc), QString());
    QCOMPARE(doc->volume()->tets, captured.tets);
    QVERIFY(doc->volume()->sh != captured.sh);
    QVERIFY(doc->lastJobNotes().join(' ').contains("fitted by least squares"));
    QVERIFY(loadVolume(psv.toStdString()).metadataJson.find("\"least-squares\"") !=
            std::string::npos);
    panel->fitBox()->setChecked(false);
  }

  void evaluationsArePlottedAgainstProbeCount() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    EvaluationPanel* panel = win.w.evaluationPanel();
    QSignalSpy failed(panel, &EvaluationPanel::failed);
    QVERIFY(!panel->evaluate());  // nothing accepted, nothing baked
    QVERIFY(failed.at(0).at(1).toString().contains("accept"));

    win.w.placementPanel()->methodBox()->setCurrentText(QStringLiteral("uniform"));
    win.w.placementPanel()->budgetBox()->setValue(40);
    win.w.placementPanel()->captureSamplesBox()->setValue(16);
    QVERIFY(win.w.placementPanel()->run());
    QCOMPARE(waitForJob(doc), QString());
    std::vector<uint64_t> ids;
    for (const Probe& p : doc->probes()) ids.push_back(p.id);
    // Saved, so the reference cache goes beside the set, in a fresh folder.
    QTemporaryDir dir;
    QVERIFY(win.w.saveAs(dir.filePath("set.json")));
    panel->queriesBox()->setValue(32);
    panel->referenceSamplesBox()->setValue(32);
    // Two evaluations at different counts: every other probe, then all of them.
    std::vector<uint64_t> half;
    for (size_t i = 0; i < ids.size(); i += 2) half.push_back(ids[i]);
    doc->setStates(half, ProbeState::Accepted);
    QVERIFY(panel->evaluate());
    QCOMPARE(waitForJob(doc), QString());
    doc->setStates(ids, ProbeState::Accepted);
    QVERIFY(panel->evaluate());
    QCOMPARE(waitForJob(doc), QString());

    const auto& evals = doc->evaluations();
    QCOMPARE(evals.size(), size_t(2));
    QCOMPARE(evals[0].probes, half.size());
    QCOMPARE(evals[1].probes, ids.size());
    QCOMPARE(panel->rmseSeries()->count(), 2);
    QCOMPARE(panel->p95Series()->count(), 2);
    for (int i = 0; i < 2; ++i) {
      const QPointF a = panel->rmseSeries()->at(i), b = panel->p95Series()->at(i);
      QCOMPARE(a.x(), double(evals[size_t(i)].probes));
      QCOMPARE(a.y(), 100 * evals[size_t(i)].relRmse);
      QCOMPARE(b.y(), 100 * evals[size_t(i)].p95RelError);
      QVERIFY(evals[size_t(i)].relRmse > 0 && std::isfinite(evals[size_t(i)].relRmse));
      // The table gives the error with its uncertainty, and the reference's noise on hover.
      QVERIFY(evals[size_t(i)].relRmseStdError > 0 && evals[size_t(i)].referenceRelNoise > 0);
      const QTableWidgetItem* item = panel->table()->item(i, 1);
      QCOMPARE(item->text(), QString::number(a.y(), 'f', 2) + QStringLiteral(" ± ") +
                                 QString::number(100 * evals[size_t(i)].relRmseStdError, 'f', 2) +
                                 " %");
      QVERIFY(item->toolTip().contains(
          QString::number(100 * evals[size_t(i)].referenceRelNoise, 'f', 2) + " %"));
      // The leaking queries, and on hover how many of them are outside the probes' hull.
      const EvaluationPoint& e = evals[size_t(i)];
      QVERIFY(e.leakingOutsideHullFraction <= e.leakingFraction);
      QVERIFY(e.leakingOutsideHullFraction <= e.outsideHullFraction);
      QVERIFY(e.outsideHullFraction > 0 && e.outsideHullFraction < 1);
      // The error in stops: RMS and p90, the rest on hover.
      QVERIFY(e.stops.queries > 0 && e.stopsFloor > 0 && e.stops.p90 >= e.stops.median);
      QCOMPARE(panel->table()->item(i, 2)->text(), QString::number(e.stops.rms, 'f', 2) +
                                                       QStringLiteral(" / ") +
                                                       QString::number(e.stops.p90, 'f', 2));
      QVERIFY(panel->table()->item(i, 2)->toolTip().contains(
          QStringLiteral("median %1").arg(e.stops.median, 0, 'f', 3)));
      const QTableWidgetItem* leak = panel->table()->item(i, 4);
      QCOMPARE(leak->text(), QString::number(100 * e.leakingFraction, 'f', 2) + " %");
      QVERIFY(leak->toolTip().contains(
          QStringLiteral("Outside the probes' hull: %1 % (%2 % of all queries")
              .arg(100 * e.leakingOutsideHullFraction, 0, 'f', 2)
              .arg(100 * e.outsideHullFraction, 0, 'f', 2)));
    }
    QCOMPARE(panel->table()->rowCount(), 2);
    // The second evaluation read the reference the first one traced (the CLI's cache, beside
    // the set), and the table says so.
    QVERIFY(!evals[0].referenceCached);
    QVERIFY(evals[1].referenceCached);
    QVERIFY(QFileInfo(dir.filePath("eval-reference-cache")).isDir());
    QVERIFY(panel->table()->item(0, 5)->text().startsWith("traced"));
    QVERIFY(panel->table()->item(1, 5)->text().startsWith("cached"));
    // The preview is evaluated as it is drawn.
    QCOMPARE(evals[1].source, QStringLiteral("preview (accepted probes)"));
    // A new scene starts a new plot.
    QVERIFY(win.w.openScene(QStringLiteral(PS_SOURCE_DIR "/resources/scenes/cornell.gltf")));
    QCOMPARE(panel->rmseSeries()->count(), 0);
  }

  void greedyAddsKProbesWhereTheErrorIsWorstInOneUndoStep() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    PlacementPanel* placement = win.w.placementPanel();
    placement->methodBox()->setCurrentText(QStringLiteral("uniform"));
    placement->budgetBox()->setValue(16);
    placement->captureSamplesBox()->setValue(4);
    QVERIFY(placement->run());
    QCOMPARE(waitForJob(doc), QString());
    // The artist's set: a few accepted, one rejected, the rest candidates.
    std::vector<uint64_t> ids;
    for (const Probe& p : doc->probes()) ids.push_back(p.id);
    QVERIFY(ids.size() >= 8);
    doc->setStates({ids[0], ids[1], ids[2], ids[3]}, ProbeState::Accepted);
    doc->setStates({ids[4]}, ProbeState::Rejected);
    const std::vector<Probe> before = doc->probes();
    const int undoBefore = doc->undoStack()->index();

    // Greedy takes the Placement tab's options: no swap passes here, for a quick test.
    placement->methodBox()->setCurrentText(QStringLiteral("uniform"));
    placement->swapPassesBox()->setValue(0);
    EvaluationPanel* eval = win.w.evaluationPanel();
    eval->greedyAddCountBox()->setValue(5);
    QVERIFY(eval->greedyAddButton()->isEnabled());
    eval->greedyAddButton()->click();
    QVERIFY(doc->isBusy());
    QVERIFY(!eval->greedyAddButton()->isEnabled());
    QCOMPARE(waitForJob(doc), QString());
    QVERIFY(eval->greedyAddButton()->isEnabled());
    // The new probes are selected, so the view shows where they went.
    QCOMPARE(win.w.probeTable()->selectionModel()->selectedRows().size(), 5);

    // Exactly five more, the others untouched: greedy, accepted, captured; one undo step.
    QCOMPARE(doc->probes().size(), before.size() + 5);
    for (size_t i = 0; i < before.size(); ++i) {
      QCOMPARE(doc->probes()[i].id, before[i].id);
      QCOMPARE(doc->probes()[i].position, before[i].position);
      QCOMPARE(doc->probes()[i].state, before[i].state);
    }
    for (size_t i = before.size(); i < doc->probes().size(); ++i) {
      const Probe& p = doc->probes()[i];
      QCOMPARE(p.method, std::string("greedy"));
      QCOMPARE(p.state, ProbeState::Accepted);
      QVERIFY(p.sh.has_value());
    }
    QCOMPARE(doc->undoStack()->index(), undoBefore + 1);
    QCOMPARE(doc->undoStack()->undoText(),
             QStringLiteral("Add 5 probes where the error is worst (greedy)"));
    // The panel's method stays the artist's choice.
    QCOMPARE(placement->methodBox()->currentText(), QStringLiteral("uniform"));

    doc->undoStack()->undo();
    QCOMPARE(doc->probes().size(), before.size());
    for (size_t i = 0; i < before.size(); ++i) QCOMPARE(doc->probes()[i].id, before[i].id);
    doc->undoStack()->redo();
    QCOMPARE(doc->probes().size(), before.size() + 5);
  }

  void singleKeyShortcutsActOnlyInTheView() {
    // Every shortcut of a key that types text (A, R, Shift+L, Delete, ...) is the view's: R typed
    // into the panels' fields, a table or a list is text, and no probe changes state; in the
    // view R rejects the selection (under xvfb, ui.test_panels_shown: the offscreen platform
    // shows the window without its OpenGL view).
    const bool offscreen = QGuiApplication::platformName() == QLatin1String("offscreen");
    Window win;
    QAction* reject = nullptr;
    for (QAction* a : win.w.viewport()->actions()) {
      QCOMPARE(a->shortcutContext(), Qt::WidgetShortcut);
      if (a->shortcut() == QKeySequence(Qt::Key_R)) reject = a;
    }
    QVERIFY(reject);
    for (QAction* a : win.w.findChildren<QAction*>())
      for (const QKeySequence& k : a->shortcuts())
        if (k.count() == 1 && !(k[0].keyboardModifiers() & ~Qt::ShiftModifier) &&
            k[0].key() != Qt::Key_Escape)
          QVERIFY2(win.w.viewport()->actions().contains(a), qPrintable(k.toString()));

    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    std::vector<Probe> probes(6);
    for (size_t i = 0; i < probes.size(); ++i) {
      probes[i].position = doc->scene()->bounds.center() + Vec3(0.3 * double(i), 0, 0);
      probes[i].method = "manual";
    }
    const std::vector<uint64_t> ids = doc->addProbes(probes, "Add");
    QVERIFY(win.w.placementPanel()->addVolumeAroundSelection());  // a row to type into
    std::unique_ptr<QWidget> view;
    if (offscreen) {
      view.reset(win.w.takeCentralWidget());
      view->setParent(nullptr);
    }
    win.w.show();
    win.w.activateWindow();
    QVERIFY(QTest::qWaitForWindowActive(&win.w));
    QSet<quint64> all;
    for (uint64_t id : ids) all.insert(quint64(id));
    auto states = [&] {
      std::vector<ProbeState> out;
      for (const Probe& p : doc->probes()) out.push_back(p.state);
      return out;
    };
    const std::vector<ProbeState> before = states();
    PlacementPanel* panel = win.w.placementPanel();
    QLineEdit* budgetField = panel->budgetBox()->findChild<QLineEdit*>();
    QVERIFY(budgetField);
    const QList<QWidget*> fields = {
        budgetField,
        panel->captureSamplesBox(),
        panel->methodBox(),
        panel->volumeTable(),
        win.w.evaluationPanel()->queriesBox(),
        win.w.probeTable(),
    };
    for (QWidget* field : fields) {
      win.w.selectProbes(all);
      // A panel in a tabbed dock is shown first (a hidden field takes no focus).
      for (QWidget* w = field; w; w = w->parentWidget())
        if (auto* dock = qobject_cast<QDockWidget*>(w)) dock->raise();
      field->setFocus();
      QTRY_VERIFY2_WITH_TIMEOUT(field->hasFocus(), field->metaObject()->className(), 5000);
      QTest::keyClicks(field, QStringLiteral("RrACL"));
      QTest::keyClick(field, Qt::Key_R, Qt::ShiftModifier);
      QTest::keyClick(field, Qt::Key_Delete);
      QCOMPARE(doc->probes().size(), ids.size());
      QVERIFY2(states() == before, field->metaObject()->className());
      QVERIFY2(!doc->probe(ids[0])->locked, field->metaObject()->className());
    }
    // The view: R rejects the selection.
    if (offscreen) QSKIP("R in the view needs OpenGL: run under xvfb-run (ui.test_panels_shown)");
    win.w.selectProbes(all);
    win.w.viewport()->setFocus();
    QTRY_VERIFY_WITH_TIMEOUT(win.w.viewport()->hasFocus(), 5000);
    QTest::keyClick(win.w.viewport(), Qt::Key_R);
    for (uint64_t id : ids) QCOMPARE(doc->probe(id)->state, ProbeState::Rejected);
  }

  void placementMethodAndBudgetComeBackOnReopen() {
    // The set records the method, budget and spacing that placed it (its "placement"); opening
    // it shows them in the panel, so that Run placement places as it was placed.
    QTemporaryDir dir;
    Window win;
    QVERIFY(win.w.openScene(kScene));
    PlacementPanel* panel = win.w.placementPanel();
    panel->methodBox()->setCurrentText(QStringLiteral("uniform"));
    panel->budgetBox()->setValue(30);
    panel->captureSamplesBox()->setValue(4);
    QVERIFY(panel->run());
    QCOMPARE(waitForJob(win.doc), QString());
    const QString uniformSet = dir.filePath("uniform.probes.json");
    QVERIFY(win.w.saveAs(uniformSet));
    // A set placed by greedy at 48 (as `probestudio place` writes it).
    ProbeSet greedySet = win.doc->probeSet();
    greedySet.placement = {"greedy", 0.75, 48};
    const QString greedyPath = dir.filePath("greedy.probes.json");
    saveProbeSet(greedySet, greedyPath.toStdString());

    panel->methodBox()->setCurrentText(QStringLiteral("chajdas"));
    panel->budgetBox()->setValue(0);
    QVERIFY(win.w.openProbeSet(uniformSet));
    QCOMPARE(panel->methodBox()->currentText(), QStringLiteral("uniform"));
    QCOMPARE(panel->budgetBox()->value(), 30);
    QCOMPARE(panel->placementRequest().budget, 30);
    QVERIFY(win.w.openProbeSet(greedyPath));
    QCOMPARE(panel->methodBox()->currentText(), QStringLiteral("greedy"));
    QCOMPARE(panel->budgetBox()->value(), 48);
    QCOMPARE(panel->spacingBox()->value(), 0.75);
    // A greedy set without a budget (placed to an error target) keeps the panel's budget.
    greedySet.placement = {"greedy", 0.75, 0};
    saveProbeSet(greedySet, greedyPath.toStdString());
    panel->budgetBox()->setValue(20);
    QVERIFY(win.w.openProbeSet(greedyPath));
    QCOMPARE(panel->budgetBox()->value(), 20);
  }

  void fileShortcutsAreBound() {
    // The documented file shortcuts are bound on every platform, Save as to Ctrl+Shift+S.
    Window win;
    auto* saveAs = win.w.findChild<QAction*>("saveAsAction");
    QVERIFY(saveAs);
    QCOMPARE(saveAs->shortcut(), QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_S));
    QCOMPARE(saveAs->shortcut().toString(), QStringLiteral("Ctrl+Shift+S"));
    QSet<QString> bound;
    for (const QAction* a : win.w.findChildren<QAction*>())
      for (const QKeySequence& k : a->shortcuts()) bound.insert(k.toString());
    for (const char* key : {"Ctrl+O", "Ctrl+Shift+O", "Ctrl+S", "Ctrl+Shift+S", "Ctrl+Q", "Ctrl+Z",
                            "Ctrl+Y", "Ctrl+R", "Ctrl+B", "Ctrl+E", "Esc"})
      QVERIFY2(bound.contains(QString::fromLatin1(key)), key);
  }

  void defaultLayoutGivesTheViewportMostOfTheWindow() {
    // The window at 1600 x 1000, and at the screenshot test's screen (1280 x 1024), with a
    // scene open: the viewport spans at least 60 % of the window's width.
    for (const QSize size : {QSize(1600, 1000), QSize(1280, 1024)}) {
      Window win;
      QVERIFY(win.w.openScene(kScene));
      // The offscreen platform has no GL to show the viewport with: the window's layout is run
      // and the window told its size as showing it does.
      win.w.resize(size);
      win.w.layout()->activate();
      QResizeEvent resized(size, QSize());
      QApplication::sendEvent(&win.w, &resized);
      win.w.layout()->activate();
      const int viewport = win.w.viewport()->width(), window = win.w.width();
      qInfo("window %d x %d: viewport %d x %d px (%.0f %%)", window, win.w.height(), viewport,
            win.w.viewport()->height(), 100.0 * viewport / window);
      QVERIFY2(viewport >= 0.6 * window,
               qPrintable(QStringLiteral("%1 of %2 px").arg(viewport).arg(window)));
    }
  }

  void lightingPanelListsTheScenesLightsAndSaysWhichLightTheCapturesUse() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    LightingPanel* panel = win.w.lightingPanel();
    // two-rooms brings a point light and a sun (KHR_lights_punctual): one row each, as the
    // scene file gives them (the point's node at (-3.2, 2.55, 0.6), 15 and 4 times its colour).
    const QTableWidget* table = panel->sceneLightsTable();
    QVERIFY(table->isVisibleTo(panel));
    QCOMPARE(table->rowCount(), 2);
    QCOMPARE(table->item(0, 0)->text(), QStringLiteral("point"));
    QCOMPARE(table->item(0, 1)->text(), QStringLiteral("room-a-light"));
    QCOMPARE(table->item(0, 2)->text(), QStringLiteral("at (-3.20, 2.55, 0.60)"));
    QCOMPARE(table->item(0, 3)->text(), QStringLiteral("15 W/sr"));
    QVERIFY(table->item(0, 3)->toolTip().contains(QStringLiteral("colour (RGB) (1.000, 0.780")));
    QCOMPARE(table->item(1, 0)->text(), QStringLiteral("sun"));
    QCOMPARE(table->item(1, 1)->text(), QStringLiteral("sun"));
    QCOMPARE(table->item(1, 3)->text(), QStringLiteral("4 W/m²"));
    // Its source in the sun group's terms: the direction towards it, as azimuth and elevation.
    const Vec3 travels = doc->scene()->lights[1].direction;
    const Vec3 towards =
        LightingPanel::towardsSun(qRadiansToDegrees(std::atan2(-travels.x, -travels.z)),
                                  qRadiansToDegrees(std::asin(-travels.y)));
    QVERIFY(length(towards + travels) < 1e-9);
    QCOMPARE(table->item(1, 2)->text(),
             QStringLiteral("from azimuth %1°, elevation %2°")
                 .arg(qRadiansToDegrees(std::atan2(-travels.x, -travels.z)), 0, 'f', 1)
                 .arg(qRadiansToDegrees(std::asin(-travels.y)), 0, 'f', 1));
    QVERIFY(travels.y < 0);  // it shines down

    // The captures use the scene's lights; the empty rig adds none.
    const QLabel* uses = panel->capturesUseLabel();
    QCOMPARE(uses->text(),
             QStringLiteral("Captures use the scene's lights: point \"room-a-light\", sun "
                            "\"sun\". The rig below adds none."));
    // The rig's sun is added to them, and the panel says that two suns now light the scene.
    panel->sunGroup()->setChecked(true);
    QCOMPARE(uses->text(),
             QStringLiteral("Captures use both the scene's lights (point \"room-a-light\", sun "
                            "\"sun\") and the rig's (sun). The scene's sun and the rig's sun "
                            "both light the captures."));
    // The rig is edited as before; the scene's lights stay as the file gives them.
    panel->sunIrradiance()->setValue(2);
    QCOMPARE(doc->probeSet().rig.lights.size(), size_t(1));
    QCOMPARE(doc->probeSet().rig.lights[0].intensity, Rgb(2, 2, 2));
    QCOMPARE(doc->scene()->lights.size(), size_t(2));
    QCOMPARE(table->rowCount(), 2);
    doc->undoStack()->undo();
    doc->undoStack()->undo();
    QVERIFY(doc->probeSet().rig.empty());
    QVERIFY(uses->text().endsWith(QStringLiteral("The rig below adds none.")));

    // cornell brings no punctual light but an emissive ceiling panel: no rows, and the line
    // names what lights it.
    QVERIFY(win.w.openScene(QStringLiteral(PS_SOURCE_DIR "/resources/scenes/cornell.gltf")));
    QCOMPARE(table->rowCount(), 0);
    QVERIFY(!table->isVisibleTo(panel));
    QCOMPARE(uses->text(), QStringLiteral("Captures use the scene's lights: emissive surfaces. "
                                          "The rig below adds none."));
    // A scene without any light, built in memory: the line asks for one.
    Scene dark = *doc->scene();
    for (Material& m : dark.materials) m.emission = Rgb(0, 0, 0);
    doc->setScene(std::move(dark));
    QCOMPARE(uses->text(), QStringLiteral("No light: the scene brings none. Add a sun, a sky "
                                          "or a point light below."));
    panel->skyGroup()->setChecked(true);
    QCOMPARE(uses->text(),
             QStringLiteral("The scene brings no light. Captures use the rig's: sky."));
  }

  void lightingPanelEditsTheScenesLights() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    LightingPanel* panel = win.w.lightingPanel();
    QTableWidget* table = panel->sceneLightsTable();
    const Light point = doc->scene()->lights[0], sun = doc->scene()->lights[1];
    QVERIFY(!panel->sceneLightGroup()->isVisibleTo(panel));
    // The artist picks the point light: its position and intensity, no sun angles.
    table->setCurrentCell(0, 0);
    QVERIFY(panel->sceneLightGroup()->isVisibleTo(panel));
    QCOMPARE(panel->sceneLightIntensity()->value(), 15.0);
    QCOMPARE(panel->sceneLightPosition(0)->value(), -3.2);
    QVERIFY(panel->sceneLightPosition(0)->isVisibleTo(panel));
    QVERIFY(!panel->sceneLightAzimuth()->isVisibleTo(panel));

    const quint64 changes = doc->changeCount();
    const int undoIndex = doc->undoStack()->index();
    panel->sceneLightIntensity()->setValue(30);
    QCOMPARE(doc->undoStack()->index(), undoIndex + 1);
    const Light edited = doc->scene()->lights[0];
    for (int c = 0; c < 3; ++c)
      QVERIFY2(std::abs(edited.intensity[c] - 2 * point.intensity[c]) <= 1e-3 * point.intensity[c],
               qPrintable(QString::number(edited.intensity[c])));
    QCOMPARE(edited.position, point.position);
    QCOMPARE(doc->scene()->lights[1].direction, sun.direction);
    // Captures trace the edited light, and a lighting change leaves the bake behind.
    QCOMPARE(doc->tracer()->scene().lights[0].intensity, edited.intensity);
    QVERIFY(doc->changeCount() > changes);
    QCOMPARE(table->item(0, 3)->text(), QStringLiteral("30 W/sr"));
    QCOMPARE(table->item(0, 1)->text(), QStringLiteral("room-a-light (edited)"));
    QVERIFY(panel->capturesUseLabel()->text().contains(QStringLiteral("room-a-light")));

    // Undo restores the file's light exactly, in the scene, the tracer and the panel.
    doc->undoStack()->undo();
    QCOMPARE(doc->scene()->lights[0].intensity, point.intensity);
    QCOMPARE(doc->tracer()->scene().lights[0].intensity, point.intensity);
    QCOMPARE(panel->sceneLightIntensity()->value(), 15.0);
    QCOMPARE(table->item(0, 3)->text(), QStringLiteral("15 W/sr"));
    QCOMPARE(table->item(0, 1)->text(), QStringLiteral("room-a-light"));

    // The sun: its direction as azimuth and elevation; a move of the point light.
    panel->sceneLightPosition(1)->setValue(2.0);
    QCOMPARE(doc->scene()->lights[0].position, Vec3(point.position.x, 2.0, point.position.z));
    table->setCurrentCell(1, 0);
    QVERIFY(panel->sceneLightAzimuth()->isVisibleTo(panel));
    QVERIFY(!panel->sceneLightPosition(0)->isVisibleTo(panel));
    QCOMPARE(panel->sceneLightIntensity()->value(), 4.0);
    panel->sceneLightElevation()->setValue(80);
    const Vec3 towards = -doc->scene()->lights[1].direction;
    QVERIFY(std::abs(qRadiansToDegrees(std::asin(towards.y)) - 80) < 1e-9);
    QCOMPARE(doc->scene()->lights[1].intensity, sun.intensity);
    panel->sceneLightIntensity()->setValue(8);
    QCOMPARE(doc->scene()->lights[1].intensity, sun.intensity * 2.0);
    doc->undoStack()->undo();
    doc->undoStack()->undo();
    doc->undoStack()->undo();
    QCOMPARE(doc->scene()->lights[0].position, point.position);
    QCOMPARE(doc->scene()->lights[1].direction, sun.direction);
    QCOMPARE(doc->scene()->lights[1].intensity, sun.intensity);
    QCOMPARE(doc->undoStack()->index(), undoIndex);

    // The evaluation's reference follows the edited light: a reference cached with the file's
    // lights is not read back, one traced with the edit is.
    win.w.placementPanel()->methodBox()->setCurrentText(QStringLiteral("uniform"));
    win.w.placementPanel()->budgetBox()->setValue(16);
    win.w.placementPanel()->captureSamplesBox()->setValue(4);
    QVERIFY(win.w.placementPanel()->run());
    QCOMPARE(waitForJob(doc), QString());
    std::vector<uint64_t> ids;
    for (const Probe& p : doc->probes()) ids.push_back(p.id);
    doc->setStates(ids, ProbeState::Accepted);
    QTemporaryDir dir;
    QVERIFY(win.w.saveAs(dir.filePath("set.json")));
    EvaluationPanel* eval = win.w.evaluationPanel();
    eval->queriesBox()->setValue(16);
    eval->referenceSamplesBox()->setValue(16);
    auto evaluateCached = [&] {
      if (!eval->evaluate() || !waitForJob(doc).isEmpty()) return -1;
      return doc->evaluations().back().referenceCached ? 1 : 0;
    };
    QCOMPARE(evaluateCached(), 0);
    QCOMPARE(evaluateCached(), 1);
    table->setCurrentCell(0, 0);
    panel->sceneLightIntensity()->setValue(60);
    QCOMPARE(evaluateCached(), 0);
    QCOMPARE(evaluateCached(), 1);
    doc->undoStack()->undo();
    QCOMPARE(evaluateCached(), 1);  // the file's lights again: the first reference
  }

  void lightingPanelEditsTheRig() {
    Window win;
    QVERIFY(win.w.openScene(kScene));
    Document* doc = win.doc;
    LightingPanel* panel = win.w.lightingPanel();
    QVERIFY(!panel->sunGroup()->isChecked());
    const int steps = doc->undoStack()->count();
    panel->sunGroup()->setChecked(true);
    panel->sunAzimuth()->setValue(90);
    panel->sunElevation()->setValue(30);
    panel->sunIrradiance()->setValue(7);
    const auto& rig = doc->probeSet().rig;
    QCOMPARE(rig.lights.size(), size_t(1));
    const Light& sun = rig.lights[0];
    QCOMPARE(sun.type, LightType::Directional);
    QCOMPARE(sun.name, std::string("sun"));
    // It travels away from the sun: towards -X and down.
    QVERIFY(length(sun.direction - Vec3(-std::cos(kPi / 6), -0.5, 0)) < 1e-9);
    QCOMPARE(sun.intensity, Rgb(7, 7, 7));
    QCOMPARE(doc->undoStack()->count(), steps + 4);
    QVERIFY(doc->isModified());

    panel->skyGroup()->setChecked(true);
    panel->skyRadiance(2)->setValue(0.9);
    QCOMPARE(doc->probeSet().rig.skyRadiance, Rgb(0.5, 0.5, 0.9));

    panel->addPointButton()->click();
    QCOMPARE(doc->probeSet().rig.lights.size(), size_t(2));
    QCOMPARE(panel->pointList()->count(), 1);
    panel->pointPosition(1)->setValue(2.25);
    panel->pointIntensity()->setValue(40);
    const Light& point = doc->probeSet().rig.lights[1];
    QCOMPARE(point.type, LightType::Point);
    QCOMPARE(point.position.y, 2.25);
    QCOMPARE(point.intensity, Rgb(40, 40, 40));

    // Undo walks back through the edits and the panel follows.
    doc->undoStack()->undo();
    QCOMPARE(doc->probeSet().rig.lights[1].intensity, Rgb(10, 10, 10));
    QCOMPARE(panel->pointIntensity()->value(), 10.0);
    panel->removePointButton()->click();
    QCOMPARE(doc->probeSet().rig.lights.size(), size_t(1));
    doc->undoStack()->setIndex(steps);
    QVERIFY(doc->probeSet().rig.empty());
    QVERIFY(!panel->sunGroup()->isChecked());

    // Recapture with a new point light: a captured probe near it sees more light; one undo
    // step restores the previous SH.
    {
      const Vec3 at = doc->scene()->bounds.center() + Vec3(-1.0, 0.0, 0.7);
      const uint64_t pid = doc->addManualProbe(at, "Add");
      const double before = meanLuminance(*doc->probe(pid)->sh);
      panel->addPointButton()->click();  // at the bounds' centre, in the doorway
      panel->pointIntensity()->setValue(50);
      const int index = doc->undoStack()->index();
      QSignalSpy done(doc, &Document::jobFinished);
      panel->recaptureButton()->click();
      QVERIFY(done.wait(60000));
      QCOMPARE(done.at(0).at(0).toString(), QString());
      QCOMPARE(doc->undoStack()->index(), index + 1);
      QVERIFY2(
          meanLuminance(*doc->probe(pid)->sh) > before * 1.05,
          qPrintable(QString("%1 -> %2").arg(before).arg(meanLuminance(*doc->probe(pid)->sh))));
      doc->undoStack()->undo();
      QCOMPARE(meanLuminance(*doc->probe(pid)->sh), before);
      doc->undoStack()->setIndex(steps);
    }

    // A rig set elsewhere (a loaded set) is shown: the sun's angles round-trip.
    LightingRig r;
    Light s;
    s.type = LightType::Directional;
    s.name = "sun";
    s.direction = -LightingPanel::towardsSun(-120, 55);
    s.intensity = Rgb(3, 2, 1);
    r.lights.push_back(s);
    doc->setRig(r, "Set");
    QVERIFY(panel->sunGroup()->isChecked());
    QCOMPARE(qRound(panel->sunAzimuth()->value()), -120);
    QCOMPARE(qRound(panel->sunElevation()->value()), 55);
    QCOMPARE(panel->sunIrradiance()->value(), 3.0);
    QVERIFY(length(panel->rigFromWidgets().lights[0].direction - s.direction) < 1e-3);
  }
};

QTEST_MAIN(TestPanels)
#include "test_panels.moc"
