// `uniform`: the grid at a spacing, or the spacing giving the budget within 10 %
// (core/placement/Uniform.h).
#include "core/placement/PlacementMethod.h"

namespace ps {

namespace {

class UniformPlacer : public Placer {
 public:
  explicit UniformPlacer(double spacingMeters) : spacingMeters_(spacingMeters) {}
  PlaceOutcome place(const PlaceContext& c) const override {
    return placeUniformGrid(c, spacingMeters_);
  }

 private:
  double spacingMeters_;  ///< 0: the default, or the budget's
};

constexpr std::string_view kParameters[] = {"spacingMeters"};

}  // namespace

const PlacementMethod& uniformPlacementMethod() {
  static const PlacementMethod kMethod = {
      "uniform", "a grid at a spacing, or the spacing giving the budget", kParameters,
      [](const PlaceParameters& p, const PlaceBasics& b) -> std::unique_ptr<Placer> {
        const double spacing = readGridSpacing(p, b);
        checkUniformGridBudget(b);
        return std::make_unique<UniformPlacer>(spacing);
      }};
  return kMethod;
}

}  // namespace ps
