#pragma once
// Error as the eye sees it, over eval's queries: the per-query error in stops (errorStops,
// core/math/Stops.h, which states what it rests on), its floor from the queries' adaptation
// level, its summary and its value per region of the domain.

#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "core/eval/Evaluate.h"
#include "core/math/Stops.h"
#include "core/math/Vec3.h"

namespace ps {

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

/// The reference's own path-tracing noise on the stops' scale: sqrt(mean over the queries of
/// (referenceStd / (max(reference, floorLuminance) ln 2))^2), to first order the RMS stops of a
/// volume equal to the true irradiance. Errors of that size measure the reference, not the
/// volume (a higher --reference-spp lowers it as 1 / sqrt(spp)); 0 without queries.
double referenceNoiseStops(std::span<const EvalQuery> queries, double floorLuminance);

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

/// Per region `r` of `names` (a room of core/domain/Rooms.h), the queries whose label is r
/// (labels[i] for queries[i]; -1: none), against the floor of all the queries.
std::vector<RegionError> labelledRegionErrors(std::span<const EvalQuery> queries,
                                              std::span<const double> stops,
                                              std::span<const int> labels,
                                              std::span<const std::string> names);

}  // namespace ps
