#pragma once
// Accuracy of an interpolated probe volume against a high-sample reference (DESIGN.md):
// random valid points of the domain of interest, a random normal each; reference irradiance
// path-traced directly (cosine-weighted) for that normal. The reference (points, normals,
// irradiance) is the expensive part and depends neither on the volume nor on how its probes were
// placed: a reference cache on disk keeps it, so comparing methods does not recompute it.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/common/Progress.h"
#include "core/domain/ReachableSpace.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

struct EvalSettings {
  int queries = 256;
  int referenceSpp = 1024;
  uint64_t seed = 7;
  /// Folder of the reference cache (see ReferenceCache); none = compute the reference every
  /// time.
  std::optional<std::filesystem::path> cacheDir;
  /// sceneContentHash() of the scene the tracer was built from; part of the cache key. The
  /// cache is used only when this is non-zero.
  uint64_t sceneHash = 0;
  /// The domain of interest: the probe set's importance volumes (their boxes; queries are
  /// uniform over their union). Empty: the scene bounds. Part of the cache key.
  std::vector<Bounds3> domain;
  /// When set (the `reachable` rule, DomainPoints.h), queries are uniform over its cells inside
  /// `domain` instead. Part of the cache key when set (its cells, exactly).
  std::shared_ptr<const ReachableSpace> reachable;
  /// Queries closer than this fraction of the domain's diagonal to a point or spot light are
  /// drawn again (0: none). Part of the cache key when the scene or rig has such a light.
  double lightClearanceRelative = kDefaultLightClearanceRelative;
  /// Interpolate with the visibility-aware interpolant (core/traversal/VisibleInterpolation.h)
  /// when the volume carries visibility maps; false: the barycentric weights alone
  /// (`eval --no-visibility`). Not part of the reference or its cache key.
  bool useVisibility = true;
  /// With visibility: pass each query's normal to the interpolant, for its smooth-backface
  /// term (`eval --visibility-normal-term`). Off by default: a query is a point in the air,
  /// whose normal picks the irradiance's direction rather than a side of a surface, and the
  /// term then only biases the blend towards the probes in front (docs/leaks.md).
  bool visibilityNormalTerm = false;
  /// When > 0, also EvalResult::shFloorRelRmse: a probe captured at this many samples at every
  /// query point (the bake's capture). Not cached: queries x floorSpp rays, in
  /// EvalResult::seconds.
  int floorSpp = 0;
};

/// The reference of an evaluation: query points (valid points of the domain of interest),
/// a unit normal each, and the reference irradiance there for that normal.
struct EvalReference {
  std::vector<Vec3> points, normals;
  std::vector<Rgb> irradiance;
  /// Per query, the variance of the reference irradiance's luminance from its path tracing (an
  /// upper bound: see referenceRelNoise).
  std::vector<double> variance;
  bool operator==(const EvalReference&) const = default;
};

/// One query of an evaluation: where it was, what the reference and the volume gave.
struct EvalQuery {
  Vec3 point, normal;
  double reference = 0;     ///< luminance of the reference irradiance
  double referenceStd = 0;  ///< its standard error from the path tracing (an upper bound)
  double interpolated = 0;  ///< luminance of the volume's irradiance
  double relError = 0;      ///< as for p95RelError (the denominator floored at 0.1 x the mean)
  /// It interpolates, with a final weight above 0, a probe it cannot see (the visibility-aware
  /// weights when EvalResult::visibility, else the barycentric ones)
  bool leaking = false;
  bool outside = false;  ///< outside the probes' hull, clamped to it (VolumeLocation::outside)
};

struct EvalResult {
  size_t probes = 0;
  /// The queries were interpolated with the visibility-aware interpolant (the volume has maps
  /// and EvalSettings::useVisibility).
  bool visibility = false;
  size_t queries = 0;
  /// sqrt(sum (E_vol - E_ref)^2 / sum E_ref^2) over query luminances.
  double relRmse = 0;
  /// sqrt(sum Var(E_ref) / sum E_ref^2): the reference's own noise on the scale of relRmse, the
  /// rel_rmse that a volume equal to the true irradiance would show (its square adds to the
  /// square of the volume's true error; 0 with one reference sample, which gives no estimate).
  /// An upper bound: the reference's draw is stratified, which the per-sample variance does not
  /// see. Differences between volumes smaller than this are not resolved; a higher reference
  /// spp lowers it as 1 / sqrt(spp).
  double referenceRelNoise = 0;
  /// The standard error of relRmse from the finite number of queries (delta method): another
  /// draw of as many queries gives a relRmse about this far away. Near point lights a few
  /// queries carry most of the squared error and this is large; more queries lower it as
  /// 1 / sqrt(queries). 0 with one query.
  double relRmseStdError = 0;
  /// With EvalSettings::floorSpp: the relRmse of a probe captured at every query point, each
  /// query read at its own probe. Its order-2 spherical-harmonic part is, on average over the
  /// query normals, the least any volume of order-2 SH probes reaches, whatever the placement:
  /// the SH irradiance cannot follow a sharp light, as a sun's clamped cosine (sqrt(2) / 16 =
  /// 0.088 for an unshadowed sun alone over uniform normals, test_eval). It also holds the
  /// probes' capture noise at floorSpp, which more samples, or a blend of several probes,
  /// lower (so a volume can come out below it), and the reference's own noise
  /// (referenceRelNoise). Unset without floorSpp.
  std::optional<double> shFloorRelRmse;
  /// Per-query relative error |E_vol - E_ref| / max(E_ref, 0.1 * mean E_ref): percentiles.
  double p95RelError = 0;
  double maxRelError = 0;
  /// Fraction of the queries whose tetrahedron (the hull tetrahedron they are clamped to, when
  /// outside) has a probe not visible from the query point with a final weight above 0: light
  /// leaks through geometry there (Sukys 3.2.2).
  double leakingFraction = 0;
  /// Fraction of the queries outside the probes' convex hull, where the volume clamps them to
  /// the nearest hull face and extrapolates, and of the queries that are outside and leak (a
  /// part of leakingFraction). Leaks outside the hull come from too few probes near the
  /// domain's edge, where a probe placed there ends them; leaks inside, from tetrahedra across
  /// walls whose probes on the query's side the visibility maps do not find. leakingFraction and
  /// outsideHullFraction on dream-apartment: BENCHMARKS.md, "Placement quality under the default
  /// pipeline".
  double outsideHullFraction = 0;
  double leakingOutsideHullFraction = 0;
  double seconds = 0;
  double lightClearanceMeters = 0;  ///< the clearance kept from punctual lights (0: none)
  /// The reference came from the cache (nothing was traced for it).
  bool referenceCached = false;
  /// Things the user should know that did not stop the evaluation: a damaged cache entry
  /// (recomputed), a cache entry that could not be written.
  std::vector<std::string> notes;
  /// Every query, in the reference's order: for finding where the volume is wrong.
  std::vector<EvalQuery> perQuery;
};

/// The reference for `settings` (queries, referenceSpp, seed; not the cache fields), traced.
/// Deterministic for the seed. Throws ps::ParameterError when the domain has no volume or holds
/// no point outside geometry, ps::Cancelled when `progress` returns false.
EvalReference computeReference(const Tracer& tracer, const LightingRig& rig,
                               const EvalSettings& settings, const ProgressFn& progress = {});

/// The volume's error against the reference for `settings`: read from settings.cacheDir when
/// it holds one for the same scene, rig, domain and settings, else computed (and stored there).
EvalResult evaluateVolume(const Tracer& tracer, const LightingRig& rig, const ProbeVolume& volume,
                          const EvalSettings& settings, const ProgressFn& progress = {});

}  // namespace ps
