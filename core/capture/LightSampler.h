#pragma once
// Which delta lights a path vertex takes its next-event estimate from: all of them when the
// scene has few point and spot lights, else one drawn from a light BVH by power, distance,
// orientation and range (Conty Estevez & Kulla 2018, "Importance Sampling of Many Lights with
// Adaptive Tree Splitting", sec. 4 and 5.1; the bounds follow pbrt-v4's BVHLightSampler).
#include <cstdint>
#include <span>
#include <vector>

#include "core/scene/Scene.h"

namespace ps {

/// A light to shade with, and the factor its contribution is multiplied by: 1 / the probability
/// that it was chosen (1 when every light is summed).
struct LightChoice {
  uint32_t light = 0;  ///< index into the lights the sampler was built over
  double weight = 1;
  bool sampled = false;  ///< drawn from the tree (its shadow ray can teach a LightVisibility)
};

class LightSampler;

/// What one probe's shadow rays have told about the tree's nodes: per node, how many shadow rays
/// went to its lights and how many of them reached the light. LightSampler::choose scales each
/// node's importance by (reached + 1) / (tried + 2), so that lights behind walls, which bounds
/// cannot tell from lights in the room, are chosen less once the probe's paths have found them
/// blocked (a learnt visibility factor, as many-light samplers cache light visibility per
/// region, e.g. Vevoda et al. 2018, "Bayesian online regression for adaptive direct illumination
/// sampling"). The factor is never 0, so every light that adds anything keeps a positive
/// probability and the estimate stays unbiased. What is recorded goes to a pending table,
/// folded in by commit(): a capture commits after each batch of paths, so that a batch's choices
/// depend on the earlier batches of the same probe only, whatever order its rays are traced in.
class LightVisibility {
 public:
  /// Sized for `sampler` and emptied.
  void reset(const LightSampler& sampler);
  /// The shadow ray of a sampled choice of `light` was (not) blocked.
  void record(uint32_t light, bool reached);
  /// Folds the pending records into the table choose() reads.
  void commit();
  /// The factor of node `node` (1 when the table is empty).
  double factor(uint32_t node) const {
    if (node >= tried_.size()) return 1.0;
    return (reached_[node] + 1.0) / (tried_[node] + 2.0);
  }

 private:
  const LightSampler* sampler_ = nullptr;
  std::vector<float> tried_, reached_;                ///< per node, committed
  std::vector<float> pendingTried_, pendingReached_;  ///< per node, since the last commit
};

/// Point and spot lights are summed at every path vertex up to this many; above it, one is
/// sampled per vertex. Summing costs a shadow ray per light in range and facing the surface, and
/// adds no noise; sampling costs one ray and adds the noise of the choice. Measured on the
/// generated level at a 5 % error (BENCHMARKS.md, "Capture"): with 10 lamps summing took 0.66 of
/// sampling's time, with 79 sampling took 0.51 of summing's; 16 lies between (counts between were
/// not measured). When sampling, a vertex that only few single lights reach still sums them
/// (LightSampler::choose).
inline constexpr size_t kExactLightCount = 16;

/// When sampling, the light is drawn from a cut through the tree of at most this many nodes
/// (LightSampler::choose). Measured on the generated level with a lamp in every room
/// (BENCHMARKS.md, "Capture"): a cut of 1 (a plain descent from the root) needed 2.2 times the
/// samples of 32 to reach a 5 % error, as the loose bounds of the upper nodes send many picks to
/// lamps behind walls.
inline constexpr int kMaxCut = 32;

/// A tree node is in the cut whole unless half its bounding box's diagonal, squared, is more than
/// this times the squared distance from the point to the box's centre (the point is near or
/// among its lights, so that its bounds say little about them). Measured as kMaxCut: 0.25 split
/// more and cost more per vertex than it saved in samples; 4 split too little.
inline constexpr double kSplitRatioSquared = 1.0;

class LightSampler {
 public:
  /// Builds the tree (O(n log^2 n) in the point and spot lights). `lights` must outlive the
  /// sampler. `exactCount`: point and spot lights are summed while there are at most this many
  /// (and, when sampling, a cut of at most this many single lights is summed); `maxCut` (1 to
  /// kMaxCut): the most nodes of the cut a light is drawn from.
  explicit LightSampler(std::span<const Light> lights, size_t exactCount = kExactLightCount,
                        int maxCut = kMaxCut);

  /// Appends to `out` the lights to shade the point p (offset from its surface; `n` the unit
  /// normal on the side light must arrive from) with, so that the sum over `out` of weight times
  /// the light's unshadowed contribution f (deltaLightArrival's irradiance times max(0, n . w))
  /// is an unbiased estimate of the sum of f over every light: directional lights always
  /// (weight 1); point and spot lights all (weight 1) when summed, else at most one, chosen with
  /// a probability that is positive for every light with f > 0, so nothing is lost (or the few
  /// that the cut through the tree resolves to single lights, all with weight 1). A light
  /// whose range window has ended at p, or that lies below the surface, is never chosen when
  /// sampling; when summing, a tree over more than kExactLightCount lights skips the subtrees
  /// whose windows have all ended, and the caller skips the rest before any ray
  /// (deltaLightArrival says nothing). `u` is uniform in [0, 1) and is read only when sampling.
  /// `visibility`, when given, scales the importance of the tree's nodes by what the probe's
  /// earlier shadow rays found (LightVisibility); the probabilities and weights stay exact.
  void choose(Vec3 p, Vec3 n, double u, std::vector<LightChoice>& out,
              const LightVisibility* visibility = nullptr) const;

  /// True when point and spot lights are sampled rather than summed.
  bool sampling() const { return sampling_; }
  /// The nodes of the tree (0 without one).
  size_t nodeCount() const { return nodes_.size(); }

 private:
  friend class LightVisibility;

  /// A node of the tree over the point and spot lights. Its first child is the next node, its
  /// second `second`; a leaf holds one light.
  struct Node {
    Vec3 lo, hi;          ///< bounds of the light positions
    Vec3 centre;          ///< of the bounds
    double radius = 0;    ///< half the bounds' diagonal, widened against rounding
    double power = 0;     ///< sum of the lights' mean intensity over the channels (W/sr)
    double maxRange = 0;  ///< the largest range window; infinity when a light has none
    uint32_t second = 0;  ///< internal nodes: index of the second child
    uint32_t light = 0;   ///< leaves: index into lights_
    bool leaf = false;
  };

  uint32_t build(std::vector<uint32_t>& ids, size_t first, size_t last);
  /// Whether every light of the node lies at or beyond its range window from p (it adds nothing
  /// there).
  static bool outOfRange(const Node& node, Vec3 p);
  /// Whether the cut replaces the node by its children (kSplitRatioSquared).
  bool looksLarge(const Node& node, Vec3 p) const;
  /// An upper bound (up to a constant factor shared by all nodes) of the contribution the
  /// node's lights can make at p, 0 only when none can.
  double importance(const Node& node, Vec3 p, Vec3 n) const;

  std::span<const Light> lights_;
  size_t exactCount_ = 0;
  int maxCut_ = 1;
  std::vector<uint32_t> directional_;  ///< always shaded
  std::vector<uint32_t> summed_;       ///< point and spot lights, when summed without a tree
  /// The tree, when sampling or when summing more than kExactLightCount lights (then it only
  /// skips the subtrees whose range windows have all ended at the point); root at 0.
  std::vector<Node> nodes_;
  bool sampling_ = false;
  std::vector<uint32_t> leafOf_;  ///< per light index: its leaf (UINT32_MAX when none)
  std::vector<uint32_t> parent_;  ///< per node: its parent (the root: itself)
};

}  // namespace ps
