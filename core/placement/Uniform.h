#pragma once
// The baseline placement: a regular grid at a given spacing inside the scene bounds, dropping
// points inside geometry (Kontkanen & Laine sec. 5 validity).
#include <memory>
#include <vector>

#include "core/common/Progress.h"
#include "core/domain/DomainPoints.h"
#include "core/trace/Tracer.h"

namespace ps {

/// The largest probe budget: the budget search places a whole grid per step, and a budget in the
/// millions would run for hours. `place` refuses larger budgets for every method.
inline constexpr int kMaxProbeBudget = 1000000;

struct UniformSettings {
  double spacingMeters = 1.0;
  /// Per-axis spacings (x, y, z) when all three are positive, else spacingMeters on every axis.
  /// placeUniformBudget uses them when no single spacing gets within 10 % of the budget, or when
  /// it holds an axis at 2 or more points.
  Vec3 axisSpacingMeters{0, 0, 0};
  double invalidBackfaceFraction = 0.25;  ///< tol::kDefaultInvalidBackfaceFraction
  int validityRays = 64;
  uint64_t seed = 1;
  /// When set, only grid points inside it (Domain::contains) are kept; null: the scene bounds.
  std::shared_ptr<const Domain> domain;
};

/// Grid points at cell centres of a grid with the given spacing covering the scene bounds,
/// minus those inside geometry. Throws ps::ParameterError for a spacing <= 0 or one that would
/// make more than 50 million grid points.
std::vector<Vec3> placeUniform(const Tracer& tracer, const UniformSettings& settings,
                               const ProgressFn& progress = {});

struct UniformBudgetResult {
  std::vector<Vec3> points;
  /// The grid's spacing: the geometric mean of axisSpacingMeters, over the axes not held at
  /// their fewest points when some are.
  double spacingMeters = 0;
  Vec3 axisSpacingMeters{0, 0, 0};  ///< per axis when the grid is not cubic, else zero
};

/// The grid spacing whose valid points number `budget` within 10 %, so that methods are
/// compared at equal probe count. A box's cubic grids jump in count (on cornell 27, then 64):
/// when no single spacing gets within 10 %, grids with one to a few more or fewer points per axis
/// (spacings within a factor 1.5 of each other) are tried too; the closest count found is kept.
/// When the result's valid points lie in one plane (a room much wider than tall, or a layer of
/// the grid inside geometry), the search runs again with at least 2, then 3, then 4 points along
/// each axis the scene has extent on, so that a volume can be made of them; a result that spans
/// 3D is kept as it is. A held grid has at least 8 points, so budgets 4 to 7 then get 8.
/// Throws ps::ParameterError for a budget below 4 or above 1 million.
UniformBudgetResult placeUniformBudget(const Tracer& tracer, int budget, UniformSettings settings,
                                       const ProgressFn& progress = {});

/// True when the points do not all lie in one plane (a volume can be made of them).
bool pointsSpan3D(const std::vector<Vec3>& points);

/// Number of grid points (before the validity test) for a spacing over the given bounds.
double uniformGridPointCount(const Bounds3& bounds, double spacingMeters);

}  // namespace ps
