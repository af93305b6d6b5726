#pragma once
// sin and cos of 2 pi v for a fraction of a turn v, inline and without a library call: the
// samplers' azimuths. v is split exactly into k / kTurnSteps plus a remainder of at most half a
// step; sin and cos of the step come from a table (long double, rounded once), those of the
// remainder b (|b| <= pi / kTurnSteps) from their Taylor series to b^7 and b^6 (the next terms
// are below 1e-20), and the angle-addition formulas join them.
#include <array>
#include <cmath>

namespace ps {

struct SinCos {
  double sin = 0, cos = 1;
};

namespace detail {

inline constexpr int kTurnSteps = 256;

struct TurnTable {
  std::array<double, kTurnSteps + 1> sin, cos;  ///< of 2 pi k / kTurnSteps, k = 0..kTurnSteps
};

inline const TurnTable& turnTable() {
  static const TurnTable table = [] {
    // The first quarter turn in long double, the others by exact quarter-turn rotations, so
    // that whole quarter turns are exactly 0 and +-1.
    constexpr int kQuarter = kTurnSteps / 4;
    TurnTable t;
    for (int k = 0; k <= kTurnSteps; ++k) {
      const long double a = 6.283185307179586476925286766559005768L * (k % kQuarter) / kTurnSteps;
      const double s = static_cast<double>(std::sin(a)), c = static_cast<double>(std::cos(a));
      const int quadrant = (k / kQuarter) % 4;
      t.sin[size_t(k)] = quadrant == 0 ? s : quadrant == 1 ? c : quadrant == 2 ? -s : -c;
      t.cos[size_t(k)] = quadrant == 0 ? c : quadrant == 1 ? -s : quadrant == 2 ? -c : s;
    }
    return t;
  }();
  return table;
}

}  // namespace detail

/// sin(2 pi v) and cos(2 pi v) for 0 <= v <= 1 (other v: unspecified), each within
/// tol::kSinCos2PiAbsolute of the exact value. Faster than std::sin and std::cos of 2 pi v
/// (no argument reduction for arbitrary angles, no errno) and more accurate, since the
/// rounding of 2 pi v is left out.
inline SinCos sinCos2Pi(double v) {
  const detail::TurnTable& table = detail::turnTable();
  // v = (k + f) / kTurnSteps with |f| <= 1/2 (up to an ulp); the scaling and x - k are exact.
  const double x = detail::kTurnSteps * v;
  const int k = static_cast<int>(x + 0.5);
  const double f = x - k;
  constexpr double kStep = 6.283185307179586476925286766559005768 / detail::kTurnSteps;
  const double b = f * kStep;
  const double z = b * b;
  // sin b = b - b^3/3! + b^5/5! - b^7/7!, cos b - 1 = -b^2/2! + b^4/4! - b^6/6!.
  const double sinB =
      b + b * z * (-0.16666666666666666 + z * (0.008333333333333333 - z * 1.984126984126984e-4));
  const double cosBMinus1 = z * (-0.5 + z * (0.041666666666666664 - z * 0.001388888888888889));
  const double sinA = table.sin[size_t(k)], cosA = table.cos[size_t(k)];
  // sin(a + b) = sin a + (sin a (cos b - 1) + cos a sin b), likewise cos(a + b).
  return {sinA + (sinA * cosBMinus1 + cosA * sinB), cosA + (cosA * cosBMinus1 - sinA * sinB)};
}

}  // namespace ps
