#pragma once
// Pre-filtered capture (Kontkanen & Laine, "Sampling precomputed volumetric lighting", sec. 4
// eq. 5-6 and sec. 6, Algorithm 2): instead of point-sampling the incident radiance at a grid
// node, the node's SH coefficients are the average of the radiance over the node's support,
// weighted by its trilinear basis function b_i, from ray origins inside the domain of interest
// only (sec. 5: the space from which no back face of single-sided geometry is visible; unlike
// backfaceFraction, this test still takes double-sided back faces for surfaces, so with
// double-sided walls a node's support keeps origins inside them). This
// removes the frequencies a grid of that spacing cannot represent, and a node next to a wall
// integrates only the light on its side of it.
#include <span>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Progress.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

/// One node of a grid: its position and the half-width h of its trilinear basis function,
/// b(x) = prod over the axes of max(0, 1 - |x_a - node_a| / h) (the grid spacing).
struct PrefilterNode {
  Vec3 position;
  double halfWidth = 0;
};

/// Captures each node by eq. 6: settings.samplesPerProbe candidate rays, each with an origin
/// drawn from b (normalised: the product of three triangular distributions on [-h, h], so every
/// kept sample weighs the same) and a uniform direction. A candidate whose origin sees a back
/// face (its own ray hits one, or a shadow ray to a back-face point found earlier for this node
/// does) is outside the domain of interest and dropped, and the kept ones are re-tested against
/// every new back-face point (Algorithm 2); so is a candidate whose ray meets a surface within
/// the tracer's ray offset (it could not be traced). The kept rays are path-traced (RadianceTracer)
/// and, in CaptureMode::Full, the delta lights' direct light at each kept origin is added. Per
/// node: sh, shStdError (from the kept samples' per-sample estimates), samples = kept rays,
/// backfaceFraction = the fraction of candidates dropped (1 with no sample kept: the support
/// lies outside the domain, and sh is zero), relativeError as in ProbeCapture, histograms of
/// the kept rays. Fixed sample counts only (settings.targetRelativeError must be 0).
/// Deterministic for a given seed whatever the thread count. Throws ps::ParameterError for
/// samplesPerProbe < 1, a non-positive or non-finite half-width, adaptive settings, or a scene
/// plus rig without light; ps::Cancelled through `progress`.
std::vector<ProbeCapture> capturePrefiltered(const Tracer& tracer, const LightingRig& rig,
                                             std::span<const PrefilterNode> nodes,
                                             const CaptureSettings& settings,
                                             const ProgressFn& progress = {});

}  // namespace ps
