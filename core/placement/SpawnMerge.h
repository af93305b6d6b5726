#pragma once
// `spawn-merge` placement (Sukys 3.1.1): start from a uniform grid of captured probes, then
// repeatedly merge pairs of nearby probes whose lighting is similar (one probe at their
// midpoint) and spawn a probe at the midpoint of neighbours whose lighting differs, until
// nothing changes, an iteration limit or the probe cap.
#include <span>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Progress.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

struct SpawnMergeSettings {
  double spacingMeters = 1.0;  ///< the start grid's spacing: distances below are relative to it
  int maxIterations = 6;
  size_t maxProbes = 256;  ///< the probe cap (Sukys: "maximum number of light probes reached")
  /// Neighbours closer than mergeDistance * spacing whose relative SH
  /// difference is below mergeDifference merge into one probe at their midpoint.
  double mergeDistance = 0.75;
  double mergeDifference = 0.1;
  /// Neighbours farther apart than spawnMinDistance * spacing and closer than
  /// spawnMaxDistance * spacing whose difference exceeds spawnDifference get a probe at their
  /// midpoint (when the edge crosses no surface and the midpoint is not inside geometry).
  double spawnMinDistance = 0.3;
  double spawnMaxDistance = 2.0;
  double spawnDifference = 0.3;
  int samplesPerProbe = 64;
  double invalidBackfaceFraction = 0.25;
  uint64_t seed = 1;
};

struct SpawnMergeProbe {
  Vec3 position;
  double score = 0;  ///< the relative SH difference that spawned it; 0 for grid and merged ones
};

struct SpawnMergeResult {
  std::vector<SpawnMergeProbe> probes;  ///< the new probes (kept ones not included)
  size_t spawned = 0, merged = 0;       ///< over all iterations
  int iterations = 0;
};

/// The relative difference of two probes' lighting: the L2 distance between the luminances of
/// their 9 SH coefficients over the larger norm (0 = identical, up to 2).
double shRelativeDifference(const ShRgb& a, const ShRgb& b);

/// Spawn-and-merge from `start` (the grid), with `kept` probes (locked) taking part in the
/// comparisons but never merged or moved. Neighbours are the pairs closer than
/// max(spawnMaxDistance, mergeDistance) * spacing. Deterministic for a seed. Throws
/// ps::ParameterError for a spacing <= 0 or fewer than 1 iteration; ps::Cancelled through
/// `progress`.
SpawnMergeResult placeSpawnMerge(const Tracer& tracer, const LightingRig& rig,
                                 std::span<const Vec3> start, std::span<const Vec3> kept,
                                 const SpawnMergeSettings& settings,
                                 const ProgressFn& progress = {});

}  // namespace ps
