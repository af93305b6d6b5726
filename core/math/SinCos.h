#pragma once
// sin and cos of 2 pi v for a fraction of a turn v, inline and without a library call: the
// samplers' azimuths. Exact reduction to a quarter turn, then the fdlibm kernels on
// [-pi/4, pi/4] (Sun Microsystems 1993, k_sin.c and k_cos.c: minimax polynomials, error below
// one ulp there).

namespace ps {

struct SinCos {
  double sin = 0, cos = 1;
};

/// sin(2 pi v) and cos(2 pi v) for 0 <= v <= 1 (other v: unspecified), each within
/// tol::kSinCos2PiAbsolute of the exact value. Faster than std::sin and std::cos of 2 pi v
/// (no argument reduction for arbitrary angles, no errno), and more accurate near whole
/// quarter turns, where the rounding of 2 pi v is left out.
inline SinCos sinCos2Pi(double v) {
  // 2 pi v = (pi / 2) (q + f), q a whole number of quarter turns, |f| <= 1/2 (up to an ulp).
  // 4 v and 4 v - q are exact.
  const double x = 4.0 * v;
  const int q = static_cast<int>(x + 0.5);
  const double f = x - q;
  constexpr double kHalfPi = 1.57079632679489661923;
  const double t = f * kHalfPi;  // |t| <= pi / 4
  const double z = t * t;
  const double w = z * z;
  // k_sin.c: sin t = t + t^3 (S1 + z (S2 + ...)).
  constexpr double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
                   S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
                   S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
  const double rs = S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6);
  const double s = t + z * t * (S1 + z * rs);
  // k_cos.c: cos t = 1 - z / 2 + z^2 (C1 + z (C2 + ...)), with 1 - z / 2 summed in two parts.
  constexpr double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
                   C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
                   C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;
  const double rc = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
  const double hz = 0.5 * z;
  const double oneMinusHz = 1.0 - hz;
  const double c = oneMinusHz + (((1.0 - oneMinusHz) - hz) + z * rc);
  switch (q & 3) {
    case 0:
      return {s, c};
    case 1:
      return {c, -s};
    case 2:
      return {-s, -c};
    default:
      return {-c, s};
  }
}

}  // namespace ps
