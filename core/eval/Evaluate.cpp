#include "core/eval/Evaluate.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <optional>
#include <string>

#include "core/capture/Capture.h"
#include "core/capture/DirectLight.h"
#include "core/common/Error.h"
#include "core/common/Tolerances.h"
#include "core/domain/DomainPoints.h"
#include "core/eval/ReferenceCache.h"
#include "core/math/Random.h"

namespace ps {

namespace {

/// Reference irradiance at p for normal n: cosine-weighted path-traced radiance (pdf cos/pi, so
/// E = pi/N sum L) plus the delta lights' direct irradiance, computed analytically. `variance`
/// is the variance of the estimate's luminance: the sample variance of pi lum(L) over N (the
/// delta lights add none). The draw is stratified in u1, which this estimate ignores: it is an
/// upper bound, as the stratification only lowers the true variance.
Rgb referenceIrradiance(const Tracer& tracer, const LightingRig& rig,
                        const std::vector<Light>& lights, Vec3 p, Vec3 n, int spp, uint64_t& rng,
                        double& variance) {
  Vec3 t, b;
  orthonormalBasis(n, t, b);
  Rgb sum;
  double lumSum = 0, lumSq = 0;
  for (int i = 0; i < spp; ++i) {
    // Stratified in u1 so the reference converges faster for the same spp.
    const double u1 = (i + uniform01(rng)) / spp;
    const Vec3 l = cosineHemisphere(u1, uniform01(rng));
    const Vec3 dir = normalize(t * l.x + b * l.y + n * l.z);
    const Rgb L = traceRadiance(tracer, rig, p, dir, rng);
    sum += L;
    const double y = kPi * luminance(L);
    lumSum += y;
    lumSq += y * y;
  }
  variance = spp > 1 ? std::max(0.0, lumSq - lumSum * lumSum / spp) / (double(spp - 1) * spp) : 0.0;
  Rgb e = sum * (kPi / spp);
  for (const Light& light : lights) {
    const auto a = deltaLightArrival(light, p);
    if (!a) continue;
    const double c = dot(n, a->directionToLight);
    if (c <= 0 || !deltaLightVisible(tracer, p, *a)) continue;
    e += a->irradiance * c;
  }
  return e;
}

}  // namespace

EvalReference computeReference(const Tracer& tracer, const LightingRig& rig, const EvalSettings& s,
                               const ProgressFn& progress) {
  if (s.queries < 1) throw ParameterError("queries: expected at least 1");
  if (s.referenceSpp < 1) throw ParameterError("reference-spp: expected at least 1");
  std::optional<DomainPoints> domain;
  try {
    domain.emplace(tracer, rig, s.domain, s.lightClearanceRelative);
  } catch (const ParameterError& e) {
    throw ParameterError(std::string("eval: ") + e.what());
  }
  const std::vector<Light> lights = allLights(tracer.scene(), rig);

  // Query points: uniform in the domain of interest (DomainPoints), each with a uniform normal.
  // Deterministic for the seed.
  const size_t M = size_t(s.queries);
  EvalReference ref;
  ref.points.resize(M);
  ref.normals.resize(M);
  ref.irradiance.resize(M);
  ref.variance.resize(M);
  std::vector<char> found(M, 0);
  tbb::parallel_for(size_t(0), M, [&](size_t q) {
    uint64_t rng = streamSeed(s.seed, q);
    if (const std::optional<Vec3> p = domain->draw(rng, 32, tol::kDefaultInvalidBackfaceFraction)) {
      ref.points[q] = *p;
      ref.normals[q] = uniformSphere(uniform01(rng), uniform01(rng));
      found[q] = 1;
    }
  });
  for (size_t q = 0; q < M; ++q)
    if (!found[q])
      throw ParameterError(s.domain.empty()
                               ? "eval: could not find points outside geometry (and outside "
                                 "the light clearance) in the scene bounds"
                               : "eval: could not find points outside geometry (and outside "
                                 "the light clearance) in the importance "
                                 "volumes");

  std::atomic<size_t> done{0};
  std::atomic<bool> cancelled{false};
  std::mutex progressMutex;
  tbb::parallel_for(size_t(0), M, [&](size_t q) {
    if (cancelled.load(std::memory_order_relaxed)) return;
    uint64_t rng = streamSeed(s.seed ^ 0xE7A1ull, q);
    ref.irradiance[q] = referenceIrradiance(tracer, rig, lights, ref.points[q], ref.normals[q],
                                            s.referenceSpp, rng, ref.variance[q]);
    const size_t d = ++done;
    if (progress) {
      std::lock_guard lock(progressMutex);
      if (!progress(double(d) / M)) cancelled = true;
    }
  });
  if (cancelled) throw Cancelled();
  return ref;
}

EvalResult evaluateVolume(const Tracer& tracer, const LightingRig& rig, const ProbeVolume& volume,
                          const EvalSettings& s, const ProgressFn& progress) {
  if (s.queries < 1) throw ParameterError("queries: expected at least 1");
  // Before the cache, whose key leaves the clearance out for some scenes.
  checkLightClearance(s.lightClearanceRelative);
  if (s.referenceSpp < 1) throw ParameterError("reference-spp: expected at least 1");
  if (s.floorSpp < 0) throw ParameterError("floor-spp: expected 0 (off) or more samples");
  const auto start = std::chrono::steady_clock::now();
  EvalResult r;
  const size_t M = size_t(s.queries);
  const bool hasPunctualLights = !punctualLightPositions(tracer.scene(), rig).empty();

  // The reference: from the cache when it has one, else traced (and stored).
  std::optional<ReferenceCache> cache;
  uint64_t key = 0;
  std::optional<EvalReference> reference;
  if (s.cacheDir && s.sceneHash != 0) {
    cache.emplace(*s.cacheDir);
    key = ReferenceCache::key(
        s.sceneHash, rig,
        s.domain.empty() ? std::span<const Bounds3>(&tracer.scene().bounds, 1) : s.domain, s,
        hasPunctualLights, tracer.scene().hasDoubleSidedSurfaces());
    std::string problem;
    reference = cache->find(key, M, &problem);
    if (!problem.empty())
      r.notes.push_back("damaged reference cache entry " + problem + "; recomputing it");
  }
  r.referenceCached = reference.has_value();
  // Progress: the reference (when traced), the floor's captures (when asked for), the volume.
  const double referenceShare = s.floorSpp > 0 ? 0.5 : 0.95;
  if (!reference) {
    ProgressFn refProgress;
    if (progress) refProgress = [&](double f) { return progress(referenceShare * f); };
    reference = computeReference(tracer, rig, s, refProgress);
    if (cache) {
      try {
        cache->store(key, *reference);
      } catch (const Error& e) {  // the reference is good; only the next eval pays for it
        r.notes.push_back(std::string("the reference could not be cached: ") + e.what());
      }
    }
  }
  const std::vector<Vec3>& points = reference->points;
  const std::vector<Vec3>& normals = reference->normals;

  // The volume at each query, and whether it interpolates a probe the query cannot see. With leak
  // cuts, also the weights without them (the same tet), to see what the cuts moved.
  std::optional<ProbeVolume> uncut;
  if (!volume.cutPlanes.empty()) {
    uncut = volume;
    uncut->cutStart.clear();
    uncut->cutPlanes.clear();
  }
  // The SH floor: a probe captured at each query point, read at that point (no interpolation).
  // In chunks, keeping only each capture's luminance for the query's normal.
  std::vector<double> floorGot(s.floorSpp > 0 ? M : 0);
  if (s.floorSpp > 0) {
    CaptureSettings cs;
    cs.samplesPerProbe = s.floorSpp;
    cs.seed = s.seed ^ 0xF100Du;  // not the reference's streams
    ProgressFn floorProgress;
    if (progress)
      floorProgress = [&](double f) {
        return progress(referenceShare + (0.95 - referenceShare) * f);
      };
    captureProbesInChunks(
        tracer, rig, points, cs, 4096,
        [&](size_t q, const ProbeCapture& c) {
          floorGot[q] = luminance(c.sh.irradiance(normals[q]));
        },
        floorProgress);
  }
  std::vector<double> ref(M), got(M);
  std::vector<char> leaking(M, 0), overCut(M, 0), outside(M, 0);
  tbb::parallel_for(size_t(0), M, [&](size_t q) {
    ref[q] = luminance(reference->irradiance[q]);
    // locate() is the uncut location with the cuts applied: the same tet for both.
    const VolumeLocation before = locate(uncut ? *uncut : volume, points[q]);
    VolumeLocation loc = before;
    if (uncut && loc.tet >= 0) applyCuts(volume, points[q], loc);
    got[q] = luminance(interpolate(volume, loc).irradiance(normals[q]));
    outside[q] = loc.outside ? 1 : 0;
    if (loc.tet < 0) return;
    // Sukys 3.2.2: the query interpolates a probe it cannot see (light leaking). A probe with
    // weight 0 (cut off by a leak cut, or opposite the face a query outside the hull is
    // clamped to) is not interpolated.
    bool seesAll = true;  // every probe it interpolates without the cuts
    for (int k = 0; k < 4; ++k) {
      if (!(loc.weights[k] > 0) && !(before.weights[k] > 0)) continue;
      const int32_t vi = volume.tets[size_t(loc.tet)][k];
      const Vec3 d = volume.position(vi) - points[q];
      const double len = length(d);
      if (len <= 2 * tracer.rayEpsilon()) continue;
      if (tracer.occluded(
              Ray{points[q], d, tracer.rayEpsilon() / len, 1.0 - tracer.rayEpsilon() / len})) {
        if (loc.weights[k] > 0) leaking[q] = 1;
        if (before.weights[k] > 0) seesAll = false;
      }
    }
    // A cut is a plane: it can take weight from probes in plain view (over-cut).
    if (uncut && seesAll) {
      double moved = 0;
      for (int k = 0; k < 4; ++k) moved += std::abs(double(loc.weights[k]) - before.weights[k]);
      overCut[q] = 0.5 * moved > kOverCutWeightChange;
    }
  });
  if (progress && !progress(1.0)) throw Cancelled();

  r.probes = volume.probeCount();
  r.queries = M;
  double num = 0, den = 0, mean = 0, noise = 0;
  for (size_t q = 0; q < M; ++q) {
    num += (got[q] - ref[q]) * (got[q] - ref[q]);
    den += ref[q] * ref[q];
    mean += ref[q];
    noise += reference->variance[q];
  }
  mean /= M;
  r.relRmse = den > 0 ? std::sqrt(num / den) : 0.0;
  if (s.floorSpp > 0) {
    double floorNum = 0;
    for (size_t q = 0; q < M; ++q) floorNum += (floorGot[q] - ref[q]) * (floorGot[q] - ref[q]);
    r.shFloorRelRmse = den > 0 ? std::sqrt(floorNum / den) : 0.0;
  }
  r.referenceRelNoise = den > 0 ? std::sqrt(noise / den) : 0.0;
  // The standard error of relRmse from drawing M queries (the delta method on the ratio of the
  // means of e^2 and E_ref^2): var(R) ~ var(e^2 - R E_ref^2) / (M mean(E_ref^2)^2), R = relRmse^2,
  // and sd(sqrt R) = sd(R) / (2 sqrt R).
  if (den > 0 && M > 1 && r.relRmse > 0) {
    const double R = num / den;
    double v = 0;
    for (size_t q = 0; q < M; ++q) {
      const double d = (got[q] - ref[q]) * (got[q] - ref[q]) - R * ref[q] * ref[q];
      v += d * d;
    }
    v /= double(M - 1);
    const double meanRefSq = den / double(M);
    r.relRmseStdError = std::sqrt(v / double(M)) / meanRefSq / (2 * r.relRmse);
  }
  // Per-query relative error, with the denominator floored at a tenth of the mean so that dark
  // corners do not dominate.
  std::vector<double> rel(M);
  const double floorE = std::max(0.1 * mean, 1e-12);
  for (size_t q = 0; q < M; ++q) rel[q] = std::abs(got[q] - ref[q]) / std::max(ref[q], floorE);
  r.perQuery.resize(M);
  for (size_t q = 0; q < M; ++q) {
    EvalQuery& e = r.perQuery[q];
    e.point = points[q];
    e.normal = normals[q];
    e.reference = ref[q];
    e.referenceStd = std::sqrt(reference->variance[q]);
    e.interpolated = got[q];
    e.relError = rel[q];
    e.leaking = leaking[q] != 0;
    e.outside = outside[q] != 0;
  }
  std::sort(rel.begin(), rel.end());
  r.maxRelError = rel.back();
  r.leakingFraction = double(std::count(leaking.begin(), leaking.end(), 1)) / double(M);
  r.overCutFraction = double(std::count(overCut.begin(), overCut.end(), 1)) / double(M);
  r.outsideHullFraction = double(std::count(outside.begin(), outside.end(), 1)) / double(M);
  size_t leakingOutside = 0;
  for (size_t q = 0; q < M; ++q) leakingOutside += leaking[q] && outside[q] ? 1 : 0;
  r.leakingOutsideHullFraction = double(leakingOutside) / double(M);
  r.p95RelError = rel[std::min(M - 1, size_t(std::ceil(0.95 * M)) - 1)];
  r.lightClearanceMeters =
      hasPunctualLights ? lightClearanceMeters(tracer, s.domain, s.lightClearanceRelative) : 0.0;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace ps
