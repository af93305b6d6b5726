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
#include "core/placement/Greedy.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

/// Greedy's held-out points per probe and its candidates' capture (PlaceRequest). On the bundled
/// scenes at 32 to 512 probes, they took the rows where greedy's rel_rmse (the mean of field
/// seeds 1 to 4) is at most half of uniform's from 6 to 11 of 15, at 1.8 to 2.7 times the
/// place time at 256 and 512 probes (BENCHMARKS.md, "Greedy measured at held-out points").
inline constexpr int kGreedyHeldOutPerProbe = 128;
inline constexpr int kGreedyProbeSpp = 1024;  ///< the bake's default (BakeSettings::capture)
/// Greedy's swap passes at most by default (GreedySettings::swapPasses). On the bundled scenes
/// (means of field seeds 1 to 4) they took the rows where greedy's rel_rmse is at most half of
/// uniform's from 11 to 14 of 15 (BENCHMARKS.md, "Swaps after greedy's additions"). At 512
/// probes, place took 5 to 7 times as long as without them before the local moves (field seed
/// 1: two-rooms 21 s and 129 s, dream-apartment 29 s and 214 s; "Cheaper swaps"), 12 times
/// with them (24 s and 279 s, 28 s and 335 s; "Local moves in greedy's swaps"), and 10 times
/// with the candidates tried at once (15.5 s and 153 s, 18.7 s and 198 s; "Greedy's trials in
/// parallel").
inline constexpr int kGreedySwapPasses = 4;
/// The field samples nearest to a probe that its swap tries besides the far candidates
/// (GreedySettings::swapNeighbours): a 3 x 3 x 3 block's worth. Two-rooms at 32 probes, field
/// seeds 1 to 4: mean rel_rmse 0.329 with none, 0.317 with 8, 0.290 with 26, 0.296 with 56 and
/// 0.297 with 124. With 26, greedy's rel_rmse fell by 0 to 18 % on the bundled scenes and by 5
/// to 17 % on the shared ones at 32 to 512 probes, and place took 1.5 to 3.2 times as long
/// (BENCHMARKS.md, "Local moves in greedy's swaps"); with the candidates tried at once, 1.1 to
/// 2.1 times stop 23's time at 32 to 512 probes, 1.1 to 1.7 at 512 ("Greedy's trials in
/// parallel", against stop 23's times in the table of "Local moves in greedy's swaps").
inline constexpr int kGreedySwapNeighbours = 26;
/// Held-out points at most (each keeps its position, SH and its error state).
inline constexpr size_t kMaxGreedyHeldOutPoints = 4000000;

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
  /// greedy: held-out points per probe of the budget (a budget below 64, or none, counts as 64),
  /// drawn in the domain of interest (drawGreedyHeldOut) and captured at the field's samples per
  /// probe; the error greedy
  /// lowers is measured at them (GreedySettings::heldOut). 0: on the field's own samples.
  int heldOutPerProbe = kGreedyHeldOutPerProbe;
  /// greedy: the share of the held-out points spread by volume; the rest go where the field is
  /// bright (drawGreedyHeldOut). 1: all by volume.
  double heldOutUniformShare = 0.5;
  /// greedy: samples per probe of each candidate's own capture (GreedySettings::
  /// captureProbeValues), the bake's default; at most field.samplesPerProbe (or 0): the field
  /// sample's capture.
  int probeSpp = kGreedyProbeSpp;
  /// greedy: passes of swaps after the additions (GreedySettings::swapPasses); 0: none.
  int swapPasses = kGreedySwapPasses;
  /// greedy: the nearest field samples each swap tries (GreedySettings::swapNeighbours).
  int swapNeighbours = kGreedySwapNeighbours;
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

/// How many held-out points greedy draws for `request` (PlaceRequest::heldOutPerProbe).
size_t greedyHeldOutPoints(const PlaceRequest& request);

/// Throws ps::ParameterError naming the option when greedy's held-out points or probe spp are
/// out of range.
void checkGreedyRequest(const PlaceRequest& request);

/// Greedy's held-out points (GreedySettings::heldOut) for `request` and its dense field: about
/// greedyHeldOutPoints(request) points of the domain of interest, outside geometry and the light
/// clearance as eval's queries are, each captured at a point at the field's samples per probe
/// (also when the field is pre-filtered). Stratified: the domain's
/// bounding box is cut into equal cells (about 8 points each on average); a cell gets
/// heldOutUniformShare of its points by its volume and the rest by the field's squared
/// irradiance there (the largest mean over the 14 normals of the samples whose octree cells
/// overlap it), at least one; each point weighs its cell's volume over the cell's count. The
/// weighted sums estimate eval's uniform sums without bias, with more points where the light
/// is bright: rel_rmse sums absolute errors, and there they are largest (two-rooms, greedy at
/// 32 probes: the 1 % of eval's queries with the largest errors hold 69 % of the squared
/// error, half of them within 1 m of the point light). Deterministic for request.seed; throws
/// ps::ParameterError for importance volumes without volume.
std::vector<HeldOutSample> drawGreedyHeldOut(const Tracer& tracer, const LightingRig& rig,
                                             const PlaceRequest& request,
                                             std::span<const ImportanceVolume> importanceVolumes,
                                             const DenseField& field,
                                             const ProgressFn& progress = {});

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
