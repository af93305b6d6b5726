// `ascent` (Sukys 3.1.2): the uniform grid (budget or spacing), each probe then climbing the
// luminance-weighted direction field of its own cheap captures (core/placement/Ascent.h).
#include "core/common/Error.h"
#include "core/placement/Ascent.h"
#include "core/placement/PlacementMethod.h"

namespace ps {

namespace {

struct AscentMethodSettings {
  double spacingMeters = 0;  ///< the start grid's; 0: the default, or the budget's
  int iterations = 8;        ///< steps per probe at most, >= 1
  double stepMeters = 0;     ///< the first step; 0: half the start grid's spacing
  bool direct = false;       ///< follow the full light, not the indirect light only
  int samplesPerProbe = DenseFieldSettings{}.samplesPerProbe;  ///< capture at every step
};

class AscentPlacer : public Placer {
 public:
  explicit AscentPlacer(const AscentMethodSettings& s) : s_(s) {}

  PlaceOutcome place(const PlaceContext& c) const override {
    PlaceOutcome out = placeUniformGrid(c, s_.spacingMeters);
    std::vector<Vec3> start;
    for (const PlacedProbe& p : out.probes) start.push_back(p.position);
    AscentSettings as;
    as.iterations = s_.iterations;
    as.stepMeters = s_.stepMeters > 0 ? s_.stepMeters : 0.5 * out.spacingMeters;
    as.minStepMeters = 0.05 * as.stepMeters;
    as.samplesPerProbe = s_.samplesPerProbe;
    as.mode = s_.direct ? CaptureMode::Full : CaptureMode::IndirectOnly;
    as.seed = c.seed;
    const AscentResult a = placeAscent(c.tracer, c.rig, start, as, c.stage("ascent"));
    out.notes.push_back(
        formatNote("ascent: %zu steps taken, %zu reverted, %zu probes dark from "
                   "the start",
                   a.steps, a.reverted, a.darkProbes));
    out.probes.clear();
    for (size_t i = 0; i < a.positions.size(); ++i)
      out.probes.push_back({a.positions[i], a.travelMeters[i]});
    return out;
  }

 private:
  AscentMethodSettings s_;
};

constexpr std::string_view kParameters[] = {"spacingMeters", "ascentIterations", "ascentStepMeters",
                                            "ascentDirect", "fieldSamplesPerProbe"};

std::unique_ptr<Placer> create(const PlaceParameters& p, const PlaceBasics& b) {
  AscentMethodSettings s;
  s.spacingMeters = readGridSpacing(p, b);
  checkUniformGridBudget(b);
  s.iterations = p.integer("ascentIterations", s.iterations);
  if (s.iterations < 1)
    throw ParameterError("ascentIterations",
                         "expected at least 1 step, got " + std::to_string(s.iterations));
  s.stepMeters = p.number("ascentStepMeters", s.stepMeters);
  if (s.stepMeters < 0)
    throw ParameterError("ascentStepMeters",
                         "expected 0 (half the grid spacing) or a positive number of metres, got " +
                             std::to_string(s.stepMeters));
  s.direct = p.flag("ascentDirect", s.direct);
  s.samplesPerProbe = p.integer("fieldSamplesPerProbe", s.samplesPerProbe);
  if (s.samplesPerProbe < 1)
    throw ParameterError("fieldSamplesPerProbe", "expected at least 1 sample per probe, got " +
                                                     std::to_string(s.samplesPerProbe));
  return std::make_unique<AscentPlacer>(s);
}

}  // namespace

const PlacementMethod& ascentPlacementMethod() {
  static const PlacementMethod kMethod = {
      "ascent", "the uniform grid, each probe climbing the gradient of its light (Sukys 3.1.2)",
      kParameters, create};
  return kMethod;
}

}  // namespace ps
