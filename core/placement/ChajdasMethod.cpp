// `chajdas` (Chajdas et al.): the dense field, particles traced to its sinks, clusters cleaned
// by probe matching, one representative each; k-means over unlit samples
// (core/placement/Chajdas.h).
#include "core/common/Error.h"
#include "core/placement/Chajdas.h"
#include "core/placement/PlacementMethod.h"

namespace ps {

namespace {

/// How far a chajdas probe stays from a point or spot light, in base field spacings (see
/// ChajdasSettings::lightClearanceMeters).
constexpr double kLightClearance = 0.5;

struct ChajdasMethodSettings {
  double aggressiveness = 1.0;  ///< merging strength, > 0; with a budget, bisected
  FieldParameters field;        ///< the dense field (its depth: field.depth, -1: maxDepth's)
};

class ChajdasPlacer : public Placer {
 public:
  explicit ChajdasPlacer(const ChajdasMethodSettings& s) : s_(s) {}

  PlaceOutcome place(const PlaceContext& c) const override {
    const int budget = c.budget - int(c.kept.size());
    ChajdasSettings cs;
    cs.aggressiveness = s_.aggressiveness;
    cs.importanceVolumes.assign(c.importanceVolumes.begin(), c.importanceVolumes.end());
    cs.seed = c.seed;
    DenseFieldSettings fs = s_.field.field;
    fs.seed = c.seed;
    if (s_.field.depth != -1) fs.maxDepth = s_.field.depth;
    fs.importanceVolumes = cs.importanceVolumes;
    fs.reachable = c.domainOf().reachable;
    const DenseField field = buildDenseField(c.tracer, c.rig, fs, c.stage("field"));
    cs.punctualLights = punctualLightPositions(c.tracer.scene(), c.rig);
    cs.lightClearanceMeters = kLightClearance * field.baseSpacingMeters;
    PlaceOutcome out;
    ChajdasResult ch;
    if (c.budget != 0) {
      ChajdasBudgetResult b = placeChajdasBudget(field.samples, budget, cs);
      out.notes.push_back(
          formatNote("chajdas: budget %d gives aggressiveness %.3f", c.budget, b.aggressiveness));
      ch = std::move(b.result);
    } else {
      ch = placeChajdas(field.samples, cs);
    }
    out.notes.push_back(
        formatNote("chajdas: %zu field samples (%zu unlit), %zu sinks, %zu candidate clusters, "
                   "%zu probes (%.2f s)",
                   field.samples.size(), ch.unlitSamples, ch.sinks, ch.candidateClusters,
                   ch.probes.size(), ch.seconds));
    out.spacingMeters = field.baseSpacingMeters;
    std::vector<PlacedProbe> placed;
    for (const ChajdasProbe& p : ch.probes) placed.push_back({p.position, p.score});
    out.probes = awayFromKept(c, std::move(placed), field.baseSpacingMeters);
    return out;
  }

 private:
  ChajdasMethodSettings s_;
};

constexpr std::string_view kParameters[] = {
    "aggressiveness",       "fieldSpacingMeters", "fieldDepth",     "fieldSurfaceDepth",
    "fieldSamplesPerProbe", "prefilter",          "fieldMaxSamples"};

std::unique_ptr<Placer> create(const PlaceParameters& p, const PlaceBasics& b) {
  ChajdasMethodSettings s;
  const int fresh = b.budget - int(b.keptCount);
  if (b.budget != 0 && fresh < 4)
    throw ParameterError("budget", b.keptCount == 0
                                       ? "expected at least 4 probes, got " + std::to_string(fresh)
                                       : std::to_string(b.budget) +
                                             " leaves fewer than 4 new probes beside the " +
                                             std::to_string(b.keptCount) + " kept ones");
  s.aggressiveness = p.number("aggressiveness", s.aggressiveness);
  if (!(s.aggressiveness > 0))
    throw ParameterError("aggressiveness",
                         "expected a positive number, got " + std::to_string(s.aggressiveness));
  s.field = readFieldParameters(p);
  return std::make_unique<ChajdasPlacer>(s);
}

}  // namespace

const PlacementMethod& chajdasPlacementMethod() {
  static const PlacementMethod kMethod = {
      "chajdas",
      "the dense field's light traced to its sinks, clustered, one probe per cluster (Chajdas et "
      "al.)",
      kParameters, create};
  return kMethod;
}

}  // namespace ps
