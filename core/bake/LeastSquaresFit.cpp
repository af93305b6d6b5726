#include "core/bake/LeastSquaresFit.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "core/math/Random.h"

namespace ps {

namespace {

/// Fit points at most: each keeps its position, SH target and location (about 300 bytes).
constexpr size_t kMaxFitPoints = 5'000'000;
/// Points captured per captureProbes call: only their SH is kept, not the whole capture.
constexpr size_t kCaptureChunk = 262'144;
constexpr int kValues = 27;  ///< per probe: 9 SH coefficients x RGB, as in ProbeVolume::sh

/// A symmetric sparse matrix in compressed rows, with the pattern of the mesh's edges (two
/// probes share a row entry when some tetrahedron holds both).
struct SparseMatrix {
  std::vector<size_t> rowStart;  ///< N + 1
  std::vector<int32_t> cols;     ///< sorted within a row
  std::vector<double> vals;
  std::vector<size_t> diag;  ///< index of each row's diagonal entry

  explicit SparseMatrix(const ProbeVolume& v) {
    const size_t n = v.probeCount();
    std::vector<uint64_t> keys;
    keys.reserve(v.tets.size() * 16 + n);
    for (size_t i = 0; i < n; ++i) keys.push_back(uint64_t(i) << 32 | i);
    for (const auto& t : v.tets)
      for (int32_t a : t)
        for (int32_t b : t) keys.push_back(uint64_t(uint32_t(a)) << 32 | uint32_t(b));
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    rowStart.assign(n + 1, 0);
    cols.resize(keys.size());
    for (size_t e = 0; e < keys.size(); ++e) {
      ++rowStart[size_t(keys[e] >> 32) + 1];
      cols[e] = int32_t(keys[e] & 0xffffffffu);
    }
    for (size_t i = 0; i < n; ++i) rowStart[i + 1] += rowStart[i];
    vals.assign(keys.size(), 0.0);
    diag.resize(n);
    for (size_t i = 0; i < n; ++i) diag[i] = index(int32_t(i), int32_t(i));
  }
  size_t index(int32_t row, int32_t col) const {
    const auto b = cols.begin() + std::ptrdiff_t(rowStart[size_t(row)]);
    const auto e = cols.begin() + std::ptrdiff_t(rowStart[size_t(row) + 1]);
    return size_t(std::lower_bound(b, e, col) - cols.begin());
  }
  void multiply(const std::vector<double>& x, std::vector<double>& y) const {
    for (size_t r = 0; r + 1 < rowStart.size(); ++r) {
      double s = 0;
      for (size_t e = rowStart[r]; e < rowStart[r + 1]; ++e) s += vals[e] * x[size_t(cols[e])];
      y[r] = s;
    }
  }
};

/// Solves A x = b by conjugate gradients with the Jacobi preconditioner, from x's value, to a
/// residual of 1e-8 of b's norm (the values are stored as floats). Returns the iterations taken.
int conjugateGradients(const SparseMatrix& A, const std::vector<double>& b,
                       std::vector<double>& x) {
  const size_t n = b.size();
  std::vector<double> r(n), z(n), p(n), ap(n);
  A.multiply(x, ap);
  double bNorm = 0;
  for (size_t i = 0; i < n; ++i) {
    r[i] = b[i] - ap[i];
    bNorm += b[i] * b[i];
  }
  bNorm = std::sqrt(bNorm);
  auto precondition = [&] {
    for (size_t i = 0; i < n; ++i) z[i] = r[i] / A.vals[A.diag[i]];
  };
  auto dotp = [&](const std::vector<double>& u, const std::vector<double>& v) {
    double s = 0;
    for (size_t i = 0; i < n; ++i) s += u[i] * v[i];
    return s;
  };
  precondition();
  p = z;
  double rz = dotp(r, z);
  const int maxIterations = int(std::min<size_t>(10 * n + 100, 5000));
  int it = 0;
  for (; it < maxIterations; ++it) {
    if (std::sqrt(dotp(r, r)) <= 1e-8 * bNorm) break;
    A.multiply(p, ap);
    const double pap = dotp(p, ap);
    if (!(pap > 0)) break;
    const double alpha = rz / pap;
    for (size_t i = 0; i < n; ++i) {
      x[i] += alpha * p[i];
      r[i] -= alpha * ap[i];
    }
    precondition();
    const double rzNew = dotp(r, z);
    const double beta = rzNew / rz;
    rz = rzNew;
    for (size_t i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
  }
  return it;
}

}  // namespace

std::vector<float> leastSquaresValues(const ProbeVolume& volume, std::span<const VolumeLocation> at,
                                      std::span<const ShRgb> targets, double regularization,
                                      int* iterations) {
  PS_CHECK_EQ(at.size(), targets.size());
  PS_CHECK(regularization > 0);  // else a probe no point reaches has a zero row
  const size_t n = volume.probeCount();
  PS_CHECK_EQ(volume.sh.size(), n * kValues);
  for (const VolumeLocation& l : at) PS_CHECK(l.tet >= 0 && size_t(l.tet) < volume.tets.size());
  // Normal equations: (W^T W + lambda m I) c = W^T s + lambda m c0, one column per SH value,
  // W holding each point's barycentric weights, c0 the current values, m the mean of W^T W's
  // diagonal (what the points weigh for a probe on average).
  SparseMatrix A(volume);
  std::vector<double> rhs(n * kValues, 0.0);
  for (size_t i = 0; i < at.size(); ++i) {
    const auto& t = volume.tets[size_t(at[i].tet)];
    for (int a = 0; a < 4; ++a) {
      const double wa = at[i].weights[size_t(a)];
      if (wa == 0) continue;
      for (int b = 0; b < 4; ++b)
        A.vals[A.index(t[size_t(a)], t[size_t(b)])] += wa * at[i].weights[size_t(b)];
      double* row = rhs.data() + size_t(t[size_t(a)]) * kValues;
      for (int k = 0; k < kShCoeffCount; ++k) {
        const Rgb& c = targets[i].c[size_t(k)];
        row[3 * k] += wa * c.r;
        row[3 * k + 1] += wa * c.g;
        row[3 * k + 2] += wa * c.b;
      }
    }
  }
  double meanDiag = 0;
  for (size_t i = 0; i < n; ++i) meanDiag += A.vals[A.diag[i]] / double(n);
  // No point at all: every probe keeps its value (any positive pull gives that).
  const double lambda = meanDiag > 0 ? regularization * meanDiag : regularization;
  for (size_t i = 0; i < n; ++i) {
    A.vals[A.diag[i]] += lambda;
    for (int v = 0; v < kValues; ++v)
      rhs[i * kValues + size_t(v)] += lambda * double(volume.sh[i * kValues + size_t(v)]);
  }
  std::vector<float> fitted(volume.sh.size());
  std::atomic<int> maxIterations{0};
  tbb::parallel_for(0, kValues, [&](int v) {
    std::vector<double> b(n), x(n);
    for (size_t i = 0; i < n; ++i) {
      b[i] = rhs[i * kValues + size_t(v)];
      x[i] = volume.sh[i * kValues + size_t(v)];  // starts from the current values
    }
    const int it = conjugateGradients(A, b, x);
    int seen = maxIterations.load();
    while (it > seen && !maxIterations.compare_exchange_weak(seen, it)) {
    }
    for (size_t i = 0; i < n; ++i) fitted[i * kValues + size_t(v)] = float(x[i]);
  });
  if (iterations) *iterations = maxIterations.load();
  return fitted;
}

void checkFitSettings(const FitSettings& s, size_t probes) {
  if (s.pointsPerProbe < 1 || s.pointsPerProbe > 4096)
    throw ParameterError("pointsPerProbe", "expected 1 to 4096 points per probe, got " +
                                               std::to_string(s.pointsPerProbe));
  if (s.samplesPerPoint < 1 || s.samplesPerPoint > (1 << 20))
    throw ParameterError("samplesPerPoint", "expected 1 to 1048576 samples per point, got " +
                                                std::to_string(s.samplesPerPoint));
  if (!(s.regularization > 0) || !std::isfinite(s.regularization))
    throw ParameterError("regularization", "expected a positive number");
  checkLightClearance(s.lightClearanceRelative);
  if (probes * size_t(s.pointsPerProbe) > kMaxFitPoints)
    throw ParameterError("fit: " + std::to_string(probes) + " probes x " +
                         std::to_string(s.pointsPerProbe) + " points per probe is above the " +
                         "limit of 5 million fit points; lower the points per probe");
}

namespace {

/// The fit points' domain; its errors (a flat importance box) say they come from the fit.
DomainPoints fitDomain(const Tracer& tracer, const LightingRig& rig, const Domain& domain,
                       const FitSettings& s) {
  try {
    return DomainPoints(tracer, rig, domain, s.lightClearanceRelative);
  } catch (const ParameterError& e) {
    throw ParameterError(std::string("fit: ") + e.what());
  }
}

}  // namespace

void checkFitDomain(const Tracer& tracer, const LightingRig& rig, const Domain& domain,
                    const FitSettings& s) {
  fitDomain(tracer, rig, domain, s);
}

FitResult fitProbeValues(const Tracer& tracer, const LightingRig& rig, ProbeVolume& volume,
                         const Domain& domain, const FitSettings& s, const ProgressFn& progress) {
  const size_t n = volume.probeCount();
  checkFitSettings(s, n);
  if (n == 0 || volume.tets.empty()) throw ParameterError("fit: the volume has no tetrahedra");
  const size_t wanted = n * size_t(s.pointsPerProbe);
  const auto start = std::chrono::steady_clock::now();
  FitResult result;

  // The fit points: uniform over the domain of interest, as eval's queries are.
  const DomainPoints domainPoints = fitDomain(tracer, rig, domain, s);
  // Salted: eval's queries with the same seed are other points (a fit to the very queries that
  // judge it would hide its error).
  const std::vector<Vec3> points = domainPoints.drawMany(wanted, s.seed ^ 0x9E3779B97F4A7C15ull);
  if (points.empty())
    throw ParameterError(
        "fit: no point of the domain of interest lies outside geometry (and the light "
        "clearance)");
  result.points = points.size();

  // Captured in chunks, keeping only the SH (the target of the fit).
  std::vector<ShRgb> targets(points.size());
  CaptureSettings cs;
  cs.samplesPerProbe = s.samplesPerPoint;
  cs.seed = s.seed ^ 0xF17F17F17ull;
  cs.mode = s.mode;
  cs.threads = s.threads;
  ProgressFn captureProgress;
  if (progress) captureProgress = [&](double f) { return progress(0.9 * f); };
  captureProbesInChunks(
      tracer, rig, points, cs, kCaptureChunk,
      [&](size_t i, const ProbeCapture& c) { targets[i] = c.sh; }, captureProgress);

  // Where each point interpolates (clamped to the hull outside it, as every query is).
  const HullClamp hullClamp(volume);
  std::vector<VolumeLocation> loc(points.size());
  tbb::parallel_for(size_t(0), points.size(),
                    [&](size_t i) { loc[i] = locate(volume, points[i], -1, &hullClamp); });

  auto misfit = [&](const std::vector<float>& sh) {
    double num = 0, den = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      const auto& t = volume.tets[size_t(loc[i].tet)];
      for (int k = 0; k < kShCoeffCount; ++k) {
        Rgb interp;
        for (int a = 0; a < 4; ++a) {
          const float* c = sh.data() + size_t(t[size_t(a)]) * kValues + 3 * size_t(k);
          interp += Rgb(c[0], c[1], c[2]) * double(loc[i].weights[size_t(a)]);
        }
        const double target = luminance(targets[i].c[size_t(k)]);
        num += (luminance(interp) - target) * (luminance(interp) - target);
        den += target * target;
      }
    }
    return den > 0 ? std::sqrt(num / den) : 0.0;
  };
  result.residualBefore = misfit(volume.sh);

  if (progress && !progress(0.9)) throw Cancelled();
  std::vector<float> fitted =
      leastSquaresValues(volume, loc, targets, s.regularization, &result.iterations);
  result.residualAfter = misfit(fitted);
  volume.sh = std::move(fitted);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (progress && !progress(1.0)) throw Cancelled();
  return result;
}

}  // namespace ps
