#pragma once
// Probe capture: path-traced incident radiance at points, projected to SH L2 (Sh.h), with the
// standard error of every coefficient and the validity of the point (Kontkanen & Laine sec. 5).
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "core/capture/LightSampler.h"
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
  /// Adaptive mode when > 0: each probe traces batches of kAdaptiveBatchSamples rays and stops
  /// once the relative standard error of its irradiance (captureRelativeError) is at most this,
  /// or at maxSamplesPerProbe; samplesPerProbe is then ignored. Deterministic: the decision
  /// depends only on the probe's own samples.
  double targetRelativeError = 0;
  int minSamplesPerProbe = 64;     ///< adaptive mode: never fewer rays than this
  int maxSamplesPerProbe = 65536;  ///< adaptive mode: never more rays than this
  uint64_t seed = 1;               ///< per-probe streams derive from (seed, probe index)
  CaptureMode mode = CaptureMode::Full;
  int threads = 0;  ///< 0 = all hardware threads; results do not depend on it
  /// Point and spot lights are summed at every path vertex while there are at most this many;
  /// above it, one is importance-sampled per vertex from a light tree (LightSampler.h). The
  /// estimate is unbiased either way; the default is the faster to a given error.
  size_t exactLightCount = kExactLightCount;
  /// When sampling, the most nodes of the tree's cut a light is drawn from (LightSampler.h).
  int maxLightCut = kMaxCut;
  /// When sampling, steer each probe's choice of lights by what its earlier batches' shadow
  /// rays found (LightVisibility): lights behind walls are chosen less. Unbiased either way.
  bool learnLightVisibility = true;
  /// Trace each batch of kPathBatchSamples paths bounce by bounce, every bounce's rays in one
  /// Embree stream call and its shadow rays in another; false: one ray at a time. The random
  /// streams are per sample, so both give the same paths, up to the last bits of Embree's packet
  /// kernels (and, where two coincident triangles tie, which one is reported). Off by default:
  /// a ray at a time was the faster in bench_capture on a quiet machine (packets took 1.06 to
  /// 1.18 times as long on cornell, two-rooms and dream-apartment, and the same on the full
  /// level's bake): a probe's rays and its shadow rays go every way, which leaves Embree's
  /// stream calls little coherence to use, and the copies into and out of them cost.
  bool tracePackets = false;
  /// Record each probe's visibility map (ProbeCapture::distanceMoments). Off by default: the
  /// bake turns it on for the probes it stores; placement's many cheap captures do not need
  /// the 2 KB per probe.
  bool visibilityMaps = false;
};

/// Adaptive sampling checks its error after every this many rays.
inline constexpr int kAdaptiveBatchSamples = 64;
/// Paths traced together (CaptureSettings::tracePackets): one adaptive batch, so that the
/// stopping rule sees the same samples either way.
inline constexpr int kPathBatchSamples = kAdaptiveBatchSamples;

/// Histograms of the incident radiance over the probe's rays (the same rays as the SH; light
/// arriving straight from delta lights is not in them), for placement's probe matching
/// (Chajdas et al. sec. 4.3). Fixed layout:
///  * luminance (Rec. 709 Y of the ray's radiance): kLuminanceBins bins, each ray weighing
///    1 / samples (rays are uniform on the sphere, so a bin is the fraction of the sphere):
///    bin 0 holds Y < 2^kLuminanceLog2Min (black included), bin k in 1..kLuminanceBins-2 holds
///    2^(kLuminanceLog2Min + k - 1) <= Y < 2^(kLuminanceLog2Min + k), the last bin Y at or
///    above 2^(kLuminanceLog2Min + kLuminanceBins - 2);
///  * hue (HSV hue of the radiance): kHueBins bins of 360 / kHueBins degrees starting at red
///    (bin 0 holds hues in [0, 30) degrees), each ray weighing its luminance; achromatic rays
///    (max - min <= 1e-6 max) count in no bin; normalized to sum 1 (all 0 when no ray has a
///    hue).
inline constexpr int kLuminanceBins = 16;
inline constexpr int kLuminanceLog2Min = -10;
inline constexpr int kHueBins = 12;

/// Visibility maps (Majercik et al. 2019, "Dynamic Diffuse Global Illumination with Ray-Traced
/// Irradiance Probes", JCGT 8(2), sec. 4): per probe, an octahedral map (core/math/Octahedral.h)
/// of kVisibilityMapSize x kVisibilityMapSize texels, each holding the mean and the mean square
/// of the distance (metres) from the probe to the first surface its rays hit in that texel's
/// directions. Every ray of the capture counts once, in the texel its direction falls in (a box
/// filter: DDGI's cos^50 lobe over every texel would cost a power per texel per ray, as much as
/// the path itself); a texel no ray fell in takes the moments of the nearest texel that has
/// some. A ray that leaves the scene counts at missDistance() (below). 16 x 16 texels, chosen by
/// measurement (docs/leaks.md): at 8 x 8 a texel spans about 25 degrees, and the spread of the
/// distances to a wall seen obliquely within it let 34 of the 400 queries next to a thin wall
/// (tests/core/test_visibility.cpp) read light from behind it; at 16 x 16 none did. At the
/// bake's 1024 rays a texel gets 4 rays on average, and the lookup's bilinear blend reads 4
/// texels.
inline constexpr int kVisibilityMapSize = 16;
inline constexpr int kVisibilityTexels = kVisibilityMapSize * kVisibilityMapSize;
/// Floats per probe in a map: (mean, mean square) per texel, texel-major.
inline constexpr int kVisibilityFloats = 2 * kVisibilityTexels;
/// The distance a ray that hits nothing counts at: the diagonal of the scene's bounds (at least
/// 1 m), farther than any point of the scene.
double missDistance(const Scene& scene);

/// The luminance bin of a radiance (the layout above).
int luminanceBin(Rgb radiance);
/// The hue bin of a radiance, or -1 when it is achromatic (the layout above).
int hueBin(Rgb radiance);

struct ProbeCapture {
  ShRgb sh;          ///< incident radiance
  ShRgb shStdError;  ///< standard error of each coefficient
  int samples = 0;   ///< rays traced from the probe
  /// Fraction of probe rays that hit back faces, a double-sided one counting half (as in
  /// backfaceFraction()); above the threshold the probe is inside geometry.
  double backfaceFraction = 0;
  double seconds = 0;  ///< wall time spent on this probe
  /// The relative standard error of the irradiance reached: for each of the six axis normals,
  /// the standard error of the luminance of the L2 irradiance estimate E(n) (each ray's estimate
  /// is L(w) pi (1 + 2 c + 5/8 (3 c^2 - 1)), c = n . w: the ray's SH L2 projection folded with
  /// the Ramamoorthi-Hanrahan convolution), divided by the largest of the six irradiances
  /// (direct delta light included), so that a probe's dark sides are measured against its
  /// bright side and cannot demand unbounded samples; the largest of the six ratios, 0 when the
  /// probe receives no light. Adaptive sampling stops on it.
  double relativeError = 0;
  std::array<double, kLuminanceBins> luminanceHistogram{};  ///< layout above; sums to 1
  std::array<double, kHueBins> hueHistogram{};              ///< layout above; sums to 1 or 0
  /// The visibility map (layout above) when CaptureSettings::visibilityMaps, else empty:
  /// kVisibilityFloats floats, the mean and mean square of the first-hit distance (m, and m^2)
  /// per texel. Both are the back-face distances when the probe is inside geometry.
  std::vector<float> distanceMoments;
};

/// Captures one probe per point. Deterministic for a given seed whatever the thread count: sample
/// j of probe i draws from its own random stream, derived from (seed, i, j).
/// Throws ps::ParameterError when the scene plus rig has no light at all, or a setting is out
/// of range.
std::vector<ProbeCapture> captureProbes(const Tracer& tracer, const LightingRig& rig,
                                        std::span<const Vec3> points,
                                        const CaptureSettings& settings,
                                        const ProgressFn& progress = {});

/// Captures one probe per point as captureProbes does, `chunk` points at a time, and hands each
/// capture to `take(index into points, capture)` instead of keeping them all (a capture holds its
/// SH, histograms and more: for millions of points, keep only what is needed). Chunk c is
/// captured with seed settings.seed + 2^32 c, so that each chunk has its own streams (a probe's
/// stream follows its index in its chunk). `progress` covers all the chunks.
void captureProbesInChunks(const Tracer& tracer, const LightingRig& rig,
                           std::span<const Vec3> points, const CaptureSettings& settings,
                           size_t chunk,
                           const std::function<void(size_t, const ProbeCapture&)>& take,
                           const ProgressFn& progress = {});

/// Fraction of `rays` uniformly distributed rays from p that hit back faces (Kontkanen & Laine
/// sec. 5), a back face of double-sided geometry (glTF doubleSided; its winding still says
/// which side is out) counting half. Behind one double-sided sheet (a leaf, a wall modelled as
/// a single plane) fewer than half of the rays see its back, which stays under the 0.25 of
/// tol::kDefaultInvalidBackfaceFraction, except within a few centimetres of a large sheet,
/// where it nears 0.25 and the ray sample decides; inside a closed double-sided object nearly
/// all rays see back faces.
/// Every asset of the shared real scenes is double-sided: were those back faces counted as nothing,
/// points inside walls and furniture would pass as valid, at zero irradiance. Where two solids
/// share a face (a wall standing on a floor slab, two slabs meeting), a ray that reaches the shared
/// face counts its back face: Embree reports either of the two coincident triangles, and counting
/// the front one would let points inside the solids there pass. A sheet made of two triangles back
/// to back is told apart by what lies past it: a ray that crosses a shared face is inside the other
/// solid (its next hit is a back face), one that crosses a sheet is not. The capture's own
/// ProbeCapture::backfaceFraction takes the first hit as it is. Deterministic for a given seed.
double backfaceFraction(const Tracer& tracer, Vec3 p, int rays, uint64_t seed);

/// Path-traced radiance along rays leaving points of the scene, for the evaluation's reference
/// and the prefiltered capture: the same path tracer as captureProbes, its lights gathered and its
/// light tree built once for every ray traced through it. `exactLightCount` and `maxLightCut` as
/// in CaptureSettings; the evaluation's reference sums every light (SIZE_MAX), for the least
/// noise per path. Delta lights (sun, point, spot) are never hit
/// by a ray, so the light they send straight to the origin is not in the radiance: add it from
/// core/capture/DirectLight.h for a reference irradiance. Safe to call from many threads.
class RadianceTracer {
 public:
  RadianceTracer(const Tracer& tracer, const LightingRig& rig,
                 size_t exactLightCount = kExactLightCount, int maxLightCut = kMaxCut);
  ~RadianceTracer();
  RadianceTracer(const RadianceTracer&) = delete;
  RadianceTracer& operator=(const RadianceTracer&) = delete;

  /// Radiance arriving at `origin` from -dir (`dir` unit), one ray at a time; `rngState` is the
  /// path's random stream and is advanced.
  Rgb radiance(Vec3 origin, Vec3 dir, uint64_t& rngState) const;
  /// out[k] = the radiance along dirs[k] from `origin`, path k drawing from the stream whose
  /// state is streams[k] (not advanced). The paths are traced together, bounce by bounce, in
  /// Embree stream calls (CaptureSettings::tracePackets); each gives what radiance() gives for
  /// its ray and stream, up to the last bits of Embree's packet kernels. All three spans have
  /// the same size.
  void radiance(Vec3 origin, std::span<const Vec3> dirs, std::span<const uint64_t> streams,
                std::span<Rgb> out) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ps
