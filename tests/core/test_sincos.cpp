// sinCos2Pi (core/math/SinCos.h) against long-double sin and cos of 2 pi v.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/common/Tolerances.h"
#include "core/math/SinCos.h"

namespace ps {
namespace {

constexpr long double kTwoPiL = 6.283185307179586476925286766559005768L;

void expectNearExact(double v) {
  const SinCos sc = sinCos2Pi(v);
  const long double a = kTwoPiL * static_cast<long double>(v);
  EXPECT_NEAR(sc.sin, static_cast<double>(std::sin(a)), tol::kSinCos2PiAbsolute) << "v = " << v;
  EXPECT_NEAR(sc.cos, static_cast<double>(std::cos(a)), tol::kSinCos2PiAbsolute) << "v = " << v;
}

TEST(SinCos2Pi, MatchesLongDoubleOnAHundredThousandSeededFractions) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 100000; ++i) expectNearExact(u(rng));
}

TEST(SinCos2Pi, MatchesLongDoubleAroundEveryTableStepAndHalfStep) {
  // The table entry used switches at odd half steps; whole steps leave only the table value.
  for (int k = 0; k <= 2 * detail::kTurnSteps; ++k) {
    const double v = k / (2.0 * detail::kTurnSteps);
    expectNearExact(v);
    for (int ulps = 1; ulps <= 4; ++ulps) {
      expectNearExact(std::nextafter(v, v + ulps));
      if (v > 0) expectNearExact(std::nextafter(v, v - ulps));
    }
  }
}

TEST(SinCos2Pi, WholeQuarterTurnsAreExact) {
  EXPECT_EQ(sinCos2Pi(0.0).sin, 0.0);
  EXPECT_EQ(sinCos2Pi(0.0).cos, 1.0);
  EXPECT_EQ(sinCos2Pi(0.25).sin, 1.0);
  EXPECT_EQ(sinCos2Pi(0.25).cos, 0.0);
  EXPECT_EQ(sinCos2Pi(0.5).sin, 0.0);
  EXPECT_EQ(sinCos2Pi(0.5).cos, -1.0);
  EXPECT_EQ(sinCos2Pi(0.75).sin, -1.0);
  EXPECT_EQ(sinCos2Pi(0.75).cos, 0.0);
  EXPECT_EQ(sinCos2Pi(1.0).sin, 0.0);
  EXPECT_EQ(sinCos2Pi(1.0).cos, 1.0);
}

TEST(SinCos2Pi, TheSmallestFractionsGiveTheirAngle) {
  for (double v : {1e-300, 1e-20, 1e-10, 0x1.0p-53}) {
    const SinCos sc = sinCos2Pi(v);
    EXPECT_NEAR(sc.sin, 2 * 3.14159265358979323846 * v, 4e-16 * v) << "v = " << v;
    EXPECT_EQ(sc.cos, 1.0) << "v = " << v;
  }
}

}  // namespace
}  // namespace ps
