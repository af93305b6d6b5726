#include "ui/Document.h"

#include <QtConcurrent/QtConcurrentRun>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>

#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/placement/Uniform.h"
#include "core/trace/Tracer.h"
#include "ui/ProbeCommands.h"

namespace ps::ui {

namespace {
std::filesystem::path toPath(const QString& s) {
  return std::filesystem::path(s.toStdString());
}

/// A scene and its tracer, kept alive together (the tracer references the scene).
struct LoadedScene {
  std::shared_ptr<const Scene> scene;
  std::shared_ptr<const Tracer> tracer;
  uint64_t hash = 0;  ///< sceneContentHash() of the file
};

LoadedScene load(const QString& path) {
  auto scene = std::make_shared<const Scene>(loadScene(toPath(path)));
  // The deleter keeps the scene alive for as long as the tracer lives.
  auto tracer =
      std::shared_ptr<const Tracer>(new Tracer(*scene), [scene](const Tracer* t) { delete t; });
  return {scene, tracer, sceneContentHash(toPath(path))};
}
}  // namespace

struct Document::Proposal {
  int generation = 0;
  double spacingMeters = 0;
  std::vector<Probe> probes;
  QString error;  ///< capture or placement failure; probes may still be usable
};

Document::Document(QObject* parent) : QObject(parent) {
  connect(&undo_, &QUndoStack::cleanChanged, this,
          [this](bool clean) { emit modifiedChanged(!clean); });
}

Document::~Document() {
  cancelJob();
}

void Document::cancelJob() {
  if (jobCancel_) jobCancel_->store(true);
  if (watcher_ && watcher_->isRunning()) watcher_->waitForFinished();
}

void Document::replace(std::shared_ptr<const Scene> scene, std::shared_ptr<const Tracer> tracer,
                       ProbeSet set, const QString& scenePath, const QString& setPath) {
  cancelJob();
  ++generation_;
  const bool sceneChanges = scene != scene_;
  emit probesAboutToBeReset();
  scene_ = std::move(scene);
  tracer_ = std::move(tracer);
  set_ = std::move(set);
  scenePath_ = scenePath;
  setPath_ = setPath;
  undo_.clear();
  undo_.setClean();
  emit probesReset();
  if (sceneChanges) emit sceneChanged();
  emit pathsChanged();
  emit modifiedChanged(false);
  if (busy_) {
    busy_ = false;
    emit jobFinished(QString());
  }
}

void Document::openScene(const QString& path) {
  LoadedScene loaded = load(path);  // throws; nothing changed yet
  ProbeSet set;
  set.scenePath = path.toStdString();
  set.sceneHash = loaded.hash;
  replace(loaded.scene, loaded.tracer, std::move(set), path, QString());
  sceneHash_ = loaded.hash;
  if (autoPropose_) proposeCandidates();
}

void Document::openProbeSet(const QString& path, bool keepScene) {
  ProbeSet set = loadProbeSet(toPath(path));  // throws; nothing changed yet
  if (keepScene && scene_) {
    set.scenePath = scenePath_.toStdString();
    replace(scene_, tracer_, std::move(set), scenePath_, path);
    return;
  }
  if (set.scenePath.empty())
    throw FileError(path.toStdString(), "scene", "the probe set names no scene");
  const QString scenePath = QString::fromStdString(set.scenePath);
  std::error_code ec;  // a missing file is simply "not the same scene"
  if (scene_ && std::filesystem::equivalent(toPath(scenePath), toPath(scenePath_), ec)) {
    replace(scene_, tracer_, std::move(set), scenePath_, path);
    return;
  }
  LoadedScene loaded = load(scenePath);  // throws; nothing changed yet
  replace(loaded.scene, loaded.tracer, std::move(set), scenePath, path);
  sceneHash_ = loaded.hash;
}

std::string Document::staleCapturesText() const {
  if (sceneHash_ == 0) return "";
  return describeStaleCaptures(set_, staleCaptures(set_, sceneHash_));
}

void Document::saveProbeSet(const QString& path) {
  ProbeSet set = set_;
  if (sceneHash_ != 0) set.sceneHash = sceneHash_;
  if (!scenePath_.isEmpty())
    set.scenePath = std::filesystem::absolute(toPath(scenePath_)).lexically_normal().string();
  ps::saveProbeSet(set, toPath(path));  // throws; the document is unchanged then
  setPath_ = path;
  undo_.setClean();
  emit pathsChanged();
}

void Document::setScene(Scene scene) {
  auto s = std::make_shared<const Scene>(std::move(scene));
  ProbeSet set;
  set.scenePath = s->sourcePath;
  replace(s, nullptr, std::move(set), QString::fromStdString(s->sourcePath), QString());
  sceneHash_ = 0;  // built in memory: no file to hash
}

int Document::indexOf(uint64_t id) const {
  const auto& ps = set_.probes;
  for (size_t i = 0; i < ps.size(); ++i)
    if (ps[i].id == id) return int(i);
  return -1;
}

const Probe* Document::probe(uint64_t id) const {
  const int i = indexOf(id);
  return i < 0 ? nullptr : &set_.probes[size_t(i)];
}

void Document::setStates(const std::vector<uint64_t>& ids, ProbeState state) {
  if (ids.empty()) return;
  undo_.push(new SetStateCommand(this, ids, state));
}

void Document::deleteProbes(const std::vector<uint64_t>& ids) {
  if (ids.empty()) return;
  undo_.push(new DeleteProbesCommand(this, ids));
}

std::vector<uint64_t> Document::addProbes(std::vector<Probe> probes, const QString& text) {
  std::vector<uint64_t> ids;
  for (Probe& p : probes) {
    p.id = allocateId();
    ids.push_back(p.id);
  }
  if (!probes.empty()) undo_.push(new AddProbesCommand(this, std::move(probes), text));
  return ids;
}

void Document::moveProbe(uint64_t id, Vec3 position) {
  const Probe* p = probe(id);
  if (!p) return;
  undo_.push(new MoveProbeCommand(this, id, p->position, position));
}

void Document::insertProbeRaw(int row, const Probe& p) {
  row = std::clamp(row, 0, int(set_.probes.size()));
  emit probeAboutToBeInserted(row);
  set_.probes.insert(set_.probes.begin() + row, p);
  set_.nextId = std::max(set_.nextId, p.id + 1);
  emit probeInserted(row);
}

void Document::removeProbeRaw(uint64_t id) {
  const int row = indexOf(id);
  if (row < 0) return;
  emit probeAboutToBeRemoved(row);
  set_.probes.erase(set_.probes.begin() + row);
  emit probeRemoved(row);
}

void Document::setProbeStateRaw(uint64_t id, ProbeState s) {
  const int row = indexOf(id);
  if (row < 0) return;
  set_.probes[size_t(row)].state = s;
  emit probeChanged(row);
}

void Document::setProbePositionRaw(uint64_t id, Vec3 p) {
  const int row = indexOf(id);
  if (row < 0) return;
  set_.probes[size_t(row)].position = p;
  // The captured SH belonged to the old position.
  set_.probes[size_t(row)].sh.reset();
  emit probeChanged(row);
}

void Document::proposeCandidates() {
  if (!tracer_ || busy_) return;
  busy_ = true;
  const int generation = generation_;
  const ProposalSettings settings = proposal_;
  const LightingRig rig = set_.rig;
  std::shared_ptr<const Tracer> tracer = tracer_;
  const uint64_t sceneHash = sceneHash_;
  jobCancel_ = std::make_shared<std::atomic<bool>>(false);
  auto cancel = jobCancel_;
  // Progress arrives from worker threads; it is forwarded (throttled) to the GUI thread. The
  // job stops at its next progress report once cancelJob() set the flag; the document waits
  // for it before it changes or dies, so `this` outlives the job.
  auto lastPercent = std::make_shared<std::atomic<int>>(-1);
  auto report = [this, generation, lastPercent, cancel](const QString& what, double fraction) {
    if (cancel->load()) return false;
    const int percent = int(fraction * 100);
    if (lastPercent->exchange(percent) != percent)
      QMetaObject::invokeMethod(
          this,
          [this, what, fraction, generation] {
            if (generation_ == generation) emit jobProgress(what, fraction);
          },
          Qt::QueuedConnection);
    return true;
  };

  emit jobProgress(tr("Proposing probes…"), 0.0);
  if (!watcher_) {
    watcher_ = new QFutureWatcher<std::shared_ptr<Proposal>>(this);
    connect(watcher_, &QFutureWatcherBase::finished, this, &Document::onProposalDone);
  }
  watcher_->setFuture(QtConcurrent::run([=]() -> std::shared_ptr<Proposal> {
    auto result = std::make_shared<Proposal>();
    result->generation = generation;
    try {
      const Bounds3 b = tracer->scene().bounds;
      const Vec3 e = b.extent();
      const double floor = std::max(b.diagonal() * 0.05, 1e-6);
      const double volume = std::max(e.x, floor) * std::max(e.y, floor) * std::max(e.z, floor);
      double spacing = std::cbrt(volume / settings.targetProbeCount);
      std::vector<Vec3> points;
      // Interior walls and validity culling remove points: adjust the spacing so the count
      // lands in roughly [30, 150].
      for (int attempt = 0; attempt < 4; ++attempt) {
        UniformSettings us;
        us.spacingMeters = spacing;
        points = placeUniform(*tracer, us, [&](double f) {
          return report(tr("Placing probes…"), 0.4 * (attempt + f) / 4.0);
        });
        const double n = double(points.size());
        if (n >= 30 && n <= 150) break;
        const double ratio = std::cbrt(std::max(n, 1.0) / settings.targetProbeCount);
        spacing *= std::clamp(ratio, 0.5, 2.0);
      }
      result->spacingMeters = spacing;
      for (const Vec3& p : points) {
        Probe probe;
        probe.position = p;
        probe.method = "uniform";
        result->probes.push_back(probe);
      }
      try {
        CaptureSettings cs;
        cs.samplesPerProbe = settings.samplesPerProbe;
        const auto captures = captureProbes(*tracer, rig, points, cs, [&](double f) {
          return report(tr("Capturing SH…"), 0.4 + 0.6 * f);
        });
        for (size_t i = 0; i < captures.size() && i < result->probes.size(); ++i) {
          result->probes[i].sh = captures[i].sh;
          result->probes[i].captureSceneHash = sceneHash;
        }
      } catch (const Cancelled&) {
        throw;
      } catch (const Error& err) {
        result->error = tr("Capture failed: %1").arg(QString::fromStdString(err.what()));
      }
    } catch (const Cancelled&) {
      result->error = QStringLiteral("cancelled");
      result->probes.clear();
    } catch (const std::exception& e) {
      result->error = tr("Placement failed: %1").arg(QString::fromStdString(e.what()));
      result->probes.clear();
    }
    return result;
  }));
}

void Document::onProposalDone() {
  std::shared_ptr<Proposal> r = watcher_->result();
  if (!r || r->generation != generation_) return;  // stale: the document moved on
  busy_ = false;
  set_.placement.method = "uniform";
  set_.placement.spacingMeters = r->spacingMeters;
  const QString text = tr("Propose %1 candidates").arg(r->probes.size());
  if (!r->probes.empty()) addProbes(std::move(r->probes), text);
  emit jobProgress(QString(), 1.0);
  emit jobFinished(r->error);
}

}  // namespace ps::ui
