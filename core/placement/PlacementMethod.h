#pragma once
// A placement method as a unit, after pbrt-v4's `Integrator::Create(parameters)`: each method
// reads its own named parameters with its own defaults, checks them once (here, in the core,
// with messages that name the parameter), and is listed in one table (placementMethodTable).
// The CLI and the editor pass the parameters under these names and show an error under their
// own flag or field name (ParameterError::parameter()). The whole `place` step around a method
// (kept probes, leak refinement, provenance) is core/placement/Place.h.
//
// Adding a method: a file core/placement/<Name>Method.cpp defining a Placer and its
// `PlacementMethod` (name, summary, parameters, create), one line in placementMethodTable()
// (PlacementMethod.cpp), and the flag of each new parameter in app/cli/CmdPlace.cpp.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/Progress.h"
#include "core/domain/DomainPoints.h"
#include "core/domain/Rooms.h"
#include "core/io/ProbeSet.h"
#include "core/math/Vec3.h"
#include "core/placement/DenseField.h"
#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"

namespace ps {

/// A method's named numeric parameters (pbrt-v4's ParameterDictionary, reduced to numbers:
/// counts, lengths in metres, shares, and switches as 0 or 1). Names are the core's own, in
/// camelCase with the unit in the name (`spacingMeters`); each method lists the ones it reads
/// (PlacementMethod::parameters). An absent parameter takes the method's default.
class PlaceParameters {
 public:
  void set(const std::string& name, double value) { values_[name] = value; }
  /// A parameter whose value is a word (choice()).
  void setText(const std::string& name, const std::string& value) { texts_[name] = value; }
  bool has(const std::string& name) const {
    return values_.count(name) != 0 || texts_.count(name) != 0;
  }
  const std::map<std::string, double>& values() const { return values_; }
  const std::map<std::string, std::string>& texts() const { return texts_; }

  /// The value of `name`, or `fallback` when it is absent. Throws ps::ParameterError(name) when
  /// the value is not finite.
  double number(const std::string& name, double fallback) const;
  /// As number(), for a whole number in int's range.
  int integer(const std::string& name, int fallback) const;
  /// As number(), for 0 (false) or 1 (true).
  bool flag(const std::string& name, bool fallback) const;
  /// The word given for `name` (setText), or `fallback` when it is absent. Throws
  /// ps::ParameterError(name) listing `options` when the word is not one of them, or when the
  /// parameter was given as a number.
  std::string choice(const std::string& name, std::string_view fallback,
                     std::span<const std::string_view> options) const;

 private:
  std::map<std::string, double> values_;
  std::map<std::string, std::string> texts_;
};

/// What every method is run with. `kept` are the probes that stay (the artist's locked and accepted
/// ones, with their SH where captured), placed around; `budget` is the request's probe count (0:
/// none), kept probes included where the method says so.
struct PlaceContext {
  const Tracer& tracer;
  const LightingRig& rig;
  std::span<const Probe> kept;
  std::span<const ImportanceVolume> importanceVolumes;
  int budget = 0;
  uint64_t seed = 1;
  /// Reports progress per stage ("place", "field", "greedy", ...): returns the ProgressFn for a
  /// stage, or an empty one.
  std::function<ProgressFn(const std::string& stage)> progress;

  /// The domain of interest (DomainPoints.h) the method's fields, grids and held-out points
  /// keep to; null: the importance volumes' boxes under the `bounds` rule.
  std::shared_ptr<const Domain> domain;
  /// The domain's rooms (core/domain/Rooms.h) when the covering found them, else null: regional
  /// greedy then makes its regions of whole rooms.
  std::shared_ptr<const RoomMap> rooms;

  ProgressFn stage(const std::string& name) const { return progress ? progress(name) : nullptr; }
  /// *domain, or the importance volumes' boxes under the `bounds` rule when it is null.
  Domain domainOf() const;
  /// The grid spacing when none is given: the scene's diagonal / 10, at least 0.25 m.
  double defaultSpacingMeters() const;
};

struct PlacedProbe {
  Vec3 position;
  double score = 0;  ///< method-specific provenance score (Probe::score)
};

struct PlaceOutcome {
  std::vector<PlacedProbe> probes;  ///< the new probes only (kept ones are not repeated)
  double spacingMeters = 0;         ///< the grid or field spacing used (PlacementSettings)
  std::vector<std::string> notes;   ///< what the method did, one line each
};

/// A method whose parameters were read and checked: placing runs it.
class Placer {
 public:
  virtual ~Placer() = default;
  /// Places the new probes. Throws ps::ParameterError for what only the scene can tell (a flat
  /// domain, a field without light), ps::Cancelled when a progress callback returns false.
  virtual PlaceOutcome place(const PlaceContext& context) const = 0;
};

/// What a method's create() may check besides its parameters.
struct PlaceBasics {
  int budget = 0;
  size_t keptCount = 0;
};

struct PlacementMethod {
  std::string_view name;     ///< as given to PlaceRequest::method
  std::string_view summary;  ///< one line, for help texts
  /// The parameters it reads (PlaceParameters); any other one given is an error.
  std::span<const std::string_view> parameters;
  /// Reads and checks the parameters; throws ps::ParameterError naming the parameter (or
  /// "budget") before any tracing.
  std::unique_ptr<Placer> (*create)(const PlaceParameters& parameters, const PlaceBasics& basics);
};

/// Every method, sorted by name.
std::span<const PlacementMethod> placementMethodTable();

/// The method called `name`; throws ps::ParameterError("method") naming the valid ones.
const PlacementMethod& findPlacementMethod(std::string_view name);

/// The method's Placer for `parameters`: throws ps::ParameterError naming a parameter the method
/// does not read, or one its create() refuses.
std::unique_ptr<Placer> createPlacer(const PlacementMethod& method,
                                     const PlaceParameters& parameters, const PlaceBasics& basics);

/// The method names, sorted.
std::vector<std::string> placementMethods();

// The registered methods, each defined in its <Name>Method.cpp.
const PlacementMethod& uniformPlacementMethod();
const PlacementMethod& greedyPlacementMethod();
const PlacementMethod& chajdasPlacementMethod();
const PlacementMethod& ascentPlacementMethod();
const PlacementMethod& spawnMergePlacementMethod();

// Shared by the methods.

/// printf into a std::string (a note line).
std::string formatNote(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

/// True when p lies closer than `meters` to one of `points`.
bool withinAny(std::span<const Vec3> points, Vec3 p, double meters);
/// Drops the points closer than half `spacingMeters` to a kept probe (it stands for them).
std::vector<PlacedProbe> awayFromKept(const PlaceContext& context, std::vector<PlacedProbe> in,
                                      double spacingMeters);

/// The dense field's parameters (fieldSpacingMeters, fieldDepth, fieldSurfaceDepth,
/// fieldSamplesPerProbe, prefilter, fieldMaxSamples) read into `field` and checked.
/// fieldDepth is returned apart (-1: the method's default).
struct FieldParameters {
  DenseFieldSettings field;
  int depth = -1;
};
FieldParameters readFieldParameters(const PlaceParameters& parameters);

/// The grid spacing `spacingMeters` (0: the default), checked: not negative, not with a budget.
double readGridSpacing(const PlaceParameters& parameters, const PlaceBasics& basics);

/// placeUniformGrid's precondition: throws ps::ParameterError("budget") when a budget leaves
/// fewer than 4 new probes beside the kept ones.
void checkUniformGridBudget(const PlaceBasics& basics);

/// The uniform grid of PlaceContext::budget probes (kept ones counted), or at `spacingMeters`
/// (0: the default) when there is no budget. The grid of `uniform`, started from by `ascent`.
PlaceOutcome placeUniformGrid(const PlaceContext& context, double spacingMeters);

}  // namespace ps
