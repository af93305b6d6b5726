// The editor's file handling, headless (QT_QPA_PLATFORM=offscreen): recent files, the unsaved
// marker in the title, the prompt on close, autosave and recovery after a crash, atomic saves.
#include <QAbstractButton>
#include <QComboBox>
#include <QDir>
#include <QFile>
#include <QMessageBox>
#include <QSettings>
#include <QSignalSpy>
#include <QSpinBox>
#include <QTemporaryDir>
#include <QTimer>
#include <QtTest>

#include "core/io/ProbeSetFile.h"
#include "ui/Autosave.h"
#include "ui/Document.h"
#include "ui/MainWindow.h"
#include "ui/PlacementPanel.h"

using namespace ps;
using namespace ps::ui;

namespace {
const QString kScene = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");

std::vector<Probe> makeProbes(int n) {
  std::vector<Probe> out;
  for (int i = 0; i < n; ++i) {
    Probe p;
    p.position = Vec3(0.5 * i, 1.0, -0.25 * i);
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
}  // namespace

class TestFiles : public QObject {
  Q_OBJECT
  QTemporaryDir settingsDir_;

 private slots:
  void initTestCase() {
    if (!QFile::exists(kScene)) QSKIP("two-rooms.gltf not present");
    // Keep QSettings (recent files) out of the user's configuration.
    QSettings::setDefaultFormat(QSettings::IniFormat);
    QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settingsDir_.path());
    QCoreApplication::setOrganizationName("ProbeStudioTest");
    QCoreApplication::setApplicationName("test_files");
  }

  void recentFilesListOpensAndSavesNewestFirst() {
    QSettings().remove("recentFiles");
    QTemporaryDir dir;
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    w.document()->setAutoPropose(false);
    QVERIFY(w.recentFiles().isEmpty());
    QVERIFY(w.openScene(kScene));
    QCOMPARE(w.recentFiles(), QStringList{QFileInfo(kScene).absoluteFilePath()});
    w.document()->addProbes(makeProbes(2), "Add");
    const QString set = dir.filePath("a.probes.json");
    QVERIFY(w.saveAs(set));
    QCOMPARE(w.recentFiles().value(0), set);
    QCOMPARE(w.recentFiles().value(1), QFileInfo(kScene).absoluteFilePath());
    // A failed open is not recorded; reopening moves the file to the front without duplicates.
    QVERIFY(!w.openProbeSet(dir.filePath("missing.json")));
    QCOMPARE(w.recentFiles().size(), 2);
    QVERIFY(w.openRecent(QFileInfo(kScene).absoluteFilePath()));
    QCOMPARE(w.recentFiles().value(0), QFileInfo(kScene).absoluteFilePath());
    QCOMPARE(w.recentFiles().size(), 2);
    QVERIFY(w.openRecent(set));  // a .json opens as a probe set
    QCOMPARE(w.document()->probeSetPath(), set);
    QCOMPARE(w.document()->probes().size(), size_t(2));
    // At most kMaxRecent entries, shared by every window.
    for (int i = 0; i < MainWindow::kMaxRecent + 3; ++i)
      QVERIFY(w.saveAs(dir.filePath(QStringLiteral("s%1.json").arg(i))));
    MainWindow other;
    QCOMPARE(other.recentFiles().size(), MainWindow::kMaxRecent);
    QCOMPARE(other.recentFiles().value(0),
             dir.filePath(QStringLiteral("s%1.json").arg(MainWindow::kMaxRecent + 2)));
  }

  void titleMarksUnsavedChangesAndClosePrompts() {
    QTemporaryDir dir;
    MainWindow w;
    w.document()->setAutoPropose(false);
    w.setQuiet(true);
    QVERIFY(w.openScene(kScene));
    QVERIFY(w.windowTitle().contains("[*]"));
    QVERIFY(!w.isWindowModified());
    w.document()->addProbes(makeProbes(1), "Add");
    QVERIFY(w.isWindowModified());  // shown as an asterisk
    w.document()->undoStack()->undo();
    QVERIFY(!w.isWindowModified());
    w.document()->undoStack()->redo();

    // Close with unsaved changes: Cancel keeps the window open.
    QString text;
    answerNextMessageBox(QMessageBox::Cancel, &text);
    QVERIFY(!w.close());
    QVERIFY(text.contains("unsaved"));
    QVERIFY(w.isWindowModified());
    // Discard closes without saving.
    answerNextMessageBox(QMessageBox::Discard);
    QVERIFY(w.close());

    // Save from the prompt (the set has a file): the file is written, then the window closes.
    MainWindow w2;
    w2.document()->setAutoPropose(false);
    QVERIFY(w2.openScene(kScene));
    w2.document()->addProbes(makeProbes(3), "Add");
    const QString path = dir.filePath("prompted.json");
    QVERIFY(w2.saveAs(path));
    w2.document()->deleteProbes({w2.document()->probes()[0].id});
    answerNextMessageBox(QMessageBox::Save);
    QVERIFY(w2.close());
    QCOMPARE(loadProbeSet(path.toStdString()).probes.size(), size_t(2));
  }

  void reopenedSetShowsThePlacementItWasSavedWith() {
    // The placement panel's method and budget are saved with the set, whatever placement ran
    // last (here the opening proposal's uniform grid), and shown again when it is reopened.
    QTemporaryDir dir;
    const QString path = dir.filePath("placed.probes.json");
    {
      MainWindow w;
      w.setQuiet(true);
      w.setPromptOnClose(false);
      QSignalSpy proposed(w.document(), &Document::jobFinished);
      QVERIFY(w.openScene(kScene));
      QVERIFY(proposed.wait(120000));
      w.placementPanel()->methodBox()->setCurrentText("greedy");
      w.placementPanel()->budgetBox()->setValue(48);
      QVERIFY(w.saveAs(path));
    }
    const ProbeSet saved = loadProbeSet(path.toStdString());
    QCOMPARE(saved.placement.method, std::string("greedy"));
    QCOMPARE(saved.placement.budget, 48);
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    w.document()->setAutoPropose(false);
    w.placementPanel()->methodBox()->setCurrentText("uniform");
    w.placementPanel()->budgetBox()->setValue(0);
    QVERIFY(w.openPath(path));
    QCOMPARE(w.placementPanel()->methodBox()->currentText(), QStringLiteral("greedy"));
    QCOMPARE(w.placementPanel()->budgetBox()->value(), 48);
    QVERIFY(!w.isWindowModified());
  }

  void autosaveIsOfferedAfterACrash() {
    QTemporaryDir recovery, dir;
    const QString original = dir.filePath("work.json");
    std::vector<Vec3> positions;
    {
      // The session that "crashes".
      MainWindow w;
      w.setQuiet(true);
      w.setPromptOnClose(false);
      w.document()->setAutoPropose(false);
      w.startAutosave(recovery.path(), 50);
      QVERIFY(w.openScene(kScene));
      w.document()->addProbes(makeProbes(4), "Add");
      QVERIFY(w.saveAs(original));
      QVERIFY(!QFile::exists(w.autosave()->recoveryPath()));  // clean: nothing to recover
      w.document()->setStates({w.document()->probes()[1].id}, ProbeState::Accepted);
      w.document()->moveProbe(w.document()->probes()[2].id, Vec3(3, 2, 1));
      // The timer autosaves.
      QTRY_VERIFY_WITH_TIMEOUT(QFile::exists(w.autosave()->recoveryPath()), 5000);
      for (const Probe& p : w.document()->probes()) positions.push_back(p.position);
      // While that session runs, its file is no orphan.
      QVERIFY(Autosave::findOrphans(recovery.path()).empty());
      w.autosave()->abandon();  // the process dies here: lock gone, files stay
    }
    const auto orphans = Autosave::findOrphans(recovery.path());
    QCOMPARE(orphans.size(), size_t(1));
    QCOMPARE(orphans[0].originalSetPath, original);

    // "Not now" keeps the files for a later start.
    MainWindow later;
    later.setQuiet(true);
    later.setPromptOnClose(false);
    later.document()->setAutoPropose(false);
    later.startAutosave(recovery.path());
    QVERIFY(!later.offerRecovery(QMessageBox::Ignore));
    QCOMPARE(Autosave::findOrphans(recovery.path()).size(), size_t(1));
    // The dialog path: its text names the file; Recover restores the work.
    QString text;
    answerNextMessageBox(QMessageBox::Yes, &text);
    QVERIFY(later.offerRecovery());
    QVERIFY(text.contains("work.json"));
    Document* doc = later.document();
    QCOMPARE(doc->probes().size(), size_t(4));
    for (size_t i = 0; i < positions.size(); ++i) QCOMPARE(doc->probes()[i].position, positions[i]);
    QCOMPARE(doc->probes()[1].state, ProbeState::Accepted);
    QCOMPARE(doc->probeSetPath(), original);
    QVERIFY(doc->isModified());  // the recovered edits are not saved to work.json yet
    QVERIFY(later.isWindowModified());
    QVERIFY(Autosave::findOrphans(recovery.path()).empty());
    // The original file still holds the last explicit save.
    QCOMPARE(loadProbeSet(original.toStdString()).probes[1].state, ProbeState::Candidate);
    // Saving makes it clean and removes this session's recovery copy.
    QVERIFY(later.save());
    QVERIFY(!QFile::exists(later.autosave()->recoveryPath()));
    QCOMPARE(loadProbeSet(original.toStdString()).probes[1].state, ProbeState::Accepted);
  }

  void discardedAndCleanSessionsLeaveNothing() {
    QTemporaryDir recovery;
    QString path;
    {
      MainWindow w;
      w.setPromptOnClose(false);
      w.document()->setAutoPropose(false);
      w.startAutosave(recovery.path(), 60000);
      QVERIFY(w.openScene(kScene));
      w.document()->addProbes(makeProbes(2), "Add");
      QVERIFY(w.autosave()->saveNow());
      path = w.autosave()->recoveryPath();
      QVERIFY(QFile::exists(path));
    }  // a normal end
    QVERIFY(!QFile::exists(path));
    QVERIFY(Autosave::findOrphans(recovery.path()).empty());

    {
      MainWindow w;
      w.document()->setAutoPropose(false);
      w.startAutosave(recovery.path(), 60000);
      QVERIFY(w.openScene(kScene));
      w.document()->addProbes(makeProbes(2), "Add");
      QVERIFY(w.autosave()->saveNow());
      w.autosave()->abandon();
    }
    QCOMPARE(Autosave::findOrphans(recovery.path()).size(), size_t(1));
    MainWindow w;
    w.startAutosave(recovery.path());
    QVERIFY(!w.offerRecovery(QMessageBox::Discard));
    QVERIFY(Autosave::findOrphans(recovery.path()).empty());
    QVERIFY(QDir(recovery.path()).entryList({"*.probes.json"}, QDir::Files).isEmpty());
  }

  void savesAreAtomicAndFailedLoadsKeepTheDocument() {
    QTemporaryDir dir;
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    w.document()->setAutoPropose(false);
    QVERIFY(w.openScene(kScene));
    w.document()->addProbes(makeProbes(3), "Add");
    const QString path = dir.filePath("set.json");
    QVERIFY(w.saveAs(path));
    const QByteArray first = [&] {
      QFile f(path);
      return f.open(QIODevice::ReadOnly) ? f.readAll() : QByteArray();
    }();
    // A save that cannot complete (its temp file cannot be renamed over a folder) leaves the old
    // file as it was and no temp file behind, and the document stays modified.
    w.document()->addProbes(makeProbes(1), "Add");
    QDir(dir.path()).mkdir("blocked.json");
    QVERIFY(!w.saveAs(dir.filePath("blocked.json")));
    QVERIFY(w.lastError().contains("blocked.json"));
    QVERIFY(w.isWindowModified());
    QCOMPARE(w.document()->probeSetPath(), path);
    QVERIFY(w.save());
    QFile f(path);
    QVERIFY(f.open(QIODevice::ReadOnly));
    QVERIFY(f.readAll() != first);
    QCOMPARE(loadProbeSet(path.toStdString()).probes.size(), size_t(4));
    const QStringList left =
        QDir(dir.path()).entryList(QDir::Files | QDir::Hidden | QDir::NoDotAndDotDot);
    QCOMPARE(left, QStringList{"set.json"});

    // A truncated file fails to load with its reason and leaves the document as it was.
    const QString bad = dir.filePath("truncated.json");
    {
      QFile t(bad);
      QVERIFY(t.open(QIODevice::WriteOnly));
      t.write(first.left(first.size() / 2));
    }
    const size_t before = w.document()->probes().size();
    QVERIFY(!w.openProbeSet(bad));
    QVERIFY(w.lastError().contains("truncated.json"));
    QVERIFY(w.lastError().contains("JSON"));
    QCOMPARE(w.document()->probes().size(), before);
    QCOMPARE(w.document()->probeSetPath(), path);
  }
};

QTEST_MAIN(TestFiles)
#include "test_files.moc"
