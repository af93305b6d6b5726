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

/// The fewest points --budget's grids put along an axis: 2, so that the grid spans 3D and can be
/// tetrahedralized (a budget grid used to come out as one flat layer on a room much wider than
/// tall: dream-apartment at 32 and 64); 1 along an axis the scene has no extent on.
int minAxisCount(const Vec3& extent, int a) {
  return extent[a] > 1e-6 * std::max({extent.x, extent.y, extent.z}) ? 2 : 1;
}

/// The per-axis spacings of --budget's grid at `spacing`: `spacing`, except along an axis where it
/// would give fewer than minAxisCount points, which gets that many (extent / (n + 0.5), so that
/// floor(extent / spacing) = n). Zero (a cubic grid) when no axis needed it.
Vec3 budgetAxisSpacing(const Vec3& extent, double spacing) {
  Vec3 axis(spacing, spacing, spacing);
  bool changed = false;
  for (int a = 0; a < 3; ++a) {
    const int least = minAxisCount(extent, a);
    if (axisCount(extent[a], spacing) < least) {
      axis[a] = extent[a] / (least + 0.5);
      changed = true;
    }
  }
  return changed ? axis : Vec3(0, 0, 0);
}

}  // namespace

/// The spacing along axis a.
double axisSpacing(const UniformSettings& s, int a) {
  const Vec3& v = s.axisSpacingMeters;
  return v.x > 0 && v.y > 0 && v.z > 0 ? v[a] : s.spacingMeters;
}

double uniformGridPointCount(const Bounds3& b, double spacing) {
  const Vec3 e = b.extent();
  return double(axisCount(e.x, spacing)) * axisCount(e.y, spacing) * axisCount(e.z, spacing);
}

std::vector<Vec3> placeUniform(const Tracer& tracer, const UniformSettings& s,
                               const ProgressFn& progress) {
  for (int a = 0; a < 3; ++a)
    if (!(axisSpacing(s, a) > 0) || !std::isfinite(axisSpacing(s, a)))
      throw ParameterError("spacing: expected a positive number of metres, got " +
                           std::to_string(axisSpacing(s, a)));
  const Bounds3& b = tracer.scene().bounds;
  const Vec3 e = b.extent();
  const int n[3] = {axisCount(e.x, axisSpacing(s, 0)), axisCount(e.y, axisSpacing(s, 1)),
                    axisCount(e.z, axisSpacing(s, 2))};
  const double count = double(n[0]) * n[1] * n[2];
  if (count > kMaxGridPoints)
    throw ParameterError("spacing " + std::to_string(s.spacingMeters) + " m would make " +
                         std::to_string(static_cast<long long>(count)) +
                         " grid points (limit 50 million); use a larger spacing");
  // Cell-centred grid at exactly the requested spacing, centred in the bounds.
  Vec3 origin;
  for (int a = 0; a < 3; ++a) origin[a] = b.center()[a] - 0.5 * (n[a] - 1) * axisSpacing(s, a);

  const size_t total = size_t(n[0]) * n[1] * n[2];
  std::vector<Vec3> grid(total);
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        grid[(size_t(k) * n[1] + j) * n[0] + i] =
            origin + Vec3(i * axisSpacing(s, 0), j * axisSpacing(s, 1), k * axisSpacing(s, 2));

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
  UniformBudgetResult best;
  double bestMiss = std::numeric_limits<double>::infinity();
  double bestCubicSpacing = 0;  ///< the bisection's spacing for `best`, before budgetAxisSpacing
  // Start from the spacing that gives `budget` grid points if every point were valid, then
  // bisect on log(spacing): fewer valid points -> smaller spacing. With `hold`, an axis the
  // spacing would leave with fewer than minAxisCount points keeps that many (budgetAxisSpacing).
  auto bisect = [&](bool hold) {
    best = {};
    bestMiss = std::numeric_limits<double>::infinity();
    double lo = std::max({e.x, e.y, e.z}) / std::max(2.0, std::cbrt(budget) * 64.0);
    double hi = std::max({e.x, e.y, e.z}) * 2.0;
    for (int iter = 0; iter < 40; ++iter) {
      const double spacing = std::sqrt(lo * hi);
      if (uniformGridPointCount(b, spacing) > kMaxGridPoints) {
        lo = spacing;
        continue;
      }
      s.spacingMeters = spacing;
      s.axisSpacingMeters = hold ? budgetAxisSpacing(e, spacing) : Vec3(0, 0, 0);
      std::vector<Vec3> pts = placeUniform(tracer, s, {});
      if (progress && !progress(std::min(1.0, (iter + 1) / 20.0))) throw Cancelled();
      const size_t count = pts.size();
      const double miss = std::abs(double(count) - budget) / budget;
      if (miss < bestMiss) {
        bestMiss = miss;
        best.points = std::move(pts);
        best.spacingMeters = spacing;
        bestCubicSpacing = spacing;
        best.axisSpacingMeters = s.axisSpacingMeters;
        const Vec3& a = best.axisSpacingMeters;
        if (a.x > 0) best.spacingMeters = std::cbrt(a.x * a.y * a.z);
      }
      if (bestMiss <= 0.1) break;
      // Too many points: the spacing is too small.
      if (double(count) > budget)
        lo = spacing;
      else
        hi = spacing;
      if (hi / lo < 1.0001) break;
    }
  };
  bisect(false);
  // A flat closest grid (a room much wider than tall: dream-apartment at 32 and 64 probes): again,
  // holding each axis at its fewest points. Grids that span 3D stay as they were.
  for (int a = 0; a < 3; ++a)
    if (axisCount(e[a], bestCubicSpacing) < minAxisCount(e, a)) {
      bisect(true);
      break;
    }
  if (bestMiss <= 0.1 || best.points.empty()) return best;

  // No cubic grid is close enough: grids with up to one fewer or two more points per axis than
  // the closest one, spacings within a factor 1.5 of each other (an axis held at its fewest
  // points aside), most promising first (their point counts scaled by the closest grid's valid
  // fraction), at most 12 of them placed.
  int base[3];
  bool held[3];  ///< the axes budgetAxisSpacing held at their fewest points
  for (int a = 0; a < 3; ++a) {
    held[a] = axisCount(e[a], bestCubicSpacing) < minAxisCount(e, a);
    base[a] = std::max(axisCount(e[a], bestCubicSpacing), minAxisCount(e, a));
  }
  const double validFraction = double(best.points.size()) / (double(base[0]) * base[1] * base[2]);
  struct Candidate {
    Vec3 spacing;  ///< per axis: e / (n + 0.5), so that floor(e / spacing) = n
    double estimateMiss;
  };
  std::vector<Candidate> candidates;
  for (int dx = -1; dx <= 2; ++dx)
    for (int dy = -1; dy <= 2; ++dy)
      for (int dz = -1; dz <= 2; ++dz) {
        const int n[3] = {base[0] + dx, base[1] + dy, base[2] + dz};
        if (n[0] < minAxisCount(e, 0) || n[1] < minAxisCount(e, 1) || n[2] < minAxisCount(e, 2) ||
            (dx == 0 && dy == 0 && dz == 0))
          continue;
        const Vec3 spacing(e.x / (n[0] + 0.5), e.y / (n[1] + 0.5), e.z / (n[2] + 0.5));
        double smallest = std::numeric_limits<double>::infinity(), largest = 0;
        for (int a = 0; a < 3; ++a)
          if (!held[a] || n[a] > minAxisCount(e, a)) {
            smallest = std::min(smallest, spacing[a]);
            largest = std::max(largest, spacing[a]);
          }
        if (largest > 1.5 * smallest) continue;
        const double estimate = double(n[0]) * n[1] * n[2] * validFraction;
        candidates.push_back({spacing, std::abs(estimate - budget) / budget});
      }
  std::stable_sort(
      candidates.begin(), candidates.end(),
      [](const Candidate& x, const Candidate& y) { return x.estimateMiss < y.estimateMiss; });
  for (size_t i = 0; i < std::min<size_t>(candidates.size(), 12); ++i) {
    const Vec3 axis = candidates[i].spacing;
    s.axisSpacingMeters = axis;
    std::vector<Vec3> pts = placeUniform(tracer, s, {});
    if (progress && !progress(1.0)) throw Cancelled();
    const double miss = std::abs(double(pts.size()) - budget) / budget;
    if (miss < bestMiss) {
      bestMiss = miss;
      best.points = std::move(pts);
      best.axisSpacingMeters = axis;
      best.spacingMeters = std::cbrt(axis.x * axis.y * axis.z);
    }
    if (bestMiss <= 0.1) break;
  }
  return best;
}

}  // namespace ps
