// Pre-filtered capture: Kontkanen & Laine, "Sampling precomputed volumetric lighting", sec. 4
// (eq. 5: c_ij = integral over the domain of b_i(x) times the SH projection of L(x, .), over the
// integral of b_i) estimated by eq. 6 (sec. 6) from random origins and directions, with the
// domain of interest of sec. 5 found by Algorithm 2 (back-face points shared within a node).
#include "core/capture/PrefilteredCapture.h"

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <string>

#include "core/capture/DirectLight.h"
#include "core/capture/ParallelProbes.h"
#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/math/Random.h"

namespace ps {
namespace {

/// A draw from the triangular density max(0, 1 - |t|) on [-1, 1] (the sum of two uniforms,
/// centred): sampling b_i in proportion gives every origin the same weight in eq. 6.
double tent(uint64_t& rng) {
  return uniform01(rng) - uniform01(rng);
}

bool isBackFace(const Scene& scene, const Hit& hit) {
  return !hit.frontFace && !scene.materials[scene.triangleMaterial[hit.triangle]].doubleSided;
}

/// True when the segment from `from` to back-face point `to` first meets a back face (Algorithm
/// 2's query ray): `from` sees that back face, so it is outside the domain of interest.
bool seesBackFacePoint(const Tracer& tracer, Vec3 from, Vec3 to) {
  const Vec3 d = to - from;
  const double len = length(d);
  if (!(len > 0)) return true;
  // A little past the point: from just outside a wall, the query grazes the wall, and the
  // point (rounded off the plane) could otherwise be reached without crossing it.
  const auto hit = tracer.intersect(Ray{from, d / len, 0, 1.01 * len + tracer.rayEpsilon()});
  return hit && isBackFace(tracer.scene(), *hit);
}

/// The per-sample estimators of eq. 6 (27 SH values) and of the luminance of the L2 irradiance
/// for the six axis normals, accumulated as sums and sums of squares.
struct Accumulator {
  std::array<Rgb, kShCoeffCount> sum{}, sumSq{};
  std::array<double, 6> irrSum{}, irrSumSq{};
  int n = 0;

  void add(const ShRgb& x) {
    ++n;
    for (int i = 0; i < kShCoeffCount; ++i) {
      sum[i] += x.c[i];
      sumSq[i] += x.c[i] * x.c[i];
    }
    static const std::array<Vec3, 6> axes = {Vec3{1, 0, 0},  Vec3{-1, 0, 0}, Vec3{0, 1, 0},
                                             Vec3{0, -1, 0}, Vec3{0, 0, 1},  Vec3{0, 0, -1}};
    for (size_t k = 0; k < 6; ++k) {
      const double e = luminance(x.irradiance(axes[k]));
      irrSum[k] += e;
      irrSumSq[k] += e * e;
    }
  }
  static double standardError(double s, double sq, int n) {
    if (n < 2) return 0;
    const double var = (sq - s * s / n) / (n - 1);
    return std::sqrt(std::max(0.0, var) / n);
  }
};

}  // namespace

std::vector<ProbeCapture> capturePrefiltered(const Tracer& tracer, const LightingRig& rig,
                                             std::span<const PrefilterNode> nodes,
                                             const CaptureSettings& settings,
                                             const ProgressFn& progress) {
  if (settings.targetRelativeError != 0)
    throw ParameterError(
        "pre-filtered capture: targetRelativeError is " +
        std::to_string(settings.targetRelativeError) +
        ", expected 0 (pre-filtered capture takes a fixed number of samples per node)");
  // The settings and the light as captureProbes() checks them (it throws before any work).
  captureProbes(tracer, rig, {}, settings);
  for (size_t i = 0; i < nodes.size(); ++i) {
    if (!isFinite(nodes[i].position))
      throw ParameterError("pre-filtered capture: node " + std::to_string(i) +
                           " has a non-finite position, expected finite coordinates");
    if (!(nodes[i].halfWidth > 0) || !std::isfinite(nodes[i].halfWidth))
      throw ParameterError("pre-filtered capture: node " + std::to_string(i) + " has half-width " +
                           std::to_string(nodes[i].halfWidth) + ", expected a positive length");
  }
  const Scene& scene = tracer.scene();
  const std::vector<Light> lights =
      settings.mode == CaptureMode::Full ? allLights(scene, rig) : std::vector<Light>{};
  const RadianceTracer radiance(tracer, rig);
  const int N = settings.samplesPerProbe;
  std::vector<ProbeCapture> out(nodes.size());
  forEachProbeInParallel(
      nodes.size(), settings.threads, progress, [&](size_t index, const std::atomic<bool>&) {
        const auto t0 = std::chrono::steady_clock::now();
        const PrefilterNode& node = nodes[index];
        uint64_t rng = streamSeed(settings.seed, index);
        // Algorithm 2: candidate rays, the back-face points seen from this node's support, and the
        // kept rays (origin, direction).
        struct Candidate {
          Vec3 origin, dir;
        };
        std::vector<Candidate> kept;
        std::vector<Vec3> backFacePoints;
        kept.reserve(size_t(N));
        for (int s = 0; s < N; ++s) {
          const Vec3 origin =
              node.position + Vec3(tent(rng), tent(rng), tent(rng)) * node.halfWidth;
          const double u = uniform01(rng), v = uniform01(rng);
          const Vec3 dir = uniformSphere(u, v);
          bool outside = false;
          for (Vec3 b : backFacePoints)
            if (seesBackFacePoint(tracer, origin, b)) {
              outside = true;
              break;
            }
          if (outside) continue;
          const auto hit = tracer.intersect(Ray{origin, dir});
          // An origin within the ray offset of the surface its ray meets cannot be traced: the path
          // tracer's first ray starts past that surface. Such candidates (a band of width ~1e-4 of
          // the scene along the walls) are dropped like those outside the domain.
          if (hit && hit->t < tracer.rayEpsilon()) continue;
          if (hit && isBackFace(scene, *hit)) {
            const Vec3 b = origin + dir * hit->t;
            backFacePoints.push_back(b);
            std::erase_if(
                kept, [&](const Candidate& c) { return seesBackFacePoint(tracer, c.origin, b); });
            continue;
          }
          kept.push_back({origin, dir});
        }

        // Eq. 6 with b_i sampled in proportion: the plain mean of the kept samples' estimators
        // 4 pi L(x_s, w_s) Y_j(w_s), plus each delta light's E(x_s) Y_j(w_light) at x_s.
        ProbeCapture& c = out[index];
        Accumulator acc;
        for (const Candidate& k : kept) {
          ShRgb x = directDeltaSh(tracer, lights, k.origin);
          const Rgb L = radiance.radiance(k.origin, k.dir, rng);
          x.addSample(k.dir, L, 4.0 * kPi);
          acc.add(x);
          c.luminanceHistogram[size_t(luminanceBin(L))] += 1.0;
          if (const int h = hueBin(L); h >= 0) c.hueHistogram[size_t(h)] += luminance(L);
        }
        c.samples = acc.n;
        c.backfaceFraction = double(N - acc.n) / double(N);
        if (acc.n > 0) {
          for (int i = 0; i < kShCoeffCount; ++i) {
            c.sh.c[i] = acc.sum[i] / acc.n;
            for (int ch = 0; ch < 3; ++ch)
              c.shStdError.c[i][ch] =
                  Accumulator::standardError(acc.sum[i][ch], acc.sumSq[i][ch], acc.n);
          }
          double brightest = 0, worst = 0;
          for (size_t k = 0; k < 6; ++k) brightest = std::max(brightest, acc.irrSum[k] / acc.n);
          for (size_t k = 0; k < 6; ++k)
            worst =
                std::max(worst, Accumulator::standardError(acc.irrSum[k], acc.irrSumSq[k], acc.n));
          c.relativeError = brightest > 0 ? worst / brightest : 0.0;
          for (double& b : c.luminanceHistogram) b /= acc.n;
          double hueTotal = 0;
          for (double b : c.hueHistogram) hueTotal += b;
          if (hueTotal > 0)
            for (double& b : c.hueHistogram) b /= hueTotal;
        }
        for (int i = 0; i < kShCoeffCount; ++i)
          for (int ch = 0; ch < 3; ++ch) PS_CHECK(std::isfinite(c.sh.c[i][ch]));
        c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      });
  return out;
}

}  // namespace ps
