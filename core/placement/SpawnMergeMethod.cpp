// `spawn-merge` (Sukys 3.1.1): a uniform grid of half the budget (or at the spacing), then
// merge similar close neighbours and spawn between differing ones, up to the budget as the
// probe cap (4 times the grid without a budget); core/placement/SpawnMerge.h.
#include "core/common/Error.h"
#include "core/placement/PlacementMethod.h"
#include "core/placement/SpawnMerge.h"
#include "core/placement/Uniform.h"

namespace ps {

namespace {

class SpawnMergePlacer : public Placer {
 public:
  SpawnMergePlacer(double spacingMeters, int samplesPerProbe)
      : spacingMeters_(spacingMeters), samplesPerProbe_(samplesPerProbe) {}

  PlaceOutcome place(const PlaceContext& c) const override {
    const int keptCount = int(c.kept.size());
    UniformSettings us;
    us.seed = c.seed;
    if (c.domain && c.domain->rule == DomainRule::Reachable) us.domain = c.domain;
    std::vector<Vec3> grid;
    if (c.budget != 0) {
      UniformBudgetResult b =
          placeUniformBudget(c.tracer, (c.budget - keptCount) / 2, us, c.stage("grid"));
      grid = std::move(b.points);
      us.spacingMeters = b.spacingMeters;
    } else {
      us.spacingMeters = spacingMeters_ != 0 ? spacingMeters_ : c.defaultSpacingMeters();
      grid = placeUniform(c.tracer, us, c.stage("grid"));
    }
    SpawnMergeSettings ss;
    ss.spacingMeters = us.spacingMeters;
    ss.maxProbes = c.budget != 0 ? size_t(c.budget) : 4 * (grid.size() + c.kept.size());
    ss.samplesPerProbe = samplesPerProbe_;
    ss.seed = c.seed;
    std::vector<Vec3> kept;
    for (const Probe& k : c.kept) kept.push_back(k.position);
    const SpawnMergeResult s =
        placeSpawnMerge(c.tracer, c.rig, grid, kept, ss, c.stage("spawn-merge"));
    PlaceOutcome out;
    out.spacingMeters = us.spacingMeters;
    out.notes.push_back(
        formatNote("spawn-merge: %zu grid probes, %zu spawned, %zu merges in %d "
                   "iterations",
                   grid.size(), s.spawned, s.merged, s.iterations));
    for (const SpawnMergeProbe& p : s.probes) out.probes.push_back({p.position, p.score});
    return out;
  }

 private:
  double spacingMeters_;  ///< the start grid's; 0: the default, or the budget's
  int samplesPerProbe_;
};

constexpr std::string_view kParameters[] = {"spacingMeters", "fieldSamplesPerProbe"};

std::unique_ptr<Placer> create(const PlaceParameters& p, const PlaceBasics& b) {
  const double spacing = readGridSpacing(p, b);
  const int fresh = b.budget - int(b.keptCount);
  if (b.budget != 0 && fresh < 8)
    throw ParameterError("budget",
                         "spawn-merge needs at least 8 new probes (its grid is half "
                         "the budget), got " +
                             std::to_string(fresh));
  const int spp = p.integer("fieldSamplesPerProbe", DenseFieldSettings{}.samplesPerProbe);
  if (spp < 1)
    throw ParameterError("fieldSamplesPerProbe",
                         "expected at least 1 sample per probe, got " + std::to_string(spp));
  return std::make_unique<SpawnMergePlacer>(spacing, spp);
}

}  // namespace

const PlacementMethod& spawnMergePlacementMethod() {
  static const PlacementMethod kMethod = {
      "spawn-merge",
      "a grid of half the budget, merging similar neighbours and spawning between differing "
      "ones (Sukys 3.1.1)",
      kParameters, create};
  return kMethod;
}

}  // namespace ps
