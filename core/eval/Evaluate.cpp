#include "core/eval/Evaluate.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
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
#include "core/traversal/VisibleInterpolation.h"

namespace ps {

namespace {

/// Reference irradiance at p for normal n: cosine-weighted path-traced radiance (pdf cos/pi, so
/// E = pi/N sum L) plus the delta lights' direct irradiance, computed analytically. `variance`
/// is the variance of the estimate's luminance: the sample variance of pi lum(L) over N (the
/// delta lights add none). The draw is stratified in u1, which this estimate ignores: it is an
/// upper bound, as the stratification only lowers the true variance. Each path draws from its
/// own stream (seeded from `rng`), so the paths are traced together (RadianceTracer).
Rgb referenceIrradiance(const Tracer& tracer, const RadianceTracer& radiance,
                        const std::vector<Light>& lights, Vec3 p, Vec3 n, int spp, uint64_t& rng,
                        double& variance) {
  Vec3 t, b;
  orthonormalBasis(n, t, b);
  thread_local std::vector<Vec3> dirs;
  thread_local std::vector<uint64_t> streams;
  thread_local std::vector<Rgb> L;
  dirs.resize(size_t(spp));
  streams.resize(size_t(spp));
  L.resize(size_t(spp));
  const uint64_t pathSeed = splitMix64(rng);
  for (int i = 0; i < spp; ++i) {
    // Stratified in u1 so the reference converges faster for the same spp.
    const double u1 = (i + uniform01(rng)) / spp;
    const Vec3 l = cosineHemisphere(u1, uniform01(rng));
    dirs[size_t(i)] = normalize(t * l.x + b * l.y + n * l.z);
    streams[size_t(i)] = streamSeed(pathSeed, uint64_t(i));
  }
  radiance.radiance(p, dirs, streams, L);
  Rgb sum;
  double lumSum = 0, lumSq = 0;
  for (const Rgb& li : L) {
    sum += li;
    const double y = kPi * luminance(li);
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
    domain.emplace(tracer, rig, Domain{s.domain, s.reachable}, s.lightClearanceRelative);
  } catch (const ParameterError& e) {
    throw ParameterError(std::string("eval: ") + e.what());
  }
  const std::vector<Light> lights = allLights(tracer.scene(), rig);
  // Every light summed at every vertex: a reference wants the least noise per path.
  const RadianceTracer radiance(tracer, rig, std::numeric_limits<size_t>::max());

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
      throw ParameterError(s.reachable ? "eval: could not find points outside geometry (and "
                                         "outside the light clearance) in the reachable space"
                           : s.domain.empty()
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
    ref.irradiance[q] = referenceIrradiance(tracer, radiance, lights, ref.points[q], ref.normals[q],
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

namespace {

/// The reference for `s` with M = s.queries points: read from the cache when s.cacheDir and
/// s.sceneHash give one and it holds an entry, else traced (computeReference) and stored there.
/// Sets r.referenceCached; adds a note to r.notes for a damaged entry (recomputed) and for a
/// reference that could not be stored (kept all the same). `progress` sees the tracing only,
/// scaled to [0, referenceShare]. Throws as computeReference (ps::ParameterError, ps::Cancelled)
/// and ps::Error when a cache folder asked for cannot be used.
EvalReference obtainReference(const Tracer& tracer, const LightingRig& rig, const EvalSettings& s,
                              bool hasPunctualLights, double referenceShare,
                              const ProgressFn& progress, EvalResult& r) {
  const size_t M = size_t(s.queries);
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
  return std::move(*reference);
}

/// The SH floor: a probe captured at each query point at s.floorSpp samples, read at that point
/// (no interpolation) for the query's normal. Returns the luminance of that irradiance (W/m^2)
/// per query; empty when s.floorSpp is 0. Captures in chunks of 4096, keeping only each
/// capture's luminance. `progress` sees [referenceShare, 0.95]. Throws ps::Cancelled when it
/// returns false.
std::vector<double> floorLuminance(const Tracer& tracer, const LightingRig& rig,
                                   const EvalSettings& s, const EvalReference& reference,
                                   double referenceShare, const ProgressFn& progress) {
  std::vector<double> floorGot(s.floorSpp > 0 ? reference.points.size() : 0);
  if (s.floorSpp <= 0) return floorGot;
  CaptureSettings cs;
  cs.samplesPerProbe = s.floorSpp;
  cs.seed = s.seed ^ 0xF100Du;  // not the reference's streams
  ProgressFn floorProgress;
  if (progress)
    floorProgress = [&](double f) {
      return progress(referenceShare + (0.95 - referenceShare) * f);
    };
  captureProbesInChunks(
      tracer, rig, reference.points, cs, 4096,
      [&](size_t q, const ProbeCapture& c) {
        floorGot[q] = luminance(c.sh.irradiance(reference.normals[q]));
      },
      floorProgress);
  return floorGot;
}

/// The volume against the reference at each query, in the reference's order (M entries each).
struct QueryMeasures {
  std::vector<double> ref;    ///< luminance of the reference irradiance (W/m^2)
  std::vector<double> got;    ///< luminance of the volume's irradiance (W/m^2)
  std::vector<char> leaking;  ///< 1: interpolates, with weight, a probe the query cannot see
  std::vector<char> outside;  ///< 1: outside the probes' hull, clamped to it
};

/// Query q of `reference` in `volume`: writes entry q of each of m's vectors (sized M by the
/// caller; no other entry, so queries may run in parallel). `visibility`: interpolate with the
/// visibility-aware weights (the volume has maps), with the query's normal for their normal term
/// when `normalTerm`. One ray per probe the query's weights blend.
void measureQuery(const Tracer& tracer, const ProbeVolume& volume, bool visibility, bool normalTerm,
                  const EvalReference& reference, size_t q, QueryMeasures& m) {
  const Vec3 point = reference.points[q];
  m.ref[q] = luminance(reference.irradiance[q]);
  const VolumeLocation loc = locate(volume, point);
  // The probes and weights the query is read with: the location's, or the visibility-aware
  // ones (the tet's four, or the neighbour search's).
  std::array<int32_t, kMaxVisibleProbes> probes{};
  std::array<double, kMaxVisibleProbes> weights{};
  int count = 0;
  if (visibility) {
    // The query is a point in the air: its normal picks the irradiance's direction, not a side
    // of a surface, so the normal term is off unless asked for (docs/leaks.md measures both).
    const VisibleWeights w = visibleWeights(
        volume, loc, point, normalTerm ? std::optional<Vec3>(reference.normals[q]) : std::nullopt);
    m.got[q] = luminance(interpolate(volume, w).irradiance(reference.normals[q]));
    probes = w.probes;
    weights = w.weights;
    count = w.count;
  } else {
    m.got[q] = luminance(interpolate(volume, loc).irradiance(reference.normals[q]));
    if (loc.tet >= 0) count = 4;
    for (int k = 0; k < count; ++k) {
      probes[size_t(k)] = volume.tets[size_t(loc.tet)][k];
      weights[size_t(k)] = loc.weights[k];
    }
  }
  m.outside[q] = loc.outside ? 1 : 0;
  if (loc.tet < 0) return;
  // Sukys 3.2.2: the query interpolates a probe it cannot see (light leaking). A probe with
  // weight 0 (opposite the face a query outside the hull is clamped to, or unseen by the
  // visibility maps) is not interpolated.
  for (int k = 0; k < count; ++k) {
    if (!(weights[size_t(k)] > 0)) continue;
    const Vec3 d = volume.position(probes[size_t(k)]) - point;
    const double len = length(d);
    if (len <= 2 * tracer.rayEpsilon()) continue;
    if (tracer.occluded(Ray{point, d, tracer.rayEpsilon() / len, 1.0 - tracer.rayEpsilon() / len}))
      m.leaking[q] = 1;
  }
}

/// Every query of `reference` in `volume` (measureQuery), in parallel; deterministic, as each
/// query writes only its own entries.
QueryMeasures measureQueries(const Tracer& tracer, const ProbeVolume& volume, bool visibility,
                             bool normalTerm, const EvalReference& reference) {
  const size_t M = reference.points.size();
  QueryMeasures m{std::vector<double>(M), std::vector<double>(M), std::vector<char>(M, 0),
                  std::vector<char>(M, 0)};
  tbb::parallel_for(size_t(0), M, [&](size_t q) {
    measureQuery(tracer, volume, visibility, normalTerm, reference, q, m);
  });
  return m;
}

/// Sums over the queries, in query order (the order fixes their rounding).
struct ErrorSums {
  double num = 0;    ///< sum of (got - ref)^2
  double den = 0;    ///< sum of ref^2
  double mean = 0;   ///< mean of ref (W/m^2)
  double noise = 0;  ///< sum of the reference's variances
};

/// The sums of m over its M >= 1 queries, with the reference's variances.
ErrorSums sumErrors(const QueryMeasures& m, const std::vector<double>& variance) {
  const size_t M = m.ref.size();
  const std::vector<double>& ref = m.ref;
  const std::vector<double>& got = m.got;
  ErrorSums e;
  for (size_t q = 0; q < M; ++q) {
    e.num += (got[q] - ref[q]) * (got[q] - ref[q]);
    e.den += ref[q] * ref[q];
    e.mean += ref[q];
    e.noise += variance[q];
  }
  e.mean /= M;
  return e;
}

/// Sets r.relRmse, r.shFloorRelRmse (when `floorGot`, the floor's luminance per query, is not
/// empty), r.referenceRelNoise and r.relRmseStdError from the sums `e` of m. Each is 0 when the
/// reference is black (den 0); the standard error also with one query or no error.
void setRelativeErrors(const ErrorSums& e, const QueryMeasures& m,
                       const std::vector<double>& floorGot, EvalResult& r) {
  const size_t M = m.ref.size();
  const std::vector<double>& ref = m.ref;
  const std::vector<double>& got = m.got;
  const double num = e.num, den = e.den;
  r.relRmse = den > 0 ? std::sqrt(num / den) : 0.0;
  if (!floorGot.empty()) {
    double floorNum = 0;
    for (size_t q = 0; q < M; ++q) floorNum += (floorGot[q] - ref[q]) * (floorGot[q] - ref[q]);
    r.shFloorRelRmse = den > 0 ? std::sqrt(floorNum / den) : 0.0;
  }
  r.referenceRelNoise = den > 0 ? std::sqrt(e.noise / den) : 0.0;
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
}

/// Sets r.perQuery (in the reference's order), the per-query relative error's percentiles
/// (r.maxRelError, r.p95RelError) and the fractions of the M >= 1 queries that leak, lie
/// outside the hull, and both leak and lie outside. `mean`: the reference's mean
/// luminance (W/m^2). O(M log M).
void setPerQuery(const QueryMeasures& m, const EvalReference& reference, double mean,
                 EvalResult& r) {
  const size_t M = m.ref.size();
  const std::vector<double>& ref = m.ref;
  const std::vector<double>& got = m.got;
  // Per-query relative error, with the denominator floored at a tenth of the mean so that dark
  // corners do not dominate.
  std::vector<double> rel(M);
  const double floorE = std::max(0.1 * mean, 1e-12);
  for (size_t q = 0; q < M; ++q) rel[q] = std::abs(got[q] - ref[q]) / std::max(ref[q], floorE);
  r.perQuery.resize(M);
  for (size_t q = 0; q < M; ++q) {
    EvalQuery& e = r.perQuery[q];
    e.point = reference.points[q];
    e.normal = reference.normals[q];
    e.reference = ref[q];
    e.referenceStd = std::sqrt(reference.variance[q]);
    e.interpolated = got[q];
    e.relError = rel[q];
    e.leaking = m.leaking[q] != 0;
    e.outside = m.outside[q] != 0;
  }
  std::sort(rel.begin(), rel.end());
  r.maxRelError = rel.back();
  const auto fraction = [M](const std::vector<char>& flags) {
    return double(std::count(flags.begin(), flags.end(), 1)) / double(M);
  };
  r.leakingFraction = fraction(m.leaking);
  r.outsideHullFraction = fraction(m.outside);
  size_t leakingOutside = 0;
  for (size_t q = 0; q < M; ++q) leakingOutside += m.leaking[q] && m.outside[q] ? 1 : 0;
  r.leakingOutsideHullFraction = double(leakingOutside) / double(M);
  r.p95RelError = rel[std::min(M - 1, size_t(std::ceil(0.95 * M)) - 1)];
}

}  // namespace

EvalResult evaluateVolume(const Tracer& tracer, const LightingRig& rig, const ProbeVolume& volume,
                          const EvalSettings& s, const ProgressFn& progress) {
  if (s.queries < 1) throw ParameterError("queries: expected at least 1");
  // Before the cache, whose key leaves the clearance out for some scenes.
  checkLightClearance(s.lightClearanceRelative);
  if (s.referenceSpp < 1) throw ParameterError("reference-spp: expected at least 1");
  if (s.floorSpp < 0) throw ParameterError("floor-spp: expected 0 (off) or more samples");
  const auto start = std::chrono::steady_clock::now();
  EvalResult r;
  const bool hasPunctualLights = !punctualLightPositions(tracer.scene(), rig).empty();
  // Progress: the reference (when traced), the floor's captures (when asked for), the volume.
  const double referenceShare = s.floorSpp > 0 ? 0.5 : 0.95;
  const EvalReference reference =
      obtainReference(tracer, rig, s, hasPunctualLights, referenceShare, progress, r);
  const std::vector<double> floorGot =
      floorLuminance(tracer, rig, s, reference, referenceShare, progress);
  r.visibility = s.useVisibility && volume.hasVisibility();
  const QueryMeasures measures =
      measureQueries(tracer, volume, r.visibility, s.visibilityNormalTerm, reference);
  if (progress && !progress(1.0)) throw Cancelled();

  r.probes = volume.probeCount();
  r.queries = size_t(s.queries);
  const ErrorSums sums = sumErrors(measures, reference.variance);
  setRelativeErrors(sums, measures, floorGot, r);
  setPerQuery(measures, reference, sums.mean, r);
  r.lightClearanceMeters =
      hasPunctualLights ? lightClearanceMeters(tracer, s.domain, s.lightClearanceRelative) : 0.0;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace ps
