#include "core/placement/Uniform.h"

#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <mutex>

#include "core/capture/Capture.h"
#include "core/common/Error.h"

namespace ps {

namespace {

constexpr double kMaxGridPoints = 50e6;
constexpr int kMaxBudget = 1'000'000;

int axisCount(double extent, double spacing) {
  return std::max(1, static_cast<int>(std::floor(extent / spacing)));
}

}  // namespace

double uniformGridPointCount(const Bounds3& b, double spacing) {
  const Vec3 e = b.extent();
  return double(axisCount(e.x, spacing)) * axisCount(e.y, spacing) * axisCount(e.z, spacing);
}

std::vector<Vec3> placeUniform(const Tracer& tracer, const UniformSettings& s,
                               const ProgressFn& progress) {
  if (!(s.spacingMeters > 0) || !std::isfinite(s.spacingMeters))
    throw ParameterError("spacing: expected a positive number of metres, got " +
                         std::to_string(s.spacingMeters));
  const Bounds3& b = tracer.scene().bounds;
  const double count = uniformGridPointCount(b, s.spacingMeters);
  if (count > kMaxGridPoints)
    throw ParameterError("spacing " + std::to_string(s.spacingMeters) + " m would make " +
                         std::to_string(static_cast<long long>(count)) +
                         " grid points (limit 50 million); use a larger spacing");
  const Vec3 e = b.extent();
  const int n[3] = {axisCount(e.x, s.spacingMeters), axisCount(e.y, s.spacingMeters),
                    axisCount(e.z, s.spacingMeters)};
  // Cell-centred grid at exactly the requested spacing, centred in the bounds.
  Vec3 origin;
  for (int a = 0; a < 3; ++a) origin[a] = b.center()[a] - 0.5 * (n[a] - 1) * s.spacingMeters;

  const size_t total = size_t(n[0]) * n[1] * n[2];
  std::vector<Vec3> grid(total);
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        grid[(size_t(k) * n[1] + j) * n[0] + i] = origin + Vec3(i, j, k) * s.spacingMeters;

  // Kontkanen & Laine sec. 5: a point whose rays see back faces is inside geometry.
  std::vector<char> valid(total, 0);
  std::atomic<size_t> done{0};
  std::atomic<bool> cancelled{false};
  std::mutex progressMutex;
  tbb::parallel_for(size_t(0), total, [&](size_t i) {
    if (cancelled.load(std::memory_order_relaxed)) return;
    valid[i] =
        backfaceFraction(tracer, grid[i], s.validityRays, s.seed + i) <= s.invalidBackfaceFraction;
    const size_t d = ++done;
    if (progress && (d % 256 == 0 || d == total)) {
      std::lock_guard lock(progressMutex);
      if (!progress(double(d) / total)) cancelled = true;
    }
  });
  if (cancelled) throw Cancelled();
  std::vector<Vec3> points;
  for (size_t i = 0; i < total; ++i)
    if (valid[i]) points.push_back(grid[i]);
  return points;
}

UniformBudgetResult placeUniformBudget(const Tracer& tracer, int budget, UniformSettings s,
                                       const ProgressFn& progress) {
  if (budget < 4)
    throw ParameterError("budget: expected at least 4 probes, got " + std::to_string(budget));
  // Each bisection step places a whole grid: a budget in the millions would run for hours.
  if (budget > kMaxBudget)
    throw ParameterError("budget: expected at most " + std::to_string(kMaxBudget) +
                         " probes (the limit), got " + std::to_string(budget));
  const Bounds3& b = tracer.scene().bounds;
  const Vec3 e = b.extent();
  // Start from the spacing that gives `budget` grid points if every point were valid, then
  // bisect on log(spacing): fewer valid points -> smaller spacing.
  double lo = std::max({e.x, e.y, e.z}) / std::max(2.0, std::cbrt(budget) * 64.0);
  double hi = std::max({e.x, e.y, e.z}) * 2.0;
  UniformBudgetResult best;
  double bestMiss = std::numeric_limits<double>::infinity();
  for (int iter = 0; iter < 40; ++iter) {
    const double spacing = std::sqrt(lo * hi);
    if (uniformGridPointCount(b, spacing) > kMaxGridPoints) {
      lo = spacing;
      continue;
    }
    s.spacingMeters = spacing;
    std::vector<Vec3> pts = placeUniform(tracer, s, {});
    if (progress && !progress(std::min(1.0, (iter + 1) / 20.0))) throw Cancelled();
    const size_t count = pts.size();
    const double miss = std::abs(double(count) - budget) / budget;
    if (miss < bestMiss) {
      bestMiss = miss;
      best.points = std::move(pts);
      best.spacingMeters = spacing;
    }
    if (bestMiss <= 0.1) break;
    // Too many points: the spacing is too small.
    if (double(count) > budget)
      lo = spacing;
    else
      hi = spacing;
    if (hi / lo < 1.0001) break;
  }
  return best;
}

}  // namespace ps
