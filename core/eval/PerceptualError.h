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

#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "core/eval/Evaluate.h"
#include "core/math/Vec3.h"

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
double errorStops(double estimate, double reference, double floorLuminance);

/// kAdaptationFloorFraction times the median of the queries' reference luminances; when that
/// median is 0 (a mostly black scene), the same fraction of the mean; 1e-12 when all are 0.
double adaptationFloor(std::span<const EvalQuery> queries);

/// A set of per-query errors in stops, summarised.
struct EvalStops {
  size_t queries = 0;
  double rms = 0;              ///< sqrt(mean of the squared stops)
  double median = 0;           ///< 50th percentile (nearest rank)
  double p90 = 0;              ///< 90th percentile (nearest rank)
  double beyondThirdStop = 0;  ///< fraction of the queries with at least kVisibleStops
};

/// The summary of `stops` (all zero when empty).
EvalStops summarizeStops(std::span<const double> stops);

/// errorStops of each query against `floorLuminance`, in the queries' order.
std::vector<double> queryStops(std::span<const EvalQuery> queries, double floorLuminance);

/// The perceptual error of a region of the domain: its queries' stops and rel_rmse.
struct RegionError {
  std::string name;
  EvalStops stops;
  double relRmse = 0;        ///< sqrt(sum (E_vol - E_ref)^2 / sum E_ref^2) over its queries
  double meanReference = 0;  ///< mean reference luminance of its queries
};

/// Per box (an importance volume: `names[i]` for `boxes[i]`), the queries inside it, against
/// the floor of all the queries (`stops` are queryStops of them): a dim region cannot hide
/// behind a bright one. A region without queries is reported with 0 queries.
std::vector<RegionError> regionErrors(std::span<const EvalQuery> queries,
                                      std::span<const double> stops, std::span<const Bounds3> boxes,
                                      std::span<const std::string> names);

}  // namespace ps
