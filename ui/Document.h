#pragma once
// The editor's document: one scene (with its tracer) and the probe set being edited. Probes are
// addressed by their stable id; every user edit goes through the undo stack (ProbeCommands.h).
// Loads are transactional: a load that throws ps::Error leaves the document as it was.
#include <QFutureWatcher>
#include <QObject>
#include <QString>
#include <QStringList>
#include <QThreadPool>
#include <QUndoStack>
#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/eval/PerceptualError.h"
#include "core/io/ProbeSet.h"
#include "core/placement/GreedyMethod.h"
#include "core/placement/Place.h"
#include "core/scene/Scene.h"

namespace ps {
class Tracer;
struct ProbeVolume;
}  // namespace ps

namespace ps::ui {

/// Settings of the background candidate proposal made when a scene is opened without a set: a
/// uniform placement through the same pipeline and domain as Run placement
/// (Document::runPlacement), at a budget of about targetProbeCount new candidates.
struct ProposalSettings {
  double targetProbeCount = 80;  ///< new candidates (uniform's budget beyond the kept probes)
  int samplesPerProbe = 64;      ///< quick SH capture
  /// Where the candidates go without importance volumes: the placement panel's domain
  /// (PlacementRequest::domain), so that the proposal lands where Run placement puts probes.
  DomainRule domain = DomainRule::Reachable;
};

/// Live capture of edited probes: a probe moved (or added) is captured alone in the background,
/// quickly for the preview first, then at the bake's sample count. Both captures split their
/// rays over independent captures of the same point (core/capture seeds each by its index),
/// averaged: the same estimator as one capture of all the rays, spread over the cores.
struct LiveCaptureSettings {
  bool enabled = true;
  int previewSamples = 64;   ///< the quick capture (ProposalSettings' count)
  int finalSamples = 1024;   ///< then this many (the bake panel's samples per probe); 0: none
  int samplesPerChunk = 32;  ///< rays per independent capture; cancellation between chunks
};

/// The placement panel's settings, which it starts with: greedy at 64 probes, as
/// `scripts/run --headless` places. toPlaceRequest() turns them into the core's request
/// (core/placement/Place.h), the one the command line builds from its flags.
struct PlacementRequest {
  static constexpr int kDefaultBudget = 64;
  std::string method = "greedy";
  double spacingMeters = 1.0;     ///< grid methods, used when budget == 0
  int budget = kDefaultBudget;    ///< > 0: the probe count (PlaceRequest::budget); 0: none
  int samplesPerProbe = 64;       ///< quick capture of the new probes, so they show their light
  bool replaceCandidates = true;  ///< false: keep the unlocked candidates too, only add
  double aggressiveness = 1.0;    ///< chajdas: merging strength (without a budget)
  int swapPasses = kGreedySwapPasses;  ///< greedy: swap passes after the additions (0: none)
  /// greedy: the error it lowers, "perceptual" (stops) or "energy" (rel_rmse)
  /// (GreedyMethodSettings::objective).
  std::string objective = greedyObjectiveName(GreedyMethodSettings{}.objective);
  bool cover = true;                          ///< PlaceRequest::cover
  DomainRule domain = DomainRule::Reachable;  ///< PlaceRequest::domain's rule
  /// The new probes are accepted (PlaceRequest::newState) instead of candidates.
  bool acceptNew = false;
  /// The undo step's name; empty: "Place N candidates (method)".
  QString undoText;
  /// The core's request: the method's parameters among the fields above, the accepted probes
  /// kept (and the candidates unless replaceCandidates). Throws ps::ParameterError("method")
  /// for an unknown method.
  PlaceRequest toPlaceRequest() const;
  /// True when `method` (one of placementMethods()) reads this parameter
  /// (PlacementMethod::parameters). Throws ps::ParameterError("method") for an unknown method.
  static bool methodReads(const std::string& method, std::string_view parameter);
  /// The panel's name of a core parameter (ParameterError::parameter()).
  static QString fieldLabel(const std::string& parameter);
};

/// The bake's settings: the accepted probes captured at final quality.
struct BakeRequest {
  int samplesPerProbe = 1024;
  /// Least-squares probe values (core/bake/LeastSquaresFit.h, `bake --fit`) with its defaults.
  bool fit = false;
};

/// The evaluation's settings (core/eval/Evaluate.h).
struct EvalRequest {
  int queries = 128;
  int referenceSpp = 256;
};

/// One query of an evaluation where it is: the point and the normal its irradiance faces, the
/// reference and the volume's irradiance (luminance, W/m²) and the error in stops
/// (errorStops against the evaluation's floor). In eval's order (its per-query CSV's rows).
struct QueryError {
  Vec3 point, normal;
  double reference = 0, interpolated = 0;
  double stops = 0;
  bool leaking = false;
};

/// One evaluation the artist ran: the volume's probe count and its errors against the
/// path-traced reference (relative RMS, 95th percentile, max), what was evaluated.
struct EvaluationPoint {
  size_t probes = 0;
  double relRmse = 0, p95RelError = 0, maxRelError = 0;
  /// How far another draw of as many queries would move relRmse, and the reference's own noise
  /// on relRmse's scale (EvalResult::relRmseStdError, referenceRelNoise).
  double relRmseStdError = 0, referenceRelNoise = 0;
  /// Queries that interpolate a probe they cannot see, those of them outside the probes' hull,
  /// and the queries outside the hull (EvalResult).
  double leakingFraction = 0, leakingOutsideHullFraction = 0, outsideHullFraction = 0;
  /// The perceptual error in stops (core/eval/PerceptualError.h) and the floor it is measured
  /// against (luminance, W/m²).
  EvalStops stops;
  double stopsFloor = 0;
  std::vector<QueryError> queries;  ///< each query, in eval's order
  QString source;                   ///< "baked volume" or "preview (accepted probes)"
  bool referenceCached = false;     ///< the reference came from the eval reference cache
  double seconds = 0;               ///< wall time of the evaluation
};

class Document : public QObject {
  Q_OBJECT
 public:
  explicit Document(QObject* parent = nullptr);
  ~Document() override;

  // --- loading and saving (throw ps::Error; the document is unchanged when they throw) ---

  /// Loads a glTF scene in its unit (`metresPerUnit`, core/scene/SceneUnits.h; the document
  /// works in metres) and starts an empty probe set for it, saved with that unit (then, when
  /// autoPropose() is on, proposes candidates in the background).
  void openScene(const QString& path, double metresPerUnit = 1.0);
  /// Loads a probe set. Its scene is loaded too, in the set's unit, unless `keepScene` and a
  /// scene is open in that unit. A volume beside it (volumePathFor) becomes volume(), current
  /// when it holds the accepted probes.
  void openProbeSet(const QString& path, bool keepScene = false);
  /// The scene's unit, metres per unit; saved with the set ("units").
  double metresPerUnit() const { return set_.metresPerUnit; }
  /// One line when the open scene was read as metres and its size suggests cm or mm
  /// (sceneUnitHint), naming the editor's --units option; empty otherwise.
  const QString& unitHint() const { return unitHint_; }
  /// Saves atomically to `path` and makes it the document's file; marks the document clean.
  /// The set's placement settings are those of the placement source when there is one.
  void saveProbeSet(const QString& path);
  /// Where saves (and recovery copies) take the set's method, spacing and budget from: the
  /// placement panel, so that a reopened set shows the settings it was saved with rather than
  /// those of the last placement that ran (the editor's proposal, a "greedy adds"). Not an
  /// edit: it marks nothing modified. Without a source the set keeps the last placement's.
  void setPlacementSource(std::function<PlacementSettings()> source) {
    placementSource_ = std::move(source);
  }

  /// Replaces the scene by one built in memory (tests, previews); no tracer, no proposal.
  void setScene(Scene scene);

  // --- state ---
  bool hasScene() const { return scene_ != nullptr; }
  const Scene* scene() const { return scene_.get(); }
  const ProbeSet& probeSet() const { return set_; }
  const std::vector<Probe>& probes() const { return set_.probes; }
  /// Row of the probe with this id, or -1.
  int indexOf(uint64_t id) const;
  const Probe* probe(uint64_t id) const;
  QString scenePath() const { return scenePath_; }
  /// sceneContentHash() of the open scene's file; 0 for a scene built in memory.
  uint64_t sceneHash() const { return sceneHash_; }
  /// Which captures of the probe set the scene's changes made stale, in one line (empty when
  /// none, or when the scene has no file).
  std::string staleCapturesText() const;
  QString probeSetPath() const { return setPath_; }
  bool isModified() const { return !undo_.isClean(); }
  QUndoStack* undoStack() { return &undo_; }

  // --- undoable edits (push one QUndoCommand each) ---
  void setStates(const std::vector<uint64_t>& ids, ProbeState state);
  void deleteProbes(const std::vector<uint64_t>& ids);
  /// Adds probes (ids are assigned here) and returns their ids.
  std::vector<uint64_t> addProbes(std::vector<Probe> probes, const QString& text);
  /// Adds one accepted "manual" probe at `position`, captured quickly (ProposalSettings'
  /// samplesPerProbe) when a tracer is there and the scene has light; one undo step.
  uint64_t addManualProbe(Vec3 position, const QString& text);
  /// Moves one probe; successive moves of the same probe with the same merge key merge into one
  /// undo step (a negative key never merges).
  void moveProbe(uint64_t id, Vec3 position, int mergeKey = 0);
  /// Moves several probes as one undo step; successive calls with the same probes and the same
  /// merge key merge (a drag of the selection is one step). Locked probes are moved too: callers
  /// that must respect locks filter them (the viewport does).
  void moveProbes(const std::vector<std::pair<uint64_t, Vec3>>& targets, int mergeKey);
  /// A merge key no earlier edit used (one per drag, one per numeric edit).
  int newMergeKey() { return ++lastMergeKey_; }
  void setLocked(const std::vector<uint64_t>& ids, bool locked);
  /// Replaces the lighting rig (undoable). The probes' captured SH stays as it was.
  void setRig(const LightingRig& rig, const QString& text);
  /// Replaces the scene's own lights (undoable) for this session: the scene is copied with
  /// `lights` and traced anew (an Embree build), so that every later capture, placement, bake
  /// and evaluation uses them. The scene file keeps its lights (the probe set stores the rig
  /// only). Like a rig change, it drops the live captures of the old light and leaves the baked
  /// volume no longer current; the probes' SH stays as it was (Recapture applies the new
  /// light). Nothing happens without a scene.
  void setSceneLights(const std::vector<Light>& lights, const QString& text);
  /// The lights of the scene file as loaded (scene()->lights differs once edited).
  const std::vector<Light>& sceneFileLights() const { return fileLights_; }
  /// Replaces the importance volumes (undoable). Each is checked first: a non-empty name is not
  /// required, but lo <= hi on every axis, finite corners and a positive weight are; a bad one
  /// throws ParameterError naming it ("importance volume 2: ...") and changes nothing.
  void setImportanceVolumes(const std::vector<ImportanceVolume>& volumes, const QString& text);

  // --- recovery (autosave) ---
  /// Writes the probe set (scene path absolute) to `path` atomically without changing the
  /// document's file, its clean state or its undo stack. Throws ps::Error.
  void writeCopy(const QString& path) const;
  /// Loads a recovery copy written by writeCopy(): the document gets its probes and scene, takes
  /// `originalSetPath` (may be empty) as its file and is marked modified. Throws ps::Error and
  /// leaves the document unchanged then.
  void recover(const QString& recoveryPath, const QString& originalSetPath);
  /// Bumped by every change of the probes or the rig (autosave writes when it moved).
  quint64 changeCount() const { return changeCount_; }

  const Tracer* tracer() const { return tracer_.get(); }
  /// The tracer, shared (it keeps its scene alive), for background work.
  std::shared_ptr<const Tracer> tracerShared() const { return tracer_; }

  // --- candidate proposal in the background ---
  bool autoPropose() const { return autoPropose_; }
  void setAutoPropose(bool on) { autoPropose_ = on; }
  ProposalSettings& proposalSettings() { return proposal_; }
  /// Starts the proposal (ProposalSettings): runPlacement's job with method "uniform", the
  /// budget the kept probes plus targetProbeCount, the unlocked candidates replaced, the
  /// proposal's domain and quick capture. The result is one undo step ("Propose N candidates")
  /// that leaves a clean document clean. Returns false (and does nothing) when busy or without
  /// a tracer; throws ParameterError as runPlacement does.
  bool proposeCandidates();
  bool isBusy() const { return busy_; }
  /// The least time between two progress reports of one step of a job (jobProgress), ms.
  static constexpr int kProgressIntervalMs = 1000;
  /// A job's work was started and the end of it has not been handled yet: true from its start
  /// until its finished signal reaches the document (its result applied, or dropped when the
  /// document moved on), also after replace() stopped it and reported jobFinished.
  bool isJobInFlight() const { return jobInFlight_; }
  /// What the running job is ("propose", "place", "bake"), empty when idle.
  QString jobKind() const { return busy_ ? jobKind_ : QString(); }
  /// What the last finished job reported it did (a placement method's notes), one line each.
  QStringList lastJobNotes() const { return jobNotes_; }
  /// Asks the running job to stop at its next progress report; jobFinished("cancelled") follows.
  /// Emits jobProgress("Cancelling…") at once, at the fraction last reported, so that the
  /// artist sees the request taken while the job runs on to its next report (the core's
  /// stages without reports can take a minute).
  void requestCancel();
  /// A cancel was asked for and the job has not ended yet.
  bool isCancelling() const { return busy_ && jobCancel_ && jobCancel_->load(); }

  /// Runs a placement method in the background. When it finishes, one undo step replaces the
  /// unlocked candidates by the new ones (or, with replaceCandidates off, keeps them and only
  /// adds); accepted, rejected and locked probes are kept as they are, and new points closer
  /// than half the spacing to a kept probe are dropped. Returns false
  /// (and does nothing) when busy, without a tracer, or for an unknown method (ParameterError
  /// thrown for bad numbers).
  bool runPlacement(const PlacementRequest& request);
  /// Greedy adds `count` probes where its error is worst: a placement (runPlacement) with
  /// `settings`' greedy options (objective, swap passes, preview samples), every non-rejected
  /// probe kept where it is and counted (PlaceRequest::keepAccepted, keepCandidates), a budget of
  /// their count plus `count`, and the new probes accepted (the evaluation
  /// measures the accepted probes); one undo step adds them. Greedy adds fewer when it reaches
  /// its noise floor first or a new probe falls beside a rejected one. Returns false when busy
  /// or without a tracer; throws ParameterError for count < 1 or bad settings.
  bool addProbesWhereErrorIsWorst(int count, PlacementRequest settings);
  /// Bakes the accepted probes in the background (capture, tetrahedralization) and saves the
  /// volume to volumePathFor(probeSetPath()). Needs a saved probe set; throws ParameterError when
  /// there is none or fewer than 4 probes are accepted. On success volume() holds the result.
  /// Captures go through `probestudio bake`'s cache (SET.capture-cache beside the set).
  bool bake(const BakeRequest& request);
  /// The volume file beside a probe set: "X.probes.json" and "X.json" give "X.psv".
  static QString volumePathFor(const QString& probeSetPath);
  /// The last volume baked (or loaded) for this document; null when none.
  std::shared_ptr<const ProbeVolume> volume() const { return volume_; }
  QString volumePath() const { return volumePath_; }
  /// What volume() is to the probe set. Baked: its probes from the set (the volume file's
  /// "probe_ids"; by position for a file without them) are exactly the accepted probes, each
  /// where the set has it, and the lighting did not change since it was baked or loaded (probes
  /// with id 0 are the volume's own, not in the set: a volume file may hold such probes). Stale: it
  /// no longer matches. Updated at every change of the probes, the lighting or the volume
  /// (volumeStateChanged).
  enum class VolumeState { None, Baked, Stale };
  VolumeState volumeState() const { return volumeState_; }
  bool volumeIsCurrent() const { return volumeState_ == VolumeState::Baked; }
  /// Why the volume is stale, one line naming a probe that differs ("73 probes in the volume,
  /// 72 accepted: probe 12 is no longer accepted"); empty unless stale.
  QString volumeStaleReason() const { return volumeStaleReason_; }
  /// The volume named with its state, one line: "X.psv: baked, 73 probes", "X.psv: stale
  /// (reason)", or "not baked yet".
  QString volumeStatusText() const;
  /// What evaluate() measures now, named with its state: "baked volume X.psv", or
  /// "preview (accepted probes)" followed by "; X.psv is stale: reason" when a
  /// stale volume is left aside.
  QString evaluationSource() const;
  /// Loads a volume file for the preview and the overlays. Throws ps::Error.
  void openVolume(const QString& path);

  // --- live capture of edited probes (LiveCaptureSettings) ---
  LiveCaptureSettings& liveCaptureSettings() { return live_; }
  /// Probes waiting for, or in, a live capture.
  bool isCapturingLive() const;
  /// This probe waits for, or is in, a quick live capture (its SH is on its way).
  bool isQuickCapturePending(uint64_t id) const;
  /// Some probe waits for, or is in, a quick live capture.
  bool isQuickCapturePending() const;
  /// Queues a live capture of this probe where it is now (a move or an add already does).
  void captureLive(uint64_t id);

  /// Captures every non-rejected probe again in the background with the current rig (after a
  /// lighting change) at `samplesPerProbe`; one undo step replaces their SH. Probes moved or
  /// deleted while it runs are left alone.
  bool recapture(int samplesPerProbe);

  /// Evaluates in the background the baked volume when there is one (and no probe changed since
  /// the bake), else the volume of the accepted probes with their preview SH; the result is
  /// appended to evaluations(). Throws ParameterError when there is nothing to evaluate.
  bool evaluate(const EvalRequest& request);
  const std::vector<EvaluationPoint>& evaluations() const { return evaluations_; }

  // --- raw mutators used by the undo commands only (no undo, emit the change signals) ---
  void insertProbeRaw(int row, const Probe& p);
  void removeProbeRaw(uint64_t id);
  void setProbeStateRaw(uint64_t id, ProbeState s);
  /// Sets the position and the captured SH (nothing = not captured at the new position).
  void setProbePositionRaw(uint64_t id, Vec3 p, const std::optional<ShRgb>& sh);
  void setProbeLockedRaw(uint64_t id, bool locked);
  void setRigRaw(const LightingRig& rig);
  void setSceneLightsRaw(const std::vector<Light>& lights);
  void setImportanceVolumesRaw(const std::vector<ImportanceVolume>& volumes);
  uint64_t allocateId() { return set_.nextId++; }

 signals:
  void sceneChanged();
  void probesAboutToBeReset();
  void probesReset();
  void probeAboutToBeInserted(int row);
  void probeInserted(int row);
  void probeAboutToBeRemoved(int row);
  void probeRemoved(int row);
  void probeChanged(int row);
  void modifiedChanged(bool modified);
  void pathsChanged();
  void rigChanged();
  /// The scene's own lights were edited (setSceneLights) or undone.
  void sceneLightsChanged();
  void importanceVolumesChanged();
  /// volume() changed (baked, loaded, or dropped with the scene).
  void volumeChanged();
  /// volumeState() or volumeStaleReason() changed.
  void volumeStateChanged();
  /// A probe set was opened (openProbeSet) or recovered (recover): its placement settings
  /// (ProbeSet::placement, the method, budget and spacing that placed it) are there to show.
  void probeSetOpened();
  void evaluationsChanged();
  /// A live capture landed: the probe's SH now holds `samples` rays taken at its position, in
  /// `seconds` since the edit that asked for it.
  void liveCaptured(quint64 id, int samples, double seconds);
  /// Background work: a message and the fraction done in [0, 1]. Emitted when the job starts,
  /// when its message changes (a new step), at most every kProgressIntervalMs otherwise, on
  /// a cancel request and at the end (empty message, 1).
  void jobProgress(const QString& message, double fraction);
  /// Background work finished; `error` is empty on success.
  void jobFinished(const QString& error);

 private:
  struct JobResult;
  using JobFn = std::function<void(JobResult&, const std::function<bool(QString, double)>&)>;
  void startJob(const QString& kind, const QString& firstMessage, JobFn work);
  /// runPlacement's job under `kind` ("place" or "propose"; onJobDone applies both alike).
  bool startPlacement(const PlacementRequest& request, const QString& kind);
  void onJobDone();
  void replace(std::shared_ptr<const Scene> scene, std::shared_ptr<const Tracer> tracer,
               ProbeSet set, const QString& scenePath, const QString& setPath);
  /// Takes the volume file beside a probe set just opened (volumePathFor) as volume() (Baked or
  /// Stale, volumeState); drops any other volume.
  void pickUpVolumeBeside(const QString& setPath);
  /// Makes `volume` (saved at `path`, with the volume file's metadata JSON) volume(), baked under
  /// the lighting of `rigGeneration`, and emits volumeChanged. Null drops the volume.
  void setVolume(std::shared_ptr<const ProbeVolume> volume, const QString& path,
                 const std::string& metadataJson, int rigGeneration);
  /// Compares the volume with the probe set (volumeState) and emits volumeStateChanged when the
  /// state or its reason changed. O(probes).
  void refreshVolumeState();
  struct LiveTask;
  struct LiveResult;
  /// Starts the next live capture (quick ones before final ones) unless one runs.
  void pumpLive();
  void onLiveDone();
  /// Drops the queued live captures, cancels the running one and waits for it.
  void stopLive();
  /// Sets a probe's SH from a live capture: no undo step (the edit that asked for it is one).
  void setProbeShLive(uint64_t id, const ShRgb& sh);
  /// What every lighting change does to the captures: live captures of the old light dropped
  /// (the moved probes still waiting are captured with the new one), the volume not current.
  void lightingChanged();
  /// sceneHash() with the scene's lights edited in this session folded in: the key of the
  /// capture and reference caches for the lighting the scene has now; 0 without a file.
  uint64_t lightingSceneHash() const;
  /// Stops the background job (if any) and waits for it.
  void cancelJob();

  std::shared_ptr<const Scene> scene_;
  std::shared_ptr<const Tracer> tracer_;
  /// The set as saved: set_ with the placement source's settings.
  ProbeSet setToSave() const;

  ProbeSet set_;
  std::function<PlacementSettings()> placementSource_;  ///< setPlacementSource()
  std::vector<Light> fileLights_;                       ///< the scene file's lights as loaded
  QString scenePath_, setPath_;
  uint64_t sceneHash_ = 0;
  QString unitHint_;  ///< unitHint()
  QUndoStack undo_;
  bool autoPropose_ = true;
  ProposalSettings proposal_;
  bool busy_ = false;
  bool jobInFlight_ = false;  ///< isJobInFlight()
  int lastMergeKey_ = 0;
  quint64 changeCount_ = 0;
  int generation_ = 0;  ///< bumped by every document replacement; stale jobs are dropped
  QString jobKind_;
  QStringList jobNotes_;
  std::shared_ptr<const ProbeVolume> volume_;
  QString volumePath_;
  /// The set's probes in the volume, in its order: id (0 when the file has no "probe_ids") and
  /// position; volumeIds_ maps an id to its index. volumeExtra_: the volume's own probes in a file
  /// without ids (metadata "leak_probes_added"), which then match no accepted probe.
  std::vector<std::pair<uint64_t, Vec3>> volumeProbes_;
  std::unordered_map<uint64_t, size_t> volumeIds_;
  size_t volumeExtra_ = 0;
  int volumeRigGeneration_ = 0;  ///< rigGeneration_ of the volume's lighting
  VolumeState volumeState_ = VolumeState::None;
  QString volumeStaleReason_;
  std::vector<EvaluationPoint> evaluations_;
  QFutureWatcher<std::shared_ptr<JobResult>>* watcher_ = nullptr;
  LiveCaptureSettings live_;
  /// Probes waiting for a quick / a final live capture: where, and since when (ms since epoch).
  std::map<uint64_t, std::pair<Vec3, qint64>> liveQuick_, liveFinal_;
  int rigGeneration_ = 0;  ///< bumped by every rig change; live captures of an older rig drop
  QFutureWatcher<std::shared_ptr<LiveResult>>* liveWatcher_ = nullptr;
  std::shared_ptr<std::atomic<bool>> liveCancel_;
  QThreadPool livePool_;
  bool liveRunning_ = false;
  bool liveRunningFinal_ = false;
  std::set<uint64_t> liveRunningIds_;  ///< the probes of the running live capture
  std::shared_ptr<std::atomic<bool>> jobCancel_;
  double jobFraction_ = 0;  ///< the running job's last reported fraction
};

}  // namespace ps::ui
