#pragma once
// Probe capture: path-traced incident radiance at points, projected to SH L2 (Sh.h), with the
// standard error of every coefficient and the validity of the point (Kontkanen & Laine sec. 5).
#include <cstdint>
#include <span>
#include <vector>

#include "core/common/Progress.h"
#include "core/math/Sh.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

enum class CaptureMode {
  Full,          ///< all light
  IndirectOnly,  ///< direct light from punctual lights and the sun left out at the probe
                 ///< (Sukys 3.1.2, "light decoupling")
};

struct CaptureSettings {
  int samplesPerProbe = 256;  ///< rays per probe (fixed-count mode)
  uint64_t seed = 1;          ///< per-probe streams derive from (seed, probe index)
  CaptureMode mode = CaptureMode::Full;
  int threads = 0;  ///< 0 = all hardware threads; results do not depend on it
};

struct ProbeCapture {
  ShRgb sh;                     ///< incident radiance
  ShRgb shStdError;             ///< standard error of each coefficient
  int samples = 0;              ///< rays traced from the probe
  double backfaceFraction = 0;  ///< fraction of probe rays that hit back faces of single-sided
                                ///< geometry; above the threshold the probe is inside geometry
  double seconds = 0;           ///< wall time spent on this probe
};

/// Captures one probe per point. Deterministic for a given seed whatever the thread count.
/// Throws ps::ParameterError when the scene plus rig has no light at all.
std::vector<ProbeCapture> captureProbes(const Tracer& tracer, const LightingRig& rig,
                                        std::span<const Vec3> points,
                                        const CaptureSettings& settings,
                                        const ProgressFn& progress = {});

/// Fraction of `rays` uniformly distributed rays from p that hit back faces of single-sided
/// geometry (Kontkanen & Laine sec. 5). Deterministic for a given seed.
double backfaceFraction(const Tracer& tracer, Vec3 p, int rays, uint64_t seed);

/// Radiance path-traced along a ray leaving point `origin` in unit direction `dir`; exposed for
/// the evaluation's reference. `rngState` is advanced. Delta lights (sun, point, spot) are never
/// hit by a ray, so the light they send straight to `origin` is not in it (and `mode` changes
/// nothing here): add it from core/capture/DirectLight.h for a reference irradiance.
Rgb traceRadiance(const Tracer& tracer, const LightingRig& rig, Vec3 origin, Vec3 dir,
                  uint64_t& rngState, CaptureMode mode = CaptureMode::Full);

}  // namespace ps
