#pragma once
// `greedy` placement (ours, error-driven): start from a few field samples
// spanning the domain, tetrahedralize, and repeatedly add the dense-field sample where the
// tetrahedral interpolation of the current probes is worst, until a probe budget or an error
// target is reached. Answers "with N probes, how wrong is the lighting, and where?".
#include <array>
#include <cstddef>
#include <functional>
#include <span>
#include <vector>

#include "core/common/Progress.h"
#include "core/math/Sh.h"
#include "core/placement/DenseField.h"

namespace ps {

/// A point greedy measures its error at but never places a probe on: drawn in the domain of
/// interest (drawGreedyHeldOut in Place.h), its weight making the sums eval's uniform ones.
struct HeldOutSample {
  Vec3 position;
  ShRgb sh;
  ShRgb shStdError;
  double weight = 1;  ///< the volume it stands for (any unit, the same for all)
};

/// A probe's value for greedy's interpolation: its SH and, for the visibility-aware interpolant
/// (GreedySettings::visibility), its visibility map and validity as the bake records them.
struct GreedyProbeValue {
  ShRgb sh;
  /// kVisibilityFloats floats (core/capture/Capture.h), or empty: the probe's visibility is 1.
  std::vector<float> distanceMoments;
  bool inside = false;  ///< the capture found the probe inside geometry: visibility 0
};

/// What greedy lowers at its points (GreedySettings::objective).
enum class GreedyObjective {
  /// The error as the eye sees it: per point, the mean over the 14 normals of the squared
  /// errorStops (core/eval/PerceptualError.h: |log2| of interpolated over reference, both
  /// floored at kAdaptationFloorFraction of the points' median luminance); fieldError is the
  /// weighted RMS in stops, eval's rms stops. A dim room weighs as much as a bright one.
  kPerceptual,
  /// The error's energy: per point, the mean squared difference of the irradiance; fieldError
  /// is sqrt(sum w err^2 / sum w |E|^2), eval's rel_rmse. The bright places dominate it.
  kEnergy,
};

/// "perceptual" or "energy".
const char* greedyObjectiveName(GreedyObjective objective);

struct GreedySettings {
  /// The error lowered. The placement method (GreedyMethodSettings) defaults to kPerceptual;
  /// the algorithm alone, to kEnergy.
  GreedyObjective objective = GreedyObjective::kEnergy;
  /// Total probes in the result, kept probes included; 0 = no budget (maxError must be set).
  int budget = 0;
  /// Stop once the field error (GreedyResult::fieldError: relative for kEnergy, stops for
  /// kPerceptual) is at or below this; 0 = off.
  double maxError = 0;
  /// When > 0, a sample's error counts at most this many times the field's RMS irradiance (next
  /// to a light the irradiance, and any interpolation's error, grows without bound over a tiny
  /// volume). Off by default: eval's rel_rmse is dominated by exactly those places. kEnergy
  /// only: a ratio in stops stays bounded next to a light.
  double errorCapRelative = 0;
  /// Samples within avoidRadius of one of these points (the punctual lights) take no part: no
  /// error, no probe. The same ball eval keeps its queries out of (EvalSettings::
  /// lightClearanceRelative): a probe next to a point light captures a near-singular irradiance
  /// and spreads it over its whole fan of tetrahedra.
  std::vector<Vec3> avoid;
  double avoidRadius = 0;
  /// Held-out points: when given, the error is measured at them alone (with their weights) and
  /// the field's samples are only the candidates. A field sample that becomes a
  /// probe has error 0 from then on, and few samples lie between probes, so the error on the
  /// field's own samples falls faster than the error between the probes does, which is the
  /// error eval measures at its random queries.
  std::vector<HeldOutSample> heldOut;
  /// When set, a candidate's value as a probe is its capture by this function (the bake's
  /// samples per probe) rather than its field sample's cheap capture, whose noise the
  /// interpolation would carry to every point around it. Called once per sample, with batches
  /// of positions; returns one value each (with its visibility map when `visibility`).
  std::function<std::vector<GreedyProbeValue>(std::span<const Vec3>)> captureProbeValues;
  /// The error interpolates as the runtime does with a volume that carries visibility maps
  /// (core/traversal/VisibleInterpolation.h: barycentric weights times each probe's DDGI
  /// visibility of the point, renormalised), from the maps captureProbeValues and the kept
  /// probes give; a probe without one weighs by its barycentric weight alone. Needs
  /// captureProbeValues (ParameterError otherwise). Off: barycentric weights alone.
  bool visibility = false;
  /// Passes of swaps after the additions (placeGreedy), at most; a pass without a swap ends
  /// them, as does one that lowers the error by less than swapMinGain of it. 0: none. The
  /// passes are skipped where the error points' captures do not resolve the light
  /// (GreedyResult::swapsSkipped).
  int swapPasses = 0;
  double swapMinGain = 0.01;
  /// A swap also tries the swapNeighbours field samples nearest to the probe it took out (a
  /// local move: the other candidates come from wherever the error is then largest). 0: none.
  int swapNeighbours = 0;
  /// Tests: after every change, interpolate every point afresh and count those whose kept state
  /// differs (GreedyResult::stateMismatches). Slow.
  bool verifyState = false;
};

/// A probe that placement keeps where it is (locked by the artist), with its captured SH.
struct KeptProbe {
  Vec3 position;
  ShRgb sh;
  std::vector<float> distanceMoments;  ///< as GreedyProbeValue's
  bool inside = false;
};

struct GreedyResult {
  /// The new probes (field samples), in the order they were added (a swapped-in probe takes
  /// the slot of the one it replaced); the first ones are the initial samples spanning the
  /// domain, or those swapped in for them.
  std::vector<Vec3> positions;
  std::vector<size_t> sampleIndex;  ///< index into DenseField::samples of each new probe
  /// Per new probe: its error (as in fieldError, for that one sample) when it was added (or
  /// swapped in); 0 for the initial samples that stayed, added before any interpolation existed.
  std::vector<double> scores;
  /// How many of `positions` are initial samples (or were, before a swap replaced them).
  size_t initialCount = 0;
  /// fieldError after the initial set (index 0) and after each greedy addition (index i).
  std::vector<double> errorHistory;
  double fieldError = 0;  ///< at the end
  /// The sum fieldError is normalised by (fieldError^2 * errorNorm is the weighted squared
  /// error): the points' sum of weight |E|^2 for kEnergy, their sum of weights for kPerceptual.
  double errorNorm = 0;
  /// True when, at some point, no candidate lowered the field error (the field's noise, or error
  /// its samples do not resolve):
  /// without a budget placement stops there; with one it goes on, adding the least harmful
  /// candidate whenever none lowers the error and the best one otherwise, so errorHistory is
  /// non-increasing only up to probesAtNoImprovement (on the real scenes the field error still
  /// falls overall).
  bool noImprovement = false;
  size_t probesAtNoImprovement = 0;  ///< probe count (kept included) when that first happened
  size_t trials = 0;                 ///< meshes tried (candidates evaluated)
  /// kPerceptual: the weighted share of the error points whose capture resolves no light
  /// (greedy::ErrorPoints::unresolvedShare); 0 for kEnergy.
  double unresolvedShare = 0;
  /// The swap passes were skipped: more than kGreedyUnresolvedShareLimit of the error points
  /// resolve no light (unresolvedShare), so a move's measured gain would be mostly their
  /// noise. Measured on a generated level of 233 rooms (93 % unresolved), the swaps lowered
  /// greedy's own error by 23 % but eval's RMS stops by 1.7 %, within its noise, and raised its
  /// rel_rmse by 4 %, at 74 % of the run's trials.
  bool swapsSkipped = false;
  size_t reevaluations = 0;  ///< points re-interpolated after the first mesh (locality measure)
  size_t swapPasses = 0;     ///< swap passes run
  size_t swaps = 0;          ///< moves the swaps made (a slot moved twice counts twice)
  size_t localSwaps = 0;     ///< of swaps, moves to one of the nearest samples (swapNeighbours)
  size_t swapTries = 0;      ///< probes taken out and tried elsewhere (moved or not)
  size_t swapTrials = 0;     ///< of trials, those the swaps made
  std::vector<double> swapErrorHistory;  ///< fieldError after each swap pass
  /// With GreedySettings::verifyState: points whose kept state differed from a fresh
  /// interpolation, summed over the changes.
  size_t stateMismatches = 0;
};

/// Above this share of unresolved error points (GreedyResult::unresolvedShare), the
/// perceptual objective mostly measures the captures' noise: placement warns, and the swaps
/// are skipped.
inline constexpr double kGreedyUnresolvedShareLimit = 0.5;

/// Whether greedy skips the `swapPasses` asked for (GreedyResult::swapsSkipped) when its error
/// points' unresolved share is `unresolvedShare`.
inline bool greedySwapsSkipped(int swapPasses, double unresolvedShare) {
  return swapPasses > 0 && unresolvedShare > kGreedyUnresolvedShareLimit;
}

/// The irradiance luminance of `sh` for the 14 fixed normals the error is measured with (the 6
/// axes and the 8 cube diagonals).
std::array<double, 14> greedyErrorNormalsIrradiance(const ShRgb& sh);

/// The volume a field sample stands for in the field error: its octree cell's (0 for a split
/// cell, whose children cover it); a boundary sample, the half of its slab nearer the wall
/// (cell face area times slab / 2).
double greedySampleWeight(const FieldSample& sample);

/// The parameter checks of placeGreedy, to run before building a dense field for it: throws
/// ps::ParameterError naming the setting (budget, maxError, swapPasses, swapNeighbours,
/// swapMinGain).
void checkGreedySettings(const GreedySettings& settings, size_t keptCount);

/// Greedy placement over `field`. The squared error of a sample is the mean over the 14 fixed
/// normals of the squared error (GreedyObjective: a difference of irradiance luminance, or a
/// log2 ratio in stops) between the irradiance interpolated from the
/// probes (Delaunay tetrahedra, barycentric weights, clamped to the hull outside it:
/// core/traversal) and the sample's own, less the variance of the sample's capture noise
/// (from shStdError, in the objective's unit), floored at 0 and capped by errorCapRelative when
/// set. Samples are weighted by greedySampleWeight (uniform weights when the field records no
/// cell sizes). kEnergy: fieldError = sqrt(sum w err^2 / sum w |E|^2), eval's rel_rmse on the
/// field as a volume average; kPerceptual: fieldError = sqrt(sum w err^2 / sum w), eval's RMS
/// stops. With held-out points (GreedySettings::heldOut) the same sums run over them instead,
/// with their weights: eval's figure on points that are never probes.
/// The initial probes: the kept ones, plus the field samples nearest to the 8 corners of the
/// field's bounding box (only the 4 alternate corners when the budget is smaller than
/// kept + 8). Each addition tries candidates from the tetrahedra holding the most weighted
/// error (in each, the worst sample and the sample nearest the centroid of its samples),
/// re-tetrahedralizing with each, and keeps the one leaving the lowest field error; only the
/// samples whose tetrahedron disappeared, or that are outside the hull near a change of its
/// faces, are re-interpolated.
/// An addition never raises the field error until none can lower it (noImprovement).
/// Then, with swapPasses, swaps: each new probe in turn (the initial ones too) is taken out, and
/// the best of it, the candidates of the 8 tetrahedra then holding the most error and the
/// swapNeighbours free samples nearest to it goes in its place; a pass that moves no probe, or
/// gains less than swapMinGain, ends them.
/// After the first pass, only the probes a move touched (the moved ones and those sharing a
/// tetrahedron with them, before or after the move) are taken out again (a heuristic: a
/// probe left alone may have missed a gain elsewhere).
/// A swap never raises the error, and
/// errorHistory stays that of the additions (fieldError is after the swaps).
/// Throws ps::ParameterError when neither budget nor maxError is set, a budget is below 4 or
/// below kept + 4 or above kept plus the field's free samples (outside the light clearance),
/// the field has fewer than 4 samples or is black, the initial probes span less than 3D, or
/// visibility is asked for without captureProbeValues ("interpolant"); ps::Cancelled through
/// `progress`.
GreedyResult placeGreedy(const DenseField& field, std::span<const KeptProbe> kept,
                         const GreedySettings& settings, const ProgressFn& progress = {});

}  // namespace ps
