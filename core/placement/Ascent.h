#pragma once
// `ascent` placement (Sukys 3.1.2, after Chajdas et al.): probes start on a grid and climb the
// luminance-weighted direction field f (Chajdas sec. 2.1, eq. 1) of their own captures, with
// "second-order" rejection: a step that lands in the dark (behind geometry), inside geometry or
// across a surface is reverted and the step halved. Optionally on indirect-only captures
// ("light decoupling"), so that probes are not all drawn into the lights.
#include <span>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Progress.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

struct AscentSettings {
  int iterations = 8;                            ///< ascent steps per probe at most
  double stepMeters = 0.5;                       ///< first step length
  double minStepMeters = 0.05;                   ///< a probe whose step falls below this stops
  int samplesPerProbe = 64;                      ///< capture at every step
  CaptureMode mode = CaptureMode::IndirectOnly;  ///< Sukys 3.1.2 "light decoupling"
  /// A capture whose mean luminance is below this fraction of the starting probes' mean is dark:
  /// the step is reverted (Sukys 3.1.2, second-order gradient ascent).
  double darkRelative = 1e-3;
  double invalidBackfaceFraction = 0.25;
  uint64_t seed = 1;
};

struct AscentResult {
  std::vector<Vec3> positions;       ///< one per start point, after the ascent
  std::vector<double> travelMeters;  ///< distance each probe moved in total
  size_t steps = 0;                  ///< accepted steps, all probes
  size_t reverted = 0;               ///< rejected steps (dark, inside or across geometry)
  size_t darkProbes = 0;             ///< probes dark from the start (left where they were)
};

/// Climbs every start point along f. Deterministic for a seed. Throws ps::ParameterError for
/// fewer than 1 iteration, a step <= 0 or a minimum step <= 0; ps::Cancelled through `progress`.
AscentResult placeAscent(const Tracer& tracer, const LightingRig& rig, std::span<const Vec3> start,
                         const AscentSettings& settings, const ProgressFn& progress = {});

}  // namespace ps
