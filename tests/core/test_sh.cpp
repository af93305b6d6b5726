// SH L2 basis, projection and irradiance convolution (core/math/Sh.h).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "core/math/Sh.h"

namespace ps {
namespace {

/// A quadrature rule on the sphere: Gauss-Legendre in z on [z0, z1] times the trapezoid rule in
/// phi. With n nodes in z and m in phi it integrates polynomials of x, y, z of degree < min(2n,
/// m) exactly: the oracle for every exact projection here.
struct SphereRule {
  std::vector<Vec3> dirs;
  std::vector<double> weights;
};

void gaussLegendre(int n, std::vector<double>& x, std::vector<double>& w) {
  x.resize(n);
  w.resize(n);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (z * p1 - p0) / (z * z - 1);
      const double dz = p1 / dp;
      z -= dz;
      if (std::abs(dz) < 1e-16) break;
    }
    x[i] = z;
    w[i] = 2 / ((1 - z * z) * dp * dp);
  }
}

SphereRule sphereRule(int n, int m, double z0 = -1, double z1 = 1) {
  std::vector<double> x, w;
  gaussLegendre(n, x, w);
  SphereRule r;
  for (int i = 0; i < n; ++i) {
    const double z = 0.5 * (z0 + z1) + 0.5 * (z1 - z0) * x[i];
    const double s = std::sqrt(std::max(0.0, 1 - z * z));
    for (int j = 0; j < m; ++j) {
      const double phi = 2 * kPi * (j + 0.5) / m;
      r.dirs.push_back({s * std::cos(phi), s * std::sin(phi), z});
      r.weights.push_back(0.5 * (z1 - z0) * w[i] * 2 * kPi / m);
    }
  }
  return r;
}

ShRgb randomSh(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  ShRgb sh;
  for (auto& c : sh.c) c = {u(rng), u(rng), u(rng)};
  return sh;
}

Vec3 randomDir(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return normalize(Vec3{g(rng), g(rng), g(rng)});
}

/// Legendre polynomial P_l(x) for l <= 2.
double legendre(int l, double x) {
  return l == 0 ? 1 : (l == 1 ? x : 0.5 * (3 * x * x - 1));
}
int band(int i) {
  return i == 0 ? 0 : (i < 4 ? 1 : 2);
}

TEST(ShBasis, StatedConstants) {
  // The header quotes the constants to 6 digits; they are these closed forms.
  const double k0 = 0.5 * std::sqrt(1 / kPi), k1 = std::sqrt(3 / (4 * kPi)),
               k2 = 0.5 * std::sqrt(15 / kPi), k20 = 0.25 * std::sqrt(5 / kPi),
               k22 = 0.25 * std::sqrt(15 / kPi);
  EXPECT_NEAR(k0, 0.282095, 5e-7);
  EXPECT_NEAR(k1, 0.488603, 5e-7);
  EXPECT_NEAR(k2, 1.092548, 5e-7);
  EXPECT_NEAR(k20, 0.315392, 5e-7);
  EXPECT_NEAR(k22, 0.546274, 5e-7);
  std::mt19937_64 rng(11);
  for (int k = 0; k < 1000; ++k) {
    const Vec3 d = randomDir(rng);
    const auto y = shBasis(d);
    const std::array<double, 9> want = {k0,
                                        k1 * d.y,
                                        k1 * d.z,
                                        k1 * d.x,
                                        k2 * d.x * d.y,
                                        k2 * d.y * d.z,
                                        k20 * (3 * d.z * d.z - 1),
                                        k2 * d.x * d.z,
                                        k22 * (d.x * d.x - d.y * d.y)};
    for (int i = 0; i < kShCoeffCount; ++i) EXPECT_NEAR(y[i], want[i], 1e-14) << i;
  }
  EXPECT_DOUBLE_EQ(shCosineLobe(0), kPi);
  for (int i = 1; i < 4; ++i) EXPECT_DOUBLE_EQ(shCosineLobe(i), 2 * kPi / 3);
  for (int i = 4; i < 9; ++i) EXPECT_DOUBLE_EQ(shCosineLobe(i), kPi / 4);
}

TEST(ShBasis, IsOrthonormal) {
  const SphereRule q = sphereRule(8, 16);
  for (int i = 0; i < kShCoeffCount; ++i)
    for (int j = 0; j < kShCoeffCount; ++j) {
      double s = 0;
      for (size_t k = 0; k < q.dirs.size(); ++k) {
        const auto y = shBasis(q.dirs[k]);
        s += q.weights[k] * y[i] * y[j];
      }
      EXPECT_NEAR(s, i == j ? 1.0 : 0.0, 1e-13) << i << ", " << j;
    }
}

TEST(ShProjection, QuadratureRecoversAnL2Function) {
  std::mt19937_64 rng(3);
  const SphereRule q = sphereRule(8, 16);
  for (int trial = 0; trial < 20; ++trial) {
    const ShRgb f = randomSh(rng);
    ShRgb p;
    for (size_t k = 0; k < q.dirs.size(); ++k)
      p.addSample(q.dirs[k], f.radiance(q.dirs[k]), q.weights[k]);
    for (int i = 0; i < kShCoeffCount; ++i)
      for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(p.c[i][ch], f.c[i][ch], 1e-12);
  }
}

TEST(ShProjection, MonteCarloRecoversAnL2Function) {
  // Uniform directions, weight 1 / (pdf N) = 4 pi / N. The per-sample estimator 4 pi f Y_i has
  // a standard deviation of about 2 for these coefficients, so 10^6 samples give ~0.002; 0.01
  // is five sigma, and a wrong weight (a factor of 4 pi, 2 or pi) fails by far more.
  std::mt19937_64 rng(5);
  const ShRgb f = randomSh(rng);
  const int n = 1000000;
  ShRgb p;
  for (int k = 0; k < n; ++k) {
    const Vec3 d = randomDir(rng);
    p.addSample(d, f.radiance(d), 4 * kPi / n);
  }
  double maxErr = 0;
  for (int i = 0; i < kShCoeffCount; ++i)
    for (int ch = 0; ch < 3; ++ch) maxErr = std::max(maxErr, std::abs(p.c[i][ch] - f.c[i][ch]));
  EXPECT_LT(maxErr, 0.01);
}

TEST(ShIrradiance, ConstantRadianceGivesPiLForEveryNormal) {
  const Rgb l{0.5, 1, 2};
  const SphereRule q = sphereRule(4, 8);
  ShRgb sh;
  for (size_t k = 0; k < q.dirs.size(); ++k) sh.addSample(q.dirs[k], l, q.weights[k]);
  // White furnace: only Y00 is non-zero, c00 = 2 sqrt(pi) L.
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(sh.c[0][ch], 2 * std::sqrt(kPi) * l[ch], 1e-13);
  std::mt19937_64 rng(7);
  for (int k = 0; k < 1000; ++k) {
    const Vec3 n = randomDir(rng);
    const Rgb e = sh.irradiance(n);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(e[ch], kPi * l[ch], 1e-12);
    const Rgb r = sh.radiance(n);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(r[ch], l[ch], 1e-12);
  }
}

TEST(ShIrradiance, CosineLobeFactorsAreTheClampedCosineConvolution) {
  // For n = +z: integral over the sphere of max(0, z) Y_i(w) = A_l Y_i(+z) (Funk-Hecke).
  // The hemisphere z > 0 is integrated exactly by its own Gauss rule.
  const SphereRule q = sphereRule(8, 16, 0, 1);
  const auto yn = shBasis({0, 0, 1});
  for (int i = 0; i < kShCoeffCount; ++i) {
    double s = 0;
    for (size_t k = 0; k < q.dirs.size(); ++k)
      s += q.weights[k] * q.dirs[k].z * shBasis(q.dirs[k])[i];
    EXPECT_NEAR(s, shCosineLobe(i) * yn[i], 1e-13) << i;
  }
}

TEST(ShIrradiance, DeltaLightMatchesTheAdditionTheorem) {
  // A delta of irradiance E from w projects to c_i = E Y_i(w); its L2 irradiance is
  // E sum_l A_l (2l+1)/(4 pi) P_l(n.w).
  std::mt19937_64 rng(9);
  for (int k = 0; k < 1000; ++k) {
    const Vec3 w = randomDir(rng), n = randomDir(rng);
    ShRgb sh;
    sh.addSample(w, {1, 2, 3}, 1.0);
    double want = 0;
    for (int l = 0; l <= 2; ++l)
      want += shCosineLobe(l * l) * (2 * l + 1) / (4 * kPi) * legendre(l, dot(n, w));
    const Rgb e = sh.irradiance(n);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(e[ch], (ch + 1) * want, 1e-12);
  }
}

TEST(ShRotation, BandEnergiesAreRotationInvariant) {
  std::mt19937_64 rng(13);
  const SphereRule q = sphereRule(8, 16);
  for (int trial = 0; trial < 20; ++trial) {
    const ShRgb f = randomSh(rng);
    // A random rotation: orthonormal frame (t, b, a) around a random axis a.
    const Vec3 a = randomDir(rng);
    Vec3 t, b;
    orthonormalBasis(a, t, b);
    // g(w) = f(R^T w), with R's columns t, b, a: R^T w = (t.w, b.w, a.w).
    ShRgb g;
    for (size_t k = 0; k < q.dirs.size(); ++k) {
      const Vec3 w = q.dirs[k];
      g.addSample(w, f.radiance({dot(t, w), dot(b, w), dot(a, w)}), q.weights[k]);
    }
    for (int ch = 0; ch < 3; ++ch) {
      std::array<double, 3> ef{}, eg{};
      for (int i = 0; i < kShCoeffCount; ++i) {
        ef[band(i)] += f.c[i][ch] * f.c[i][ch];
        eg[band(i)] += g.c[i][ch] * g.c[i][ch];
      }
      for (int l = 0; l < 3; ++l) EXPECT_NEAR(eg[l], ef[l], 1e-12) << "band " << l;
    }
    // The rotation really moved the function (the test can fail).
    EXPECT_GT(std::abs(g.c[2].r - f.c[2].r) + std::abs(g.c[3].r - f.c[3].r), 1e-6);
  }
}

}  // namespace
}  // namespace ps
