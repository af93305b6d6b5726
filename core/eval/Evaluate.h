#pragma once
// Accuracy of an interpolated probe volume against a high-sample reference (DESIGN.md):
// random valid points of the domain of interest, a random normal each; reference irradiance
// path-traced directly (cosine-weighted) for that normal.
#include <cstdint>

#include "core/common/Progress.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

struct EvalSettings {
  int queries = 256;
  int referenceSpp = 1024;
  uint64_t seed = 7;
};

struct EvalResult {
  size_t probes = 0;
  size_t queries = 0;
  /// sqrt(sum (E_vol - E_ref)^2 / sum E_ref^2) over query luminances.
  double relRmse = 0;
  /// Per-query relative error |E_vol - E_ref| / max(E_ref, 0.1 * mean E_ref): percentiles.
  double p95RelError = 0;
  double maxRelError = 0;
  /// Fraction of the queries whose tetrahedron (the hull tetrahedron they are clamped to, when
  /// outside) has a probe not visible from the query point: light leaks through geometry
  /// there (Sukys 3.2.2).
  double leakingFraction = 0;
  double seconds = 0;
};

EvalResult evaluateVolume(const Tracer& tracer, const LightingRig& rig, const ProbeVolume& volume,
                          const EvalSettings& settings, const ProgressFn& progress = {});

}  // namespace ps
