#include "core/domain/DomainPoints.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <string>

#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/math/Random.h"

namespace ps {

void checkLightClearance(double relative) {
  if (!(relative >= 0 && relative < 0.5))
    throw ParameterError(
        "light clearance: expected a fraction of the domain's diagonal in [0, 0.5), got " +
        std::to_string(relative));
}

Bounds3 domainBounds(const Tracer& tracer, std::span<const Bounds3> domain) {
  Bounds3 all;
  if (domain.empty()) all = tracer.scene().bounds;
  for (const Bounds3& b : domain) {
    all.extend(b.lo);
    all.extend(b.hi);
  }
  return all;
}

double lightClearanceMeters(const Tracer& tracer, std::span<const Bounds3> domain,
                            double relative) {
  const Bounds3 all = domainBounds(tracer, domain);
  return all.empty() ? 0.0 : relative * all.diagonal();
}

const char* domainRuleName(DomainRule rule) {
  return rule == DomainRule::Reachable ? "reachable" : "bounds";
}

DomainRule parseDomainRule(const std::string& word) {
  if (word == "reachable") return DomainRule::Reachable;
  if (word == "bounds") return DomainRule::Bounds;
  throw ParameterError("domain", "expected reachable or bounds, got '" + word + "'");
}

Domain makeDomain(const Tracer& tracer, std::span<const Bounds3> boxes,
                  const DomainSettings& settings) {
  checkReachableSettings(settings.reachable);
  Domain d{std::vector<Bounds3>(boxes.begin(), boxes.end()), nullptr, settings.rule};
  if (!boxes.empty() || settings.rule == DomainRule::Bounds) return d;
  d.reachable = std::make_shared<const ReachableSpace>(tracer, boxes, settings.reachable);
  if (d.reachable->cellCorners().empty())
    throw ParameterError("domain",
                         "the reachable space is empty (no free space within " +
                             std::to_string(settings.reachable.bandMeters) +
                             " m above a walkable surface); use the bounds rule or an importance "
                             "volume");
  return d;
}

bool Domain::contains(Vec3 p) const {
  if (!boxes.empty() &&
      !std::any_of(boxes.begin(), boxes.end(), [&](const Bounds3& b) { return b.contains(p); }))
    return false;
  return !reachable || reachable->contains(p);
}

DomainPoints::DomainPoints(const Tracer& tracer, const LightingRig& rig, const Domain& domain,
                           double clearanceRelative)
    : DomainPoints(tracer, rig, std::span<const Bounds3>(domain.boxes), clearanceRelative) {
  reachable_ = domain.reachable;
}

DomainPoints::DomainPoints(const Tracer& tracer, const LightingRig& rig,
                           std::span<const Bounds3> domain, double clearanceRelative)
    : tracer_(tracer) {
  checkLightClearance(clearanceRelative);
  if (domain.empty())
    boxes_.push_back(tracer.scene().bounds);
  else
    boxes_.assign(domain.begin(), domain.end());
  // Each box by its share of the total volume (a flat one never: it holds no volume).
  for (const Bounds3& b : boxes_) {
    total_ += b.volume();
    cumulative_.push_back(total_);
  }
  if (!domain.empty() && !(total_ > 0))
    throw ParameterError("the importance volumes have no volume");
  punctual_ = punctualLightPositions(tracer.scene(), rig);
  clearance_ = lightClearanceMeters(tracer, domain, clearanceRelative);
}

std::optional<Vec3> DomainPoints::drawInBoxes(uint64_t& rng) const {
  if (reachable_) {
    // Uniform over the reachable cells (all of one volume), kept inside the boxes' union.
    const std::vector<Vec3>& corners = reachable_->cellCorners();
    const size_t k = std::min(corners.size() - 1, size_t(uniform01(rng) * double(corners.size())));
    const double h = reachable_->cellMeters();
    const double ux = uniform01(rng), uy = uniform01(rng), uz = uniform01(rng);
    const Vec3 p = corners[k] + Vec3(ux, uy, uz) * h;
    if (!std::any_of(boxes_.begin(), boxes_.end(), [&](const Bounds3& b) { return b.contains(p); }))
      return std::nullopt;
    return p;
  }
  // Uniform in the union of the boxes: a box by its volume, a point in it kept with probability
  // 1 / the number of boxes holding it. With one box this is the plain uniform draw.
  size_t k = 0;
  if (boxes_.size() > 1) {
    const double u = uniform01(rng) * total_;
    while (k + 1 < boxes_.size() && cumulative_[k] <= u) ++k;
  }
  const Bounds3& b = boxes_[k];
  const Vec3 e = b.extent();
  const Vec3 p = b.lo + Vec3(e.x * uniform01(rng), e.y * uniform01(rng), e.z * uniform01(rng));
  if (boxes_.size() > 1) {
    int holding = 0;
    for (const Bounds3& o : boxes_) holding += o.contains(p) ? 1 : 0;
    if (uniform01(rng) * std::max(holding, 1) >= 1.0) return std::nullopt;
  }
  return p;
}

std::optional<Vec3> DomainPoints::draw(uint64_t& rng, int validityRays,
                                       double invalidBackfaceFraction) const {
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const std::optional<Vec3> p = drawInBoxes(rng);
    if (!p || !clearOfLights(*p)) continue;
    if (backfaceFraction(tracer_, *p, validityRays, splitMix64(rng)) > invalidBackfaceFraction)
      continue;
    return p;
  }
  return std::nullopt;
}

std::vector<Vec3> DomainPoints::drawMany(size_t count, uint64_t seed) const {
  std::vector<Vec3> drawn(count);
  std::vector<char> found(count, 0);
  tbb::parallel_for(size_t(0), count, [&](size_t q) {
    uint64_t rng = streamSeed(seed, q);
    if (const auto p = draw(rng)) {
      drawn[q] = *p;
      found[q] = 1;
    }
  });
  std::vector<Vec3> points;
  points.reserve(count);
  for (size_t q = 0; q < count; ++q)
    if (found[q]) points.push_back(drawn[q]);
  return points;
}

bool DomainPoints::valid(Vec3 p, uint64_t seed, int validityRays,
                         double invalidBackfaceFraction) const {
  if (!std::any_of(boxes_.begin(), boxes_.end(), [&](const Bounds3& b) { return b.contains(p); }))
    return false;
  if (reachable_ && !reachable_->contains(p)) return false;
  return clearOfLights(p) &&
         backfaceFraction(tracer_, p, validityRays, seed) <= invalidBackfaceFraction;
}

bool DomainPoints::clearOfLights(Vec3 p) const {
  for (const Vec3& l : punctual_)
    if (dot(p - l, p - l) < clearance_ * clearance_) return false;
  return true;
}

}  // namespace ps
