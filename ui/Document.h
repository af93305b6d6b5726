#pragma once
// The editor's document: one scene (with its tracer) and the probe set being edited. Probes are
// addressed by their stable id; every user edit goes through the undo stack (ProbeCommands.h).
// Loads are transactional: a load that throws ps::Error leaves the document as it was.
#include <QFutureWatcher>
#include <QObject>
#include <QString>
#include <QUndoStack>
#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "core/io/ProbeSet.h"
#include "core/scene/Scene.h"

namespace ps {
class Tracer;
}

namespace ps::ui {

/// Settings of the background candidate proposal made when a scene is opened without a set.
struct ProposalSettings {
  double targetProbeCount = 80;  ///< spacing = cbrt(volume of bounds / target)
  int samplesPerProbe = 64;      ///< quick SH capture
};

class Document : public QObject {
  Q_OBJECT
 public:
  explicit Document(QObject* parent = nullptr);
  ~Document() override;

  // --- loading and saving (throw ps::Error; the document is unchanged when they throw) ---

  /// Loads a glTF scene and starts an empty probe set for it (then, when autoPropose() is on,
  /// proposes candidates in the background).
  void openScene(const QString& path);
  /// Loads a probe set. Its scene is loaded too unless `keepScene` and a scene is open.
  void openProbeSet(const QString& path, bool keepScene = false);
  /// Saves atomically to `path` and makes it the document's file; marks the document clean.
  void saveProbeSet(const QString& path);

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
  /// Moves one probe; successive moves of the same probe merge into one undo step.
  void moveProbe(uint64_t id, Vec3 position);

  // --- candidate proposal in the background ---
  bool autoPropose() const { return autoPropose_; }
  void setAutoPropose(bool on) { autoPropose_ = on; }
  ProposalSettings& proposalSettings() { return proposal_; }
  /// Starts uniform placement + quick capture; the result is pushed as one undo command.
  void proposeCandidates();
  bool isBusy() const { return busy_; }

  // --- raw mutators used by the undo commands only (no undo, emit the change signals) ---
  void insertProbeRaw(int row, const Probe& p);
  void removeProbeRaw(uint64_t id);
  void setProbeStateRaw(uint64_t id, ProbeState s);
  void setProbePositionRaw(uint64_t id, Vec3 p);
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
  /// Background work: a message and the fraction done in [0, 1].
  void jobProgress(const QString& message, double fraction);
  /// Background work finished; `error` is empty on success.
  void jobFinished(const QString& error);

 private:
  struct Proposal;
  void replace(std::shared_ptr<const Scene> scene, std::shared_ptr<const Tracer> tracer,
               ProbeSet set, const QString& scenePath, const QString& setPath);
  void onProposalDone();
  /// Stops the background job (if any) and waits for it.
  void cancelJob();

  std::shared_ptr<const Scene> scene_;
  std::shared_ptr<const Tracer> tracer_;
  ProbeSet set_;
  QString scenePath_, setPath_;
  uint64_t sceneHash_ = 0;
  QUndoStack undo_;
  bool autoPropose_ = true;
  ProposalSettings proposal_;
  bool busy_ = false;
  int generation_ = 0;  ///< bumped by every document replacement; stale jobs are dropped
  QFutureWatcher<std::shared_ptr<Proposal>>* watcher_ = nullptr;
  std::shared_ptr<std::atomic<bool>> jobCancel_;
};

}  // namespace ps::ui
