#pragma once
// Regional greedy placement (ours): greedy (core/placement/Greedy.h) run on the regions of a
// k-d split of the dense field, with the probe budget shared between the regions by the error
// each measured. A plain greedy trial re-meshes all N probes, and an addition tries a fixed
// number of candidates, so N additions cost about N^2 log N; a region holds about
// N / regions probes, so the regions together cost about N log N for a fixed region size.
#include <cstddef>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "core/common/Progress.h"
#include "core/domain/Rooms.h"
#include "core/math/Vec3.h"
#include "core/placement/DenseField.h"
#include "core/placement/Greedy.h"

namespace ps {

/// New probes per region that `--regions auto` aims for (regionalGreedyRegions).
inline constexpr int kRegionalProbesPerRegion = 128;
/// `--regions auto` runs plain greedy up to this many new probes.
inline constexpr int kRegionalMinNewProbes = 512;
/// The first pass measures each region's error up to this many times its share of the budget
/// (by held-out weight), so that a region whose error keeps falling can take more than its share.
inline constexpr double kRegionalOvershoot = 2.0;

/// The regions `auto` gives for `newProbes` new probes: 1 (plain greedy) up to
/// kRegionalMinNewProbes, then newProbes / kRegionalProbesPerRegion rounded down.
int regionalGreedyRegions(size_t newProbes);

/// A function capturing candidates' values (GreedySettings::captureProbeValues) for one region
/// and one pass: its random streams must depend only on (region, pass) and the order of its own
/// calls, so that the regions, run at once, give the same result whatever the thread count.
using RegionCaptureFactory =
    std::function<std::function<std::vector<GreedyProbeValue>(std::span<const Vec3>)>(size_t region,
                                                                                      int pass)>;

/// One region of a regional run.
struct GreedyRegion {
  Bounds3 box;                ///< of its field samples, metres
  size_t samples = 0;         ///< field samples (its candidates)
  size_t heldOut = 0;         ///< held-out points measured in it
  size_t kept = 0;            ///< kept probes in it
  size_t measuredProbes = 0;  ///< new probes the first pass placed (its errorHistory's reach)
  size_t probes = 0;          ///< new probes it got in the result
  /// Its share of the total weighted squared error (the objective's unit squared times
  /// volume) with `probes`, after the swaps, and the sum its error is normalised by
  /// (GreedyResult::errorNorm).
  double weightedErrSq = 0;
  double errorNorm = 0;
  bool swapsSkipped = false;  ///< GreedyResult::swapsSkipped: its light is mostly unresolved
  std::string refused;        ///< non-empty: greedy refused the region (why); it got no new probes
};

struct RegionalGreedyResult {
  /// The new probes, region by region in region order, each region's in its greedy order.
  std::vector<Vec3> positions;
  std::vector<size_t> sampleIndex;  ///< into the whole field's samples
  std::vector<double> scores;       ///< as GreedyResult::scores
  std::vector<GreedyRegion> regions;
  /// sqrt(sum of the regions' weighted squared errors / sum of their norms): the objective's
  /// figure over the regions' own meshes (a point is interpolated from its region's probes).
  double fieldError = 0;
  /// kPerceptual: the weighted share of the error points whose capture resolves no light
  /// (GreedyResult::unresolvedShare over the regions, weighted by their errorNorm); 0 for kEnergy.
  double unresolvedShare = 0;
  size_t trials = 0;  ///< meshes tried, over both passes
  size_t swaps = 0;   ///< moves the second pass's swaps made
};

/// Regional greedy over `field`, for `regions` >= 2 regions (settings as placeGreedy's; the
/// budget must be set and counts the kept probes).
///
/// 1. Split: the field's samples are cut across the longest axis of their bounding box,
///    recursively, region counts halved (a count R splits into R / 2 and R - R / 2), where the
///    held-out points' weight (the samples without held-out points) parts in that ratio, each
///    cut moved to the nearest change of the samples' coordinate so that a plane parts the
///    regions; held-out points and kept probes go by the same planes. With `rooms`, every room
///    that weighs at most a region's share then goes whole to the region holding most of its
///    samples (its samples, held-out points and kept probes with it), so that regions are
///    unions of rooms and their borders run along walls; a larger room (a storey's corridors
///    joined into one space) and what lies in no room keep their k-d regions. The regions'
///    budgets and times then come out alike: on the full generated level (25 regions), whole
///    corridors gave four regions 3 to 4 times the others' share, and those four took 24 to
///    46 s each against 0.5 to 5 s.
/// 2. Measure: each region runs greedy's additions (no swaps) on its own samples and held-out
///    points up to kRegionalOvershoot times its share of the new probes (by held-out weight, or
///    samples without held-out points; at least 8, at most its free samples), recording the
///    weighted squared error after each addition.
/// 3. Share: every region keeps its initial probes; the rest of the budget goes to the steps of
///    the regions' error curves (their lower convex hulls, so a step's drop per probe falls along
///    a region) with the largest drop in weighted squared error per probe, across regions (a
///    k-way merge; ties to the lower region). A region whose light does not change gets few.
/// 4. Place: each region runs greedy again with its share as budget, with the swaps.
/// Regions run at once over the cores; their results are merged in region order, so the result
/// is deterministic for the settings and captureFor. A region greedy refuses (black, flat)
/// gets no new probes and says why (GreedyRegion::refused). Throws ps::ParameterError when the
/// budget is not set, leaves fewer than 8 new probes per region, or exceeds the free samples;
/// ps::Cancelled through `progress`.
RegionalGreedyResult placeRegionalGreedy(const DenseField& field, std::span<const KeptProbe> kept,
                                         const GreedySettings& settings, int regions,
                                         const RegionCaptureFactory& captureFor,
                                         const ProgressFn& progress = {},
                                         const RoomMap* rooms = nullptr);

}  // namespace ps
