#include "core/placement/Uniform.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>

#include "core/capture/Capture.h"
#include "core/common/Error.h"

namespace ps {

namespace {

constexpr double kMaxGridPoints = 50e6;

int axisCount(double extent, double spacing) {
  return std::max(1, static_cast<int>(std::floor(extent / spacing)));
}

/// The fewest points a held budget grid puts along an axis: `least`, or 1 along an axis the scene
/// has no extent on.
int minAxisCount(const Vec3& extent, int a, int least) {
  return extent[a] > 1e-6 * std::max({extent.x, extent.y, extent.z}) ? least : 1;
}

/// The per-axis spacings of a budget grid at `spacing` holding each axis at `least` points:
/// `spacing`, except along an axis where it would give fewer, which gets that many
/// (extent / (n + 0.5), so that floor(extent / spacing) = n). Zero (a cubic grid) when no axis
/// needed it.
Vec3 heldAxisSpacing(const Vec3& extent, double spacing, int least) {
  Vec3 axis(spacing, spacing, spacing);
  bool changed = false;
  for (int a = 0; a < 3; ++a) {
    const int n = minAxisCount(extent, a, least);
    if (axisCount(extent[a], spacing) < n) {
      axis[a] = extent[a] / (n + 0.5);
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

bool pointsSpan3D(const std::vector<Vec3>& points) {
  if (points.size() < 4) return false;
  const Vec3 p0 = points[0];
  size_t i1 = 0;
  for (size_t i = 1; i < points.size(); ++i)
    if (length(points[i] - p0) > length(points[i1] - p0)) i1 = i;
  const Vec3 u = points[i1] - p0;
  if (!(length(u) > 0)) return false;
  Vec3 n;
  for (const Vec3& p : points)
    if (length(cross(u, p - p0)) > length(n)) n = cross(u, p - p0);
  if (!(length(n) > 1e-12 * dot(u, u))) return false;
  for (const Vec3& p : points)
    if (std::abs(dot(n, p - p0)) > 1e-9 * length(n) * length(u)) return true;
  return false;
}

/// Number of grid points (before the validity test) placeUniform makes with these settings.
double gridPointCount(const Vec3& extent, const UniformSettings& s) {
  return double(axisCount(extent.x, axisSpacing(s, 0))) * axisCount(extent.y, axisSpacing(s, 1)) *
         axisCount(extent.z, axisSpacing(s, 2));
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
  const double count = gridPointCount(e, s);
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
        (!s.domain || s.domain->contains(grid[i])) &&
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

namespace {

/// A budget grid's spacing in metres: the geometric mean of `axis` (metres, per axis) over the
/// axes not `held` (three flags) at their fewest points, over all three when none or all are. A
/// held axis is denser than the rest, and ascent, spawn-merge and the distance kept from locked
/// probes read this spacing.
double meanSpacing(const Vec3& axis, const bool* held) {
  double product = 1;
  int n = 0;
  for (int a = 0; a < 3; ++a)
    if (!held[a]) {
      product *= axis[a];
      ++n;
    }
  if (n == 3 || n == 0) return std::cbrt(axis.x * axis.y * axis.z);
  return n == 2 ? std::sqrt(product) : product;
}

/// A grid near the closest one of the bisection, not yet placed.
struct NearbyGrid {
  Vec3 spacing;         ///< per axis: e / (n + 0.5), so that floor(e / spacing) = n
  double estimateMiss;  ///< |estimated valid points - budget| / budget
};

/// One search for the grid closest to `budget` valid points whose axes each have at least
/// `least` points (1: any grid, no axis held). Each grid tried is placed whole (placeUniform,
/// its validity rays at every point) with `s`, on which the search sets the spacings: the
/// bisection both, a nearby grid the per-axis ones only (with one of them zero, placeUniform
/// reads spacingMeters, the bisection's last). Its other fields are used as given. Throws
/// ps::Cancelled through `progress`, and what placeUniform throws.
class BudgetSearch {
 public:
  BudgetSearch(const Tracer& tracer, int budget, int least, UniformSettings& s,
               const ProgressFn& progress)
      : tracer_(tracer),
        budget_(budget),
        least_(least),
        s_(s),
        progress_(progress),
        e_(tracer.scene().bounds.extent()) {}

  /// The closest grid found: the bisection's, or when it misses the budget by more than 10 %, the
  /// closest of it and up to 12 grids near it. Its points are empty when no grid tried had a
  /// valid point.
  UniformBudgetResult run() {
    bisect();
    if (best_.points.empty() || !(bestCubicSpacing_ > 0)) return std::move(best_);
    bool held[3];  // the axes held at their fewest points by the closest grid
    for (int a = 0; a < 3; ++a) held[a] = axisCount(e_[a], bestCubicSpacing_) < fewest(a);
    if (best_.axisSpacingMeters.x > 0)
      best_.spacingMeters = meanSpacing(best_.axisSpacingMeters, held);
    if (bestMiss_ <= 0.1) return std::move(best_);
    tryNearbyGrids(nearbyGrids(held), held);
    return std::move(best_);
  }

 private:
  /// The fewest points a grid of this search has along axis a.
  int fewest(int a) const { return minAxisCount(e_, a, least_); }

  /// Starts from the spacing that gives `budget` grid points if every point were valid, then
  /// bisects on log(spacing) (fewer valid points -> smaller spacing), at most 40 steps, until a
  /// grid is within 10 % or the interval closes. Keeps the closest grid in best_.
  void bisect() {
    double lo = std::max({e_.x, e_.y, e_.z}) / std::max(2.0, std::cbrt(budget_) * 64.0);
    double hi = std::max({e_.x, e_.y, e_.z}) * 2.0;
    for (int iter = 0; iter < 40; ++iter) {
      const double spacing = std::sqrt(lo * hi);
      s_.spacingMeters = spacing;
      s_.axisSpacingMeters = heldAxisSpacing(e_, spacing, least_);
      const Vec3& axis = s_.axisSpacingMeters;
      if (gridPointCount(e_, s_) > kMaxGridPoints) {
        lo = spacing;
        continue;
      }
      std::vector<Vec3> pts = placeUniform(tracer_, s_, {});
      if (progress_ && !progress_(std::min(1.0, (iter + 1) / 20.0))) throw Cancelled();
      const size_t count = pts.size();
      const double miss = std::abs(double(count) - budget_) / budget_;
      if (miss < bestMiss_) {
        bestMiss_ = miss;
        best_.points = std::move(pts);
        best_.spacingMeters = spacing;
        bestCubicSpacing_ = spacing;
        best_.axisSpacingMeters = axis;
      }
      if (bestMiss_ <= 0.1) break;
      // Too many points: the spacing is too small.
      if (double(count) > budget_)
        lo = spacing;
      else
        hi = spacing;
      if (hi / lo < 1.0001) break;
    }
  }

  /// The grids with up to one fewer or two more points per axis than the closest one (at least
  /// the fewest), spacings within a factor 1.5 of each other (a held axis aside), most promising
  /// first: their point counts scaled by the closest grid's valid fraction (stable for equal
  /// estimates). At most 63.
  std::vector<NearbyGrid> nearbyGrids(const bool* held) const {
    int base[3];
    for (int a = 0; a < 3; ++a) base[a] = std::max(axisCount(e_[a], bestCubicSpacing_), fewest(a));
    const double validFraction =
        double(best_.points.size()) / (double(base[0]) * base[1] * base[2]);
    std::vector<NearbyGrid> grids;
    for (int dx = -1; dx <= 2; ++dx)
      for (int dy = -1; dy <= 2; ++dy)
        for (int dz = -1; dz <= 2; ++dz) {
          const int n[3] = {base[0] + dx, base[1] + dy, base[2] + dz};
          if (n[0] < fewest(0) || n[1] < fewest(1) || n[2] < fewest(2) ||
              (dx == 0 && dy == 0 && dz == 0))
            continue;
          const Vec3 spacing(e_.x / (n[0] + 0.5), e_.y / (n[1] + 0.5), e_.z / (n[2] + 0.5));
          double smallest = std::numeric_limits<double>::infinity(), largest = 0;
          for (int a = 0; a < 3; ++a)
            if (!held[a] || n[a] > fewest(a)) {
              smallest = std::min(smallest, spacing[a]);
              largest = std::max(largest, spacing[a]);
            }
          if (largest > 1.5 * smallest) continue;
          const double estimate = double(n[0]) * n[1] * n[2] * validFraction;
          grids.push_back({spacing, std::abs(estimate - budget_) / budget_});
        }
    std::stable_sort(grids.begin(), grids.end(), [](const NearbyGrid& x, const NearbyGrid& y) {
      return x.estimateMiss < y.estimateMiss;
    });
    return grids;
  }

  /// Places the first 12 of `grids` in order, until one is within 10 %; keeps the closest in
  /// best_, its spacing the mean over the axes still `held` (three flags) at their fewest.
  void tryNearbyGrids(const std::vector<NearbyGrid>& grids, const bool* held) {
    for (size_t i = 0; i < std::min<size_t>(grids.size(), 12); ++i) {
      const Vec3 axis = grids[i].spacing;
      s_.axisSpacingMeters = axis;
      std::vector<Vec3> pts = placeUniform(tracer_, s_, {});
      if (progress_ && !progress_(1.0)) throw Cancelled();
      const double miss = std::abs(double(pts.size()) - budget_) / budget_;
      if (miss < bestMiss_) {
        bestMiss_ = miss;
        best_.points = std::move(pts);
        best_.axisSpacingMeters = axis;
        bool heldHere[3];
        for (int a = 0; a < 3; ++a) heldHere[a] = held[a] && axisCount(e_[a], axis[a]) <= fewest(a);
        best_.spacingMeters = meanSpacing(axis, heldHere);
      }
      if (bestMiss_ <= 0.1) break;
    }
  }

  const Tracer& tracer_;
  const int budget_;
  const int least_;
  UniformSettings& s_;
  const ProgressFn& progress_;
  const Vec3 e_;  ///< the scene bounds' extent (m)
  UniformBudgetResult best_;
  double bestMiss_ = std::numeric_limits<double>::infinity();  ///< best_'s relative miss
  double bestCubicSpacing_ = 0;  ///< the bisection's spacing for best_, before holding axes
};

}  // namespace

UniformBudgetResult placeUniformBudget(const Tracer& tracer, int budget, UniformSettings s,
                                       const ProgressFn& progress) {
  if (budget < 4)
    throw ParameterError("budget: expected at least 4 probes, got " + std::to_string(budget));
  // Each bisection step places a whole grid: a budget in the millions would run for hours.
  if (budget > kMaxProbeBudget)
    throw ParameterError("budget: expected at most " + std::to_string(kMaxProbeBudget) +
                         " probes (the limit), got " + std::to_string(budget));
  UniformBudgetResult result = BudgetSearch(tracer, budget, 1, s, progress).run();
  // A flat result (a room much wider than tall: dream-apartment at 32 and 64 probes, or a layer
  // of the grid inside geometry) cannot be made a volume: search again holding each axis at 2,
  // then 3 and 4 points. Results that span 3D stay as they were.
  for (int least = 2; least <= 4 && !pointsSpan3D(result.points); ++least) {
    UniformBudgetResult held = BudgetSearch(tracer, budget, least, s, progress).run();
    if (!held.points.empty()) result = std::move(held);
  }
  return result;
}

}  // namespace ps
