#pragma once
// Virtual offset: moving a probe that sits inside geometry to the nearest point of the domain of
// interest (Kontkanen & Laine sec. 5: the space from which no back face is visible), so that
// its capture sees the lighting of the space around the solid instead of the solid's black
// inside.
#include <cstdint>
#include <optional>

#include "core/common/Tolerances.h"
#include "core/trace/Tracer.h"

namespace ps {

struct VirtualOffsetSettings {
  int rays = 64;  ///< rays from the probe to find back faces (and to test candidates)
  /// A point is invalid when more than this fraction of its rays hit back faces.
  double invalidBackfaceFraction = tol::kDefaultInvalidBackfaceFraction;
  /// How far in front of the exit face the probe is put; 0 = 0.5 % of the scene's bounding-box
  /// diagonal.
  double pushOutMeters = 0;
  uint64_t seed = 1;
};

/// The point to capture instead of `p`: `p` itself when it is valid (backfaceFraction at most
/// the threshold); otherwise the nearest valid candidate, a candidate being a back face seen
/// from p (where a ray leaves the solid) moved pushOutMeters along its front normal, tried in
/// order of distance. Nothing when p is invalid and no candidate is valid.
/// Throws ps::ParameterError for rays < 1 or a negative pushOutMeters.
std::optional<Vec3> virtualOffset(const Tracer& tracer, Vec3 p,
                                  const VirtualOffsetSettings& settings = {});

}  // namespace ps
