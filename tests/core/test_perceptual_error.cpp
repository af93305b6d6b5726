// The perceptual error (core/eval/PerceptualError.h) on hand-made cases.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/eval/PerceptualError.h"

using namespace ps;

namespace {
EvalQuery query(Vec3 p, double reference, double interpolated) {
  EvalQuery q;
  q.point = p;
  q.reference = reference;
  q.interpolated = interpolated;
  return q;
}
}  // namespace

TEST(PerceptualError, StopsOnHandMadeCases) {
  const double floor = 0.01;
  EXPECT_EQ(errorStops(3.0, 3.0, floor), 0.0);          // equal values
  EXPECT_DOUBLE_EQ(errorStops(6.0, 3.0, floor), 1.0);   // twice the reference: 1 stop
  EXPECT_DOUBLE_EQ(errorStops(0.75, 3.0, floor), 2.0);  // a quarter: 2 stops
  EXPECT_EQ(errorStops(0.0, 0.0, floor), 0.0);          // black against black
  EXPECT_EQ(errorStops(0.001, 0.005, floor), 0.0);      // both below the floor: not seen
  EXPECT_EQ(errorStops(-1e-6, 0.0, floor), 0.0);        // a negative estimate is black
  // A black reference and a bright estimate: finite and large (log2(100 / 0.01)).
  const double bright = errorStops(100.0, 0.0, floor);
  EXPECT_TRUE(std::isfinite(bright));
  EXPECT_NEAR(bright, std::log2(1e4), 1e-12);
}

TEST(PerceptualError, FloorIsAFractionOfTheMedianReference) {
  std::vector<EvalQuery> q;
  for (double r : {0.0, 1.0, 2.0, 4.0, 100.0}) q.push_back(query({}, r, r));
  EXPECT_DOUBLE_EQ(adaptationFloor(q), kAdaptationFloorFraction * 2.0);
  // A mostly black scene: the mean.
  std::vector<EvalQuery> dark;
  for (double r : {0.0, 0.0, 0.0, 8.0}) dark.push_back(query({}, r, r));
  EXPECT_DOUBLE_EQ(adaptationFloor(dark), kAdaptationFloorFraction * 2.0);
  // All black, or none: a positive floor still.
  EXPECT_GT(adaptationFloor(std::vector<EvalQuery>(3)), 0.0);
  EXPECT_GT(adaptationFloor({}), 0.0);
}

TEST(PerceptualError, SummaryPercentilesAndTheVisibleFraction) {
  const std::vector<double> stops = {0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 2.0};
  const EvalStops s = summarizeStops(stops);
  EXPECT_EQ(s.queries, 10u);
  EXPECT_DOUBLE_EQ(s.median, 0.4);  // nearest rank: the 5th of 10
  EXPECT_DOUBLE_EQ(s.p90, 0.8);     // the 9th
  EXPECT_DOUBLE_EQ(s.beyondThirdStop, 0.6);
  double sq = 0;
  for (double e : stops) sq += e * e;
  EXPECT_DOUBLE_EQ(s.rms, std::sqrt(sq / 10));
  const EvalStops none = summarizeStops({});
  EXPECT_EQ(none.queries, 0u);
  EXPECT_EQ(none.rms, 0.0);
}

TEST(PerceptualError, ADimRoomCannotHideBehindABrightOne) {
  // Two rooms of 100 queries: the bright one (reference 10) off by 10 %, the dim one (reference
  // 0.5) off by a factor of 2. rel_rmse over both is small; the dim room's stops are not.
  std::vector<EvalQuery> q;
  for (int i = 0; i < 100; ++i) q.push_back(query(Vec3(-1, 0, 0), 10.0, 11.0));
  for (int i = 0; i < 100; ++i) q.push_back(query(Vec3(1, 0, 0), 0.5, 1.0));
  const std::vector<double> stops = queryStops(q, adaptationFloor(q));
  const std::vector<Bounds3> boxes = {{Vec3(-2, -1, -1), Vec3(0, 1, 1)},
                                      {Vec3(0, -1, -1), Vec3(2, 1, 1)},
                                      {Vec3(5, 5, 5), Vec3(6, 6, 6)}};
  const std::vector<std::string> names = {"bright", "dim", "empty"};
  const std::vector<RegionError> regions = regionErrors(q, stops, boxes, names);
  ASSERT_EQ(regions.size(), 3u);
  EXPECT_EQ(regions[0].name, "bright");
  EXPECT_EQ(regions[0].stops.queries, 100u);
  EXPECT_NEAR(regions[0].stops.median, std::log2(1.1), 1e-12);
  EXPECT_NEAR(regions[0].relRmse, 0.1, 1e-12);
  EXPECT_NEAR(regions[1].stops.median, 1.0, 1e-12);
  EXPECT_NEAR(regions[1].relRmse, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(regions[1].meanReference, 0.5);
  EXPECT_EQ(regions[2].stops.queries, 0u);
  // Over both rooms rel_rmse is near the bright room's, the stops' p90 is the dim room's.
  const EvalStops all = summarizeStops(stops);
  EXPECT_NEAR(all.p90, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(all.beyondThirdStop, 0.5);
}
