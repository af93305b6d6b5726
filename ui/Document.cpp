#include "ui/Document.h"

#include <QDateTime>
#include <QElapsedTimer>
#include <QFileInfo>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QStandardPaths>
#include <QtConcurrent/QtConcurrentRun>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <tuple>
#include <unordered_set>

#include "core/bake/Bake.h"
#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/eval/Evaluate.h"
#include "core/eval/ReferenceCache.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/io/VolumeFile.h"
#include "core/placement/Place.h"
#include "core/scene/SceneUnits.h"
#include "core/trace/Tracer.h"
#include "ui/LightingField.h"
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

LoadedScene load(const QString& path, double metresPerUnit) {
  auto scene = std::make_shared<const Scene>(loadScene(toPath(path), metresPerUnit));
  // The deleter keeps the scene alive for as long as the tracer lives.
  auto tracer =
      std::shared_ptr<const Tracer>(new Tracer(*scene), [scene](const Tracer* t) { delete t; });
  return {scene, tracer, sceneContentHash(toPath(path), metresPerUnit)};
}

/// The same lights where they shine: type, position, direction and intensity.
bool sameLights(const std::vector<Light>& a, const std::vector<Light>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].type != b[i].type || a[i].position != b[i].position ||
        a[i].direction != b[i].direction || a[i].intensity != b[i].intensity)
      return false;
  return true;
}

/// Replaces the scene's own lights (Document::setSceneLights).
class SetSceneLightsCommand : public QUndoCommand {
 public:
  SetSceneLightsCommand(Document* doc, std::vector<Light> old, std::vector<Light> lights,
                        const QString& text)
      : QUndoCommand(text), doc_(doc), old_(std::move(old)), new_(std::move(lights)) {}
  void undo() override { doc_->setSceneLightsRaw(old_); }
  void redo() override { doc_->setSceneLightsRaw(new_); }

 private:
  Document* doc_;
  std::vector<Light> old_, new_;
};
}  // namespace

struct Document::JobResult {
  QString kind;
  int generation = 0;
  double spacingMeters = 0;
  std::vector<Probe> probes;
  PlacementRequest placement;
  std::shared_ptr<const ProbeVolume> volume;
  QString volumePath;
  std::string volumeMetadata;  ///< bake: the volume file's metadata JSON
  int rigGeneration = 0;       ///< bake: Document::rigGeneration_ of the lighting it baked with
  size_t bakedProbes = 0;
  QString error;      ///< failure ("cancelled" when cancelled); probes may still be usable
  QStringList notes;  ///< what the job did, one line each (placement methods' notes)
  std::optional<EvaluationPoint> evaluation;
  std::vector<std::pair<uint64_t, Vec3>> captured;  ///< recapture: id, position captured at
  std::vector<uint64_t> replaced;                   ///< place: the probes it replaced
};

Document::Document(QObject* parent) : QObject(parent) {
  connect(&undo_, &QUndoStack::cleanChanged, this,
          [this](bool clean) { emit modifiedChanged(!clean); });
  // Connected first, so that every other listener of these signals reads the volume's state as
  // it is after the change.
  for (auto signal : {&Document::probesReset, &Document::volumeChanged, &Document::rigChanged,
                      &Document::sceneLightsChanged})
    connect(this, signal, this, &Document::refreshVolumeState);
  for (auto signal : {&Document::probeInserted, &Document::probeRemoved, &Document::probeChanged})
    connect(this, signal, this, &Document::refreshVolumeState);
}

Document::~Document() {
  cancelJob();
  stopLive();
  // The undo stack announces its last clean change while it is destroyed; nothing may hear
  // about it (a parent window is already half destroyed when its children go).
  disconnect(&undo_, nullptr, this, nullptr);
  blockSignals(true);
}

void Document::cancelJob() {
  if (jobCancel_) jobCancel_->store(true);
  if (watcher_ && watcher_->isRunning()) watcher_->waitForFinished();
}

void Document::replace(std::shared_ptr<const Scene> scene, std::shared_ptr<const Tracer> tracer,
                       ProbeSet set, const QString& scenePath, const QString& setPath) {
  cancelJob();
  stopLive();
  ++generation_;
  const bool sceneChanges = scene != scene_;
  emit probesAboutToBeReset();
  scene_ = std::move(scene);
  tracer_ = std::move(tracer);
  if (sceneChanges) fileLights_ = scene_ ? scene_->lights : std::vector<Light>();
  set_ = std::move(set);
  scenePath_ = scenePath;
  setPath_ = setPath;
  undo_.clear();
  undo_.setClean();
  ++changeCount_;
  emit probesReset();
  emit rigChanged();
  emit importanceVolumesChanged();
  if (sceneChanges) {
    evaluations_.clear();
    emit evaluationsChanged();
    setVolume(nullptr, QString(), std::string(), rigGeneration_);
    emit sceneChanged();
  }
  emit pathsChanged();
  emit modifiedChanged(false);
  if (busy_) {
    busy_ = false;
    emit jobFinished(QString());
  }
}

/// The unit hint for a scene loaded in `metresPerUnit` (empty unless read as metres).
static QString unitHintOf(const QString& path, const Scene& scene, double metresPerUnit) {
  if (metresPerUnit != 1.0) return QString();
  return QString::fromStdString(
      sceneUnitHint(QFileInfo(path).fileName().toStdString(), scene.bounds, "--units"));
}

void Document::openScene(const QString& path, double metresPerUnit) {
  LoadedScene loaded = load(path, metresPerUnit);  // throws; nothing changed yet
  ProbeSet set;
  set.scenePath = path.toStdString();
  set.sceneHash = loaded.hash;
  set.metresPerUnit = metresPerUnit;
  replace(loaded.scene, loaded.tracer, std::move(set), path, QString());
  sceneHash_ = loaded.hash;
  unitHint_ = unitHintOf(path, *loaded.scene, metresPerUnit);
  if (!autoPropose_) return;
  try {
    proposeCandidates();
  } catch (const Error& e) {
    // The scene is open: a proposal that cannot start is reported as a failed job.
    emit jobFinished(QString::fromStdString(e.what()));
  }
}

void Document::openProbeSet(const QString& path, bool keepScene) {
  ProbeSet set = loadProbeSet(toPath(path));  // throws; nothing changed yet
  // The open scene serves only when it was read in the set's unit.
  const bool sameUnit = set.metresPerUnit == set_.metresPerUnit;
  if (keepScene && scene_ && sameUnit) {
    set.scenePath = scenePath_.toStdString();
    replace(scene_, tracer_, std::move(set), scenePath_, path);
    pickUpVolumeBeside(path);
    emit probeSetOpened();
    return;
  }
  if (set.scenePath.empty())
    throw FileError(path.toStdString(), "scene", "the probe set names no scene");
  const QString scenePath = QString::fromStdString(set.scenePath);
  std::error_code ec;  // a missing file is simply "not the same scene"
  if (scene_ && sameUnit &&
      std::filesystem::equivalent(toPath(scenePath), toPath(scenePath_), ec)) {
    replace(scene_, tracer_, std::move(set), scenePath_, path);
    pickUpVolumeBeside(path);
    emit probeSetOpened();
    return;
  }
  const double unit = set.metresPerUnit;
  LoadedScene loaded = load(scenePath, unit);  // throws; nothing changed yet
  replace(loaded.scene, loaded.tracer, std::move(set), scenePath, path);
  sceneHash_ = loaded.hash;
  unitHint_ = unitHintOf(scenePath, *loaded.scene, unit);
  pickUpVolumeBeside(path);
  emit probeSetOpened();
}

void Document::pickUpVolumeBeside(const QString& setPath) {
  const QString path = volumePathFor(setPath);
  if (QFileInfo::exists(path)) {
    try {
      VolumeFile f = loadVolume(toPath(path));
      setVolume(std::make_shared<const ProbeVolume>(std::move(f.volume)), path, f.metadataJson,
                rigGeneration_);
      return;
    } catch (const Error&) {
      // An unreadable volume beside the set is as good as none: a bake writes a new one.
    }
  }
  setVolume(nullptr, QString(), std::string(), rigGeneration_);
}

void Document::setVolume(std::shared_ptr<const ProbeVolume> volume, const QString& path,
                         const std::string& metadataJson, int rigGeneration) {
  volume_ = std::move(volume);
  volumePath_ = volume_ ? path : QString();
  volumeRigGeneration_ = rigGeneration;
  volumeProbes_.clear();
  volumeIds_.clear();
  volumeExtra_ = 0;
  if (volume_) {
    const QJsonObject meta =
        QJsonDocument::fromJson(QByteArray::fromStdString(metadataJson)).object();
    const QJsonArray ids = meta.value(QLatin1String("probe_ids")).toArray();
    const std::vector<float>& pos = volume_->positions;
    const size_t n = pos.size() / 3;
    const bool haveIds = size_t(ids.size()) == n;
    for (size_t i = 0; i < n; ++i) {
      const uint64_t id = haveIds ? uint64_t(ids[qsizetype(i)].toInteger()) : 0;
      if (haveIds && id == 0) continue;  // the volume's own probe: not in the set
      if (id != 0) volumeIds_[id] = volumeProbes_.size();
      volumeProbes_.emplace_back(id, Vec3(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]));
    }
    if (!haveIds)
      volumeExtra_ = size_t(std::max(0, meta.value(QLatin1String("leak_probes_added")).toInt()));
  }
  emit volumeChanged();
}

void Document::refreshVolumeState() {
  VolumeState state = VolumeState::None;
  QString reason;
  if (volume_) {
    state = VolumeState::Stale;
    // In metres the volume holds the set's floats exactly; in another unit the file's floats
    // were scaled there and back, which rounds in the last bit or two.
    const double slack = set_.metresPerUnit == 1.0 ? 0.0 : 1e-6;
    auto near = [slack](Vec3 a, Vec3 b) {
      for (int k = 0; k < 3; ++k)
        if (std::abs(float(a[k]) - float(b[k])) > slack * (1 + std::abs(a[k]))) return false;
      return true;
    };
    size_t accepted = 0;
    for (const Probe& p : set_.probes) accepted += p.state == ProbeState::Accepted ? 1 : 0;
    const size_t inVolume = volumeProbes_.size() - std::min(volumeExtra_, volumeProbes_.size());
    // The first difference found, named by its probe.
    for (const Probe& p : set_.probes) {
      if (!reason.isEmpty()) break;
      if (p.state != ProbeState::Accepted) continue;
      if (!volumeIds_.empty()) {
        const auto it = volumeIds_.find(p.id);
        if (it == volumeIds_.end())
          reason = tr("probe %1 is accepted and not in it").arg(p.id);
        else if (!near(volumeProbes_[it->second].second, p.position))
          reason = tr("probe %1 moved").arg(p.id);
      } else if (std::none_of(volumeProbes_.begin(), volumeProbes_.end(),
                              [&](const auto& v) { return near(v.second, p.position); })) {
        reason = tr("probe %1 is not in it where the set has it").arg(p.id);
      }
    }
    if (reason.isEmpty() && accepted != inVolume) {
      for (const auto& [id, position] : volumeProbes_) {
        const Probe* now = id != 0 ? probe(id) : nullptr;
        if (id != 0 && (!now || now->state != ProbeState::Accepted)) {
          reason = now ? tr("probe %1 is no longer accepted").arg(id)
                       : tr("probe %1 was deleted").arg(id);
          break;
        }
      }
      if (reason.isEmpty()) reason = tr("the probes differ");
    }
    if (!reason.isEmpty())
      reason = tr("%1 probes in it, %2 accepted: %3").arg(inVolume).arg(accepted).arg(reason);
    else if (rigGeneration_ != volumeRigGeneration_)
      reason = tr("the lighting changed since it was baked");
    if (reason.isEmpty()) state = VolumeState::Baked;
  }
  if (state == volumeState_ && reason == volumeStaleReason_) return;
  volumeState_ = state;
  volumeStaleReason_ = reason;
  emit volumeStateChanged();
}

QString Document::volumeStatusText() const {
  const QString name = QFileInfo(volumePath_).fileName();
  switch (volumeState_) {
    case VolumeState::Baked:
      return tr("%1: baked, %2 probes").arg(name).arg(volume_->positions.size() / 3);
    case VolumeState::Stale:
      return tr("%1: stale (%2)").arg(name, volumeStaleReason_);
    case VolumeState::None:
      break;
  }
  return tr("not baked yet");
}

QString Document::evaluationSource() const {
  if (volumeIsCurrent()) return tr("baked volume %1").arg(QFileInfo(volumePath_).fileName());
  QString source = tr("preview (accepted probes)");
  if (volumeState_ == VolumeState::Stale)
    source += tr("; %1 is stale: %2").arg(QFileInfo(volumePath_).fileName(), volumeStaleReason_);
  return source;
}

std::string Document::staleCapturesText() const {
  if (sceneHash_ == 0) return "";
  return describeStaleCaptures(set_, staleCaptures(set_, sceneHash_));
}

ProbeSet Document::setToSave() const {
  ProbeSet set = set_;
  if (placementSource_) set.placement = placementSource_();
  return set;
}

void Document::saveProbeSet(const QString& path) {
  ProbeSet set = setToSave();
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
  unitHint_.clear();
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

uint64_t Document::addManualProbe(Vec3 position, const QString& text) {
  Probe p;
  p.position = position;
  p.state = ProbeState::Accepted;
  p.method = "manual";
  if (tracer_) {
    try {
      CaptureSettings cs;
      cs.samplesPerProbe = proposal_.samplesPerProbe;
      const Vec3 pts[1] = {position};
      p.sh = captureProbes(*tracer_, set_.rig, pts, cs).at(0).sh;
      p.captureSceneHash = sceneHash_;
    } catch (const Error&) {
      // No light in the scene and rig: the probe stays uncaptured (drawn grey).
    }
  }
  const uint64_t id = addProbes({p}, text).at(0);
  // The quick capture above is the preview's; the bake's sample count follows in the background.
  if (p.sh && live_.enabled && live_.finalSamples > proposal_.samplesPerProbe) {
    liveFinal_[id] = {position, QDateTime::currentMSecsSinceEpoch()};
    pumpLive();
  }
  return id;
}

void Document::moveProbe(uint64_t id, Vec3 position, int mergeKey) {
  moveProbes({{id, position}}, mergeKey);
}

void Document::moveProbes(const std::vector<std::pair<uint64_t, Vec3>>& targets, int mergeKey) {
  auto* cmd = new MoveProbesCommand(this, targets, mergeKey);
  if (cmd->entries().empty()) {
    delete cmd;
    return;
  }
  undo_.push(cmd);
}

void Document::setLocked(const std::vector<uint64_t>& ids, bool locked) {
  if (ids.empty()) return;
  undo_.push(new SetLockedCommand(this, ids, locked));
}

void Document::setRig(const LightingRig& rig, const QString& text) {
  undo_.push(new SetRigCommand(this, rig, text));
}

static std::string formatNumber(double x) {
  return QString::number(x).toStdString();
}

void Document::setImportanceVolumes(const std::vector<ImportanceVolume>& volumes,
                                    const QString& text) {
  for (size_t i = 0; i < volumes.size(); ++i) {
    const ImportanceVolume& v = volumes[i];
    const std::string which = "importance volume " + std::to_string(i + 1) +
                              (v.name.empty() ? std::string() : " (" + v.name + ")");
    for (int a = 0; a < 3; ++a) {
      const char* axis = a == 0 ? "x" : a == 1 ? "y" : "z";
      if (!std::isfinite(v.lo[a]) || !std::isfinite(v.hi[a]))
        throw ParameterError(which + ": expected finite corners on " + axis);
      if (v.lo[a] > v.hi[a])
        throw ParameterError(which + ": expected min " + axis + " <= max " + axis + ", got " +
                             formatNumber(v.lo[a]) + " > " + formatNumber(v.hi[a]));
    }
    if (!(v.weight > 0) || !std::isfinite(v.weight))
      throw ParameterError(which + ": expected a positive weight, got " + formatNumber(v.weight));
  }
  undo_.push(new SetImportanceVolumesCommand(this, volumes, text));
}

void Document::writeCopy(const QString& path) const {
  ProbeSet set = setToSave();
  if (!scenePath_.isEmpty())
    set.scenePath = std::filesystem::absolute(toPath(scenePath_)).lexically_normal().string();
  ps::saveProbeSet(set, toPath(path));
}

void Document::recover(const QString& recoveryPath, const QString& originalSetPath) {
  ProbeSet set = loadProbeSet(toPath(recoveryPath));  // throws; nothing changed yet
  if (set.scenePath.empty())
    throw FileError(recoveryPath.toStdString(), "scene", "the recovery file names no scene");
  const QString scenePath = QString::fromStdString(set.scenePath);
  std::error_code ec;
  if (scene_ && set.metresPerUnit == set_.metresPerUnit &&
      std::filesystem::equivalent(toPath(scenePath), toPath(scenePath_), ec)) {
    replace(scene_, tracer_, std::move(set), scenePath_, originalSetPath);
  } else {
    const double unit = set.metresPerUnit;
    LoadedScene loaded = load(scenePath, unit);  // throws; nothing changed yet
    replace(loaded.scene, loaded.tracer, std::move(set), scenePath, originalSetPath);
  }
  undo_.resetClean();  // the recovered edits are not saved anywhere but the recovery file
  ++changeCount_;
  emit modifiedChanged(true);
  emit probeSetOpened();
}

void Document::insertProbeRaw(int row, const Probe& p) {
  row = std::clamp(row, 0, int(set_.probes.size()));
  emit probeAboutToBeInserted(row);
  set_.probes.insert(set_.probes.begin() + row, p);
  set_.nextId = std::max(set_.nextId, p.id + 1);
  ++changeCount_;
  emit probeInserted(row);
}

void Document::removeProbeRaw(uint64_t id) {
  const int row = indexOf(id);
  if (row < 0) return;
  liveQuick_.erase(id);
  liveFinal_.erase(id);
  emit probeAboutToBeRemoved(row);
  set_.probes.erase(set_.probes.begin() + row);
  ++changeCount_;
  emit probeRemoved(row);
}

void Document::setProbeStateRaw(uint64_t id, ProbeState s) {
  const int row = indexOf(id);
  if (row < 0) return;
  set_.probes[size_t(row)].state = s;
  ++changeCount_;
  emit probeChanged(row);
}

void Document::setProbePositionRaw(uint64_t id, Vec3 p, const std::optional<ShRgb>& sh) {
  const int row = indexOf(id);
  if (row < 0) return;
  Probe& probe = set_.probes[size_t(row)];
  const bool moved = probe.position != p;
  probe.position = p;
  probe.sh = sh;
  ++changeCount_;
  // A probe moved without a capture at its new place is captured there in the background.
  if (sh) {
    liveQuick_.erase(id);
    liveFinal_.erase(id);
  } else if (moved && live_.enabled && tracer_ && probe.state != ProbeState::Rejected) {
    liveQuick_[id] = {p, QDateTime::currentMSecsSinceEpoch()};
    liveFinal_.erase(id);
    if (liveRunning_ && liveRunningFinal_ && liveCancel_) liveCancel_->store(true);
  }
  emit probeChanged(row);
  pumpLive();
}

void Document::setProbeShLive(uint64_t id, const ShRgb& sh) {
  const int row = indexOf(id);
  if (row < 0) return;
  set_.probes[size_t(row)].sh = sh;
  set_.probes[size_t(row)].captureSceneHash = sceneHash_;
  ++changeCount_;
  emit probeChanged(row);
}

struct Document::LiveTask {
  struct Item {
    uint64_t id = 0;
    Vec3 position;
    qint64 since = 0;  ///< when the edit asked for it, ms since the epoch
  };
  std::vector<Item> items;  ///< a final task holds one probe; a quick one up to kLiveQuickBatch
  int samples = 0;
  bool final = false;
  int generation = 0, rigGeneration = 0;
};

struct Document::LiveResult {
  LiveTask task;
  std::vector<std::optional<ShRgb>> sh;  ///< per item; empty when the capture failed
  bool cancelled = false;
};

namespace {
/// Quick live captures taken together (a selection dragged as one): one capture call, spread
/// over the cores, instead of one after the other.
constexpr size_t kLiveQuickBatch = 64;
}  // namespace

bool Document::isCapturingLive() const {
  return liveRunning_ || !liveQuick_.empty() || !liveFinal_.empty();
}

bool Document::isQuickCapturePending(uint64_t id) const {
  return liveQuick_.count(id) > 0 ||
         (liveRunning_ && !liveRunningFinal_ && liveRunningIds_.count(id) > 0);
}

bool Document::isQuickCapturePending() const {
  return !liveQuick_.empty() || (liveRunning_ && !liveRunningFinal_);
}

void Document::captureLive(uint64_t id) {
  const Probe* p = probe(id);
  if (!p || !tracer_ || !live_.enabled) return;
  liveQuick_[id] = {p->position, QDateTime::currentMSecsSinceEpoch()};
  liveFinal_.erase(id);
  pumpLive();
}

void Document::pumpLive() {
  while (!liveRunning_ && tracer_ && live_.enabled) {
    auto* queue = !liveQuick_.empty() ? &liveQuick_ : !liveFinal_.empty() ? &liveFinal_ : nullptr;
    if (!queue) return;
    LiveTask t;
    t.final = queue == &liveFinal_;
    const size_t batch = t.final ? 1 : kLiveQuickBatch;
    while (!queue->empty() && t.items.size() < batch) {
      const auto it = queue->begin();
      const Probe* p = probe(it->first);
      if (p && p->position == it->second.first && p->state != ProbeState::Rejected)
        t.items.push_back({it->first, it->second.first, it->second.second});
      queue->erase(it);
    }
    t.samples = t.final ? live_.finalSamples : live_.previewSamples;
    if (t.items.empty() || t.samples <= 0) continue;
    t.generation = generation_;
    t.rigGeneration = rigGeneration_;
    const int chunk = std::max(1, std::min(live_.samplesPerChunk, t.samples));
    const int chunks = std::max(1, t.samples / chunk);
    t.samples = chunks * chunk;
    auto cancel = std::make_shared<std::atomic<bool>>(false);
    liveCancel_ = cancel;
    liveRunning_ = true;
    liveRunningFinal_ = t.final;
    liveRunningIds_.clear();
    for (const LiveTask::Item& item : t.items) liveRunningIds_.insert(item.id);
    if (!liveWatcher_) {
      liveWatcher_ = new QFutureWatcher<std::shared_ptr<LiveResult>>(this);
      connect(liveWatcher_, &QFutureWatcherBase::finished, this, &Document::onLiveDone);
      // Its own thread, so that a live capture never waits behind a placement or a bake.
      livePool_.setMaxThreadCount(1);
    }
    std::shared_ptr<const Tracer> tracer = tracer_;
    const LightingRig rig = set_.rig;
    liveWatcher_->setFuture(QtConcurrent::run(&livePool_, [=]() -> std::shared_ptr<LiveResult> {
      auto r = std::make_shared<LiveResult>();
      r->task = t;
      try {
        // `chunks` independent captures of each point (seeded by their index), averaged.
        CaptureSettings cs;
        cs.samplesPerProbe = chunk;
        cs.seed = t.final ? 2 : 1;
        // The final capture leaves the other cores to the preview's rebuild and the view.
        if (t.final) cs.threads = 1;
        std::vector<Vec3> points;
        for (const LiveTask::Item& item : t.items)
          points.insert(points.end(), size_t(chunks), item.position);
        const auto captures =
            captureProbes(*tracer, rig, points, cs, [&](double) { return !cancel->load(); });
        for (size_t i = 0; i < t.items.size(); ++i) {
          ShRgb sum;
          for (int c = 0; c < chunks; ++c) sum += captures.at(i * size_t(chunks) + size_t(c)).sh;
          r->sh.push_back(sum * (1.0 / double(chunks)));
        }
      } catch (const Cancelled&) {
        r->cancelled = true;
      } catch (const std::exception&) {
        // No light: the probes stay uncaptured, as a quick capture leaves them.
      }
      return r;
    }));
  }
}

void Document::onLiveDone() {
  liveRunning_ = false;
  liveRunningIds_.clear();
  const std::shared_ptr<LiveResult> r = liveWatcher_->result();
  if (r && r->task.generation == generation_ && r->task.rigGeneration == rigGeneration_) {
    const LiveTask& t = r->task;
    const qint64 now = QDateTime::currentMSecsSinceEpoch();
    for (size_t i = 0; i < t.items.size(); ++i) {
      const LiveTask::Item& item = t.items[i];
      const Probe* p = probe(item.id);
      const bool there = p && p->position == item.position && p->state != ProbeState::Rejected;
      const bool asked = liveQuick_.count(item.id) > 0;  // moved again meanwhile
      if (there && i < r->sh.size() && r->sh[i]) {
        setProbeShLive(item.id, *r->sh[i]);
        emit liveCaptured(item.id, t.samples, double(now - item.since) * 1e-3);
        if (!t.final && !asked && live_.finalSamples > t.samples)
          liveFinal_[item.id] = {item.position, item.since};
      } else if (there && r->cancelled && !asked) {
        (t.final ? liveFinal_ : liveQuick_)[item.id] = {item.position, item.since};
      }
    }
  }
  pumpLive();
}

void Document::stopLive() {
  liveQuick_.clear();
  liveFinal_.clear();
  if (liveCancel_) liveCancel_->store(true);
  if (liveWatcher_ && liveWatcher_->isRunning()) liveWatcher_->waitForFinished();
  liveRunning_ = false;
}

void Document::setProbeLockedRaw(uint64_t id, bool locked) {
  const int row = indexOf(id);
  if (row < 0) return;
  set_.probes[size_t(row)].locked = locked;
  ++changeCount_;
  emit probeChanged(row);
}

void Document::lightingChanged() {
  ++rigGeneration_;
  liveFinal_.clear();
  if (liveCancel_) liveCancel_->store(true);
  ++changeCount_;
}

void Document::setRigRaw(const LightingRig& rig) {
  set_.rig = rig;
  lightingChanged();
  emit rigChanged();
}

void Document::setSceneLights(const std::vector<Light>& lights, const QString& text) {
  if (!scene_) return;
  undo_.push(new SetSceneLightsCommand(this, scene_->lights, lights, text));
}

void Document::setSceneLightsRaw(const std::vector<Light>& lights) {
  if (!scene_) return;
  // A copy of the scene with the new lights, and its own tracer (it references the scene);
  // jobs still running keep the old pair alive until they end.
  auto scene = std::make_shared<Scene>(*scene_);
  scene->lights = lights;
  if (tracer_) {
    std::shared_ptr<const Scene> keep = scene;
    tracer_ =
        std::shared_ptr<const Tracer>(new Tracer(*keep), [keep](const Tracer* t) { delete t; });
  }
  scene_ = std::move(scene);
  lightingChanged();
  emit sceneLightsChanged();
}

void Document::setImportanceVolumesRaw(const std::vector<ImportanceVolume>& volumes) {
  set_.importanceVolumes = volumes;
  ++changeCount_;
  emit importanceVolumesChanged();
}

void Document::requestCancel() {
  if (!jobCancel_) return;
  const bool first = busy_ && !jobCancel_->exchange(true);
  if (first) emit jobProgress(tr("Cancelling…"), jobFraction_);
}

void Document::startJob(const QString& kind, const QString& firstMessage, JobFn work) {
  busy_ = true;
  jobInFlight_ = true;
  jobKind_ = kind;
  const int generation = generation_;
  jobCancel_ = std::make_shared<std::atomic<bool>>(false);
  auto cancel = jobCancel_;
  // Progress arrives from worker threads; it is forwarded to the GUI thread when its message
  // changes (a new step) and otherwise at most every kProgressIntervalMs: each report shown
  // repaints the window, which the software GL drivers compose on the job's own cores. The
  // job stops at its next progress report once the flag is set; the document waits for it
  // before it changes or dies, so `this` outlives the job.
  struct Throttle {
    std::mutex mutex;
    QElapsedTimer sinceForwarded;  ///< invalid until the first report is forwarded
    QString message;               ///< the last message forwarded
  };
  auto throttle = std::make_shared<Throttle>();
  std::function<bool(QString, double)> report = [this, generation, throttle, cancel](
                                                    const QString& what, double fraction) {
    if (cancel->load()) return false;
    bool forward = false;
    {
      const std::lock_guard lock(throttle->mutex);
      if (!throttle->sinceForwarded.isValid() || what != throttle->message ||
          throttle->sinceForwarded.elapsed() >= kProgressIntervalMs) {
        forward = true;
        throttle->sinceForwarded.start();
        throttle->message = what;
      }
    }
    if (forward)
      QMetaObject::invokeMethod(
          this,
          [this, what, fraction, generation] {
            if (generation_ != generation || !busy_ || isCancelling()) return;
            jobFraction_ = fraction;
            emit jobProgress(what, fraction);
          },
          Qt::QueuedConnection);
    return true;
  };
  jobFraction_ = 0;
  emit jobProgress(firstMessage, 0.0);
  if (!watcher_) {
    watcher_ = new QFutureWatcher<std::shared_ptr<JobResult>>(this);
    connect(watcher_, &QFutureWatcherBase::finished, this, &Document::onJobDone);
  }
  watcher_->setFuture(QtConcurrent::run([=]() -> std::shared_ptr<JobResult> {
    auto result = std::make_shared<JobResult>();
    result->kind = kind;
    result->generation = generation;
    try {
      work(*result, report);
    } catch (const Cancelled&) {
      result->error = QStringLiteral("cancelled");
      result->probes.clear();
      result->volume.reset();
    } catch (const std::exception& e) {
      result->error = QString::fromStdString(e.what());
      result->probes.clear();
      result->volume.reset();
    }
    return result;
  }));
}

namespace {
/// One stage of a placement (PlaceContext::stage names) and its rough share of the placement's
/// wall time, for one overall progress fraction across stages.
struct JobPhase {
  std::string stage;
  double share;
};

/// The stages a method reports, in order, with rough shares of its time, after the covering:
/// the progress bar's guide and the time left's. Greedy's are its stages' wall times at 64
/// probes on two-rooms and dream-apartment (`probestudio-editor SET --time-jobs place`: field
/// 11 % and 25 %, held-out 4 %, the additions and swaps 70 % to 80 %).
std::vector<JobPhase> placementPhases(const std::string& method) {
  std::vector<JobPhase> phases;
  if (method == "greedy")
    phases = {{"field", 0.2}, {"held-out", 0.05}, {"greedy", 0.75}};
  else if (method == "chajdas")
    phases = {{"field", 1.0}};
  else if (method == "spawn-merge")
    phases = {{"grid", 0.3}, {"spawn-merge", 0.7}};
  else if (method == "ascent")
    phases = {{"ascent", 1.0}};
  else
    phases = {{"place", 1.0}};
  // The covering (core/placement/Coverage.h) runs first: 0.1 s of greedy's 12 s above.
  for (JobPhase& p : phases) p.share *= 0.98;
  phases.insert(phases.begin(), {"coverage", 0.02});
  return phases;
}

/// The placement's share of a placement job, the quick capture of its new probes taking the
/// rest: a uniform grid is placed at once and its capture is the job, while greedy's 64 probes
/// were captured in 0.06 s of 12.5 s (the measurement above).
double placementShare(const std::string& method) {
  return method == "uniform" ? 0.2 : 0.95;
}

/// Where a stage starts in [0, 1], its share, and its 1-based step. A stage not in the list
/// (a method reporting more than it declares) takes the last step's span, so the overall
/// fraction never goes back.
std::tuple<double, double, size_t> phaseSpan(const std::vector<JobPhase>& phases,
                                             const std::string& stage) {
  double from = 0;
  for (size_t i = 0; i < phases.size(); ++i) {
    if (phases[i].stage == stage) return {from, phases[i].share, i + 1};
    from += phases[i].share;
  }
  const JobPhase& last = phases.back();
  return {from - last.share, last.share, phases.size()};
}

/// Quick SH of candidates so that each shows its own light; a capture failure (no light) leaves
/// them uncaptured and is reported in `error`.
void captureQuickly(const Tracer& tracer, const LightingRig& rig, std::vector<Probe>& probes,
                    int samples, const std::function<bool(QString, double)>& report, double from,
                    QString& error, uint64_t sceneHash) {
  std::vector<Vec3> points;
  for (const Probe& p : probes) points.push_back(p.position);
  try {
    CaptureSettings cs;
    cs.samplesPerProbe = samples;
    const QString label =
        from > 0 ? QObject::tr("Capturing SH (last step)…") : QObject::tr("Capturing SH…");
    const auto captures = captureProbes(
        tracer, rig, points, cs, [&](double f) { return report(label, from + (1 - from) * f); });
    for (size_t i = 0; i < captures.size() && i < probes.size(); ++i) {
      probes[i].sh = captures[i].sh;
      probes[i].captureSceneHash = sceneHash;
    }
  } catch (const Cancelled&) {
    throw;
  } catch (const Error& err) {
    error = QObject::tr("Capture failed: %1").arg(QString::fromStdString(err.what()));
  }
}
}  // namespace

bool Document::proposeCandidates() {
  if (!tracer_ || busy_) return false;
  PlacementRequest request;
  request.method = "uniform";
  request.samplesPerProbe = proposal_.samplesPerProbe;
  request.domain = proposal_.domain;
  request.replaceCandidates = true;
  // The budget counts the probes the placement keeps (PlaceRequest::budget).
  request.budget = int(keptProbes(set_, request.toPlaceRequest()).size()) +
                   int(std::lround(proposal_.targetProbeCount));
  return startPlacement(request, QStringLiteral("propose"));
}

PlaceRequest PlacementRequest::toPlaceRequest() const {
  PlaceRequest r;
  r.method = method;
  r.budget = budget;
  // The panel shows every field; a method is given those it reads (PlacementMethod::parameters).
  auto takes = [&](std::string_view name) { return methodReads(method, name); };
  if (budget <= 0 && takes("spacingMeters")) r.parameters.set("spacingMeters", spacingMeters);
  if (takes("aggressiveness")) r.parameters.set("aggressiveness", aggressiveness);
  if (takes("swapPasses")) r.parameters.set("swapPasses", swapPasses);
  if (takes("objective")) r.parameters.setText("objective", objective);
  // The artist's accepted probes stay; the candidates unless they are replaced.
  r.keepAccepted = true;
  r.keepCandidates = !replaceCandidates;
  r.cover = cover;
  r.newState = acceptNew ? ProbeState::Accepted : ProbeState::Candidate;
  r.domain.rule = domain;
  return r;
}

bool PlacementRequest::methodReads(const std::string& method, std::string_view parameter) {
  const PlacementMethod& m = findPlacementMethod(method);
  return std::find(m.parameters.begin(), m.parameters.end(), parameter) != m.parameters.end();
}

QString PlacementRequest::fieldLabel(const std::string& parameter) {
  if (parameter == "method") return QObject::tr("Method");
  if (parameter == "budget") return QObject::tr("Budget");
  if (parameter == "spacingMeters") return QObject::tr("Spacing");
  if (parameter == "aggressiveness") return QObject::tr("Aggressiveness");
  if (parameter == "swapPasses") return QObject::tr("Swap passes");
  if (parameter == "objective") return QObject::tr("Objective");
  return QString::fromStdString(parameter);
}

bool Document::runPlacement(const PlacementRequest& request) {
  return startPlacement(request, QStringLiteral("place"));
}

bool Document::startPlacement(const PlacementRequest& request, const QString& kind) {
  if (!tracer_ || busy_) return false;
  // A problem of the request is the panel's field, named as the panel names it; nothing starts.
  PlaceRequest place;
  try {
    place = request.toPlaceRequest();
    checkPlaceRequest(place, set_);
  } catch (const ParameterError& e) {
    if (e.parameter().empty()) throw;
    throw ParameterError(PlacementRequest::fieldLabel(e.parameter()).toStdString(), e.problem());
  }
  const ProbeSet set = set_;
  std::shared_ptr<const Tracer> tracer = tracer_;
  const uint64_t sceneHash = sceneHash_;
  const std::vector<JobPhase> phases = placementPhases(request.method);
  const double placing = placementShare(request.method);
  const QString firstMessage =
      kind == QLatin1String("propose") ? tr("Proposing probes…") : tr("Placing probes…");
  startJob(kind, firstMessage, [=](JobResult& result, const auto& report) {
    result.placement = request;
    const PlaceResult placed =
        placeProbeSet(*tracer, set, place, [&](const std::string& stage) -> ProgressFn {
          const auto [from, share, step] = phaseSpan(phases, stage);
          const QString label = tr("Placing probes: %1 (step %2 of %3)…")
                                    .arg(QString::fromStdString(stage))
                                    .arg(step)
                                    .arg(phases.size() + 1);
          return [&report, label, from, share, placing](double f) {
            return report(label, placing * (from + share * f));
          };
        });
    result.spacingMeters = placed.set.placement.spacingMeters;
    for (const std::string& note : placed.notes) result.notes << QString::fromStdString(note);
    // The new probes (ids from the set's nextId on), and the probes the placement replaced.
    for (const Probe& p : placed.set.probes)
      if (p.id >= set.nextId) result.probes.push_back(p);
    std::unordered_set<uint64_t> stay;
    for (const Probe& p : placed.set.probes) stay.insert(p.id);
    for (const Probe& p : set.probes)
      if (!stay.count(p.id)) result.replaced.push_back(p.id);
    captureQuickly(*tracer, set.rig, result.probes, request.samplesPerProbe, report, placing,
                   result.error, sceneHash);
  });
  return true;
}

bool Document::addProbesWhereErrorIsWorst(int count, PlacementRequest settings) {
  if (!tracer_ || busy_) return false;
  if (count < 1)
    throw ParameterError("probes to add: expected 1 or more, got " + std::to_string(count));
  settings.method = "greedy";
  settings.replaceCandidates = false;
  // Exactly `count` more where the error is worst: the artist's set stays as it is, covered or
  // not (a covering around it would spend the count elsewhere).
  settings.cover = false;
  settings.acceptNew = true;
  const size_t kept = keptProbes(set_, settings.toPlaceRequest()).size();
  settings.budget = int(kept) + count;
  settings.undoText = count == 1 ? tr("Add 1 probe where the error is worst (greedy)")
                                 : tr("Add %1 probes where the error is worst (greedy)").arg(count);
  return runPlacement(settings);
}

QString Document::volumePathFor(const QString& probeSetPath) {
  QString base = probeSetPath;
  for (const char* suffix : {".probes.json", ".json"})
    if (base.endsWith(QLatin1String(suffix), Qt::CaseInsensitive)) {
      base.chop(int(qstrlen(suffix)));
      break;
    }
  return base + ".psv";
}

bool Document::bake(const BakeRequest& request) {
  if (!tracer_ || busy_) return false;
  if (setPath_.isEmpty())
    throw ParameterError("bake: save the probe set first (the volume is saved beside it)");
  size_t accepted = 0;
  for (const Probe& p : set_.probes) accepted += p.state == ProbeState::Accepted ? 1 : 0;
  if (accepted < 4)
    throw ParameterError("bake: at least 4 probes must be accepted, " + std::to_string(accepted) +
                         " are");
  ProbeSet set = set_;
  if (!scenePath_.isEmpty())
    set.scenePath = std::filesystem::absolute(toPath(scenePath_)).lexically_normal().string();
  const QString path = volumePathFor(setPath_);
  std::shared_ptr<const Tracer> tracer = tracer_;
  const int rigGeneration = rigGeneration_;
  // The capture cache of `probestudio bake`: SET.capture-cache beside the probe set, keyed by
  // the scene's content, so that a re-bake (here or on the command line) traces only the probes
  // moved or added since. A scene built in memory (hash 0) has no cache.
  const uint64_t sceneHash = lightingSceneHash();
  const std::filesystem::path cacheDir = toPath(setPath_ + QStringLiteral(".capture-cache"));
  startJob("bake", tr("Baking…"), [=](JobResult& result, const auto& report) {
    BakeSettings bs;
    bs.capture.samplesPerProbe = request.samplesPerProbe;
    bs.sceneHash = sceneHash;
    if (sceneHash != 0) bs.cacheDir = cacheDir;
    if (request.fit) bs.fit = FitSettings{};
    BakeResult baked = bakeProbeSet(set, *tracer, bs, [&](double f) {
      return report(tr("Baking %1 probes…").arg(accepted), 0.97 * f);
    });
    saveVolume(baked.file, toPath(path));  // atomic
    result.bakedProbes = baked.probes;
    result.notes << tr("Baked %1 accepted probes (%2 captured, %3 from the cache)")
                        .arg(baked.probes)
                        .arg(baked.captured)
                        .arg(baked.cacheHits);
    if (baked.fit)
      result.notes << tr("Values fitted by least squares to %1 points (%2 s)")
                          .arg(baked.fit->points)
                          .arg(baked.fit->seconds, 0, 'f', 2);
    result.volumePath = path;
    result.volumeMetadata = baked.file.metadataJson;
    result.rigGeneration = rigGeneration;
    result.volume = std::make_shared<const ProbeVolume>(std::move(baked.file.volume));
  });
  return true;
}

bool Document::recapture(int samplesPerProbe) {
  if (!tracer_ || busy_) return false;
  std::vector<Probe> probes;
  for (const Probe& p : set_.probes)
    if (p.state != ProbeState::Rejected) probes.push_back(p);
  if (probes.empty()) return false;
  const LightingRig rig = set_.rig;
  std::shared_ptr<const Tracer> tracer = tracer_;
  const uint64_t sceneHash = sceneHash_;
  startJob("recapture", tr("Capturing SH…"), [=](JobResult& result, const auto& report) mutable {
    captureQuickly(*tracer, rig, probes, samplesPerProbe, report, 0.0, result.error, sceneHash);
    if (!result.error.isEmpty()) {
      probes.clear();
      return;
    }
    for (const Probe& p : probes) result.captured.emplace_back(p.id, p.position);
    result.probes = std::move(probes);
  });
  return true;
}

uint64_t Document::lightingSceneHash() const {
  // The scene's lights edited in this session (setSceneLights) are not in the file's hash:
  // folded in, a capture or a reference traced with other lights is never read back.
  uint64_t sceneHash = sceneHash_;
  if (sceneHash != 0 && scene_ && !sameLights(scene_->lights, fileLights_))
    for (const Light& l : scene_->lights) {
      const double values[] = {double(l.type), l.position.x,  l.position.y,  l.position.z,
                               l.direction.x,  l.direction.y, l.direction.z, l.intensity.r,
                               l.intensity.g,  l.intensity.b};
      sceneHash = fnv1a64(values, sizeof values, sceneHash);
    }
  return sceneHash;
}

bool Document::evaluate(const EvalRequest& request) {
  if (!tracer_ || busy_) return false;
  std::shared_ptr<const ProbeVolume> volume;
  const QString source = evaluationSource();
  if (volumeIsCurrent()) {
    volume = volume_;
  } else {
    std::vector<Vec3> positions;
    std::vector<ShRgb> sh;
    for (const Probe& p : set_.probes)
      if (p.state == ProbeState::Accepted && p.sh) {
        positions.push_back(p.position);
        sh.push_back(*p.sh);
      }
    if (positions.size() < 4)
      throw ParameterError("evaluate: bake, or accept at least 4 captured probes, first");
    volume = std::make_shared<const ProbeVolume>(volumeFromProbes(positions, sh));  // throws
  }
  const LightingRig rig = set_.rig;
  // The importance volumes: the queries go where probes are wanted.
  const std::vector<Bounds3> domain = importanceBoxes(set_.importanceVolumes);
  std::shared_ptr<const Tracer> tracer = tracer_;
  // The reference is cached as `probestudio eval` caches it: beside a saved set (shared with the
  // CLI's evals of the sets and volumes there), else in the user's cache folder. A folder that
  // cannot be made means no cache, not an error.
  std::optional<std::filesystem::path> cacheDir;
  if (sceneHash_ != 0) {
    const QString base = !setPath_.isEmpty()
                             ? QFileInfo(setPath_).absolutePath()
                             : QStandardPaths::writableLocation(QStandardPaths::CacheLocation);
    if (!base.isEmpty()) cacheDir = defaultReferenceCacheDir(toPath(base));
  }
  const uint64_t sceneHash = lightingSceneHash();
  startJob("eval", tr("Evaluating…"), [=](JobResult& result, const auto& report) {
    EvalSettings es;
    es.queries = request.queries;
    es.referenceSpp = request.referenceSpp;
    es.domain = domain;
    // The default domain of `probestudio eval` (PlaceRequest::domain's default rule).
    es.reachable = makeDomain(*tracer, domain, DomainSettings{}).reachable;
    es.cacheDir = cacheDir;
    es.sceneHash = sceneHash;
    const QString evaluated = source;
    const EvalResult r = evaluateVolume(*tracer, rig, *volume, es, [&](double f) {
      return report(tr("Evaluating against the reference…"), f);
    });
    EvaluationPoint e;
    e.probes = r.probes;
    e.relRmse = r.relRmse;
    e.p95RelError = r.p95RelError;
    e.maxRelError = r.maxRelError;
    e.relRmseStdError = r.relRmseStdError;
    e.referenceRelNoise = r.referenceRelNoise;
    e.leakingFraction = r.leakingFraction;
    e.leakingOutsideHullFraction = r.leakingOutsideHullFraction;
    e.outsideHullFraction = r.outsideHullFraction;
    e.stopsFloor = adaptationFloor(r.perQuery);
    const std::vector<double> stops = queryStops(r.perQuery, e.stopsFloor);
    e.stops = summarizeStops(stops);
    for (size_t i = 0; i < r.perQuery.size() && i < stops.size(); ++i) {
      const EvalQuery& q = r.perQuery[i];
      e.queries.push_back({q.point, q.normal, q.reference, q.interpolated, stops[i], q.leaking});
    }
    e.source = evaluated;
    e.referenceCached = r.referenceCached;
    e.seconds = r.seconds;
    result.evaluation = e;
  });
  return true;
}

void Document::openVolume(const QString& path) {
  VolumeFile f = loadVolume(toPath(path));  // throws; nothing changed yet
  setVolume(std::make_shared<const ProbeVolume>(std::move(f.volume)), path, f.metadataJson,
            rigGeneration_);
}

void Document::onJobDone() {
  jobInFlight_ = false;
  std::shared_ptr<JobResult> r = watcher_->result();
  if (!r || r->generation != generation_) return;  // stale: the document moved on
  busy_ = false;
  const bool proposal = r->kind == QLatin1String("propose");
  if ((proposal || r->kind == QLatin1String("place")) && r->error != QLatin1String("cancelled") &&
      (!r->probes.empty() || r->error.isEmpty())) {
    set_.placement.method = r->placement.method;
    set_.placement.spacingMeters = r->spacingMeters;
    set_.placement.budget = r->placement.budget;
    // The placement (core/placement/Place.h) kept the accepted, rejected and locked probes,
    // replaced the others, and left out new probes beside rejected ones.
    const std::vector<uint64_t> replaced = r->replaced;
    std::vector<Probe> added;
    for (Probe& p : r->probes) {
      p.id = allocateId();
      added.push_back(std::move(p));
    }
    const QString text = proposal ? tr("Propose %1 candidates").arg(added.size())
                         : !r->placement.undoText.isEmpty()
                             ? r->placement.undoText
                             : tr("Place %1 candidates (%2)")
                                   .arg(added.size())
                                   .arg(QString::fromStdString(r->placement.method));
    // The proposal is the editor's, not the artist's: a document that was clean stays clean
    // (closing it asks nothing; the proposal is undoable like any edit).
    const bool keepClean = proposal && undo_.isClean();
    if (!proposal || !added.empty() || !replaced.empty()) {
      auto* macro = new QUndoCommand(text);
      if (!replaced.empty()) new DeleteProbesCommand(this, replaced, macro);
      if (!added.empty()) new AddProbesCommand(this, std::move(added), QString(), macro);
      undo_.push(macro);
    }
    if (keepClean) undo_.setClean();
  } else if (r->kind == QLatin1String("bake") && r->volume) {
    setVolume(r->volume, r->volumePath, r->volumeMetadata, r->rigGeneration);
  } else if (r->kind == QLatin1String("recapture") && !r->probes.empty()) {
    std::vector<std::pair<uint64_t, ShRgb>> sh;
    for (size_t i = 0; i < r->probes.size(); ++i) {
      const Probe* now = probe(r->captured[i].first);
      if (now && now->position == r->captured[i].second && r->probes[i].sh)
        sh.emplace_back(now->id, *r->probes[i].sh);
    }
    if (!sh.empty())
      undo_.push(
          new SetShCommand(this, std::move(sh), tr("Recapture %1 probes").arg(r->probes.size())));
  } else if (r->kind == QLatin1String("eval") && r->evaluation) {
    evaluations_.push_back(*r->evaluation);
    emit evaluationsChanged();
  }
  jobNotes_ = r->notes;
  emit jobProgress(QString(), 1.0);
  emit jobFinished(r->error);
}

}  // namespace ps::ui
