// The artist's loop, driven as a person would (QT_QPA_PLATFORM=offscreen): opening a set with its
// scene, a clean new document, Bake offering to save, the bake found again on reopen, messages
// naming the editor's controls, redo on Ctrl+Y, no stray windows after jobs, one progress bar,
// the overlays' legends and the status bar's reason when an overlay is empty.
#include <QAbstractButton>
#include <QCheckBox>
#include <QComboBox>
#include <QDir>
#include <QDoubleSpinBox>
#include <QFile>
#include <QGuiApplication>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QLabel>
#include <QMessageBox>
#include <QProgressBar>
#include <QPushButton>
#include <QScatterSeries>
#include <QSettings>
#include <QSignalSpy>
#include <QSpinBox>
#include <QTableWidget>
#include <QTemporaryDir>
#include <QTimer>
#include <QtTest>
#include <memory>

#include "core/io/ProbeSetFile.h"
#include "ui/Document.h"
#include "ui/EvaluationPanel.h"
#include "ui/LightingPanel.h"
#include "ui/MainWindow.h"
#include "ui/PlacementPanel.h"
#include "ui/Viewport.h"

using namespace ps;
using namespace ps::ui;

namespace {
const QString kScene = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");

/// Accepted probes spread through two-rooms' left room and doorway (inside the building).
std::vector<Probe> acceptedProbes() {
  const Vec3 points[] = {{-2.5, 0.8, -1.5}, {-1.0, 0.8, 1.5}, {-2.0, 2.0, 1.0},
                         {-0.5, 2.0, -1.0}, {1.5, 1.2, 0.0},  {3.0, 1.0, 1.5}};
  std::vector<Probe> out;
  for (const Vec3& v : points) {
    Probe p;
    p.position = v;
    p.state = ProbeState::Accepted;
    p.method = "manual";
    out.push_back(p);
  }
  return out;
}

/// Clicks `button` of the next modal message box as soon as it shows; records its text.
void answerNextMessageBox(QMessageBox::StandardButton button, QString* text = nullptr) {
  QTimer::singleShot(0, [button, text] {
    auto* box = qobject_cast<QMessageBox*>(QApplication::activeModalWidget());
    if (!box) return answerNextMessageBox(button, text);  // not up yet: try again
    if (text) *text = box->text();
    box->button(button)->click();
  });
}

/// Copies two-rooms (one self-contained .gltf) into `dir`; without its lights when `unlit`.
QString copyScene(const QTemporaryDir& dir, bool unlit) {
  QFile in(kScene);
  if (!in.open(QIODevice::ReadOnly)) return {};
  QJsonObject root = QJsonDocument::fromJson(in.readAll()).object();
  if (unlit) {
    root.remove("extensions");
    root.remove("extensionsUsed");
    QJsonArray nodes = root["nodes"].toArray();
    for (auto n : nodes) {
      QJsonObject o = n.toObject();
      o.remove("extensions");
      n = o;
    }
    root["nodes"] = nodes;
  }
  const QString path = dir.filePath(unlit ? "unlit.gltf" : "two-rooms.gltf");
  QFile out(path);
  if (!out.open(QIODevice::WriteOnly)) return {};
  out.write(QJsonDocument(root).toJson());
  return path;
}

/// Waits for the running job (if any) to end; its error.
QString waitForJob(Document* doc, int timeoutMs = 120000) {
  if (!doc->isBusy()) return {};
  QSignalSpy done(doc, &Document::jobFinished);
  if (!done.wait(timeoutMs)) return QStringLiteral("timeout");
  return done.first().first().toString();
}

/// Opens a copy of two-rooms in `dir` in `w` (quiet, no prompts, no proposal) with
/// acceptedProbes() captured at 16 samples (the preview evaluation needs captured probes), saves
/// the set as two-rooms.probes.json there and sets the bake to 16 samples. Returns the set's
/// path, empty on failure.
QString openSavedSet(MainWindow& w, const QTemporaryDir& dir) {
  const QString scene = copyScene(dir, false);
  const QString set = dir.filePath("two-rooms.probes.json");
  w.setQuiet(true);
  w.setPromptOnClose(false);
  Document* doc = w.document();
  doc->setAutoPropose(false);
  if (scene.isEmpty() || !w.openPath(scene)) return {};
  doc->addProbes(acceptedProbes(), "Add");
  if (!doc->recapture(16) || !waitForJob(doc).isEmpty() || !w.saveAs(set)) return {};
  w.placementPanel()->bakeSamplesBox()->setValue(16);
  return set;
}

/// Visible top-level widgets other than `main`.
QStringList strayWindows(const QWidget* main) {
  QStringList out;
  for (QWidget* w : QApplication::topLevelWidgets())
    if (w != main && w->isVisible())
      out << QStringLiteral("%1 '%2'").arg(w->metaObject()->className(), w->windowTitle());
  return out;
}
}  // namespace

class TestArtistLoop : public QObject {
  Q_OBJECT
  QTemporaryDir settingsDir_;

 private slots:
  void initTestCase() {
    if (!QFile::exists(kScene)) QSKIP("two-rooms.gltf not present");
    QSettings::setDefaultFormat(QSettings::IniFormat);
    QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settingsDir_.path());
    QCoreApplication::setOrganizationName("ProbeStudioTest");
    QCoreApplication::setApplicationName("test_artist_loop");
  }

  void aNewDocumentIsCleanAfterItsProposal() {
    MainWindow w;
    w.setQuiet(true);
    QVERIFY(w.openScene(kScene));  // proposes candidates in the background
    QVERIFY(w.document()->isBusy());
    QCOMPARE(waitForJob(w.document()), QString());
    QVERIFY(!w.document()->probes().empty());
    QVERIFY(!w.document()->isModified());
    QVERIFY(!w.isWindowModified());
    // Closing asks nothing (no message box: close() would block on it otherwise).
    QVERIFY(w.close());
    // An artist's edit is a change.
    MainWindow w2;
    w2.setPromptOnClose(false);
    QVERIFY(w2.openScene(kScene));
    QCOMPARE(waitForJob(w2.document()), QString());
    w2.document()->deleteProbes({w2.document()->probes().front().id});
    QVERIFY(w2.isWindowModified());
  }

  void aSetAsTheArgumentOpensWithItsSceneAndItsBake() {
    QTemporaryDir dir;
    const QString scene = copyScene(dir, false);
    QVERIFY(!scene.isEmpty());
    const QString set = dir.filePath("rooms.probes.json");
    {
      MainWindow w;
      w.setQuiet(true);
      w.setPromptOnClose(false);
      w.document()->setAutoPropose(false);
      QVERIFY(w.openPath(scene));
      w.document()->addProbes(acceptedProbes(), "Add");
      // Bake on a set never saved: the editor offers to save it beside the scene; accept.
      w.placementPanel()->bakeSamplesBox()->setValue(16);
      QString text;
      answerNextMessageBox(QMessageBox::Save, &text);
      QVERIFY(w.placementPanel()->bake());
      QVERIFY2(text.contains("two-rooms.probes.json"), qPrintable(text));
      QCOMPARE(w.document()->jobKind(), QString("bake"));
      QCOMPARE(waitForJob(w.document()), QString());
      QVERIFY(QFile::exists(dir.filePath("two-rooms.probes.json")));
      QVERIFY(QFile::exists(dir.filePath("two-rooms.psv")));
      QVERIFY(w.document()->volumeIsCurrent());
      QVERIFY(w.saveAs(set));
      QVERIFY(QFile::copy(dir.filePath("two-rooms.psv"), dir.filePath("rooms.psv")));
    }
    // The command line's argument: a set opens with its scene, clean, with the bake beside it.
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    QVERIFY(w.openPath(set));
    Document* doc = w.document();
    QVERIFY(doc->hasScene());
    QCOMPARE(QFileInfo(doc->scenePath()).fileName(), QString("two-rooms.gltf"));
    QCOMPARE(doc->probeSetPath(), set);
    QCOMPARE(doc->probes().size(), acceptedProbes().size());
    QVERIFY(!doc->isBusy());  // no proposal over an opened set
    QVERIFY(!doc->isModified());
    QVERIFY(doc->volume() != nullptr);
    QCOMPARE(doc->volumePath(), dir.filePath("rooms.psv"));
    QVERIFY(doc->volumeIsCurrent());
    // Moving an accepted probe makes the bake stale; so does reopening the set edited.
    doc->moveProbe(doc->probes().front().id, Vec3(-2.4, 0.9, -1.4));
    QVERIFY(!doc->volumeIsCurrent());
    QVERIFY(w.save());
    QVERIFY(w.openPath(set));
    QVERIFY(doc->volume() != nullptr);
    QVERIFY(!doc->volumeIsCurrent());
    // A set with no volume beside it drops the previous one.
    const QString other = dir.filePath("other.json");
    QVERIFY(QFile::copy(set, other));
    QVERIFY(w.openPath(other));
    QVERIFY(doc->volume() == nullptr);

    // Declining the offer starts nothing and reports nothing.
    MainWindow w2;
    w2.setQuiet(true);
    w2.setPromptOnClose(false);
    w2.document()->setAutoPropose(false);
    QVERIFY(w2.openPath(scene));
    w2.document()->addProbes(acceptedProbes(), "Add");
    answerNextMessageBox(QMessageBox::Cancel);
    QVERIFY(!w2.placementPanel()->bake());
    QVERIFY(!w2.document()->isBusy());
    QVERIFY(w2.lastError().isEmpty());
  }

  void aStaleVolumeIsNamedStaleFromTheMomentItNoLongerMatches() {
    QTemporaryDir dir;
    MainWindow w;
    const QString set = openSavedSet(w, dir);
    QVERIFY(!set.isEmpty());
    Document* doc = w.document();
    QVERIFY(w.placementPanel()->bake());
    QCOMPARE(waitForJob(doc), QString());
    const QLabel* panel = w.placementPanel()->volumeLabel();
    const QLabel* status = w.findChild<QLabel*>("volumeStateStatus");
    const QLabel* evaluated = w.evaluationPanel()->evaluatedLabel();
    QVERIFY(status);
    QCOMPARE(doc->volumeState(), Document::VolumeState::Baked);
    QVERIFY2(panel->text().contains("two-rooms.psv: baked, 6 probes"), qPrintable(panel->text()));
    QVERIFY2(status->text().isEmpty(), qPrintable(status->text()));
    QVERIFY2(evaluated->text().contains("baked volume two-rooms.psv"),
             qPrintable(evaluated->text()));

    // Rejecting an accepted probe makes the volume stale at once, named with the probe, in the
    // placement panel, the status bar and the evaluation panel.
    const uint64_t rejected = doc->probes().back().id;
    doc->setStates({rejected}, ProbeState::Rejected);
    QCOMPARE(doc->volumeState(), Document::VolumeState::Stale);
    const QString why =
        QStringLiteral("6 probes in it, 5 accepted: probe %1 is no longer accepted").arg(rejected);
    for (const QLabel* label : {panel, status, evaluated})
      QVERIFY2(label->text().contains("stale") && label->text().contains(why),
               qPrintable(label->text()));
    QVERIFY2(evaluated->text().startsWith("Evaluates: preview (accepted probes"),
             qPrintable(evaluated->text()));
    // Undone, the set matches the volume again.
    doc->undoStack()->undo();
    QCOMPARE(doc->volumeState(), Document::VolumeState::Baked);
    QVERIFY(status->text().isEmpty());
    doc->undoStack()->redo();
    QCOMPARE(doc->volumeState(), Document::VolumeState::Stale);

    // Saved and reopened: the volume beside the set, a superset of the accepted probes, is
    // stale from the open, and Evaluate measures the accepted probes and names it stale.
    QVERIFY(w.save());
    QVERIFY(w.openPath(set));
    QVERIFY(doc->volume() != nullptr);
    QCOMPARE(doc->volumeState(), Document::VolumeState::Stale);
    QVERIFY2(panel->text().contains(why), qPrintable(panel->text()));
    QVERIFY2(status->text().contains(why), qPrintable(status->text()));
    EvaluationPanel* evaluation = w.evaluationPanel();
    evaluation->queriesBox()->setValue(16);
    evaluation->referenceSamplesBox()->setValue(16);
    QVERIFY(evaluation->evaluate());
    QCOMPARE(waitForJob(doc), QString());
    const EvaluationPoint& e = doc->evaluations().back();
    QCOMPARE(e.probes, size_t(5));
    QVERIFY2(e.source.contains("two-rooms.psv is stale: " + why), qPrintable(e.source));
    const QTableWidget* table = evaluation->table();
    QCOMPARE(table->item(table->rowCount() - 1, 6)->text(), e.source);
  }

  void greedyAddsThenOneClickMeasuresWhatWillBeBaked() {
    QTemporaryDir dir;
    MainWindow w;
    QVERIFY(!openSavedSet(w, dir).isEmpty());
    Document* doc = w.document();
    EvaluationPanel* panel = w.evaluationPanel();
    panel->queriesBox()->setValue(16);
    panel->referenceSamplesBox()->setValue(16);
    // Bake and evaluate from a set never baked: the evaluation measures the baked volume.
    QVERIFY(panel->bakeAndEvaluate());
    QCOMPARE(waitForJob(doc), QString());  // the bake; the evaluation follows
    QTRY_COMPARE_WITH_TIMEOUT(doc->evaluations().size(), size_t(1), 120000);
    QVERIFY2(doc->evaluations().back().source.startsWith("baked volume"),
             qPrintable(doc->evaluations().back().source));

    // Greedy adds four probes: the volume no longer holds the accepted probes, and the panel
    // says that its figures are of the volume without them and names the one click.
    panel->greedyAddCountBox()->setValue(4);
    w.placementPanel()->captureSamplesBox()->setValue(16);
    QVERIFY2(panel->addProbesWhereErrorIsWorst(), qPrintable(w.lastError()));
    QCOMPARE(waitForJob(doc, 300000), QString());
    size_t accepted = 0;
    for (const Probe& p : doc->probes()) accepted += p.state == ProbeState::Accepted ? 1 : 0;
    QVERIFY(accepted > acceptedProbes().size());
    QCOMPARE(doc->volumeState(), Document::VolumeState::Stale);
    QVERIFY(!panel->nextStepLabel()->isHidden());
    QVERIFY2(panel->nextStepLabel()->text().contains("Bake and evaluate"),
             qPrintable(panel->nextStepLabel()->text()));
    // One click: the volume is baked with them and that volume is what the figure measures.
    panel->bakeAndEvaluateButton()->click();
    QVERIFY(doc->isBusy());
    QCOMPARE(waitForJob(doc), QString());
    QTRY_COMPARE_WITH_TIMEOUT(doc->evaluations().size(), size_t(2), 120000);
    const EvaluationPoint& e = doc->evaluations().back();
    QCOMPARE(doc->volumeState(), Document::VolumeState::Baked);
    QCOMPARE(e.probes, accepted);
    QVERIFY2(e.source.startsWith("baked volume"), qPrintable(e.source));
    QVERIFY(panel->nextStepLabel()->isHidden());
  }

  void capturesMadeInTheEditorAreNotStaleOnReopen() {
    QTemporaryDir dir;
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    Document* doc = w.document();
    doc->setAutoPropose(false);
    QVERIFY(w.openPath(kScene));
    doc->addManualProbe(Vec3(-2.0, 1.2, 0.5), "Add");  // captured at once
    const uint64_t moved = doc->addProbes(acceptedProbes(), "Add").front();
    doc->moveProbe(moved, Vec3(-2.4, 0.9, -1.4));  // captured live
    QTRY_VERIFY_WITH_TIMEOUT(!doc->isCapturingLive(), 60000);
    QVERIFY(doc->probe(moved)->sh);
    const QString set = dir.filePath("rooms.json");
    QVERIFY(w.saveAs(set));
    QVERIFY(w.openPath(set));
    QCOMPARE(QString::fromStdString(doc->staleCapturesText()), QString());
  }

  void aSceneWithoutLightOpensWithABannerAndOneClickSky() {
    QTemporaryDir dir;
    const QString unlit = copyScene(dir, true);
    QVERIFY(!unlit.isEmpty());
    MainWindow w;
    w.setPromptOnClose(false);   // not quiet: an error would be a modal box
    QVERIFY(w.openPath(unlit));  // proposes candidates it cannot capture
    // The job ends with the capture's failure, which the banner says instead of a dialog.
    QVERIFY(waitForJob(w.document()) != QLatin1String("timeout"));
    QCoreApplication::processEvents();
    QVERIFY2(QApplication::activeModalWidget() == nullptr, "a dialog stands in front");
    QVERIFY(w.lastError().isEmpty());
    QVERIFY(!w.viewBanner()->isHidden());
    auto* reason = w.findChild<QLabel*>("overlayReason");
    QVERIFY2(reason->text().contains("no light"), qPrintable(reason->text()));
    auto* sky = w.findChild<QPushButton*>("addDefaultSky");
    QVERIFY(sky && !sky->isHidden());
    // One click lights the scene: one undo step, the banner goes.
    const int steps = w.document()->undoStack()->count();
    sky->click();
    QCOMPARE(w.document()->undoStack()->count(), steps + 1);
    QCOMPARE(w.document()->probeSet().rig.skyRadiance.b, MainWindow::kDefaultSkyRadiance.b);
    QVERIFY(sky->isHidden());
    QVERIFY2(!reason->text().contains("no light"), qPrintable(reason->text()));
  }

  void messagesNameTheEditorsControls() {
    QTemporaryDir dir;
    const QString unlit = copyScene(dir, true);
    QVERIFY(!unlit.isEmpty());
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    w.document()->setAutoPropose(false);
    QVERIFY(w.openPath(unlit));
    w.document()->addProbes(acceptedProbes(), "Add");
    // Recapture in a scene with no light: the error says where to add one.
    w.lightingPanel()->recaptureButton()->click();
    waitForJob(w.document());
    QVERIFY2(w.lastError().contains("Lighting tab"), qPrintable(w.lastError()));
    QVERIFY2(!w.lastError().contains("--"), qPrintable(w.lastError()));
  }

  void ctrlYAndCtrlShiftZRedo() {
    MainWindow w;
    w.setPromptOnClose(false);
    w.document()->setAutoPropose(false);
    QVERIFY(w.openPath(kScene));
    // The offscreen platform has no GL: the window is shown without its viewport.
    const std::unique_ptr<QWidget> viewport(w.takeCentralWidget());
    viewport->setParent(nullptr);
    w.show();
    QVERIFY(QTest::qWaitForWindowActive(&w));
    w.document()->addProbes(acceptedProbes(), "Add");
    QTest::keyClick(&w, Qt::Key_Z, Qt::ControlModifier);
    QCOMPARE(w.document()->probes().size(), size_t(0));
    QTest::keyClick(&w, Qt::Key_Y, Qt::ControlModifier);
    QCOMPARE(w.document()->probes().size(), acceptedProbes().size());
    QTest::keyClick(&w, Qt::Key_Z, Qt::ControlModifier);
    QCOMPARE(w.document()->probes().size(), size_t(0));
    QTest::keyClick(&w, Qt::Key_Z, Qt::ControlModifier | Qt::ShiftModifier);
    QCOMPARE(w.document()->probes().size(), acceptedProbes().size());
  }

  void jobsLeaveNoStrayWindowsAndShowOneProgress() {
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    w.document()->setAutoPropose(false);
    QVERIFY(w.openPath(kScene));
    // The offscreen platform has no GL: the window is shown without its viewport.
    const std::unique_ptr<QWidget> viewport(w.takeCentralWidget());
    viewport->setParent(nullptr);
    w.show();
    QVERIFY(QTest::qWaitForWindowExposed(&w));
    Document* doc = w.document();
    doc->addProbes(acceptedProbes(), "Add");
    // One placement with its phases (covering, grid, capture): the fraction the bar shows never
    // goes back, and the label names the step.
    std::vector<double> fractions;
    QStringList labels;
    connect(doc, &Document::jobProgress, this, [&](const QString& what, double f) {
      if (!doc->isBusy()) return;
      fractions.push_back(f);
      labels << what;
    });
    w.placementPanel()->methodBox()->setCurrentText("uniform");
    w.placementPanel()->spacingBox()->setValue(1.0);
    QVERIFY(w.placementPanel()->run());
    QCOMPARE(waitForJob(doc), QString());
    QVERIFY(fractions.size() >= 2);
    for (size_t i = 1; i < fractions.size(); ++i)
      QVERIFY2(fractions[i] >= fractions[i - 1], qPrintable(QStringLiteral("%1 then %2 (%3)")
                                                                .arg(fractions[i - 1])
                                                                .arg(fractions[i])
                                                                .arg(labels.join(" | "))));
    QVERIFY2(labels.join(" ").contains("step 2 of 3"), qPrintable(labels.join(" | ")));
    QVERIFY2(labels.join(" ").contains("last step"), qPrintable(labels.join(" | ")));
    // Two more jobs: still only the main window.
    for (int i = 0; i < 2; ++i) {
      QVERIFY(doc->recapture(8));
      QCOMPARE(waitForJob(doc), QString());
      QCoreApplication::processEvents();
    }
    QVERIFY2(strayWindows(&w).isEmpty(), qPrintable(strayWindows(&w).join(", ")));
    auto* bar = w.findChild<QProgressBar*>();
    QVERIFY(bar && !bar->isVisible());
  }

  void overlaysCarryLegendsAndSayWhyTheyAreEmpty() {
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    Document* doc = w.document();
    Viewport* vp = w.viewport();
    doc->setAutoPropose(false);
    QVERIFY(w.openPath(kScene));
    auto* reason = w.findChild<QLabel*>("overlayReason");
    QVERIFY(reason);
    // A set as `place` writes it: probes without captures. The preview has nothing to show and
    // the status bar says why and what to do.
    // Probe lighting is on by default; with it off and no overlay, nothing needs explaining.
    QVERIFY(vp->previewLighting());
    vp->setPreviewLighting(false);
    doc->addProbes(acceptedProbes(), "Add");
    QVERIFY(reason->text().isEmpty());  // nothing shown, nothing to explain
    vp->setPreviewLighting(true);
    QVERIFY2(reason->text().contains("no captures") && reason->text().contains("Recapture"),
             qPrintable(reason->text()));
    for (const auto& l : vp->legends()) QVERIFY(!l.title.startsWith("Probe lighting"));
    // The action it names fixes it.
    w.lightingPanel()->recaptureButton()->click();
    QCOMPARE(waitForJob(doc), QString());
    QVERIFY2(reason->text().isEmpty(), qPrintable(reason->text()));
    // The baked volume as the source, without one: say so.
    vp->setPreviewSource(PreviewSource::Baked);
    QVERIFY2(reason->text().contains("Ctrl+B"), qPrintable(reason->text()));
    vp->setPreviewSource(PreviewSource::AllCaptured);
    QVERIFY(reason->text().isEmpty());

    // Legends, with units and ranges, for each overlay shown.
    vp->setOverlay(Viewport::Overlay::Glyphs, true);
    vp->setOverlay(Viewport::Overlay::Slice, true);
    vp->setOverlay(Viewport::Overlay::TetMesh, true);
    vp->setSliceMode(Viewport::SliceMode::Error);
    QVERIFY(vp->previewVolume());
    const std::vector<Viewport::Legend> legends = vp->legends();
    QStringList titles;
    for (const auto& l : legends) titles << l.title;
    QCOMPARE(legends.size(), size_t(4));
    QVERIFY(titles[0].startsWith("Probe lighting"));
    QCOMPARE(legends[0].unit, QStringLiteral("W/m²"));
    QVERIFY(legends[0].lo > 0 && legends[0].hi > legends[0].lo);
    QVERIFY(titles[1].startsWith("Gradient glyphs"));
    QVERIFY(legends[1].hi > 0);
    // The error slice speaks in stops, with the visible third of a stop marked.
    QVERIFY2(titles[2].contains("error"), qPrintable(titles[2]));
    QCOMPARE(legends[2].unit, QStringLiteral("stops"));
    QCOMPARE(legends[2].hi, 1.0);
    QVERIFY(legends[2].mark && *legends[2].mark == kVisibleStops);
    // ... and says where the slice is.
    QVERIFY2(titles[2].contains("y = "), qPrintable(titles[2]));
    QVERIFY(titles[3].startsWith("Tetrahedra"));
    QCOMPARE(legends[3].swatches.size(), size_t(3));
  }

  void theErrorIsShownWhereItIsAndFixedInOneClick() {
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    Document* doc = w.document();
    Viewport* vp = w.viewport();
    doc->setAutoPropose(false);
    QVERIFY(w.openPath(kScene));
    doc->addProbes(acceptedProbes(), "Add");
    QVERIFY(doc->recapture(64));
    QCOMPARE(waitForJob(doc), QString());
    // Before any evaluation the error points say what to do.
    vp->setOverlay(Viewport::Overlay::ErrorPoints, true);
    auto* reason = w.findChild<QLabel*>("overlayReason");
    QVERIFY2(reason->text().contains("Ctrl+E"), qPrintable(reason->text()));
    vp->setOverlay(Viewport::Overlay::ErrorPoints, false);

    EvaluationPanel* panel = w.evaluationPanel();
    panel->queriesBox()->setValue(24);
    panel->referenceSamplesBox()->setValue(16);
    QVERIFY(panel->evaluate());
    QCOMPARE(waitForJob(doc), QString());
    const std::vector<QueryError>& queries = doc->evaluations().back().queries;
    QCOMPARE(queries.size(), size_t(24));
    // The plot speaks in stops too.
    QCOMPARE(panel->stopsSeries()->count(), 1);
    QCOMPARE(panel->stopsSeries()->at(0).y(), doc->evaluations().back().stops.rms);
    // The evaluation turns the error points on; each query is drawn where it is.
    QVERIFY(vp->overlay(Viewport::Overlay::ErrorPoints));
    QVERIFY(reason->text().isEmpty());
    const auto pixels = vp->errorPointPixels();
    QCOMPARE(pixels.size(), queries.size());
    for (size_t i = 0; i < queries.size(); ++i)
      if (pixels[i]) QCOMPARE(*pixels[i], *vp->project(queries[i].point));
    bool hasLegend = false;
    for (const auto& l : vp->legends())
      hasLegend |= l.title.startsWith("Evaluation errors") && l.unit == "stops";
    QVERIFY(hasLegend);

    if (QGuiApplication::platformName() != QLatin1String("offscreen")) {
      // Drawn (under Xvfb, ui.test_error_points_shown): the dot of each query on screen has the
      // colour of its error on the legend's ramp.
      w.resize(1400, 900);
      w.show();
      QVERIFY(QTest::qWaitForWindowExposed(&w));
      vp->frameAll();
      const QImage image = vp->grabFramebuffer();
      const double scale = double(image.width()) / std::max(vp->width(), 1);
      const auto shown = vp->errorPointPixels();
      int checked = 0, matching = 0;
      for (size_t i = 0; i < queries.size(); ++i) {
        if (!shown[i]) continue;
        const QPoint px((*shown[i] * scale).toPoint());
        if (!image.rect().contains(px)) continue;
        bool covered = false;  // a dot drawn over this one hides its colour
        for (size_t j = 0; j < queries.size(); ++j)
          covered |= j != i && shown[j] && queries[j].stops >= queries[i].stops &&
                     QLineF(*shown[i], *shown[j]).length() < 10;
        if (covered) continue;
        ++checked;
        const QColor got = image.pixelColor(px);
        const QColor want = QColor::fromRgb(
            Viewport::legendColor(queries[i].stops, 1.0));  // the ramp, red from 1 stop
        matching += std::abs(got.red() - want.red()) + std::abs(got.green() - want.green()) +
                        std::abs(got.blue() - want.blue()) <
                    40;
      }
      QVERIFY2(checked >= 5 && matching >= 0.8 * checked,
               qPrintable(QStringLiteral("%1 of %2").arg(matching).arg(checked)));
      const QByteArray artifacts = qgetenv("PS_ARTIFACTS");
      if (!artifacts.isEmpty()) {
        QDir().mkpath(QString::fromLocal8Bit(artifacts));
        image.save(QString::fromLocal8Bit(artifacts) + "/editor-two-rooms-error-points.png");
      }
    }

    // The list: worst first, each row naming its query.
    QTableWidget* worst = panel->worstTable();
    QCOMPARE(worst->rowCount(), 24);
    double previous = 1e300;
    for (int row = 0; row < worst->rowCount(); ++row) {
      const int index = worst->item(row, 0)->data(Qt::UserRole).toInt();
      QVERIFY(index >= 0 && index < 24);
      QVERIFY(queries[size_t(index)].stops <= previous);
      previous = queries[size_t(index)].stops;
    }
    // Picking the worst frames it.
    const int worstIndex = worst->item(0, 0)->data(Qt::UserRole).toInt();
    const Vec3 at = queries[size_t(worstIndex)].point;
    QVERIFY(!panel->addProbeButton()->isEnabled());
    worst->setCurrentCell(0, 0);
    const std::optional<QPointF> framed = vp->project(at);
    QVERIFY(framed);
    const QPointF centre(vp->width() / 2.0, vp->height() / 2.0);
    QVERIFY2(QLineF(*framed, centre).length() < 0.05 * vp->width(),
             qPrintable(QStringLiteral("%1, %2 of %3 x %4")
                            .arg(framed->x())
                            .arg(framed->y())
                            .arg(vp->width())
                            .arg(vp->height())));
    // "Add a probe here": one click, one undo step, an accepted probe there, selected.
    const size_t before = doc->probes().size();
    const int steps = doc->undoStack()->count();
    QVERIFY(panel->addProbeButton()->isEnabled());
    panel->addProbeButton()->click();
    QCOMPARE(doc->probes().size(), before + 1);
    QCOMPARE(doc->undoStack()->count(), steps + 1);
    const Probe& added = doc->probes().back();
    QCOMPARE(added.position, at);
    QCOMPARE(added.state, ProbeState::Accepted);
    QVERIFY(added.sh);
    QCOMPARE(vp->selection(), QSet<quint64>{quint64(added.id)});
    doc->undoStack()->undo();
    QCOMPARE(doc->probes().size(), before);
  }
};

QTEST_MAIN(TestArtistLoop)
#include "test_artist_loop.moc"
