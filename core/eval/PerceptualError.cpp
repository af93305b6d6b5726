#include "core/eval/PerceptualError.h"

#include <algorithm>
#include <cmath>

#include "core/common/Check.h"

namespace ps {

namespace {

/// The nearest-rank percentile `q` (0 to 1) of sorted values.
double percentile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0;
  const size_t rank = size_t(std::ceil(q * double(sorted.size())));
  return sorted[std::clamp(rank, size_t(1), sorted.size()) - 1];
}

/// The error of the queries marked `inside`.
RegionError regionError(std::span<const EvalQuery> queries, std::span<const double> stops,
                        std::span<const char> inside, const std::string& name) {
  std::vector<double> in;
  double errSq = 0, refSq = 0, refSum = 0;
  for (size_t i = 0; i < queries.size(); ++i) {
    if (!inside[i]) continue;
    in.push_back(stops[i]);
    const double e = queries[i].interpolated - queries[i].reference;
    errSq += e * e;
    refSq += queries[i].reference * queries[i].reference;
    refSum += queries[i].reference;
  }
  RegionError r;
  r.name = name;
  r.stops = summarizeStops(in);
  r.relRmse = refSq > 0 ? std::sqrt(errSq / refSq) : 0.0;
  r.meanReference = in.empty() ? 0.0 : refSum / double(in.size());
  return r;
}

}  // namespace

double adaptationFloor(std::span<const EvalQuery> queries) {
  std::vector<double> refs;
  refs.reserve(queries.size());
  double sum = 0;
  for (const EvalQuery& q : queries) {
    refs.push_back(std::max(q.reference, 0.0));
    sum += refs.back();
  }
  std::sort(refs.begin(), refs.end());
  double level = percentile(refs, 0.5);
  if (!(level > 0) && !refs.empty()) level = sum / double(refs.size());
  return level > 0 ? kAdaptationFloorFraction * level : 1e-12;
}

double referenceNoiseStops(std::span<const EvalQuery> queries, double floorLuminance) {
  if (queries.empty()) return 0;
  double sq = 0;
  for (const EvalQuery& q : queries) {
    const double n = q.referenceStd / (std::max(q.reference, floorLuminance) * std::log(2.0));
    sq += n * n;
  }
  return std::sqrt(sq / double(queries.size()));
}

EvalStops summarizeStops(std::span<const double> stops) {
  EvalStops s;
  s.queries = stops.size();
  if (stops.empty()) return s;
  std::vector<double> sorted(stops.begin(), stops.end());
  std::sort(sorted.begin(), sorted.end());
  double sq = 0;
  size_t visible = 0;
  for (double e : sorted) {
    sq += e * e;
    visible += e >= kVisibleStops ? 1 : 0;
  }
  s.rms = std::sqrt(sq / double(sorted.size()));
  s.median = percentile(sorted, 0.5);
  s.p90 = percentile(sorted, 0.9);
  s.beyondThirdStop = double(visible) / double(sorted.size());
  return s;
}

std::vector<double> queryStops(std::span<const EvalQuery> queries, double floorLuminance) {
  std::vector<double> out;
  out.reserve(queries.size());
  for (const EvalQuery& q : queries)
    out.push_back(errorStops(q.interpolated, q.reference, floorLuminance));
  return out;
}

std::vector<RegionError> regionErrors(std::span<const EvalQuery> queries,
                                      std::span<const double> stops, std::span<const Bounds3> boxes,
                                      std::span<const std::string> names) {
  PS_CHECK_EQ(queries.size(), stops.size());
  PS_CHECK_EQ(boxes.size(), names.size());
  std::vector<RegionError> out;
  for (size_t b = 0; b < boxes.size(); ++b) {
    std::vector<char> inside(queries.size());
    for (size_t i = 0; i < queries.size(); ++i) inside[i] = boxes[b].contains(queries[i].point);
    out.push_back(regionError(queries, stops, inside, names[b]));
  }
  return out;
}

std::vector<RegionError> labelledRegionErrors(std::span<const EvalQuery> queries,
                                              std::span<const double> stops,
                                              std::span<const int> labels,
                                              std::span<const std::string> names) {
  PS_CHECK_EQ(queries.size(), stops.size());
  PS_CHECK_EQ(queries.size(), labels.size());
  std::vector<RegionError> out;
  for (size_t r = 0; r < names.size(); ++r) {
    std::vector<char> inside(queries.size());
    for (size_t i = 0; i < queries.size(); ++i) inside[i] = labels[i] == int(r);
    out.push_back(regionError(queries, stops, inside, names[r]));
  }
  return out;
}

}  // namespace ps
