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

DeleteProbesCommand::DeleteProbesCommand(Document* doc, const std::vector<uint64_t>& ids)
    : doc_(doc) {
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

AddProbesCommand::AddProbesCommand(Document* doc, std::vector<Probe> probes, const QString& text)
    : doc_(doc), probes_(std::move(probes)) {
  setText(text);
}

void AddProbesCommand::redo() {
  for (const Probe& p : probes_) doc_->insertProbeRaw(int(doc_->probes().size()), p);
}

void AddProbesCommand::undo() {
  for (auto it = probes_.rbegin(); it != probes_.rend(); ++it) doc_->removeProbeRaw(it->id);
}

MoveProbeCommand::MoveProbeCommand(Document* doc, uint64_t id, Vec3 from, Vec3 to)
    : doc_(doc), probeId_(id), from_(from), to_(to) {
  setText(QStringLiteral("Move probe %1").arg(id));
}

void MoveProbeCommand::redo() {
  doc_->setProbePositionRaw(probeId_, to_);
}
void MoveProbeCommand::undo() {
  doc_->setProbePositionRaw(probeId_, from_);
}

bool MoveProbeCommand::mergeWith(const QUndoCommand* other) {
  const auto* o = static_cast<const MoveProbeCommand*>(other);
  if (o->probeId_ != probeId_) return false;
  to_ = o->to_;
  return true;
}

}  // namespace ps::ui
