#pragma once
// The dense field placement methods start from: cheap probes inside the domain of interest
// (the scene bounds or the importance volumes), minus the points inside geometry (Kontkanen &
// Laine sec. 5), refined adaptively where geometry is near and where neighbouring samples
// differ, so that empty space and uniform lighting cost little.

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Progress.h"
#include "core/domain/ReachableSpace.h"
#include "core/io/ProbeSet.h"
#include "core/math/Sh.h"
#include "core/math/Vec3.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

/// One cheap probe of the dense field.
struct FieldSample {
  Vec3 position;
  ShRgb sh;                     ///< incident radiance (low spp)
  ShRgb shStdError;             ///< standard error of each coefficient
  Vec3 f;                       ///< luminanceDirection(sh) (Chajdas sec. 2.1, eq. 1)
  double backfaceFraction = 0;  ///< validity (Kontkanen & Laine sec. 5); invalid ones are dropped
  /// Luminance and hue histograms of the sample's rays (ProbeCapture's layout, Capture.h), for
  /// probe matching (Chajdas sec. 4.3).
  std::array<double, kLuminanceBins> luminanceHistogram{};
  std::array<double, kHueBins> hueHistogram{};
  int depth = 0;         ///< octree level the sample was made at (0 = base grid)
  double cellSize = 0;   ///< edge of the octree cell the sample is the centre of, metres
  bool refined = false;  ///< the cell was split: samples of the next level cover it
  /// A boundary sample (DenseFieldSettings::boundarySamples): not a cell centre but a point
  /// between a leaf cell's centre and the surface or domain boundary next to it; `slab` is its
  /// distance from that centre (0 for a centre sample).
  bool boundary = false;
  double slab = 0;
};

struct DenseFieldSettings {
  double baseSpacingMeters = 0;  ///< base grid spacing; 0 = domain diagonal / 12
  int maxDepth = 2;              ///< refinement levels below the base grid
  /// Levels at which a cell splits because a surface crosses it (-1: maxDepth). Below it, only
  /// differing neighbours split cells: the light's detail, not the geometry's, draws the finest
  /// samples (next to walls, boundary samples cover what the centres miss).
  int maxSurfaceDepth = -1;
  int samplesPerProbe = 64;
  CaptureMode mode = CaptureMode::Full;
  size_t maxSamples = 200000;  ///< ParameterError above this, before any capture
  double invalidBackfaceFraction = 0.25;
  std::vector<ImportanceVolume> importanceVolumes;  ///< empty: the scene bounds
  /// When set, cells whose centre is outside it are not made (the reachable space).
  std::shared_ptr<const ReachableSpace> reachable;
  uint64_t seed = 1;
  /// A cell splits when a face neighbour differs: the L2 distance between the luminances of
  /// their 9 SH coefficients exceeds this fraction of the larger sample's norm...
  double refineRelativeDifference = 0.3;
  /// ... and exceeds this many standard errors of the difference (the cheap capture is noisy:
  /// noise alone must not refine).
  double refineSignificance = 3.0;
  int validityRays = 32;  ///< rays per point for the validity test before capture
  /// Pre-filtered capture (Kontkanen & Laine sec. 4 and 6; PrefilteredCapture.h): each sample
  /// integrates the radiance over its cell's trilinear support (half-width = the cell size)
  /// from origins inside the domain of interest, instead of point-sampling at the centre.
  bool prefilter = false;
  /// Boundary samples: from the centre of every leaf sample, along each of the 6 axes, where a
  /// surface or the domain's boundary is less than a cell away, one more sample just short of it
  /// (boundaryOffset of the finest cell size away along the axis; captured at that point, also
  /// in a pre-filtered field). Cell centres stay half a cell
  /// from every wall; a probe set chosen among them alone has a hull that misses that layer, and
  /// queries there are clamped to the hull, which is worst right under a light.
  bool boundarySamples = false;
  double boundaryOffset = 0.05;
};

struct DenseField {
  std::vector<FieldSample> samples;
  Bounds3 domain;
  double seconds = 0;
  double baseSpacingMeters = 0;  ///< the base grid spacing used
  /// Cells made per level (valid or not; index = depth) and how many of them split.
  std::vector<size_t> cellsPerLevel, splitsPerLevel;
  /// True when a refinement level was skipped because it would have exceeded maxSamples.
  bool refinementTruncated = false;
};

/// Builds the dense field: a cell-centred base grid of cubic cells over the domain (the scene
/// bounds, or the bounding box of the importance volumes keeping cells whose centre is in one),
/// each centre tested for validity and the valid ones captured at samplesPerProbe; then, level by
/// level up to maxDepth, a cell splits into 8 when a surface crosses it (at levels below
/// maxSurfaceDepth) or when a face neighbour (at its level, or the coarser cell covering that
/// place) differs (samplesDiffer in the .cpp: relative SH-luminance distance above
/// refineRelativeDifference, significant against the standard errors). Every valid sample of every
/// level is kept (a split cell's own sample too); then the boundary samples when asked for.
/// Deterministic for a given seed. Throws ps::ParameterError for a negative spacing, maxDepth or
/// maxSurfaceDepth outside [0, 8] (-1 allowed for the latter), boundaryOffset outside (0, 0.25),
/// samplesPerProbe < 1, or when the base grid alone would exceed maxSamples (a refinement level
/// that would exceed it is skipped, boundary samples beyond it are dropped, and
/// refinementTruncated set); ps::Cancelled through `progress`.
DenseField buildDenseField(const Tracer& tracer, const LightingRig& rig,
                           const DenseFieldSettings& settings, const ProgressFn& progress = {});

}  // namespace ps
