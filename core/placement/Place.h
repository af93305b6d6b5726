#pragma once
// One entry point for every placement method, so that the command line (`probestudio place`)
// and the editor's placement panel run the same code: the request names the method and its
// options, the locked probes of the artist are kept and built around, and the result carries
// each new probe's provenance score and one-line notes on what the method did.

#include <functional>
#include <span>
#include <string>
#include <vector>

#include "core/common/Progress.h"
#include "core/io/ProbeSet.h"
#include "core/math/Vec3.h"
#include "core/placement/DenseField.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

struct PlaceRequest {
  std::string method = "uniform";  ///< one of placementMethods()
  /// uniform: grid spacing; ascent and spawn-merge: their start grid's. 0 = the default (the
  /// scene diagonal / 10, at least 0.25 m) unless a budget is given.
  double spacingMeters = 0;
  /// Probe count, kept probes included where the method says so (uniform: the spacing giving
  /// it within 10 %; greedy: the total; spawn-merge: the cap). 0 = none.
  int budget = 0;
  double maxError = 0;  ///< greedy: stop at this dense-field error; 0 = off
  uint64_t seed = 1;
  /// The dense field (greedy, chajdas). Its importance volumes and seed come from the call, its
  /// depth from fieldDepth.
  DenseFieldSettings field;
  /// Dense field refinement levels; -1: the method's default. Greedy's is kGreedyFieldDepth,
  /// with surfaces splitting cells down to kGreedyFieldSurfaceDepth only (unless
  /// field.maxSurfaceDepth says otherwise) and boundary samples; chajdas keeps field.maxDepth.
  int fieldDepth = -1;
  int ascentIterations = 8;     ///< ascent: steps per probe at most
  double ascentStepMeters = 0;  ///< ascent: first step; 0 = half the start grid's spacing
  bool ascentDirect = false;    ///< ascent: follow the full light, not the indirect only
  double aggressiveness = 1.0;  ///< chajdas: merging strength (> 0); with a budget, bisected
};

/// Greedy's dense field by default: the light's detail (a point light's fall-off) refines to
/// depth 4, the geometry only to depth 2; boundary samples fill the layer along the walls.
/// On cornell at 128 probes this took greedy's rel_rmse from 0.579 (depth 2 without boundary
/// samples) to 0.322 (BENCHMARKS.md, placement).
inline constexpr int kGreedyFieldDepth = 4;
inline constexpr int kGreedyFieldSurfaceDepth = 2;

struct PlacedProbe {
  Vec3 position;
  double score = 0;  ///< method-specific provenance score (Probe::score)
};

struct PlaceOutcome {
  std::vector<PlacedProbe> probes;  ///< the new probes only (kept ones are not repeated)
  double spacingMeters = 0;         ///< the grid or field spacing used (PlacementSettings)
  std::vector<std::string> notes;   ///< what the method did, one line each
};

/// The dense field settings greedy uses for `request` (its field, seed and fieldDepth; the
/// importance volumes are left to the caller).
DenseFieldSettings greedyFieldSettings(const PlaceRequest& request);

/// The method names, sorted.
std::vector<std::string> placementMethods();

/// Reports progress per stage ("place", "field", "greedy", ...): returns the ProgressFn for a
/// stage, or an empty one.
using StageProgress = std::function<ProgressFn(const std::string& stage)>;

/// Runs `request.method`. `kept` are the artist's locked probes (with SH where captured): they
/// stay where they are and new probes are placed around them. Throws ps::ParameterError naming
/// the option for an unknown method or a bad combination (before any tracing), ps::Cancelled
/// when a progress callback returns false.
PlaceOutcome placeProbes(const Tracer& tracer, const LightingRig& rig, const PlaceRequest& request,
                         std::span<const Probe> kept,
                         std::span<const ImportanceVolume> importanceVolumes,
                         const StageProgress& progress = {});

}  // namespace ps
