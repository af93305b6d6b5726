#pragma once
// Error as the eye sees it: the ratio of the interpolated to the reference irradiance, in stops
// (log2), with a floor at a fraction of the scene's adaptation level. rel_rmse (Evaluate.h) is
// the error's energy over the light's: the bright places dominate it, so a dim room can be
// wrong by half and barely move it. The eye responds to ratios of luminance, not differences
// (Weber-Fechner: the just-noticeable difference is a constant fraction of the luminance over
// the photopic range), which is why HDR-VDP and FLIP compare luminances on a logarithmic scale.
// Far below the level the eye is adapted to, that constant fraction no longer holds: the
// threshold-versus-intensity curve flattens to an absolute threshold (HDR-VDP's
// threshold-versus-intensity function), so near-black against black must not count as
// infinitely wrong. The floor stands for it: values below it are seen as the floor.
//
// The per-value measure and its constants live here, below every stage (eval reports it,
// greedy placement lowers it); core/eval/PerceptualError.h summarises it over eval's queries.

#include <algorithm>
#include <cmath>

namespace ps {

/// The floor, as a fraction of the median reference luminance of the queries (the level a
/// viewer of the scene is adapted to): 5 %, a little over 4 stops below the median. A dim room
/// at a tenth of the median is 1.3 stops above it and counts in full.
inline constexpr double kAdaptationFloorFraction = 0.05;

/// Errors of at least this many stops count as visible (EvalStops::beyondThirdStop): a third of
/// a stop is the step of a camera's exposure settings, about the smallest change of a whole
/// room's brightness an artist corrects.
inline constexpr double kVisibleStops = 1.0 / 3.0;

/// |log2(max(estimate, floorLuminance) / max(reference, floorLuminance))| in stops: 0 when both are
/// at or below the floor, 1 when the estimate is twice or half the reference above it.
/// `floorLuminance` > 0; negative values count as 0 (below the floor).
inline double errorStops(double estimate, double reference, double floorLuminance) {
  return std::abs(
      std::log2(std::max(estimate, floorLuminance) / std::max(reference, floorLuminance)));
}

}  // namespace ps
