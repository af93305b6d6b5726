// probestudio-editor [SCENE | SET.json] [--probes SET.json] [--screenshot OUT.png] [--size WxH]
//                    [--overlays glyphs,slice,tets,test-object,domain,preview,flat] [--select ID]
//                    [--time-jobs place,bake,eval [--progress-log]]
// The Qt editor. In --screenshot mode it loads, waits for the background proposal (or the given
// probe set), renders one frame of the viewport at --size, writes OUT.png and OUT.png.json (the
// projected pixel position of every probe, the camera, the cut-away height) and exits: 0 on
// success, 1 with a one-line error. With --time-jobs it runs those jobs as their buttons do and
// prints the wall time of each (with --progress-log, also every progress report the window got).
#include <QAction>
#include <QApplication>
#include <QCommandLineParser>
#include <QElapsedTimer>
#include <QFile>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QMessageBox>
#include <QRegularExpression>
#include <QStandardPaths>
#include <QTimer>
#include <cstdio>
#include <exception>
#include <memory>

#include "core/common/Error.h"
#include "core/scene/SceneUnits.h"
#include "ui/Document.h"
#include "ui/EvaluationPanel.h"
#include "ui/LightingField.h"
#include "ui/MainWindow.h"
#include "ui/PlacementPanel.h"
#include "ui/Viewport.h"

namespace {

void fail(const QString& message) {
  std::fprintf(stderr, "probestudio-editor: %s\n", qPrintable(message));
  std::fflush(stderr);
}

QJsonArray rgb(const QColor& c) {
  return QJsonArray{c.red(), c.green(), c.blue()};
}

/// Renders the viewport, writes the PNG and its JSON sidecar. Returns false on failure.
bool writeScreenshot(ps::ui::MainWindow& w, const QString& out, int timeFrames) {
  ps::ui::Viewport* vp = w.viewport();
  vp->frameAll();
  // The overlays' data and the scene's own light, now (the window computes them in the
  // background).
  (void)vp->previewVolume();
  (void)vp->sceneLightGrid();
  const QImage image = vp->grabFramebuffer();
  if (image.isNull() || !image.save(out)) {
    fail(QStringLiteral("%1: cannot render or write the screenshot").arg(out));
    return false;
  }
  if (timeFrames > 0) {
    QElapsedTimer timer;
    timer.start();
    for (int i = 0; i < timeFrames; ++i) (void)vp->grabFramebuffer();
    std::fprintf(stderr, "viewport frame time: %.1f ms (mean of %d frames incl. readback)\n",
                 double(timer.nsecsElapsed()) / 1e6 / timeFrames, timeFrames);
  }
  const double scale = double(image.width()) / std::max(vp->width(), 1);
  QJsonArray probes;
  const QVector3D right = vp->camera().right();
  for (const ps::Probe& p : w.document()->probes()) {
    QJsonObject o;
    o["id"] = qint64(p.id);
    o["state"] = QString::fromLatin1(ps::toString(p.state));
    const auto px = vp->project(p.position);
    const float r = vp->drawnRadius(p);
    const auto edge =
        vp->project(p.position + ps::Vec3(right.x() * r, right.y() * r, right.z() * r));
    o["x"] = px ? px->x() * scale : -1.0;
    o["y"] = px ? px->y() * scale : -1.0;
    o["radiusPx"] = px && edge ? QLineF(*px, *edge).length() * scale : 0.0;
    o["onScreen"] = bool(px) && vp->onScreen(*px);
    // Mean incident radiance (luminance of the L00 term), for checks and for debugging.
    if (p.sh) o["meanRadiance"] = ps::luminance(p.sh->c[0]) * 0.282095;
    probes.append(o);
  }
  QJsonObject root;
  root["image"] = QJsonObject{{"width", image.width()}, {"height", image.height()}};
  root["background"] = QJsonObject{{"top", rgb(ps::ui::Viewport::backgroundTop())},
                                   {"bottom", rgb(ps::ui::Viewport::backgroundBottom())}};
  root["probesVisible"] = vp->probesVisible();
  root["modified"] = w.document()->isModified();
  root["probeSetPath"] = w.document()->probeSetPath();
  root["probes"] = probes;
  // The camera: world to clip space, row-major. Image pixel = ((ndc.x + 1) / 2 * width,
  // (1 - ndc.y) / 2 * height), as for the projected positions above.
  const QMatrix4x4 viewProj = vp->viewProjection();
  QJsonArray vpRows;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) vpRows.append(double(viewProj(r, c)));
  root["viewProjection"] = vpRows;
  // Geometry above this height (world y) is cut away; null when the whole scene is drawn.
  root["cutHeight"] = vp->cutaway() ? QJsonValue(double(vp->cutHeight())) : QJsonValue();
  // Overlays: where the checker should find them.
  auto px = [&](ps::Vec3 world) -> QJsonValue {
    const auto p = vp->project(world);
    if (!p) return QJsonValue();
    return QJsonArray{p->x() * scale, p->y() * scale};
  };
  using O = ps::ui::Viewport::Overlay;
  if (vp->overlay(O::Glyphs)) {
    QJsonArray glyphs;
    for (const auto& g : vp->glyphSamples()) {
      if (ps::length(g.f) <= 0) continue;
      // Visible part only: below the cut-away height.
      if (vp->cutaway() && g.centre.y > vp->cutHeight()) continue;
      glyphs.append(QJsonObject{{"centre", px(g.centre)}});
    }
    root["glyphs"] = glyphs;
  }
  if (vp->overlay(O::Slice) && vp->previewVolume()) {
    QJsonArray corners;
    for (const ps::Vec3& c : vp->sliceCorners()) corners.append(px(c));
    root["slice"] = QJsonObject{{"corners", corners}, {"axis", vp->sliceAxis()}};
  }
  if (vp->overlay(O::TestObject) && vp->previewVolume())
    root["testObject"] =
        QJsonObject{{"centre", px(vp->testObjectPosition())}, {"tet", int(vp->testObjectTet())}};
  // Importance volumes: each box's weight and its twelve edges projected (null when behind).
  QJsonArray volumes;
  for (const ps::ImportanceVolume& v : w.document()->probeSet().importanceVolumes) {
    QJsonArray edges;
    auto corner = [&](int i) {
      return ps::Vec3(i & 1 ? v.hi.x : v.lo.x, i & 2 ? v.hi.y : v.lo.y, i & 4 ? v.hi.z : v.lo.z);
    };
    for (int i = 0; i < 8; ++i)
      for (int bit : {1, 2, 4})
        if (!(i & bit)) edges.append(QJsonArray{px(corner(i)), px(corner(i | bit))});
    volumes.append(QJsonObject{{"weight", v.weight}, {"edges", edges}});
  }
  root["importanceVolumes"] = volumes;
  // The overlays' legends (image pixels): drawn over the background on purpose.
  QJsonArray legends;
  for (const QRect& r : vp->legendRects())
    legends.append(QJsonArray{r.x() * scale, r.y() * scale, r.width() * scale, r.height() * scale});
  root["legends"] = legends;
  QFile f(out + ".json");
  if (!f.open(QIODevice::WriteOnly) || f.write(QJsonDocument(root).toJson()) < 0) {
    fail(QStringLiteral("%1: cannot write").arg(out + ".json"));
    return false;
  }
  return true;
}

/// Runs the jobs of `jobs` (place, bake, eval) one after the other as the panels' buttons start
/// them, with the panels' settings, in the shown window, and prints each one's wall time (from
/// the click to the job's end reaching the window) to stdout. Quits the application when done:
/// 0 when every job succeeded, 1 otherwise. Each job starts once the editor is idle, as an
/// artist's click finds it: no job runs and the view computes nothing in the background. With
/// `logProgress`, every progress report that reaches the window is printed before the job's
/// time as `progress JOB SECONDS FRACTION`: seconds from the click, the job's overall fraction
/// in [0, 1] (what the status bar's bar and time left are computed from).
void timeJobs(QApplication& app, ps::ui::MainWindow& w, QStringList jobs, bool logProgress) {
  ps::ui::Document* doc = w.document();
  if (doc->isBusy() || doc->isCapturingLive() || !w.viewport()->isSettled()) {
    constexpr int kPollMs = 100;
    QTimer::singleShot(kPollMs, &w,
                       [&app, &w, jobs, logProgress] { timeJobs(app, w, jobs, logProgress); });
    return;
  }
  if (jobs.isEmpty()) {
    app.exit(0);
    return;
  }
  const QString job = jobs.takeFirst();
  auto timer = std::make_shared<QElapsedTimer>();
  timer->start();
  QMetaObject::Connection progressLog;
  if (logProgress)
    progressLog = QObject::connect(doc, &ps::ui::Document::jobProgress, &w,
                                   [job, timer](const QString&, double fraction) {
                                     std::printf("progress %s %.3f %.4f\n", qPrintable(job),
                                                 double(timer->nsecsElapsed()) * 1e-9, fraction);
                                   });
  bool started = false;
  if (job == QLatin1String("place"))
    started = w.placementPanel()->run();
  else if (job == QLatin1String("bake"))
    started = w.placementPanel()->bake();
  else if (job == QLatin1String("eval"))
    started = w.evaluationPanel()->evaluate();
  if (!started) {
    fail(QStringLiteral("--time-jobs: %1 did not start: %2").arg(job, w.lastError()));
    app.exit(1);
    return;
  }
  QObject::connect(
      doc, &ps::ui::Document::jobFinished, &w,
      [&app, &w, jobs, job, timer, logProgress, progressLog](const QString& error) {
        QObject::disconnect(progressLog);
        std::printf("editor %s: %.2f s%s\n", qPrintable(job), double(timer->nsecsElapsed()) * 1e-9,
                    qPrintable(error.isEmpty() ? QString() : QStringLiteral(" (") + error + ")"));
        std::fflush(stdout);
        if (!error.isEmpty()) {
          app.exit(1);
          return;
        }
        QTimer::singleShot(0, &w,
                           [&app, &w, jobs, logProgress] { timeJobs(app, w, jobs, logProgress); });
      },
      Qt::SingleShotConnection);
}

}  // namespace

int main(int argc, char** argv) {
  QSurfaceFormat::setDefaultFormat(ps::ui::Viewport::surfaceFormat());
  QApplication app(argc, argv);
  QApplication::setApplicationName("ProbeStudio");
  QApplication::setOrganizationName("ProbeStudio");

  QCommandLineParser parser;
  parser.setApplicationDescription("ProbeStudio light-probe editor");
  parser.addHelpOption();
  parser.addPositionalArgument(
      "file", "glTF scene (.gltf, .glb), or a probe set (.json) to open with its scene",
      "[SCENE | SET.json]");
  const QCommandLineOption probesOpt("probes", "Probe set to open.", "SET.json");
  const QCommandLineOption unitsOpt(
      "units",
      "The scene's length unit: m (default), cm, mm or metres per unit; saved with the probe "
      "set. A probe set opens its scene in its own unit.",
      "UNIT");
  const QCommandLineOption shotOpt(
      "screenshot", "Render the viewport to OUT.png (+ OUT.png.json) and exit.", "OUT.png");
  const QCommandLineOption sizeOpt("size", "Viewport size for --screenshot.", "WxH", "1024x768");
  const QCommandLineOption noProbesOpt("no-probes", "Hide the probes (screenshot tests).");
  const QCommandLineOption timeOpt("time-frames", "After the screenshot, time N frames.", "N", "0");
  const QCommandLineOption overlaysOpt(
      "overlays",
      "Overlays to show: any of glyphs, slice, tets, test-object, domain, preview (probe "
      "lighting, on by default), flat (flat colours instead of light).",
      "LIST");
  const QCommandLineOption selectOpt("select", "Select the probe with this id.", "ID");
  const QCommandLineOption saveOpt(
      "save-probes", "With --screenshot: also write the probe set (with its SH) here.", "SET.json");
  const QCommandLineOption recoveryDirOpt(
      "recovery-dir", "Folder of the autosave recovery files (default: the app's data folder).",
      "DIR");
  const QCommandLineOption autosaveOpt("autosave-ms", "Autosave interval in milliseconds.", "MS",
                                       "30000");
  const QCommandLineOption windowShotOpt(
      "window-screenshot", "With --screenshot: also write the whole window to this PNG.",
      "WIN.png");
  // Removed: parsed only to be refused with what replaced it.
  QCommandLineOption noCutsOpt("no-leak-cuts", "Removed (the preview has no leak cuts).");
  noCutsOpt.setFlags(QCommandLineOption::HiddenFromHelp);
  const QCommandLineOption recoverOpt(
      "recover", "With --screenshot: recover the newest crashed session's work first.");
  const QCommandLineOption timeJobsOpt(
      "time-jobs",
      "Run these jobs one after the other as their buttons do, with the panels' settings, print "
      "each one's wall time and exit: any of place, bake, eval (e.g. bake,eval).",
      "LIST");
  const QCommandLineOption progressLogOpt(
      "progress-log",
      "With --time-jobs: also print every progress report the window gets, as 'progress JOB "
      "SECONDS FRACTION' (seconds from the click, the job's overall fraction).");
  const QCommandLineOption acceptOpt(
      "accept-proposal",
      "Accept the proposed candidates once they are there (one undo step, an unsaved edit): "
      "a scripted session's work, for the recovery test.");
  parser.addOptions({acceptOpt, unitsOpt, probesOpt, shotOpt, sizeOpt, noProbesOpt, timeOpt,
                     overlaysOpt, selectOpt, saveOpt, recoveryDirOpt, autosaveOpt, recoverOpt,
                     windowShotOpt, noCutsOpt, timeJobsOpt, progressLogOpt});
  parser.process(app);

  const QString shot = parser.value(shotOpt);
  const bool screenshot = !shot.isEmpty();
  const QStringList positional = parser.positionalArguments();
  // The argument is a scene, or a probe set (.json) opened with its scene.
  const QString argument = positional.isEmpty() ? QString() : positional.first();
  const bool argumentIsSet = argument.endsWith(QLatin1String(".json"), Qt::CaseInsensitive);
  if (argumentIsSet && parser.isSet(probesOpt)) {
    fail(QStringLiteral("%1: a probe set as the argument and --probes %2: give one probe set")
             .arg(argument, parser.value(probesOpt)));
    return 1;
  }
  const QString scenePath = argumentIsSet ? QString() : argument;
  double metresPerUnit = 1.0;
  if (parser.isSet(unitsOpt)) {
    const std::optional<double> unit = ps::parseSceneUnit(parser.value(unitsOpt).toStdString());
    if (!unit) {
      fail(QStringLiteral("--units: %1, got \"%2\"")
               .arg(QString::fromLatin1(ps::kSceneUnitExpected), parser.value(unitsOpt)));
      return 1;
    }
    metresPerUnit = *unit;
  }
  const QString probesPath = argumentIsSet ? argument : parser.value(probesOpt);
  if (parser.isSet(noCutsOpt)) {
    fail(QStringLiteral(
        "--no-leak-cuts: removed; the preview has no leak cuts: the baked volume's visibility "
        "maps and their neighbour search keep light from crossing walls (docs/leaks.md)"));
    return 1;
  }

  const auto m = QRegularExpression("^(\\d+)x(\\d+)$").match(parser.value(sizeOpt));
  if (!m.hasMatch() || m.captured(1).toInt() < 16 || m.captured(2).toInt() < 16) {
    fail(QStringLiteral("--size: expected WxH (e.g. 1024x768), got '%1'")
             .arg(parser.value(sizeOpt)));
    return 1;
  }
  const QSize size(m.captured(1).toInt(), m.captured(2).toInt());

  try {
    ps::ui::MainWindow w;
    w.setPromptOnClose(!screenshot);
    w.setQuiet(screenshot);
    w.viewport()->setProbesVisible(!parser.isSet(noProbesOpt));
    for (const QString& o : parser.value(overlaysOpt).split(',', Qt::SkipEmptyParts)) {
      using O = ps::ui::Viewport::Overlay;
      if (o == "glyphs")
        w.viewport()->setOverlay(O::Glyphs, true);
      else if (o == "slice")
        w.viewport()->setOverlay(O::Slice, true);
      else if (o == "tets")
        w.viewport()->setOverlay(O::TetMesh, true);
      else if (o == "test-object")
        w.viewport()->setOverlay(O::TestObject, true);
      else if (o == "domain")
        w.viewport()->setOverlay(O::Domain, true);
      else if (o == "preview")
        w.viewport()->setPreviewLighting(true);
      else if (o == "flat")
        w.viewport()->setFlatShading(true);
      else {
        fail(QStringLiteral("--overlays: unknown overlay '%1' (expected glyphs, slice, tets, "
                            "test-object, domain, preview, flat)")
                 .arg(o));
        return 1;
      }
    }
    if (screenshot) w.viewport()->setFixedSize(size);
    ps::ui::Document* doc = w.document();
    doc->setAutoPropose(probesPath.isEmpty());

    bool ok = true;
    if (!scenePath.isEmpty()) ok = w.openScene(scenePath, metresPerUnit);
    if (ok && !probesPath.isEmpty()) {
      if (doc->hasScene()) {
        try {
          doc->openProbeSet(probesPath, /*keepScene=*/true);
        } catch (const ps::Error& e) {
          ok = false;
          if (screenshot)
            fail(QString::fromStdString(e.what()));
          else
            w.openProbeSet(probesPath);  // shows the error interactively
        }
      } else {
        ok = w.openProbeSet(probesPath);
      }
    }
    if (screenshot && !ok) {
      if (!w.lastError().isEmpty()) fail(w.lastError());
      return 1;
    }
    w.show();
    const QString recoveryDir =
        parser.isSet(recoveryDirOpt)
            ? parser.value(recoveryDirOpt)
            : QStandardPaths::writableLocation(QStandardPaths::AppLocalDataLocation) + "/recovery";
    const int autosaveMs = std::max(parser.value(autosaveOpt).toInt(), 50);
    if (parser.isSet(timeJobsOpt)) {
      const QStringList jobs = parser.value(timeJobsOpt).split(',', Qt::SkipEmptyParts);
      for (const QString& job : jobs)
        if (job != QLatin1String("place") && job != QLatin1String("bake") &&
            job != QLatin1String("eval")) {
          fail(QStringLiteral("--time-jobs: unknown job '%1' (expected place, bake, eval)")
                   .arg(job));
          return 1;
        }
      if (!ok) return 1;
      w.setPromptOnClose(false);
      w.setQuiet(true);
      const bool logProgress = parser.isSet(progressLogOpt);
      QTimer::singleShot(0, &w,
                         [&app, &w, jobs, logProgress] { timeJobs(app, w, jobs, logProgress); });
      return app.exec();
    }
    if (!screenshot) {
      if (parser.isSet(acceptOpt))
        QObject::connect(
            doc, &ps::ui::Document::jobFinished, &w,
            [doc] {
              std::vector<uint64_t> ids;
              for (const ps::Probe& p : doc->probes())
                if (p.state == ps::ProbeState::Candidate) ids.push_back(p.id);
              doc->setStates(ids, ps::ProbeState::Accepted);
            },
            Qt::SingleShotConnection);
      doc->setAutoPropose(true);
      // Autosave, and offer what a crashed session left (Autosave.h).
      w.startAutosave(recoveryDir, autosaveMs);
      QTimer::singleShot(0, &w, [&w] { w.offerRecovery(); });
      return app.exec();
    }
    if (parser.isSet(recoverOpt)) {
      w.startAutosave(recoveryDir, autosaveMs);
      if (!w.offerRecovery(QMessageBox::Yes)) {
        fail(QStringLiteral("--recover: nothing recovered from %1 %2")
                 .arg(recoveryDir, w.lastError()));
        return 1;
      }
    }
    if (!doc->hasScene()) {
      fail("--screenshot needs a scene or a probe set");
      return 1;
    }

    int result = 0;
    const int timeFrames = parser.value(timeOpt).toInt();
    auto take = [&] {
      // Let the window map and lay out before rendering.
      QTimer::singleShot(50, &app, [&] {
        if (parser.isSet(saveOpt)) {
          try {
            doc->writeCopy(parser.value(saveOpt));
          } catch (const ps::Error& e) {
            fail(QString::fromStdString(e.what()));
            app.exit(1);
            return;
          }
        }
        if (parser.isSet(selectOpt)) w.selectProbes({parser.value(selectOpt).toULongLong()});
        result = writeScreenshot(w, shot, timeFrames) ? 0 : 1;
        if (parser.isSet(windowShotOpt) && !w.grab().save(parser.value(windowShotOpt))) {
          fail(QStringLiteral("%1: cannot write").arg(parser.value(windowShotOpt)));
          result = 1;
        }
        app.exit(result);
      });
    };
    QObject::connect(doc, &ps::ui::Document::jobFinished, &app, [&](const QString& error) {
      if (!error.isEmpty()) fail(QStringLiteral("warning: ") + error);  // not fatal
      take();
    });
    if (!doc->isBusy()) take();
    const int rc = app.exec();
    return rc != 0 ? rc : result;
  } catch (const ps::Error& e) {
    fail(QString::fromStdString(e.what()));
    return 1;
  } catch (const std::exception& e) {
    fail(QStringLiteral("internal error: ") + e.what());
    return 1;
  }
}
