#pragma once
// `greedy` as a placement method (core/placement/PlacementMethod.h): its parameters and
// defaults, its dense field and its held-out points. The algorithm is core/placement/Greedy.h.

#include <span>
#include <vector>

#include "core/common/Progress.h"
#include "core/domain/DomainPoints.h"
#include "core/io/ProbeSet.h"
#include "core/placement/DenseField.h"
#include "core/placement/Greedy.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

/// Held-out points per probe of the budget, by default (GreedyMethodSettings::heldOutPerProbe).
/// The error greedy lowers is measured there rather than at the field's own samples, which sit
/// where the field refined and miss most of the volume.
inline constexpr int kGreedyHeldOutPerProbe = 128;
/// Samples per probe of each candidate's own capture: the bake's default
/// (BakeSettings::capture), so that greedy weighs a probe as the bake will capture it.
inline constexpr int kGreedyProbeSpp = 1024;
/// Swap passes at most after the additions (GreedySettings::swapPasses). Swaps move the probes
/// the early additions put down where later ones made them redundant; a pass that gains less
/// than GreedySettings::swapMinGain ends them, so a larger cap costs little.
inline constexpr int kGreedySwapPasses = 4;
/// The field samples nearest to a probe that its swap tries besides the far candidates
/// (GreedySettings::swapNeighbours): a 3 x 3 x 3 block's worth, the local move.
inline constexpr int kGreedySwapNeighbours = 26;
/// Held-out points at most (each keeps its position, SH and its error state).
inline constexpr size_t kMaxGreedyHeldOutPoints = 4000000;
/// Greedy's dense field by default: the light's detail (a point light's fall-off) refines to
/// depth 4, the geometry only to depth 2; boundary samples fill the layer along the walls.
inline constexpr int kGreedyFieldDepth = 4;
inline constexpr int kGreedyFieldSurfaceDepth = 2;

/// greedy's parameters (PlaceParameters names in brackets) with their defaults.
struct GreedyMethodSettings {
  /// The error lowered: perceptual (stops, the default) or energy (rel_rmse). [objective]
  GreedyObjective objective = GreedyObjective::kPerceptual;
  /// Stop at this held-out (or field) error, >= 0, in the objective's unit (RMS stops, or
  /// relative RMS); 0: off [maxError]
  double maxError = 0;
  /// The dense field [fieldSpacingMeters, fieldSurfaceDepth, fieldSamplesPerProbe, prefilter,
  /// fieldMaxSamples]; its seed and importance volumes come from the run.
  DenseFieldSettings field;
  int fieldDepth = -1;  ///< refinement levels, 0 to 8; -1: kGreedyFieldDepth [fieldDepth]
  /// Points per probe of the budget (a budget below 64, or none, counts as 64) drawn in the
  /// domain of interest and captured at the field's samples per probe; the error greedy lowers
  /// is measured at them (drawGreedyHeldOut). 0: at the field's own samples. [heldOutPerProbe]
  int heldOutPerProbe = kGreedyHeldOutPerProbe;
  /// The share of the held-out points spread by volume, in [0, 1]; the rest go where the field
  /// is bright (where the energy objective's errors are largest). -1: by the objective, all of
  /// them for perceptual (a ratio weighs as much in a dim place as in a bright one), half for
  /// energy (greedyHeldOutUniformShare). [heldOutUniformShare]
  double heldOutUniformShare = -1;
  /// Samples per probe of each candidate's own capture (GreedySettings::captureProbeValues);
  /// at most field.samplesPerProbe: the field sample's capture, or with `visibility` a capture
  /// of its own at the field's samples per probe (for its map). [candidateSamplesPerProbe]
  int probeSpp = kGreedyProbeSpp;
  /// The error interpolates as the runtime reads a volume with visibility maps
  /// (GreedySettings::visibility): "visible" (true, the default), or "barycentric".
  /// [interpolant]
  bool visibility = true;
  int swapPasses = kGreedySwapPasses;          ///< >= 0; 0: none [swapPasses]
  int swapNeighbours = kGreedySwapNeighbours;  ///< >= 0 [swapNeighbours]
  /// Regional greedy (core/placement/RegionalGreedy.h): -1 auto (regionalGreedyRegions of the
  /// new probes; plain without a budget), 1 off (plain greedy), N >= 2 that many regions
  /// (budget required). [regions: the word auto or off, or a count]
  int regions = -1;
};

/// Regions at most (GreedyMethodSettings::regions).
inline constexpr int kMaxGreedyRegions = 4096;

/// Throws ps::ParameterError naming the parameter when a setting is out of range for `budget`
/// (0: none) and `keptCount` kept probes.
void checkGreedyMethodSettings(const GreedyMethodSettings& settings, int budget,
                               size_t keptCount = 0);

/// The regions greedy runs with for `settings`, `budget` (0: none) and `keptCount` kept
/// probes: settings.regions, or with auto regionalGreedyRegions of the new probes (1 without a
/// budget). 1: plain greedy.
int greedyRegions(const GreedyMethodSettings& settings, int budget, size_t keptCount);

/// The dense field greedy builds for `settings` and `seed` (its importance volumes are left to
/// the caller).
DenseFieldSettings greedyFieldSettings(const GreedyMethodSettings& settings, uint64_t seed = 1);

/// The share of held-out points spread by volume that `settings` asks for (resolving -1 by its
/// objective).
double greedyHeldOutUniformShare(const GreedyMethodSettings& settings);

/// How many held-out points greedy draws for `settings` and `budget`.
size_t greedyHeldOutPoints(const GreedyMethodSettings& settings, int budget);

/// Greedy's held-out points (GreedySettings::heldOut): about greedyHeldOutPoints() points of the
/// domain of interest, outside geometry and the light clearance as eval's queries are, each
/// captured at the field's samples per probe (also when the field is pre-filtered).
/// Stratified: the domain's bounding box is cut into about cubic cells (about 8 points each on
/// average); a cell gets greedyHeldOutUniformShare of its points by its volume and the rest by the
/// field's squared irradiance there (the largest mean over the 14 normals of the samples whose
/// octree cells overlap it), at least one; each point weighs its cell's volume over the cell's
/// count. The weighted sums estimate eval's uniform sums without bias, with more points where
/// the light is bright, where rel_rmse's absolute errors are largest. Deterministic for `seed`;
/// throws ps::ParameterError for bad settings or importance volumes without volume.
std::vector<HeldOutSample> drawGreedyHeldOut(const Tracer& tracer, const LightingRig& rig,
                                             const GreedyMethodSettings& settings, int budget,
                                             uint64_t seed, const Domain& domain,
                                             const DenseField& field,
                                             const ProgressFn& progress = {});

}  // namespace ps
