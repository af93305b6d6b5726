// Probe capture by path tracing (Kontkanen & Laine sec. 4-5; Sukys 3.1.2 for IndirectOnly).
//
// Estimator. Incident radiance L(w) at the probe is projected to SH L2:
//   c_i = integral over the sphere of L(w) Y_i(w) dw  ~=  (4 pi / N) sum_j L(w_j) Y_i(w_j)
// with w_j uniform on the sphere (pdf 1 / 4 pi). The directions are a Cranley-Patterson-rotated
// R2 sequence (Roberts 2018) mapped to the sphere by the equal-area map z = 1 - 2u, phi = 2 pi v:
// every point of a randomly rotated sequence is uniform, so the estimate is unbiased, and the
// low discrepancy lowers the variance of the first dimension.
//
// Radiance along a ray: a Lambertian path tracer with next-event estimation (NEE) to the delta
// lights (sun, point, spot), cosine-weighted bounces, Russian roulette by throughput after
// kRussianRouletteStartBounce bounces and a hard cap of kMaxBounces. Emissive surfaces and the
// constant sky are reached by sampled rays only (no NEE for them), so nothing is counted twice.
// A vertex takes NEE from the delta lights LightSampler chooses (all of them when few, else one
// from a light tree, weighted by one over its probability: unbiased either way).
// The environment map is reached by the probe's own rays in full and, at surface vertices, by
// NEE (importance-sampled by texel power) and by the bounce ray, each weighted by the power
// heuristic (Veach 1997, sec. 9.2) so that together they count it once. Albedo and emission are the
// material's factors times its textures at the hit's TEXCOORD_0 (Scene::albedoAt, emissionAt);
// cut-out (alphaMode MASK) points are never hit (the tracer's Embree filter).
//
// Adaptive sampling (CaptureSettings::targetRelativeError): after every kAdaptiveBatchSamples
// rays the standard error of each axis irradiance's luminance is estimated from the per-ray
// estimates L(w) sum_l A_l (2l+1) P_l(n . w) (the SH L2 projection of one ray folded with the
// Ramamoorthi-Hanrahan convolution, so it is exactly the variance of the irradiance the probe
// reports); the probe stops when the largest, relative to its brightest axis, is at most the
// target. The decision uses only the probe's own samples: deterministic for any thread count.
// Every sample draws from its own stream, derived from (seed, probe, sample), so a batch of paths
// traced bounce by bounce in Embree stream calls gives the same paths as one ray at a time.
// The same rays feed the luminance and hue histograms and the visibility map (Capture.h gives
// the layouts; DDGI, Majercik et al. 2019, sec. 4, for the map).
// A single-sided surface seen from behind ends the path with zero radiance (the inside of a
// solid is black); the first hit from the probe counts towards backfaceFraction.
//
// Delta lights (DirectLight.h: inverse square, glTF's windowed range falloff and smooth spot
// cone) are never hit by a ray, so the light they send straight to the probe is added
// analytically: a delta of irradiance E from direction w projects to c_i = E Y_i(w). CaptureMode
// ::IndirectOnly leaves out exactly this term (Sukys 3.1.2, "light decoupling"); their light
// reflected by surfaces (NEE at path vertices) is indirect at the probe and stays.
#include "core/capture/Capture.h"

#include "core/capture/DirectLight.h"
#include "core/capture/ParallelProbes.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>

#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/math/Octahedral.h"
#include "core/math/SinCos.h"

namespace ps {

namespace {

/// Paths never get longer than this many surface vertices (Russian roulette ends nearly all
/// of them much earlier; the cap only guards against albedo-1 scenes).
constexpr int kMaxBounces = 128;
/// Russian roulette starts after this many bounces.
constexpr int kRussianRouletteStartBounce = 3;

// ---- Random numbers ------------------------------------------------------------------------

/// splitmix64 (Steele, Lea & Flood 2014): the state is a Weyl counter, the output a mix of it.
uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/// Uniform double in [0, 1) with 53 random bits.
double uniform01(uint64_t& state) {
  return static_cast<double>(splitmix64(state) >> 11) * 0x1.0p-53;
}

/// The initial state of an independent stream for (seed, index).
uint64_t streamState(uint64_t seed, uint64_t index) {
  uint64_t a = seed;
  uint64_t b = index ^ 0xD1B54A32D192ED03ull;
  const uint64_t hs = splitmix64(a);
  const uint64_t hi = splitmix64(b);
  uint64_t c = hs ^ (hi + 0x9E3779B97F4A7C15ull + (hs << 6) + (hs >> 2));
  return splitmix64(c);
}

/// Point j of the R2 sequence, rotated by `offset` (Cranley-Patterson), in [0, 1)^2.
/// alpha = (1/g, 1/g^2) with g the plastic number (Roberts 2018).
void r2Point(uint64_t j, const double offset[2], double& u, double& v) {
  constexpr double g = 1.32471795724474602596;
  constexpr double a1 = 1.0 / g, a2 = 1.0 / (g * g);
  const double jd = static_cast<double>(j);
  u = offset[0] + a1 * jd;
  v = offset[1] + a2 * jd;
  u -= std::floor(u);
  v -= std::floor(v);
}

// ---- Sampling ------------------------------------------------------------------------------

/// Equal-area map of [0,1)^2 to the unit sphere (pdf 1 / 4 pi); azimuth 2 pi v.
Vec3 uniformSphere(double u, double v) {
  const double z = 1.0 - 2.0 * u;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const SinCos phi = sinCos2Pi(v);
  return {r * phi.cos, r * phi.sin, z};
}

/// Cosine-weighted direction around the unit normal n (pdf cos / pi), Malley's method. Unit by
/// construction (r^2 + z^2 = 1 in the orthonormal frame t, b, n), to rounding: not renormalised.
Vec3 cosineHemisphere(Vec3 n, double u, double v) {
  const double r = std::sqrt(u);
  const SinCos phi = sinCos2Pi(v);  // azimuth 2 pi v
  const double z = std::sqrt(std::max(0.0, 1.0 - u));
  Vec3 t, b;
  orthonormalBasis(n, t, b);
  return t * (r * phi.cos) + b * (r * phi.sin) + n * z;
}

bool isFinite(Rgb c) {
  return std::isfinite(c.r) && std::isfinite(c.g) && std::isfinite(c.b);
}

// ---- Path tracer ---------------------------------------------------------------------------

/// How much a ray's first hit counts towards "inside geometry" (Kontkanen & Laine sec. 5): 1 for
/// the back of single-sided geometry, 0.5 for the back of double-sided geometry (its winding
/// still tells its outside; backfaceFraction), 0 for a front face.
double insideWeight(const Scene& scene, const Hit& hit) {
  if (hit.frontFace) return 0;
  const uint32_t materialIndex = scene.triangleMaterial[hit.triangle];
  PS_CHECK_LT(size_t{materialIndex}, scene.materials.size());
  return scene.materials[materialIndex].doubleSided ? 0.5 : 1.0;
}

/// A path being traced: its current ray (o, d), the radiance it has gathered, its throughput,
/// its own random stream and what its first hit told about the probe.
struct PathState {
  Vec3 o, d;
  Rgb L;
  Rgb beta{1, 1, 1};
  double bouncePdf = 0;  // pdf (per sr) of the cosine-weighted bounce that made d; 0 at the probe
  uint64_t rng = 0;
  int bounce = 0;
  double firstHitBackface = 0;  ///< insideWeight of the first hit
  double firstHitDistance = std::numeric_limits<double>::infinity();
};

/// A shadow ray of a path vertex and the radiance it adds to path `path` when nothing blocks it.
struct ShadowRay {
  Ray ray;
  Rgb contribution;
  uint32_t path = 0;
  /// The light a sampled choice (LightChoice::sampled) sent it to, else kNoLight: what it finds
  /// teaches the probe's LightVisibility.
  uint32_t light = kNoLight;
  static constexpr uint32_t kNoLight = std::numeric_limits<uint32_t>::max();
};

class PathTracer {
 public:
  PathTracer(const Tracer& tracer, const LightingRig& rig, size_t exactLightCount, int maxLightCut)
      : tracer_(tracer),
        scene_(tracer.scene()),
        lights_(allLights(tracer.scene(), rig)),
        sampler_(lights_, exactLightCount, maxLightCut),
        sky_(rig.skyRadiance),
        env_(environmentOf(rig)),
        envNee_(env_ && env_->canSample()),
        eps_(tracer.rayEpsilon()) {
    // Material indices are checked per hit.
    PS_CHECK_EQ(scene_.triangleMaterial.size(), scene_.triangleCount());
  }
  PathTracer(const PathTracer&) = delete;  // sampler_ refers to lights_
  PathTracer& operator=(const PathTracer&) = delete;

  const std::vector<Light>& lights() const { return lights_; }
  const LightSampler& sampler() const { return sampler_; }
  Rgb sky() const { return sky_; }
  /// True when rays that leave the scene can bring light (constant sky or a non-black map).
  bool hasSky() const {
    if (!sky_.isBlack()) return true;
    if (!env_) return false;
    for (float v : env_->rgb)
      if (v > 0) return true;
    return false;
  }

  /// Also checks every triangle's material index (once per capture).
  bool hasEmissiveSurface() const {
    bool any = false;
    for (uint32_t m : scene_.triangleMaterial) {
      PS_CHECK_LT(size_t{m}, scene_.materials.size());
      any = any || !scene_.materials[m].emission.isBlack();
    }
    return any;
  }

  /// Radiance arriving at `origin` from direction -dir (travelling along dir from origin), one
  /// ray at a time; `rng` is the path's stream and is advanced. `firstHitBackface` is set to how
  /// much the first surface hit counts towards "inside" (insideWeight; a path goes on from the
  /// back of double-sided geometry), `firstHitDistance` to the distance along dir to the first
  /// hit (infinity when the ray leaves the scene).
  Rgb radiance(Vec3 origin, Vec3 dir, uint64_t& rng, double* firstHitBackface,
               double* firstHitDistance = nullptr) const {
    PathState s;
    s.o = origin;
    s.d = dir;
    s.rng = rng;
    trace(std::span<PathState>(&s, 1), false);
    rng = s.rng;
    if (firstHitBackface) *firstHitBackface = s.firstHitBackface;
    if (firstHitDistance) *firstHitDistance = s.firstHitDistance;
    return s.L;
  }

  /// Traces every path to its end (each set up with its ray and stream). `packets`: bounce by
  /// bounce over all the paths, each bounce's rays in one Embree stream call (the first
  /// bounce's, which share the probe as origin, as coherent) and its shadow rays in another;
  /// else path by path, one ray at a time. A path's arithmetic and random draws are the same
  /// either way. Radiance that is not finite is set to 0 (a degenerate configuration must not
  /// poison a probe). `visibility`, when given, steers the choice of lights (LightVisibility) and
  /// records what the sampled lights' shadow rays found; the caller commits it.
  void trace(std::span<PathState> paths, bool packets,
             LightVisibility* visibility = nullptr) const {
    thread_local std::vector<ShadowRay> shadows;
    thread_local std::vector<LightChoice> choices;
    // What a shadow ray found: its light when nothing blocked it, and a record of it for the
    // visibility when it went to a sampled light.
    auto settle = [visibility](PathState& path, const ShadowRay& sh, bool blocked) {
      if (!blocked) path.L += sh.contribution;
      if (visibility && sh.light != ShadowRay::kNoLight) visibility->record(sh.light, !blocked);
    };
    if (!packets) {
      for (size_t i = 0; i < paths.size(); ++i) {
        PathState& s = paths[i];
        bool going = true;
        while (going) {
          shadows.clear();
          going = step(s, tracer_.intersect(Ray{s.o, s.d}), 0, shadows, choices, visibility);
          for (const ShadowRay& sh : shadows) settle(s, sh, tracer_.occluded(sh.ray));
        }
        if (!isFinite(s.L)) s.L = Rgb{};
      }
      return;
    }
    thread_local std::vector<uint32_t> active, next;
    thread_local std::vector<Ray> rays, shadowRays;
    thread_local std::vector<std::optional<Hit>> hits;
    thread_local std::vector<uint8_t> blocked;
    active.clear();
    for (size_t i = 0; i < paths.size(); ++i) active.push_back(static_cast<uint32_t>(i));
    for (bool first = true; !active.empty(); first = false) {
      rays.clear();
      for (uint32_t i : active) rays.push_back(Ray{paths[i].o, paths[i].d});
      hits.resize(rays.size());
      tracer_.intersectStream(rays, hits, first);
      shadows.clear();
      next.clear();
      for (size_t k = 0; k < active.size(); ++k)
        if (step(paths[active[k]], hits[k], active[k], shadows, choices, visibility))
          next.push_back(active[k]);
      shadowRays.clear();
      for (const ShadowRay& sh : shadows) shadowRays.push_back(sh.ray);
      blocked.resize(shadowRays.size());
      tracer_.occludedStream(shadowRays, blocked, false);
      for (size_t k = 0; k < shadows.size(); ++k)
        settle(paths[shadows[k].path], shadows[k], blocked[k] != 0);
      std::swap(active, next);
    }
    for (PathState& s : paths)
      if (!isFinite(s.L)) s.L = Rgb{};
  }

  /// SH of the radiance arriving at p straight from the delta lights (unoccluded ones), every
  /// light summed.
  ShRgb directDeltaSh(Vec3 p) const { return ps::directDeltaSh(tracer_, lights_, p); }

 private:
  /// One vertex of path s, whose current ray found `hit` (or left the scene): adds what it
  /// reaches (sky, emission), appends the vertex's shadow rays (for path `index`) to `shadows`,
  /// and draws the next ray. Returns false when the path ends here; its shadow rays still count.
  bool step(PathState& s, const std::optional<Hit>& hit, uint32_t index,
            std::vector<ShadowRay>& shadows, std::vector<LightChoice>& choices,
            const LightVisibility* visibility) const {
    if (!hit) {
      // Escaped: the constant sky plus the environment map. From the probe (uniform
      // directions) the map counts fully; after a bounce it is weighted by the power
      // heuristic against the map's own sampling at that vertex (Veach 1997, eq. 9.13).
      if (!env_) {
        s.L += s.beta * sky_;
      } else {
        double w = 1;
        if (s.bounce > 0 && envNee_) {
          const double pe = env_->pdf(s.d);
          w = s.bouncePdf * s.bouncePdf / (s.bouncePdf * s.bouncePdf + pe * pe);
        }
        s.L += s.beta * (sky_ + env_->radiance(s.d) * w);
      }
      return false;
    }
    const uint32_t materialIndex = scene_.triangleMaterial[hit->triangle];
    PS_CHECK_LT(size_t{materialIndex}, scene_.materials.size());
    const Material& m = scene_.materials[materialIndex];
    if (s.bounce == 0) {
      s.firstHitBackface = insideWeight(scene_, *hit);
      s.firstHitDistance = hit->t;
    }
    // Inside of a solid (Kontkanen & Laine sec. 5): black.
    if (!hit->frontFace && !m.doubleSided) return false;
    // Emission, reached by sampled rays only; factor times texture at the hit's UV0.
    if (!m.emission.isBlack())
      s.L +=
          s.beta * (m.isTextured() ? scene_.emissionAt(hit->triangle, hit->u, hit->v) : m.emission);
    const Rgb albedo = m.isTextured() ? scene_.albedoAt(hit->triangle, hit->u, hit->v) : m.albedo;
    if (albedo.isBlack()) return false;

    // Shade on the side the ray arrived from.
    const Vec3 n = hit->frontFace ? hit->geometricNormal : -hit->geometricNormal;
    const Vec3 p = s.o + s.d * hit->t + n * eps_;
    const Rgb betaBrdf = s.beta * albedo * (1.0 / kPi);
    // Next-event estimation to the delta lights: L_r = albedo / pi * E * max(0, cos), over the
    // lights the sampler picks, each weighted by 1 / its probability (LightSampler.h). A light
    // whose range window has ended at p, or that lies below the surface, costs no ray.
    choices.clear();
    sampler_.choose(p, n, sampler_.sampling() ? uniform01(s.rng) : 0.0, choices, visibility);
    for (const LightChoice& c : choices) {
      const auto a = finiteDeltaArrival(lights_[c.light], p);
      if (!a) continue;
      const double cosTheta = dot(n, a->directionToLight);
      if (cosTheta <= 0) continue;
      shadows.push_back({deltaLightShadowRay(eps_, p, *a),
                         betaBrdf * a->irradiance * (cosTheta * c.weight), index,
                         c.sampled ? c.light : ShadowRay::kNoLight});
    }

    // Next-event estimation to the environment map, importance-sampled by its luminance and
    // weighted by the power heuristic against the cosine-weighted bounce (Veach 1997, 9.2).
    if (envNee_) {
      double pe = 0;
      const Vec3 wl = env_->sample(uniform01(s.rng), uniform01(s.rng), pe);
      const double cosTheta = dot(n, wl);
      if (cosTheta > 0 && pe > 0) {
        const double pb = cosTheta / kPi;
        const double w = pe * pe / (pe * pe + pb * pb);
        shadows.push_back({Ray{p, wl, eps_, std::numeric_limits<double>::infinity()},
                           betaBrdf * env_->radiance(wl) * (cosTheta * w / pe), index});
      }
    }

    // Lambertian bounce, cosine-weighted: f cos / pdf = albedo.
    const double u1 = uniform01(s.rng), u2 = uniform01(s.rng);
    s.d = cosineHemisphere(n, u1, u2);
    // Only the environment map's MIS weight reads it: skip the division otherwise.
    if (envNee_) s.bouncePdf = std::max(0.0, dot(n, s.d)) / kPi;
    s.o = p;
    s.beta = s.beta * albedo;
    if (s.bounce + 1 >= kRussianRouletteStartBounce) {
      const double q = std::min(1.0, s.beta.maxComponent());  // survival by throughput
      if (!(q > 0) || uniform01(s.rng) >= q) return false;
      s.beta *= 1.0 / q;
    }
    return ++s.bounce < kMaxBounces;
  }

  const Tracer& tracer_;
  const Scene& scene_;
  std::vector<Light> lights_;
  LightSampler sampler_;
  Rgb sky_;
  std::shared_ptr<const EnvironmentMap> env_;
  bool envNee_;  ///< the map can be importance-sampled (loaded through loadEnvironmentMap)
  double eps_;
};

/// Sums and sums of squares of the 27 per-sample estimators 4 pi L Y_i (in double: the
/// cancellation in sumSq - sum^2 / n loses ~1e-16 of the second moment, far below any standard
/// error we report; a negative difference is clamped to 0). Stored per channel, so that the
/// per-sample update is three loops over the 9 basis values that the compiler vectorises.
struct ShAccumulator {
  std::array<std::array<double, kShCoeffCount>, 3> sum{};  ///< [channel][coefficient]
  std::array<std::array<double, kShCoeffCount>, 3> sumSq{};
  int n = 0;

  void add(Vec3 d, Rgb radiance) {
    ++n;
    // A black sample adds exactly 0 to every sum (most paths in a room lit by a small emitter
    // never reach it): skip the basis and the 54 updates.
    if (radiance.r == 0.0 && radiance.g == 0.0 && radiance.b == 0.0) return;
    const auto y = shBasis(d);
    const Rgb l = radiance * (4.0 * kPi);
    for (int ch = 0; ch < 3; ++ch) {
      const double lc = l[ch];
      auto& s = sum[size_t(ch)];
      auto& s2 = sumSq[size_t(ch)];
      for (size_t i = 0; i < kShCoeffCount; ++i) {
        const double x = lc * y[i];
        s[i] += x;
        s2[i] += x * x;
      }
    }
  }
  Rgb mean(int i) const {
    if (n <= 0) return Rgb{};
    return Rgb{sum[0][size_t(i)], sum[1][size_t(i)], sum[2][size_t(i)]} / n;
  }
  /// The standard error of mean(i) per channel: sample standard deviation / sqrt(n).
  Rgb standardError(int i) const {
    Rgb se;
    if (n < 2) return se;
    for (int ch = 0; ch < 3; ++ch) {
      const double s = sum[size_t(ch)][size_t(i)], s2 = sumSq[size_t(ch)][size_t(i)];
      const double var = (s2 - s * s / n) / (n - 1);
      se[ch] = std::sqrt(std::max(0.0, var) / n);
    }
    return se;
  }
};

/// Running mean and variance (Welford) of the per-ray estimates of the luminance of the L2
/// irradiance for the six axis normals (+x, -x, +y, -y, +z, -z).
struct AxisIrradianceAccumulator {
  std::array<double, 6> mean{};
  std::array<double, 6> m2{};
  int n = 0;

  void add(Vec3 d, double lum) {
    ++n;
    const double inv = 1.0 / n;
    if (lum == 0.0) {  // x = 0 on every axis: the same update without the polynomials
      for (size_t k = 0; k < 6; ++k) {
        const double delta = -mean[k];
        mean[k] += delta * inv;
        m2[k] += delta * (0.0 - mean[k]);
      }
      return;
    }
    const double cs[3] = {d.x, d.y, d.z};
    for (int k = 0; k < 6; ++k) {
      const double c = (k % 2 == 0 ? 1.0 : -1.0) * cs[k / 2];
      // sum_l A_l (2l + 1) P_l(c), A = (pi, 2pi/3, pi/4) (Ramamoorthi & Hanrahan 2001, eq. 8)
      const double x = lum * kPi * (1.0 + 2.0 * c + 0.625 * (3.0 * c * c - 1.0));
      const double delta = x - mean[size_t(k)];
      mean[size_t(k)] += delta * inv;
      m2[size_t(k)] += delta * (x - mean[size_t(k)]);
    }
  }

  /// CaptureSettings' relative error, with `direct` the delta lights' irradiance per axis.
  double relativeError(const std::array<double, 6>& direct) const {
    if (n < 2) return std::numeric_limits<double>::infinity();
    double brightest = 0;
    for (int k = 0; k < 6; ++k)
      brightest = std::max(brightest, mean[size_t(k)] + direct[size_t(k)]);
    double worst = 0;
    for (int k = 0; k < 6; ++k) {
      const double se = std::sqrt(std::max(0.0, m2[size_t(k)] / (n - 1)) / n);
      worst = std::max(worst, se);
    }
    if (worst == 0) return 0;
    return brightest > 0 ? worst / brightest : std::numeric_limits<double>::infinity();
  }
};

/// The visibility map's sums (Capture.h): per texel, the ray count and the sums of the distance
/// and of its square.
struct DistanceAccumulator {
  std::array<int, kVisibilityTexels> n{};
  std::array<double, kVisibilityTexels> sum{}, sumSq{};

  void add(Vec3 dir, double distance) {
    const size_t k = size_t(octTexel(dir, kVisibilityMapSize));
    ++n[k];
    sum[k] += distance;
    sumSq[k] += distance * distance;
  }

  /// The moments per texel; a texel without rays takes those of the texel nearest to it (by
  /// angle between texel centres, the lower index on a tie) that has rays. All zero when no
  /// texel has rays.
  std::vector<float> moments() const {
    static const std::array<Vec3, kVisibilityTexels> centres = [] {
      std::array<Vec3, kVisibilityTexels> c;
      for (int j = 0; j < kVisibilityMapSize; ++j)
        for (int i = 0; i < kVisibilityMapSize; ++i)
          c[size_t(i + kVisibilityMapSize * j)] = octTexelDirection(i, j, kVisibilityMapSize);
      return c;
    }();
    std::vector<float> out(size_t(kVisibilityFloats), 0.0f);
    for (size_t k = 0; k < size_t(kVisibilityTexels); ++k) {
      size_t from = k;
      if (n[k] == 0) {
        double best = -2;
        for (size_t o = 0; o < size_t(kVisibilityTexels); ++o)
          if (n[o] > 0 && dot(centres[k], centres[o]) > best) {
            best = dot(centres[k], centres[o]);
            from = o;
          }
        if (n[from] == 0) continue;
      }
      out[2 * k] = float(sum[from] / n[from]);
      out[2 * k + 1] = float(sumSq[from] / n[from]);
    }
    return out;
  }
};

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

double missDistance(const Scene& scene) {
  const double d = scene.bounds.diagonal();
  return std::isfinite(d) ? std::max(1.0, d) : 1.0;
}

int luminanceBin(Rgb radiance) {
  const double y = luminance(radiance);
  if (!(y >= std::ldexp(1.0, kLuminanceLog2Min))) return 0;  // black and NaN too
  if (!std::isfinite(y)) return kLuminanceBins - 1;
  const int k = std::ilogb(y) - kLuminanceLog2Min + 1;  // ilogb: floor(log2 y), exactly
  return std::clamp(k, 1, kLuminanceBins - 1);
}

int hueBin(Rgb c) {
  const double mx = c.maxComponent();
  const double mn = std::min(c.r, std::min(c.g, c.b));
  if (!(mx > 0) || mx - mn <= 1e-6 * mx) return -1;
  // HSV hue in degrees (Smith 1978).
  const double d = mx - mn;
  double h;
  if (mx == c.r) {
    h = 60.0 * ((c.g - c.b) / d);
    if (h < 0) h += 360.0;
  } else if (mx == c.g)
    h = 60.0 * ((c.b - c.r) / d + 2.0);
  else
    h = 60.0 * ((c.r - c.g) / d + 4.0);
  const int k = static_cast<int>(h / (360.0 / kHueBins));
  return std::clamp(k, 0, kHueBins - 1);
}

std::vector<ProbeCapture> captureProbes(const Tracer& tracer, const LightingRig& rig,
                                        std::span<const Vec3> points,
                                        const CaptureSettings& settings,
                                        const ProgressFn& progress) {
  if (settings.samplesPerProbe < 1)
    throw ParameterError("capture: samplesPerProbe is " + std::to_string(settings.samplesPerProbe) +
                         ", expected at least 1");
  const bool adaptive = settings.targetRelativeError > 0;
  if (!(settings.targetRelativeError >= 0) || !std::isfinite(settings.targetRelativeError))
    throw ParameterError("capture: targetRelativeError is " +
                         std::to_string(settings.targetRelativeError) +
                         ", expected 0 (fixed samples) or a positive fraction");
  if (adaptive && (settings.minSamplesPerProbe < 2 ||
                   settings.maxSamplesPerProbe < settings.minSamplesPerProbe))
    throw ParameterError("capture: adaptive sampling needs 2 <= minSamplesPerProbe (" +
                         std::to_string(settings.minSamplesPerProbe) + ") <= maxSamplesPerProbe (" +
                         std::to_string(settings.maxSamplesPerProbe) + ")");
  if (settings.threads < 0)
    throw ParameterError("capture: threads is " + std::to_string(settings.threads) +
                         ", expected 0 (all) or a positive count");
  const PathTracer pt(tracer, rig, settings.exactLightCount, settings.maxLightCut);
  if (pt.lights().empty() && !pt.hasSky() && !pt.hasEmissiveSurface())
    throw ParameterError(
        "the scene has no light: it brings no punctual light and no emissive surface, and the "
        "rig is empty (or its environment map is black); add a sun (--sun DX,DY,DZ,E), a sky "
        "(--env R,G,B) or an environment map (--env-map FILE.hdr)");
  for (size_t i = 0; i < points.size(); ++i)
    if (!isFinite(points[i]))
      throw ParameterError("capture: probe " + std::to_string(i) +
                           " has a non-finite position, expected finite coordinates");

  std::vector<ProbeCapture> out(points.size());
  const int maxSamples = adaptive ? settings.maxSamplesPerProbe : settings.samplesPerProbe;
  const double miss = missDistance(tracer.scene());
  const std::array<Vec3, 6> axes = {Vec3{1, 0, 0},  Vec3{-1, 0, 0}, Vec3{0, 1, 0},
                                    Vec3{0, -1, 0}, Vec3{0, 0, 1},  Vec3{0, 0, -1}};
  forEachProbeInParallel(
      points.size(), settings.threads, progress,
      [&](size_t probe, const std::atomic<bool>& cancelled) {
        const auto t0 = std::chrono::steady_clock::now();
        const Vec3 p = points[probe];
        // The probe's stream gives the sequence's rotation and seeds one stream per sample.
        const uint64_t probeStream = streamState(settings.seed, probe);
        uint64_t rng = probeStream;
        const double offset[2] = {uniform01(rng), uniform01(rng)};
        // The delta lights' direct light: added to the SH in Full mode, and part of the irradiance
        // the relative error is measured against.
        const ShRgb direct = settings.mode == CaptureMode::Full ? pt.directDeltaSh(p) : ShRgb{};
        std::array<double, 6> directLum{};
        for (size_t k = 0; k < 6; ++k) directLum[k] = luminance(direct.irradiance(axes[k]));
        ShAccumulator acc;
        AxisIrradianceAccumulator irr;
        DistanceAccumulator dist;
        ProbeCapture& c = out[probe];
        std::array<double, kHueBins> hue{};
        double backfaces = 0;
        std::array<PathState, kPathBatchSamples> paths;
        std::array<Vec3, kPathBatchSamples> dirs;
        // What this probe's shadow rays found, committed after each batch (LightVisibility).
        thread_local LightVisibility visibility;
        visibility.reset(pt.sampler());
        int j = 0;
        while (j < maxSamples) {
          if (cancelled.load()) return;
          // Batches start at multiples of kAdaptiveBatchSamples: the rule is checked there.
          if (adaptive && j >= settings.minSamplesPerProbe &&
              irr.relativeError(directLum) <= settings.targetRelativeError)
            break;
          const int count = std::min(kPathBatchSamples, maxSamples - j);
          for (int k = 0; k < count; ++k) {
            double u, v;
            r2Point(static_cast<uint64_t>(j + k), offset, u, v);
            PathState& s = paths[size_t(k)];
            s = PathState{};
            s.o = p;
            s.d = dirs[size_t(k)] = uniformSphere(u, v);
            s.rng = streamState(probeStream, static_cast<uint64_t>(j + k));
          }
          pt.trace(std::span<PathState>(paths.data(), size_t(count)), settings.tracePackets,
                   settings.learnLightVisibility ? &visibility : nullptr);
          visibility.commit();
          for (int k = 0; k < count; ++k) {
            const PathState& s = paths[size_t(k)];
            const Vec3 dir = dirs[size_t(k)];
            backfaces += s.firstHitBackface;
            if (settings.visibilityMaps) dist.add(dir, std::min(s.firstHitDistance, miss));
            acc.add(dir, s.L);
            const double lum = luminance(s.L);
            irr.add(dir, lum);
            c.luminanceHistogram[size_t(luminanceBin(s.L))] += 1.0;
            const int h = hueBin(s.L);
            if (h >= 0) hue[size_t(h)] += lum;
          }
          j += count;
        }
        const int n = j;
        c.samples = n;
        c.backfaceFraction = backfaces / n;
        for (double& b : c.luminanceHistogram) b /= n;
        double hueTotal = 0;
        for (double b : hue) hueTotal += b;
        for (size_t k = 0; k < hue.size(); ++k)
          c.hueHistogram[k] = hueTotal > 0 ? hue[k] / hueTotal : 0;
        for (int i = 0; i < kShCoeffCount; ++i) {
          c.sh.c[i] = acc.mean(i);
          c.shStdError.c[i] = acc.standardError(i);
        }
        c.sh += direct;
        c.relativeError = irr.relativeError(directLum);
        if (settings.visibilityMaps) c.distanceMoments = dist.moments();
        for (int i = 0; i < kShCoeffCount; ++i) {
          PS_CHECK(isFinite(c.sh.c[i]));
          PS_CHECK(isFinite(c.shStdError.c[i]));
        }
        c.seconds = secondsSince(t0);
      });
  return out;
}

void captureProbesInChunks(const Tracer& tracer, const LightingRig& rig,
                           std::span<const Vec3> points, const CaptureSettings& settings,
                           size_t chunk,
                           const std::function<void(size_t, const ProbeCapture&)>& take,
                           const ProgressFn& progress) {
  PS_CHECK(chunk > 0);
  CaptureSettings cs = settings;
  for (size_t first = 0; first < points.size(); first += chunk) {
    const size_t count = std::min(chunk, points.size() - first);
    cs.seed = settings.seed + 0x100000000ull * (first / chunk);
    ProgressFn chunkProgress;
    if (progress)
      chunkProgress = [&](double f) {
        return progress((double(first) + f * double(count)) / double(points.size()));
      };
    const std::vector<ProbeCapture> caps =
        captureProbes(tracer, rig, points.subspan(first, count), cs, chunkProgress);
    for (size_t i = 0; i < count; ++i) take(first + i, caps[i]);
  }
}

double backfaceFraction(const Tracer& tracer, Vec3 p, int rays, uint64_t seed) {
  if (rays < 1)
    throw ParameterError("backfaceFraction: rays is " + std::to_string(rays) +
                         ", expected at least 1");
  const Scene& scene = tracer.scene();
  PS_CHECK_EQ(scene.triangleMaterial.size(), scene.triangleCount());
  uint64_t rng = streamState(seed, 0);
  const double offset[2] = {uniform01(rng), uniform01(rng)};
  // Two coincident triangles facing opposite ways (oppositeFaceAt) are reported either way
  // round. Where two solids share a face, a ray from inside one reaches its back face there,
  // with the other solid's front face beside it, and past the pair it is inside the other
  // solid: its next hit is a back face. A sheet made of two triangles back to back looks the
  // same at the pair, but past it the ray is outside (its next hit is a front face, or
  // nothing): no back face. Beside: within the ray offset plus the float roundings of the two
  // hits (Embree intersects in float, from float coordinates).
  const double coincident =
      tracer.rayEpsilon() + 1e-6 * std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  double inside = 0;
  for (int j = 0; j < rays; ++j) {
    double u, v;
    r2Point(static_cast<uint64_t>(j), offset, u, v);
    const Ray ray{p, uniformSphere(u, v)};
    const auto hit = tracer.intersect(ray);
    if (!hit) continue;
    Hit first = *hit;
    const double halfWidth = coincident + 1e-6 * hit->t;
    if (const auto other = tracer.oppositeFaceAt(ray, *hit, halfWidth)) {
      // A pair: what lies past it decides (a back face: a shared face; else a sheet).
      const auto next = tracer.intersect(Ray{p, ray.direction, hit->t + halfWidth});
      if (!next || next->frontFace) continue;
      if (first.frontFace) {
        first.triangle = *other;
        first.frontFace = false;
      }
    }
    inside += insideWeight(scene, first);
  }
  return inside / rays;
}

struct RadianceTracer::Impl {
  Impl(const Tracer& tracer, const LightingRig& rig, size_t exactLightCount, int maxLightCut)
      : pt(tracer, rig, exactLightCount, maxLightCut) {}
  PathTracer pt;
};

RadianceTracer::RadianceTracer(const Tracer& tracer, const LightingRig& rig, size_t exactLightCount,
                               int maxLightCut)
    : impl_(std::make_unique<Impl>(tracer, rig, exactLightCount, maxLightCut)) {}

RadianceTracer::~RadianceTracer() = default;

Rgb RadianceTracer::radiance(Vec3 origin, Vec3 dir, uint64_t& rngState) const {
  return impl_->pt.radiance(origin, dir, rngState, nullptr);
}

void RadianceTracer::radiance(Vec3 origin, std::span<const Vec3> dirs,
                              std::span<const uint64_t> streams, std::span<Rgb> out) const {
  PS_CHECK_EQ(dirs.size(), streams.size());
  PS_CHECK_EQ(dirs.size(), out.size());
  std::array<PathState, kPathBatchSamples> paths;
  for (size_t first = 0; first < dirs.size(); first += paths.size()) {
    const size_t count = std::min(paths.size(), dirs.size() - first);
    for (size_t k = 0; k < count; ++k) {
      PathState& s = paths[k];
      s = PathState{};
      s.o = origin;
      s.d = dirs[first + k];
      s.rng = streams[first + k];
    }
    impl_->pt.trace(std::span<PathState>(paths.data(), count), true);
    for (size_t k = 0; k < count; ++k) out[first + k] = paths[k].L;
  }
}

}  // namespace ps
