#pragma once
// One QUndoCommand per kind of probe edit (after Qt's undoframework example). Commands address
// probes by stable id and call the document's raw mutators; they never hold row numbers across
// other commands.
#include <QUndoCommand>
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
  DeleteProbesCommand(Document* doc, const std::vector<uint64_t>& ids);
  void undo() override;
  void redo() override;

 private:
  Document* doc_;
  std::vector<std::pair<int, Probe>> removed_;  ///< row, probe; ascending rows
};

/// Appends probes that already carry fresh ids.
class AddProbesCommand : public QUndoCommand {
 public:
  AddProbesCommand(Document* doc, std::vector<Probe> probes, const QString& text);
  void undo() override;
  void redo() override;

 private:
  Document* doc_;
  std::vector<Probe> probes_;
};

/// Moves one probe; consecutive moves of the same probe merge (a drag is one undo step).
class MoveProbeCommand : public QUndoCommand {
 public:
  static constexpr int kId = 1001;
  MoveProbeCommand(Document* doc, uint64_t id, Vec3 from, Vec3 to);
  void undo() override;
  void redo() override;
  int id() const override { return kId; }
  bool mergeWith(const QUndoCommand* other) override;

 private:
  Document* doc_;
  uint64_t probeId_;
  Vec3 from_, to_;
};

}  // namespace ps::ui
