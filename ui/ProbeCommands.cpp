#include "ui/ProbeCommands.h"

#include <algorithm>

#include "ui/Document.h"

namespace ps::ui {

namespace {
QString plural(size_t n) {
  return n == 1 ? QStringLiteral("1 probe") : QStringLiteral("%1 probes").arg(n);
}
QString stateVerb(ProbeState s) {
  switch (s) {
    case ProbeState::Accepted:
      return QStringLiteral("Accept");
    case ProbeState::Rejected:
      return QStringLiteral("Reject");
    case ProbeState::Candidate:
      break;
  }
  return QStringLiteral("Reset");
}
}  // namespace

SetStateCommand::SetStateCommand(Document* doc, const std::vector<uint64_t>& ids, ProbeState state)
    : doc_(doc), state_(state) {
  for (uint64_t id : ids)
    if (const Probe* p = doc->probe(id)) old_.emplace_back(id, p->state);
  setText(QStringLiteral("%1 %2").arg(stateVerb(state), plural(old_.size())));
}

void SetStateCommand::redo() {
  for (const auto& [id, old] : old_) doc_->setProbeStateRaw(id, state_);
}

void SetStateCommand::undo() {
  for (const auto& [id, old] : old_) doc_->setProbeStateRaw(id, old);
}

DeleteProbesCommand::DeleteProbesCommand(Document* doc, const std::vector<uint64_t>& ids,
                                         QUndoCommand* parent)
    : QUndoCommand(parent), doc_(doc) {
  for (uint64_t id : ids) {
    const int row = doc->indexOf(id);
    if (row >= 0) removed_.emplace_back(row, doc->probes()[row]);
  }
  std::sort(removed_.begin(), removed_.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  removed_.erase(std::unique(removed_.begin(), removed_.end(),
                             [](const auto& a, const auto& b) { return a.first == b.first; }),
                 removed_.end());
  setText(QStringLiteral("Delete %1").arg(plural(removed_.size())));
}

void DeleteProbesCommand::redo() {
  for (auto it = removed_.rbegin(); it != removed_.rend(); ++it)
    doc_->removeProbeRaw(it->second.id);
}

void DeleteProbesCommand::undo() {
  for (const auto& [row, probe] : removed_) doc_->insertProbeRaw(row, probe);
}

AddProbesCommand::AddProbesCommand(Document* doc, std::vector<Probe> probes, const QString& text,
                                   QUndoCommand* parent)
    : QUndoCommand(parent), doc_(doc), probes_(std::move(probes)) {
  setText(text);
}

void AddProbesCommand::redo() {
  for (const Probe& p : probes_) doc_->insertProbeRaw(int(doc_->probes().size()), p);
}

void AddProbesCommand::undo() {
  for (auto it = probes_.rbegin(); it != probes_.rend(); ++it) doc_->removeProbeRaw(it->id);
}

SetLockedCommand::SetLockedCommand(Document* doc, const std::vector<uint64_t>& ids, bool locked)
    : doc_(doc), locked_(locked) {
  for (uint64_t id : ids)
    if (const Probe* p = doc->probe(id)) old_.emplace_back(id, p->locked);
  setText(QStringLiteral("%1 %2").arg(locked ? "Lock" : "Unlock", plural(old_.size())));
}

void SetLockedCommand::redo() {
  for (const auto& [id, old] : old_) doc_->setProbeLockedRaw(id, locked_);
}

void SetLockedCommand::undo() {
  for (const auto& [id, old] : old_) doc_->setProbeLockedRaw(id, old);
}

MoveProbesCommand::MoveProbesCommand(Document* doc,
                                     const std::vector<std::pair<uint64_t, Vec3>>& targets,
                                     int mergeKey)
    : doc_(doc), mergeKey_(mergeKey) {
  for (const auto& [id, to] : targets)
    if (const Probe* p = doc->probe(id)) entries_.push_back({id, p->position, to, p->sh});
  setText(entries_.size() == 1 ? QStringLiteral("Move probe %1").arg(entries_[0].id)
                               : QStringLiteral("Move %1").arg(plural(entries_.size())));
}

void MoveProbesCommand::redo() {
  for (const Entry& e : entries_) doc_->setProbePositionRaw(e.id, e.to, std::nullopt);
}

void MoveProbesCommand::undo() {
  for (const Entry& e : entries_) doc_->setProbePositionRaw(e.id, e.from, e.fromSh);
}

bool MoveProbesCommand::mergeWith(const QUndoCommand* other) {
  const auto* o = static_cast<const MoveProbesCommand*>(other);
  if (mergeKey_ < 0 || o->mergeKey_ != mergeKey_ || o->entries_.size() != entries_.size())
    return false;
  for (size_t i = 0; i < entries_.size(); ++i)
    if (o->entries_[i].id != entries_[i].id) return false;
  for (size_t i = 0; i < entries_.size(); ++i) entries_[i].to = o->entries_[i].to;
  return true;
}

SetShCommand::SetShCommand(Document* doc, std::vector<std::pair<uint64_t, ShRgb>> sh,
                           const QString& text)
    : doc_(doc), new_(std::move(sh)) {
  for (const auto& [id, value] : new_)
    if (const Probe* p = doc->probe(id)) old_.emplace_back(id, p->sh);
  setText(text);
}

void SetShCommand::redo() {
  for (const auto& [id, sh] : new_)
    if (const Probe* p = doc_->probe(id)) doc_->setProbePositionRaw(id, p->position, sh);
}

void SetShCommand::undo() {
  for (const auto& [id, sh] : old_)
    if (const Probe* p = doc_->probe(id)) doc_->setProbePositionRaw(id, p->position, sh);
}

SetRigCommand::SetRigCommand(Document* doc, LightingRig rig, const QString& text)
    : doc_(doc), old_(doc->probeSet().rig), new_(std::move(rig)) {
  setText(text);
}

void SetRigCommand::redo() {
  doc_->setRigRaw(new_);
}

void SetRigCommand::undo() {
  doc_->setRigRaw(old_);
}

SetImportanceVolumesCommand::SetImportanceVolumesCommand(Document* doc,
                                                         std::vector<ImportanceVolume> volumes,
                                                         const QString& text)
    : doc_(doc), old_(doc->probeSet().importanceVolumes), new_(std::move(volumes)) {
  setText(text);
}

void SetImportanceVolumesCommand::redo() {
  doc_->setImportanceVolumesRaw(new_);
}

void SetImportanceVolumesCommand::undo() {
  doc_->setImportanceVolumesRaw(old_);
}

}  // namespace ps::ui
