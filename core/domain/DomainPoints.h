#pragma once
// Random points of the domain of interest (DESIGN.md): uniform over the union of the importance
// volumes' boxes or, when there are none, over the space a player can reach
// (core/domain/ReachableSpace.h; the scene bounds under the `bounds` rule), kept out of geometry
// (Kontkanen & Laine sec. 5) and out of a clearance around point and spot lights. Eval's queries,
// greedy's held-out points, the leak cuts' points and the bake's least-squares fit points are drawn
// from it, so it stands apart from all of those stages.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/domain/ReachableSpace.h"
#include "core/math/Vec3.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

/// How the domain is made when the artist drew no importance volume: `reachable` (the space a
/// player can reach, ReachableSpace) or `bounds` (the scene's bounding box). Importance volumes,
/// when there are any, are the domain as drawn under either rule.
enum class DomainRule { Reachable, Bounds };

/// The domain of interest: the importance volumes' boxes (empty: the scene bounds), and within
/// them only the reachable space when `reachable` is set.
/// `rule` is the one it was made by: under `reachable` the grid methods (uniform, ascent,
/// spawn-merge) keep only their points inside it; under `bounds` they cover the scene bounds.
struct Domain {
  std::vector<Bounds3> boxes;
  std::shared_ptr<const ReachableSpace> reachable;
  DomainRule rule = DomainRule::Bounds;

  /// True when p is in one of the boxes (any p when there are none) and, when set, in the
  /// reachable space. Geometry and lights are not tested.
  bool contains(Vec3 p) const;
};

struct DomainSettings {
  DomainRule rule = DomainRule::Reachable;
  ReachableSettings reachable;
};

/// "reachable" or "bounds".
const char* domainRuleName(DomainRule rule);
/// The rule named `word`; throws ps::ParameterError("domain") naming the choices otherwise.
DomainRule parseDomainRule(const std::string& word);

/// The domain for the importance boxes `boxes` under `settings`: the boxes alone when there are
/// any or the rule is `bounds`, else the reachable space of the scene bounds. Throws
/// ps::ParameterError for bad settings, or when the reachable space is empty (no walkable
/// surface: the message names the `bounds` rule).
Domain makeDomain(const Tracer& tracer, std::span<const Bounds3> boxes,
                  const DomainSettings& settings);

/// Throws ps::ParameterError unless `relative` (a fraction of the domain's diagonal kept from
/// point and spot lights) is in [0, 0.5).
void checkLightClearance(double relative);

/// The bounding box of the domain: of the boxes, or the scene bounds when there are none.
Bounds3 domainBounds(const Tracer& tracer, std::span<const Bounds3> domain);

/// The light clearance in metres: `relative` times the diagonal of the boxes' union (the scene
/// bounds when there are none).
double lightClearanceMeters(const Tracer& tracer, std::span<const Bounds3> domain, double relative);

/// DomainPoints' validity test: a point is outside geometry when at most
/// kDomainInvalidBackfaceFraction of its kDomainValidityRays rays first meet a back face.
inline constexpr int kDomainValidityRays = 32;
inline constexpr double kDomainInvalidBackfaceFraction = 0.25;

class DomainPoints {
 public:
  /// `domain`: the boxes (empty: the scene bounds). `clearanceRelative`: the fraction of the
  /// domain's diagonal kept from the scene's and rig's point and spot lights (0: none). Throws
  /// ps::ParameterError when the boxes given have no volume or the clearance is outside
  /// [0, 0.5).
  DomainPoints(const Tracer& tracer, const LightingRig& rig, std::span<const Bounds3> domain,
               double clearanceRelative);
  /// As above for `domain.boxes`, restricted to `domain.reachable` when it is set: draws are
  /// then uniform over the reachable cells inside the boxes' union.
  DomainPoints(const Tracer& tracer, const LightingRig& rig, const Domain& domain,
               double clearanceRelative);

  /// A point uniform over the boxes' union, outside geometry (at most `invalidBackfaceFraction`
  /// of `validityRays` rays hit back faces) and outside the light clearance; nothing after
  /// 1000 draws that all failed. Consumes `rng` the same way for the same draws.
  std::optional<Vec3> draw(uint64_t& rng, int validityRays = kDomainValidityRays,
                           double invalidBackfaceFraction = kDomainInvalidBackfaceFraction) const;

  /// One try of draw(): a point uniform over the boxes' union (or over the reachable cells in
  /// it), or nothing where a point drawn in a box overlapping others, or in a cell outside the
  /// boxes, is turned down (the union stays uniform). Neither geometry nor the light clearance
  /// is tested.
  std::optional<Vec3> drawInBoxes(uint64_t& rng) const;

  /// `count` draws, draw q from the stream streamSeed(seed, q) (in parallel, deterministic):
  /// the points found, in draw order (fewer than `count` where draws failed).
  std::vector<Vec3> drawMany(size_t count, uint64_t seed) const;

  /// True when p is in one of the boxes (and the reachable space, when set), keeps the light
  /// clearance and is outside geometry (as draw() tests it, with the validity rays seeded by
  /// `seed`).
  bool valid(Vec3 p, uint64_t seed, int validityRays = kDomainValidityRays,
             double invalidBackfaceFraction = kDomainInvalidBackfaceFraction) const;

  /// True when p keeps the clearance from every point and spot light.
  bool clearOfLights(Vec3 p) const;

 private:
  const Tracer& tracer_;
  std::vector<Bounds3> boxes_;
  std::vector<double> cumulative_;
  double total_ = 0;
  std::shared_ptr<const ReachableSpace> reachable_;
  std::vector<Vec3> punctual_;
  double clearance_ = 0;
};

}  // namespace ps
