// The light tree of Conty Estevez & Kulla 2018, sec. 4 (a binary BVH over the lights, each node
// holding its lights' total power and bounds) and sec. 5.1 (a stochastic descent that picks a
// child with probability proportional to its importance, with one uniform number rescaled at
// each level), with point-light bounds as in pbrt-v4's LightBounds::Importance. The glTF range
// window adds an exact cut: a node whose lights all lie at least their range away from p adds
// nothing and is never entered.
#include "core/capture/LightSampler.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/capture/DirectLight.h"
#include "core/common/Check.h"

namespace ps {

namespace {

double meanChannel(Rgb c) {
  return (c.r + c.g + c.b) / 3.0;
}

/// Squared distance from p to the box [lo, hi] (0 inside).
double distanceSquaredToBox(Vec3 p, Vec3 lo, Vec3 hi) {
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double d = std::max({lo[a] - p[a], 0.0, p[a] - hi[a]});
    d2 += d * d;
  }
  return d2;
}

}  // namespace

LightSampler::LightSampler(std::span<const Light> lights, size_t exactCount, int maxCut)
    : lights_(lights), exactCount_(exactCount), maxCut_(std::clamp(maxCut, 1, kMaxCut)) {
  std::vector<uint32_t> local;
  for (size_t i = 0; i < lights.size(); ++i)
    (lights[i].type == LightType::Directional ? directional_ : local)
        .push_back(static_cast<uint32_t>(i));
  sampling_ = local.size() > exactCount;
  if (!sampling_ && local.size() <= kExactLightCount) {
    summed_ = std::move(local);
    return;
  }
  nodes_.reserve(2 * local.size() - 1);
  build(local, 0, local.size());
  parent_.assign(nodes_.size(), 0);
  leafOf_.assign(lights.size(), std::numeric_limits<uint32_t>::max());
  for (uint32_t i = 0; i < uint32_t(nodes_.size()); ++i) {
    if (nodes_[i].leaf) {
      leafOf_[nodes_[i].light] = i;
    } else {
      parent_[i + 1] = i;
      parent_[nodes_[i].second] = i;
    }
  }
}

void LightVisibility::reset(const LightSampler& sampler) {
  sampler_ = &sampler;
  const size_t n = sampler.sampling() ? sampler.nodeCount() : 0;
  tried_.assign(n, 0.0f);
  reached_.assign(n, 0.0f);
  pendingTried_.assign(n, 0.0f);
  pendingReached_.assign(n, 0.0f);
}

void LightVisibility::record(uint32_t light, bool reached) {
  if (!sampler_ || tried_.empty()) return;
  PS_CHECK_LT(size_t{light}, sampler_->leafOf_.size());
  uint32_t node = sampler_->leafOf_[light];
  PS_CHECK_LT(size_t{node}, pendingTried_.size());
  for (;;) {
    pendingTried_[node] += 1.0f;
    pendingReached_[node] += reached ? 1.0f : 0.0f;
    if (node == 0) break;
    node = sampler_->parent_[node];
  }
}

void LightVisibility::commit() {
  for (size_t i = 0; i < tried_.size(); ++i) {
    tried_[i] += pendingTried_[i];
    reached_[i] += pendingReached_[i];
    pendingTried_[i] = 0.0f;
    pendingReached_[i] = 0.0f;
  }
}

uint32_t LightSampler::build(std::vector<uint32_t>& ids, size_t first, size_t last) {
  PS_CHECK_LT(first, last);
  const auto index = static_cast<uint32_t>(nodes_.size());
  nodes_.emplace_back();
  Node node;
  node.lo = Vec3{1, 1, 1} * std::numeric_limits<double>::infinity();
  node.hi = -node.lo;
  for (size_t i = first; i < last; ++i) {
    const Light& l = lights_[ids[i]];
    node.lo = min(node.lo, l.position);
    node.hi = max(node.hi, l.position);
    node.power += meanChannel(l.intensity);
    node.maxRange = std::max(
        node.maxRange, l.rangeMeters > 0 ? l.rangeMeters : std::numeric_limits<double>::infinity());
  }
  node.centre = (node.lo + node.hi) * 0.5;
  node.radius = 0.5 * length(node.hi - node.lo) * (1 + 1e-9) + 1e-12;
  if (last - first == 1) {
    node.leaf = true;
    node.light = ids[first];
  } else {
    // Median split along the longest axis of the positions' bounds.
    const Vec3 extent = node.hi - node.lo;
    const int axis =
        extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
    const size_t mid = first + (last - first) / 2;
    std::nth_element(ids.begin() + std::ptrdiff_t(first), ids.begin() + std::ptrdiff_t(mid),
                     ids.begin() + std::ptrdiff_t(last), [&](uint32_t a, uint32_t b) {
                       const double pa = lights_[a].position[axis], pb = lights_[b].position[axis];
                       return pa < pb || (pa == pb && a < b);
                     });
    build(ids, first, mid);
    node.second = build(ids, mid, last);
  }
  nodes_[index] = node;
  return index;
}

bool LightSampler::outOfRange(const Node& node, Vec3 p) {
  // Every light's window clamp(1 - (d / range)^4, 0, 1)^2 is 0 at d >= range.
  return node.maxRange < std::numeric_limits<double>::infinity() &&
         distanceSquaredToBox(p, node.lo, node.hi) >= node.maxRange * node.maxRange;
}

double LightSampler::importance(const Node& node, Vec3 p, Vec3 n) const {
  if (node.leaf) {
    // A single light: its exact unshadowed contribution (range window and spot cone included).
    const auto a = deltaLightArrival(lights_[node.light], p);
    if (!a) return 0;
    const double f = meanChannel(a->irradiance) * dot(n, a->directionToLight);
    return std::isfinite(f) && f > 0 ? f : 0;
  }
  if (outOfRange(node, p)) return 0;
  // The cone from p around the bounding sphere's centre that holds the sphere (half-angle
  // thetaB, the radius widened against rounding): every light lies within thetaB of the
  // centre's direction, so cos(max(0, theta - thetaB)) bounds every light's cosine, and no
  // light faces the surface when theta - thetaB is at least 90 degrees.
  const double radius = node.radius;
  const Vec3 toCentre = node.centre - p;
  const double d2 = dot(toCentre, toCentre);
  double cosBound = 1;
  if (d2 > radius * radius) {
    const double d = std::sqrt(d2);
    const double cosTheta = dot(n, toCentre) / d;
    const double sinB = radius / d;
    const double cosB = std::sqrt(std::max(0.0, 1 - sinB * sinB));
    if (cosTheta < cosB) {
      const double sinTheta = std::sqrt(std::max(0.0, 1 - cosTheta * cosTheta));
      const double c = cosTheta * cosB + sinTheta * sinB;  // cos(theta - thetaB)
      if (c <= -1e-9) return 0;
      cosBound = std::max(c, 1e-9);
    }
  }
  // pbrt-v4: the distance is at least the sphere's radius, so that a point among the lights
  // does not see an unbounded importance.
  return node.power * cosBound / std::max(d2, radius * radius);
}

void LightSampler::choose(Vec3 p, Vec3 n, double u, std::vector<LightChoice>& out,
                          const LightVisibility* visibility) const {
  for (uint32_t i : directional_) out.push_back({i, 1.0});
  for (uint32_t i : summed_) out.push_back({i, 1.0});
  if (nodes_.empty()) return;
  if (!sampling_) {
    // Every light summed: the tree only skips the subtrees whose range windows have all ended.
    uint32_t stack[64];
    int depth = 0;
    stack[depth++] = 0;
    while (depth > 0) {
      const uint32_t at = stack[--depth];
      const Node& node = nodes_[at];
      if (outOfRange(node, p)) continue;
      if (node.leaf) {
        out.push_back({node.light, 1.0});
        continue;
      }
      PS_CHECK_LT(depth + 2, 64);
      stack[depth++] = node.second;
      stack[depth++] = at + 1;
    }
    return;
  }
  // A cut through the tree (as Conty Estevez & Kulla sec. 5.2 refine the tree where its nodes
  // look large from p, here to choose among rather than to sample each): starting at the root, a
  // node that looks large (looksLarge) is replaced by its children while the cut holds fewer than
  // maxCut_ nodes; a node of importance 0 is dropped (none of its lights adds anything). Near p the
  // cut ends in single lights, weighed by their exact unshadowed contribution; far away, in
  // clusters weighed by their bounds. The cut depends on p and n alone.
  struct Entry {
    uint32_t node;
    double importance;
  };
  // A node's importance, scaled by the probe's learnt visibility of its lights (LightVisibility).
  auto weigh = [&](uint32_t node) {
    const double i = importance(nodes_[node], p, n);
    return visibility ? i * visibility->factor(node) : i;
  };
  Entry cut[kMaxCut];
  int size = 0;
  Entry pending[kMaxCut];
  int top = 0;
  pending[top++] = {0, weigh(0)};
  while (top > 0) {
    const Entry e = pending[--top];
    if (!(e.importance > 0) || !std::isfinite(e.importance)) continue;
    const Node& node = nodes_[e.node];
    if (!node.leaf && size + top + 2 <= maxCut_ && looksLarge(node, p)) {
      pending[top++] = {e.node + 1, weigh(e.node + 1)};
      pending[top++] = {node.second, weigh(node.second)};
      continue;
    }
    cut[size++] = e;
  }
  if (size == 0) return;  // no light adds anything at p
  // Few single lights reach p (the rest are out of range or below the surface): sum them, with no
  // noise from the choice.
  bool allLeaves = size <= int(exactCount_);
  for (int i = 0; i < size && allLeaves; ++i) allLeaves = nodes_[cut[i].node].leaf;
  if (allLeaves) {
    for (int i = 0; i < size; ++i) out.push_back({nodes_[cut[i].node].light, 1.0});
    return;
  }
  // One node of the cut, with probability proportional to its importance; then, within it, the
  // stochastic descent of sec. 5.1: each child with probability proportional to its importance,
  // the one uniform number rescaled at each level. The light's probability is the product.
  double total = 0;
  for (int i = 0; i < size; ++i) total += cut[i].importance;
  constexpr double kBelowOne = 1.0 - 0x1.0p-53;
  double target = u * total, probability = 0;
  int pick = size - 1;
  for (int i = 0; i < size; ++i) {
    if (target < cut[i].importance || i == size - 1) {
      pick = i;
      break;
    }
    target -= cut[i].importance;
  }
  probability = cut[pick].importance / total;
  u = std::clamp(target / cut[pick].importance, 0.0, kBelowOne);
  uint32_t at = cut[pick].node;
  while (!nodes_[at].leaf) {
    const uint32_t first = at + 1, second = nodes_[at].second;
    const double i0 = weigh(first);
    const double i1 = weigh(second);
    const double sum = i0 + i1;
    if (!(sum > 0) || !std::isfinite(sum)) return;  // no light here adds anything
    const double p0 = i0 / sum;
    if (u < p0) {
      u = std::min(u / p0, kBelowOne);
      probability *= p0;
      at = first;
    } else {
      u = std::min((u - p0) / (1 - p0), kBelowOne);
      probability *= 1 - p0;
      at = second;
    }
  }
  if (probability > 0) out.push_back({nodes_[at].light, 1.0 / probability, true});
}

bool LightSampler::looksLarge(const Node& node, Vec3 p) const {
  // Called only for nodes of positive importance, whose range windows have not all ended.
  const Vec3 toCentre = node.centre - p;
  return node.radius * node.radius > kSplitRatioSquared * dot(toCentre, toCentre);
}

}  // namespace ps
