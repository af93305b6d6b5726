#pragma once
// The whole `place` step, called alike by the command line (`probestudio place`) and the
// editor's placement panel, so that both give the same probe set for the same request: which
// probes of the existing set stay, the method (core/placement/PlacementMethod.h) and the
// provenance the set records.

#include <functional>
#include <string>
#include <vector>

#include "core/common/Progress.h"
#include "core/io/ProbeSet.h"
#include "core/placement/Coverage.h"
#include "core/placement/PlacementMethod.h"
#include "core/trace/Tracer.h"

namespace ps {

struct PlaceRequest {
  std::string method = "uniform";  ///< one of placementMethods()
  /// Probe count, kept probes included where the method says so (uniform: the spacing giving it
  /// within 10 %; greedy: the total; chajdas: the aggressiveness giving it; spawn-merge: the
  /// cap). 0: none.
  int budget = 0;
  uint64_t seed = 1;
  PlaceParameters parameters;  ///< the method's own (PlacementMethod::parameters)
  /// Which probes of the existing set stay where they are and are placed around: the locked
  /// ones always, the accepted ones with keepAccepted, the unlocked candidates with
  /// keepCandidates. Rejected probes stay in the set, rejected, and no new probe comes within
  /// half the method's spacing of one (the artist rejected that spot). The rest are replaced.
  bool keepAccepted = false;
  bool keepCandidates = false;
  /// Coverage first (core/placement/Coverage.h): probes that give every room of the domain
  /// probes of its own and put the domain inside the probes' hull, placed around the kept
  /// probes before the method and kept by it (method "coverage"). With a budget, the method
  /// places the rest; a budget below the covering is refused with its size. Off: the method
  /// alone, and the result's notes say how many rooms hold no probe.
  bool cover = true;
  CoverageSettings coverage;
  ProbeState newState = ProbeState::Candidate;  ///< of the new probes
  /// The domain of interest where the set has no importance volume (DomainPoints.h).
  DomainSettings domain;
};

struct PlaceResult {
  /// The existing set with the probes that stay (in their order, with their ids), then the new
  /// probes (new ids from the set's nextId); placement provenance set.
  ProbeSet set;
  std::vector<std::string> notes;  ///< what the method did, one line each
  size_t kept = 0;                 ///< probes placed around
  size_t covered = 0;              ///< new probes of the covering (PlaceRequest::cover)
  /// Kept plus covering probes: the smallest budget that covers the scene (0 without cover).
  size_t minimumBudget = 0;
  size_t placed = 0;        ///< new probes of the method
  size_t nearRejected = 0;  ///< the method's probes dropped beside a rejected one
};

/// The probes of `set` that `request` keeps and places around (PlaceRequest::keepAccepted).
std::vector<Probe> keptProbes(const ProbeSet& set, const PlaceRequest& request);

/// Checks `request` against `set` (the method, its parameters, the budget against the kept
/// probes) without tracing: throws ps::ParameterError naming the parameter ("method",
/// "budget", or one of the method's).
void checkPlaceRequest(const PlaceRequest& request, const ProbeSet& set);

/// Reports progress per stage ("place", "field", "greedy", ...): returns the
/// ProgressFn for a stage, or an empty one.
using StageProgress = std::function<ProgressFn(const std::string& stage)>;

/// Places probes in `set`'s scene (traced by `tracer`) with `set`'s rig and importance volumes:
/// keeps the probes PlaceRequest says, runs the method around them, drops its probes beside
/// rejected ones, and records the method, budget and spacing in the result's
/// PlacementSettings. Deterministic for request.seed. Throws ps::ParameterError as
/// checkPlaceRequest does (before any tracing) or for what only the scene can tell;
/// ps::Cancelled when a progress callback returns false.
PlaceResult placeProbeSet(const Tracer& tracer, const ProbeSet& set, const PlaceRequest& request,
                          const StageProgress& progress = {});

}  // namespace ps
