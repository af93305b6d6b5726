#include "core/placement/Place.h"

#include <algorithm>

#include "core/common/Error.h"
#include "core/placement/Uniform.h"

namespace ps {

namespace {

/// No covering probe comes this near a rejected one (the artist rejected that spot), metres.
constexpr double kCoverageAvoidMeters = 0.5;

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
  if (r.budget > kMaxProbeBudget)
    throw ParameterError("budget", "expected at most " + std::to_string(kMaxProbeBudget) +
                                       " probes (the limit), got " + std::to_string(r.budget));
  createPlacer(findPlacementMethod(r.method), r.parameters, {r.budget, keptProbes(set, r).size()});
}

PlaceResult placeProbeSet(const Tracer& tracer, const ProbeSet& set, const PlaceRequest& r,
                          const StageProgress& progress) {
  checkPlaceRequest(r, set);
  const std::vector<Probe> kept = keptProbes(set, r);
  const auto domain = std::make_shared<const Domain>(
      makeDomain(tracer, importanceBoxes(set.importanceVolumes), r.domain));

  PlaceResult out;
  if (domain->reachable) out.notes.push_back(domain->reachable->summary());
  out.kept = kept.size();
  std::vector<Vec3> rejected;
  std::vector<Vec3> keptAt;
  for (const Probe& p : set.probes)
    if (p.state == ProbeState::Rejected) rejected.push_back(p.position);
  for (const Probe& p : kept) keptAt.push_back(p.position);

  // Coverage first: its probes are kept by the method, which places the rest of the budget.
  std::vector<Probe> methodKept = kept;
  std::vector<Probe> covering;
  std::shared_ptr<const RoomMap> roomMap;
  if (r.cover) {
    CoverageSettings cs = r.coverage;
    cs.seed = r.seed;
    cs.lights = punctualLightPositions(tracer.scene(), set.rig);
    cs.lightClearanceMeters = lightClearanceMeters(tracer, importanceBoxes(set.importanceVolumes),
                                                   kDefaultLightClearanceRelative);
    const CoverageResult cov = coverDomain(tracer, *domain, keptAt, rejected, kCoverageAvoidMeters,
                                           cs, progress ? progress("coverage") : nullptr);
    out.minimumBudget = kept.size() + cov.probes.size();
    roomMap = cov.roomMap;
    if (r.budget != 0 && size_t(r.budget) < out.minimumBudget)
      throw ParameterError(
          "budget",
          formatNote("%d is below the %zu probes that cover the scene: each of its %d "
                     "rooms needs probes of its own and the domain must lie inside "
                     "the probes' hull (%zu kept probes included); give at least %zu",
                     r.budget, out.minimumBudget, cov.rooms, kept.size(), out.minimumBudget));
    if (!cov.roomNote.empty()) out.notes.push_back(cov.roomNote);
    out.notes.push_back(formatNote(
        "coverage: %zu probes give each of the %d rooms probes of its own (%d covered by the kept "
        "probes) and %zu put the domain inside the hull; the smallest budget that covers the "
        "scene is %zu",
        cov.roomProbes, cov.rooms, cov.roomsCoveredByKept, cov.hullProbes, out.minimumBudget));
    if (cov.roomsPartlyCovered > 0)
      out.notes.push_back(formatNote(
          "coverage: in %d rooms more than %.0f %% of the space sees none of the %d probes a room "
          "gets at most from the covering; the method adds where the error asks",
          cov.roomsPartlyCovered, 100 * cs.unseenShare, cs.maxProbesPerRoom));
    for (const Vec3& at : cov.probes) {
      Probe probe;
      probe.position = at;
      probe.state = r.newState;
      probe.method = "coverage";
      covering.push_back(probe);
      methodKept.push_back(probe);
    }
    out.covered = covering.size();
  }

  // A budget the covering fills (or leaves fewer than 4 probes of) gets no method probes: every
  // method needs 4 new ones to place around the kept.
  PlaceOutcome placed;
  if (r.budget == 0 || r.budget - int(methodKept.size()) >= 4) {
    const std::unique_ptr<Placer> placer =
        createPlacer(findPlacementMethod(r.method), r.parameters, {r.budget, methodKept.size()});
    const PlaceContext context{tracer,   set.rig, methodKept, set.importanceVolumes,
                               r.budget, r.seed,  progress,   domain,
                               roomMap};
    placed = placer->place(context);
  } else {
    out.notes.push_back(formatNote("%s adds no probe: the budget leaves %d beyond the covering",
                                   r.method.c_str(), r.budget - int(methodKept.size())));
  }
  for (const std::string& note : placed.notes) out.notes.push_back(note);
  out.set = set;
  out.set.probes.clear();
  for (const Probe& p : set.probes)
    if (p.state == ProbeState::Rejected || keeps(r, p)) out.set.probes.push_back(p);
  for (const Probe& p : covering) out.set.add(p);
  out.set.placement.method = r.method;
  out.set.placement.budget = r.budget;
  out.set.placement.spacingMeters = placed.spacingMeters;
  const double minDistance = 0.5 * placed.spacingMeters;
  for (const PlacedProbe& p : placed.probes) {
    if (withinAny(rejected, p.position, minDistance)) {
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
  if (!r.cover) {
    std::vector<Vec3> all;
    for (const Probe& p : out.set.probes)
      if (p.state != ProbeState::Rejected) all.push_back(p.position);
    const RoomCount dark = roomsWithoutProbes(tracer, *domain, all, r.coverage.rooms);
    if (dark.empty > 0)
      out.notes.push_back(
          formatNote("coverage off: %d of the domain's %d rooms hold no probe "
                     "and read their light through walls",
                     dark.empty, dark.rooms));
  }
  if (out.nearRejected > 0)
    out.notes.push_back(
        formatNote("%zu proposed probes dropped within half the spacing of a "
                   "rejected one",
                   out.nearRejected));
  return out;
}

}  // namespace ps
