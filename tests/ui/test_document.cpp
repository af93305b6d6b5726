// The editor's document, undo stack and probe table model, headless (QT_QPA_PLATFORM=offscreen).
#include <QComboBox>
#include <QFile>
#include <QSignalSpy>
#include <QSortFilterProxyModel>
#include <QSpinBox>
#include <QStandardPaths>
#include <QTemporaryDir>
#include <QtTest>

#include "core/common/Error.h"
#include "core/domain/ReachableSpace.h"
#include "core/io/ProbeSetFile.h"
#include "core/placement/Uniform.h"
#include "ui/Document.h"
#include "ui/MainWindow.h"
#include "ui/PlacementPanel.h"
#include "ui/ProbeTableModel.h"

using namespace ps;
using namespace ps::ui;

namespace {
const QString kScene = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");
const QString kApartment =
    QStringLiteral(PS_SHARED_SCENES_DIR "/dream-apartment/dream-apartment.glb");

/// Waits for the running job; its error ("timeout" when it did not end in 4 minutes).
QString waitForJob(Document* doc) {
  QSignalSpy done(doc, &Document::jobFinished);
  if (!done.wait(240000)) return QStringLiteral("timeout");
  return done.at(0).at(0).toString();
}

std::vector<Probe> makeProbes(int n) {
  std::vector<Probe> out;
  for (int i = 0; i < n; ++i) {
    Probe p;
    p.position = Vec3(0.5 * i, 1.0 + 0.1 * i, -0.25 * i);
    p.method = "manual";
    p.score = i * 1.5;
    out.push_back(p);
  }
  return out;
}

QString cell(const ProbeTableModel& m, int row, int col) {
  return m.data(m.index(row, col)).toString();
}

/// Everything the user can see of a probe set, for "unchanged" comparisons.
struct Snapshot {
  std::vector<uint64_t> ids;
  std::vector<Vec3> positions;
  std::vector<ProbeState> states;
  QString setPath, scenePath;
  bool modified = false;
  int undoCount = 0;
  bool operator==(const Snapshot&) const = default;
};
Snapshot snapshot(Document& d) {
  Snapshot s;
  for (const Probe& p : d.probes()) {
    s.ids.push_back(p.id);
    s.positions.push_back(p.position);
    s.states.push_back(p.state);
  }
  s.setPath = d.probeSetPath();
  s.scenePath = d.scenePath();
  s.modified = d.isModified();
  s.undoCount = d.undoStack()->count();
  return s;
}
}  // namespace

class TestDocument : public QObject {
  Q_OBJECT
 private slots:
  void initTestCase() {
    QStandardPaths::setTestModeEnabled(true);  // recent files go to a test config, not the user's
    if (!QFile::exists(kScene)) QSKIP("two-rooms.gltf not present");
  }

  void editUndoRedoSaveReload() {
    Document doc;
    doc.setAutoPropose(false);
    ProbeTableModel model(&doc);
    doc.openScene(kScene);
    QVERIFY(doc.hasScene());
    QVERIFY(doc.scene()->triangleCount() > 0);
    QCOMPARE(model.rowCount(), 0);
    QVERIFY(!doc.isModified());

    const auto ids = doc.addProbes(makeProbes(5), "Add");
    QCOMPARE(ids.size(), size_t(5));
    QCOMPARE(model.rowCount(), 5);
    QCOMPARE(model.columnCount(), int(ProbeTableModel::ColumnCount));
    QCOMPARE(model.data(model.index(2, ProbeTableModel::Id)).toULongLong(), ids[2]);
    QCOMPARE(cell(model, 2, ProbeTableModel::X), QStringLiteral("1.00"));
    QCOMPARE(cell(model, 2, ProbeTableModel::Method), QStringLiteral("manual"));
    QVERIFY(doc.isModified());

    // Accept two, reject one, delete one.
    QSignalSpy changed(&model, &QAbstractItemModel::dataChanged);
    doc.setStates({ids[0], ids[1]}, ProbeState::Accepted);
    QCOMPARE(changed.count(), 2);
    QCOMPARE(cell(model, 0, ProbeTableModel::State), QString(toString(ProbeState::Accepted)));
    doc.setStates({ids[2]}, ProbeState::Rejected);
    QCOMPARE(cell(model, 2, ProbeTableModel::State), QString(toString(ProbeState::Rejected)));
    doc.deleteProbes({ids[3]});
    QCOMPARE(model.rowCount(), 4);
    QCOMPARE(doc.indexOf(ids[3]), -1);
    QCOMPARE(model.data(model.index(3, ProbeTableModel::Id)).toULongLong(), ids[4]);

    // Undo the delete and the reject, redo both.
    QUndoStack* undo = doc.undoStack();
    undo->undo();
    QCOMPARE(model.rowCount(), 5);
    QCOMPARE(doc.indexOf(ids[3]), 3);
    QCOMPARE(doc.probe(ids[3])->position, makeProbes(5)[3].position);
    undo->undo();
    QCOMPARE(doc.probe(ids[2])->state, ProbeState::Candidate);
    QCOMPARE(cell(model, 2, ProbeTableModel::State), QString(toString(ProbeState::Candidate)));
    undo->redo();
    undo->redo();
    QCOMPARE(doc.probe(ids[2])->state, ProbeState::Rejected);
    QCOMPARE(model.rowCount(), 4);

    // Moves of one probe merge into one undo step.
    const int before = undo->count();
    doc.moveProbe(ids[4], Vec3(1, 1, 1));
    doc.moveProbe(ids[4], Vec3(2, 1, 1));
    QCOMPARE(undo->count(), before + 1);
    undo->undo();
    QCOMPARE(doc.probe(ids[4])->position, makeProbes(5)[4].position);
    undo->redo();
    QCOMPARE(doc.probe(ids[4])->position, Vec3(2, 1, 1));

    // The sorted proxy follows the model.
    QSortFilterProxyModel proxy;
    proxy.setSourceModel(&model);
    proxy.setSortRole(ProbeTableModel::SortRole);
    proxy.sort(ProbeTableModel::X, Qt::DescendingOrder);
    QCOMPARE(proxy.data(proxy.index(0, ProbeTableModel::Id)).toULongLong(), ids[4]);
    doc.deleteProbes({ids[4]});
    QCOMPARE(proxy.rowCount(), 3);
    QCOMPARE(proxy.data(proxy.index(0, ProbeTableModel::Id)).toULongLong(), ids[2]);

    // Save, reload, compare.
    QTemporaryDir dir;
    const QString path = dir.filePath("set.json");
    QSignalSpy modified(&doc, &Document::modifiedChanged);
    doc.saveProbeSet(path);
    QVERIFY(!doc.isModified());
    QCOMPARE(doc.probeSetPath(), path);
    QVERIFY(modified.count() >= 1);

    Document reloaded;
    reloaded.openProbeSet(path);
    QVERIFY(reloaded.hasScene());
    QCOMPARE(reloaded.scene()->triangleCount(), doc.scene()->triangleCount());
    QCOMPARE(reloaded.probes().size(), doc.probes().size());
    for (size_t i = 0; i < doc.probes().size(); ++i) {
      const Probe& a = doc.probes()[i];
      const Probe& b = reloaded.probes()[i];
      QCOMPARE(b.id, a.id);
      QCOMPARE(b.state, a.state);
      QVERIFY(length(b.position - a.position) < 1e-9);
    }
    QVERIFY(!reloaded.isModified());
    // Ids are never reused after a reload.
    const auto more = reloaded.addProbes(makeProbes(1), "Add");
    for (uint64_t id : ids) QVERIFY(more[0] != id);
  }

  void badFilesLeaveTheDocumentUnchanged() {
    Document doc;
    doc.setAutoPropose(false);
    ProbeTableModel model(&doc);
    doc.openScene(kScene);
    doc.addProbes(makeProbes(3), "Add");
    const Snapshot before = snapshot(doc);
    const int triangles = int(doc.scene()->triangleCount());

    QTemporaryDir dir;
    const QString bad = dir.filePath("bad.json");
    {
      QFile f(bad);
      QVERIFY(f.open(QIODevice::WriteOnly));
      f.write("{\"version\": 1, \"probes\": [{\"id\": 1, \"position\": [1, 2]}]}");
    }
    QSignalSpy reset(&model, &QAbstractItemModel::modelReset);
    QVERIFY_THROWS_EXCEPTION(ps::Error, doc.openProbeSet(bad));
    QVERIFY_THROWS_EXCEPTION(ps::Error, doc.openProbeSet(dir.filePath("missing.json")));
    QVERIFY_THROWS_EXCEPTION(ps::Error, doc.openScene(dir.filePath("missing.gltf")));
    QVERIFY_THROWS_EXCEPTION(ps::Error, doc.saveProbeSet(dir.filePath("no/such/dir/set.json")));
    QCOMPARE(reset.count(), 0);
    QVERIFY(snapshot(doc) == before);
    QCOMPARE(int(doc.scene()->triangleCount()), triangles);
    QCOMPARE(model.rowCount(), 3);

    // The window's action reports the error (quietly here) and keeps the document.
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    w.document()->setAutoPropose(false);
    QVERIFY(w.openScene(kScene));
    QVERIFY(!w.openProbeSet(bad));
    QVERIFY(w.lastError().contains("bad.json"));
    QVERIFY(w.document()->hasScene());
    QVERIFY(!w.openScene(dir.filePath("missing.gltf")));
    QCOMPARE(w.document()->scenePath(), kScene);
  }

  void proposalRunsInTheBackground() {
    Document doc;
    ProbeTableModel model(&doc);
    QSignalSpy finished(&doc, &Document::jobFinished);
    doc.openScene(kScene);
    QVERIFY(doc.isBusy());
    QVERIFY(finished.wait(240000));
    QVERIFY(!doc.isBusy());
    const QString error = finished.takeFirst().at(0).toString();
    QVERIFY2(error.isEmpty(), qPrintable(error));
    const int n = model.rowCount();
    QVERIFY2(n >= 20 && n <= 200, qPrintable(QString::number(n)));
    for (const Probe& p : doc.probes()) {
      QCOMPARE(p.state, ProbeState::Candidate);
      QVERIFY(p.sh.has_value());
      QVERIFY(doc.scene()->bounds.contains(p.position));
    }
    QVERIFY(!doc.isModified());  // the editor's proposal leaves a new document clean
    doc.undoStack()->undo();     // the proposal is one undo step
    QCOMPARE(model.rowCount(), 0);
  }

  void proposalLiesInTheReachableDomain_data() {
    QTest::addColumn<QString>("scene");
    QTest::newRow("two-rooms") << kScene;
    QTest::newRow("dream-apartment") << kApartment;
  }

  void proposalLiesInTheReachableDomain() {
    // The first open proposes through Run placement's pipeline and domain: in an interior every
    // candidate lies in the space View > Domain of interest shows, and Run placement with the
    // proposal's method and budget gives the same candidates.
    QFETCH(QString, scene);
    if (!QFile::exists(scene))
      QSKIP(qPrintable(QStringLiteral("the scene %1 is not present").arg(scene)));
    MainWindow w;
    w.setQuiet(true);  // dream-apartment has no light: the quick capture fails, the probes stay
    w.setPromptOnClose(false);
    Document* doc = w.document();
    QVERIFY(doc->autoPropose());
    QSignalSpy finished(doc, &Document::jobFinished);
    QVERIFY(w.openScene(scene));
    QCOMPARE(doc->jobKind(), QStringLiteral("propose"));
    QVERIFY(finished.wait(240000));
    QVERIFY(!doc->isModified());
    std::vector<Vec3> proposed;
    for (const Probe& p : doc->probes()) proposed.push_back(p.position);
    QVERIFY2(proposed.size() >= 20 && proposed.size() <= 200,
             qPrintable(QString::number(proposed.size())));
    QVERIFY(pointsSpan3D(proposed));
    const ReachableSpace reachable(*doc->tracer(), {});
    QVERIFY2(reachable.interior(), reachable.summary().c_str());
    size_t outside = 0;
    for (const Vec3& p : proposed) outside += reachable.contains(p) ? 0 : 1;
    QVERIFY2(outside == 0, qPrintable(QStringLiteral("%1 of %2 candidates outside the reachable "
                                                     "domain (%3)")
                                          .arg(outside)
                                          .arg(proposed.size())
                                          .arg(QString::fromStdString(reachable.summary()))));

    // Ctrl+R with the proposal's settings: the same candidates in their place.
    PlacementPanel* panel = w.placementPanel();
    panel->methodBox()->setCurrentText(QStringLiteral("uniform"));
    panel->budgetBox()->setValue(int(doc->proposalSettings().targetProbeCount));
    panel->captureSamplesBox()->setValue(doc->proposalSettings().samplesPerProbe);
    QVERIFY(panel->run());
    (void)waitForJob(doc);  // without light the capture's error is expected; positions count
    std::vector<Vec3> placed;
    for (const Probe& p : doc->probes()) placed.push_back(p.position);
    QCOMPARE(placed.size(), proposed.size());
    QVERIFY(placed == proposed);
  }

  void proposalSpansThreeDimensionsInALowWideScene() {
    // dream-apartment is much wider than tall: a cubic grid of about 80 points is one flat layer,
    // of which no volume can be made. The proposal's points must not lie in one plane.
    const QString scene =
        QStringLiteral(PS_SHARED_SCENES_DIR "/dream-apartment/dream-apartment.glb");
    if (!QFile::exists(scene)) QSKIP("the shared scene dream-apartment is not present");
    Document doc;
    doc.setAutoPropose(false);
    QSignalSpy finished(&doc, &Document::jobFinished);
    doc.openScene(scene);
    LightingRig sky;  // the scene brings no light
    sky.skyRadiance = {0.3, 0.4, 0.6};
    doc.setRig(sky, QStringLiteral("Sky"));
    doc.proposeCandidates();
    QVERIFY(finished.wait(240000));
    const QString error = finished.takeFirst().at(0).toString();
    QVERIFY2(error.isEmpty(), qPrintable(error));
    std::vector<Vec3> points;
    for (const Probe& p : doc.probes()) points.push_back(p.position);
    QVERIFY2(points.size() >= 20 && points.size() <= 200,
             qPrintable(QString::number(points.size())));
    QVERIFY(pointsSpan3D(points));
  }

  void reopeningCancelsTheRunningProposal() {
    Document doc;
    doc.openScene(kScene);
    QVERIFY(doc.isBusy());
    doc.setAutoPropose(false);
    QSignalSpy inserted(&doc, &Document::probeInserted), finished(&doc, &Document::jobFinished);
    doc.openScene(kScene);  // waits for the old job to stop, drops its result
    QVERIFY(!doc.isBusy());
    QVERIFY(doc.isJobInFlight());   // its finished signal is still queued
    QCOMPARE(finished.count(), 1);  // the stopped job, reported by the reopening
    // Once the old job's own finished signal has reached the document, nothing came of it.
    QTRY_VERIFY_WITH_TIMEOUT(!doc.isJobInFlight(), 60000);
    QCOMPARE(finished.count(), 1);
    QCOMPARE(inserted.count(), 0);
    QCOMPARE(doc.probes().size(), size_t(0));
  }
};

QTEST_MAIN(TestDocument)
#include "test_document.moc"
