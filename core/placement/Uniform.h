#pragma once
// The baseline placement: a regular grid at a given spacing inside the scene bounds, dropping
// points inside geometry (Kontkanen & Laine sec. 5 validity).
#include <vector>

#include "core/common/Progress.h"
#include "core/trace/Tracer.h"

namespace ps {

struct UniformSettings {
  double spacingMeters = 1.0;
  double invalidBackfaceFraction = 0.25;  ///< tol::kDefaultInvalidBackfaceFraction
  int validityRays = 64;
  uint64_t seed = 1;
};

/// Grid points at cell centres of a grid with the given spacing covering the scene bounds,
/// minus those inside geometry. Throws ps::ParameterError for a spacing <= 0 or one that would
/// make more than 50 million grid points.
std::vector<Vec3> placeUniform(const Tracer& tracer, const UniformSettings& settings,
                               const ProgressFn& progress = {});

struct UniformBudgetResult {
  std::vector<Vec3> points;
  double spacingMeters = 0;
};

/// The grid spacing whose valid points number `budget` within 10 % (the closest count found when
/// no spacing gets that close), so that methods are compared at equal probe count.
/// Throws ps::ParameterError for a budget below 4 or above 1 million.
UniformBudgetResult placeUniformBudget(const Tracer& tracer, int budget, UniformSettings settings,
                                       const ProgressFn& progress = {});

/// Number of grid points (before the validity test) for a spacing over the given bounds.
double uniformGridPointCount(const Bounds3& bounds, double spacingMeters);

}  // namespace ps
