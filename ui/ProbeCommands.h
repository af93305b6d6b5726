#pragma once
// One QUndoCommand per kind of probe edit (after Qt's undoframework example). Commands address
// probes by stable id and call the document's raw mutators; they never hold row numbers across
// other commands.
#include <QUndoCommand>
#include <optional>
#include <utility>
#include <vector>

#include "core/io/ProbeSet.h"

namespace ps::ui {

class Document;

/// Sets the state (accept / reject / back to candidate) of several probes.
class SetStateCommand : public QUndoCommand {
 public:
  SetStateCommand(Document* doc, const std::vector<uint64_t>& ids, ProbeState state);
  void undo() override;
  void redo() override;

 private:
  Document* doc_;
  ProbeState state_;
  std::vector<std::pair<uint64_t, ProbeState>> old_;  ///< id, state before
};

/// Deletes several probes; undo puts them back at their rows with their ids.
class DeleteProbesCommand : public QUndoCommand {
 public:
  DeleteProbesCommand(Document* doc, const std::vector<uint64_t>& ids,
                      QUndoCommand* parent = nullptr);
  void undo() override;
  void redo() override;

 private:
  Document* doc_;
  std::vector<std::pair<int, Probe>> removed_;  ///< row, probe; ascending rows
};

/// Appends probes that already carry fresh ids.
class AddProbesCommand : public QUndoCommand {
 public:
  AddProbesCommand(Document* doc, std::vector<Probe> probes, const QString& text,
                   QUndoCommand* parent = nullptr);
  void undo() override;
  void redo() override;

 private:
  Document* doc_;
  std::vector<Probe> probes_;
};

/// Locks or unlocks several probes (placement keeps locked probes; the viewport will not drag
/// them).
class SetLockedCommand : public QUndoCommand {
 public:
  SetLockedCommand(Document* doc, const std::vector<uint64_t>& ids, bool locked);
  void undo() override;
  void redo() override;

 private:
  Document* doc_;
  bool locked_;
  std::vector<std::pair<uint64_t, bool>> old_;  ///< id, locked before
};

/// Moves several probes to new positions. Consecutive commands with the same non-negative merge
/// key and the same probes merge into one undo step (a drag is one step; Qt's undoframework).
/// Undo puts back the positions and the captured SH that the move discarded.
class MoveProbesCommand : public QUndoCommand {
 public:
  static constexpr int kId = 1001;
  struct Entry {
    uint64_t id = 0;
    Vec3 from, to;
    std::optional<ShRgb> fromSh;  ///< the SH captured at `from`, restored by undo
  };
  /// `targets`: probe id and new position; unknown ids are skipped. A negative `mergeKey`
  /// never merges.
  MoveProbesCommand(Document* doc, const std::vector<std::pair<uint64_t, Vec3>>& targets,
                    int mergeKey);
  void undo() override;
  void redo() override;
  int id() const override { return kId; }
  bool mergeWith(const QUndoCommand* other) override;
  const std::vector<Entry>& entries() const { return entries_; }

 private:
  Document* doc_;
  int mergeKey_;
  std::vector<Entry> entries_;
};

/// Replaces the captured SH of several probes (a recapture); undo puts the previous SH back.
class SetShCommand : public QUndoCommand {
 public:
  SetShCommand(Document* doc, std::vector<std::pair<uint64_t, ShRgb>> sh, const QString& text);
  void undo() override;
  void redo() override;

 private:
  Document* doc_;
  std::vector<std::pair<uint64_t, ShRgb>> new_;
  std::vector<std::pair<uint64_t, std::optional<ShRgb>>> old_;
};

/// Replaces the lighting rig (sun, sky, extra lights) of the probe set.
class SetRigCommand : public QUndoCommand {
 public:
  SetRigCommand(Document* doc, LightingRig rig, const QString& text);
  void undo() override;
  void redo() override;

 private:
  Document* doc_;
  LightingRig old_, new_;
};

/// Replaces the importance volumes (boxes weighting where placement puts probes).
class SetImportanceVolumesCommand : public QUndoCommand {
 public:
  SetImportanceVolumesCommand(Document* doc, std::vector<ImportanceVolume> volumes,
                              const QString& text);
  void undo() override;
  void redo() override;

 private:
  Document* doc_;
  std::vector<ImportanceVolume> old_, new_;
};

}  // namespace ps::ui
