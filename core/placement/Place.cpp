#include "core/placement/Place.h"

#include <algorithm>

#include "core/common/Error.h"

namespace ps {

namespace {

bool keeps(const PlaceRequest& r, const Probe& p) {
  return p.state != ProbeState::Rejected &&
         (p.locked || (r.keepAccepted && p.state == ProbeState::Accepted) ||
          (r.keepCandidates && p.state == ProbeState::Candidate));
}

}  // namespace

std::vector<Probe> keptProbes(const ProbeSet& set, const PlaceRequest& r) {
  std::vector<Probe> kept;
  for (const Probe& p : set.probes)
    if (keeps(r, p)) kept.push_back(p);
  return kept;
}

void checkPlaceRequest(const PlaceRequest& r, const ProbeSet& set) {
  createPlacer(findPlacementMethod(r.method), r.parameters, {r.budget, keptProbes(set, r).size()});
}

PlaceResult placeProbeSet(const Tracer& tracer, const ProbeSet& set, const PlaceRequest& r,
                          const StageProgress& progress) {
  const std::vector<Probe> kept = keptProbes(set, r);
  const std::unique_ptr<Placer> placer =
      createPlacer(findPlacementMethod(r.method), r.parameters, {r.budget, kept.size()});
  const PlaceContext context{tracer,
                             set.rig,
                             kept,
                             set.importanceVolumes,
                             r.budget,
                             r.seed,
                             progress,
                             std::make_shared<const Domain>(makeDomain(
                                 tracer, importanceBoxes(set.importanceVolumes), r.domain))};
  const PlaceOutcome placed = placer->place(context);

  PlaceResult out;
  if (context.domain->reachable) out.notes.push_back(context.domain->reachable->summary());
  for (const std::string& note : placed.notes) out.notes.push_back(note);
  out.kept = kept.size();
  out.set = set;
  std::vector<Vec3> rejected;
  out.set.probes.clear();
  for (const Probe& p : set.probes)
    if (p.state == ProbeState::Rejected) {
      rejected.push_back(p.position);
      out.set.probes.push_back(p);
    } else if (keeps(r, p)) {
      out.set.probes.push_back(p);
    }
  out.set.placement.method = r.method;
  out.set.placement.budget = r.budget;
  out.set.placement.spacingMeters = placed.spacingMeters;
  const double minDistance = 0.5 * placed.spacingMeters;
  for (const PlacedProbe& p : placed.probes) {
    if (std::any_of(rejected.begin(), rejected.end(),
                    [&](const Vec3& q) { return length(q - p.position) < minDistance; })) {
      ++out.nearRejected;
      continue;
    }
    Probe probe;
    probe.position = p.position;
    probe.state = r.newState;
    probe.method = r.method;
    probe.score = p.score;
    out.set.add(probe);
    ++out.placed;
  }
  if (out.nearRejected > 0)
    out.notes.push_back(
        formatNote("%zu proposed probes dropped within half the spacing of a "
                   "rejected one",
                   out.nearRejected));
  return out;
}

}  // namespace ps
