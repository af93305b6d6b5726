#pragma once
// Least-squares probe values: instead of each probe's own capture (point sampling), the values
// that make the volume's interpolation closest to the lighting over the whole domain of
// interest. Kontkanen & Laine (sec. 4, footnote 2) note that their pre-filtered grid values are
// not the minimum-error projection onto the interpolation basis, which on an infinite grid
// would need dual basis functions of infinite support. On a finite tetrahedral mesh that
// projection is a sparse linear system: the least-squares fit of the barycentric interpolant to
// captures at random points of the domain, solved here by conjugate gradients. A term pulling
// each probe towards its own capture keeps the system well posed where few points fall (and the
// values of probes no point reaches unchanged).
// The fit minimizes the absolute squared error, as eval's rel_rmse measures it: where a bright,
// sharp feature (a sun patch) sits beside dark space, the piecewise-linear fit overshoots into
// the dark side, and the relative error there can grow.
#include <cstdint>
#include <span>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Progress.h"
#include "core/domain/DomainPoints.h"
#include "core/math/Sh.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

struct FitSettings {
  /// Random points of the domain per probe (DomainPoints: outside geometry and the light
  /// clearance), each captured at samplesPerPoint.
  int pointsPerProbe = 128;
  int samplesPerPoint = 64;
  /// Weight of the pull towards each probe's own capture, relative to the mean weight the fit
  /// points give a probe (the mean diagonal of W^T W).
  double regularization = 0.01;
  /// Fit points keep this fraction of the domain's diagonal from point and spot lights, as
  /// eval's queries do (next to such a light the irradiance grows without bound, and a few
  /// points there would decide every value around it).
  double lightClearanceRelative = kDefaultLightClearanceRelative;
  uint64_t seed = 1;
  /// What the fit points capture, as the probes' own capture does (the bake passes its own:
  /// fitting indirect-only probes to full light would be wrong).
  CaptureMode mode = CaptureMode::Full;
  int threads = 0;  ///< CaptureSettings::threads
};

struct FitResult {
  size_t points = 0;   ///< fit points used
  int iterations = 0;  ///< conjugate-gradient iterations (the most of the 27 systems)
  /// Relative RMS misfit of the interpolated SH luminance at the fit points (all 9
  /// coefficients), with the captured values and with the fitted ones.
  double residualBefore = 0, residualAfter = 0;
  double seconds = 0;
};

/// Throws ps::ParameterError naming the setting out of range (parameter(): its field name
/// here), or when `probes` probes would need more than 5 million fit points (fitProbeValues
/// checks too; the bake and the CLI call it before their capture).
void checkFitSettings(const FitSettings& settings, size_t probes = 0);

/// The least-squares values (ProbeVolume::sh layout) for SH `targets` at points located at `at`
/// in `volume` (clamped locations count with their face weights), pulled towards volume.sh with
/// `regularization` (> 0) x the mean weight the points give a probe. Sets `*iterations` to the most
/// conjugate-gradient iterations of the 27 systems.
std::vector<float> leastSquaresValues(const ProbeVolume& volume, std::span<const VolumeLocation> at,
                                      std::span<const ShRgb> targets, double regularization,
                                      int* iterations = nullptr);

/// The fit's domain points (DomainPoints) for `domain`; throws ps::ParameterError when the
/// domain has no volume (a flat importance box), as the bake checks before its capture.
void checkFitDomain(const Tracer& tracer, const LightingRig& rig, const Domain& domain,
                    const FitSettings& settings);

/// Replaces volume.sh by the least-squares values. `domain`: the importance volumes' boxes
/// (empty: the scene bounds). Deterministic for the seed. Throws ps::ParameterError when a
/// setting is out of range or no valid point is found, ps::Cancelled through `progress`.
FitResult fitProbeValues(const Tracer& tracer, const LightingRig& rig, ProbeVolume& volume,
                         const Domain& domain, const FitSettings& settings,
                         const ProgressFn& progress = {});

}  // namespace ps
