// probestudio place: maps its flags to a core PlaceRequest (core/placement/Place.h, the same
// pipeline the editor's placement panel runs), loads the set whose probes are kept, places and
// writes the probe set with the rig. A parameter the core refuses is reported under its flag;
// bad input surfaces as ps::Error, caught in main.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>

#include "app/cli/Common.h"
#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/placement/Place.h"

namespace ps::cli {

namespace fs = std::filesystem;

namespace {

/// A method parameter's flag (PlacementMethod::parameters), with its help. A flag without a
/// value (`isSwitch`) sets the parameter to 1; one whose value is a word (`isText`) passes it
/// on as given, for the method to check.
struct ParameterFlag {
  const char* flag;
  const char* parameter;
  const char* help;
  bool isSwitch = false;
  bool isText = false;
};

const ParameterFlag kParameterFlags[] = {
    {"--objective", "objective",
     "greedy: the error it lowers: perceptual (default: the RMS of |log2| of interpolated over "
     "reference irradiance, in stops, floored at 5 % of the median; a dim room counts as much "
     "as a bright one) or energy (rel_rmse, dominated by the bright places)",
     false, true},
    {"--interpolant", "interpolant",
     "greedy: how its error interpolates the probes: visible (default: as the runtime reads a "
     "baked volume, each probe weighed by whether its visibility map sees the point, so no "
     "light crosses a wall) or barycentric (the tetrahedron's weights alone)",
     false, true},
    {"--spacing", "spacingMeters",
     "Grid spacing in metres (uniform, and the start grid of ascent and spawn-merge; default: "
     "the scene diagonal / 10, at least 0.25 m)"},
    {"--max-error", "maxError",
     "greedy: stop once the held-out (or dense field) error is this low (RMS stops with "
     "--objective perceptual, relative RMS irradiance with energy)"},
    {"--field-spacing", "fieldSpacingMeters",
     "Dense field base grid spacing in metres (default: domain diagonal / 12)"},
    {"--field-depth", "fieldDepth",
     "Dense field refinement levels, 0 to 8 (default, or -1: greedy 4, chajdas 2)"},
    {"--field-surface-depth", "fieldSurfaceDepth",
     "Dense field levels at which a surface splits a cell (default: greedy 2, at most "
     "--field-depth; others --field-depth); deeper levels split only where neighbouring samples "
     "differ"},
    {"--field-spp", "fieldSamplesPerProbe",
     "Samples per cheap probe (dense field, ascent, spawn-merge; default 64)"},
    {"--prefilter", "prefilter",
     "Pre-filtered dense field: each sample averages the light over its cell's trilinear "
     "support, from origins inside the domain (Kontkanen & Laine sec. 4, 6)",
     true},
    {"--field-max-samples", "fieldMaxSamples",
     "Dense field sample limit: a base grid above it is an error, a refinement level above it is "
     "skipped (default 200000)"},
    {"--held-out", "heldOutPerProbe",
     "greedy: points per probe of the budget (at least 64 probes' worth) in the domain, captured "
     "at --field-spp, where the error is measured (default 128; 0: on the dense field's own "
     "samples)"},
    {"--held-out-uniform", "heldOutUniformShare",
     "greedy: the share of the held-out points spread by volume, 0 to 1 (default: 1 with "
     "--objective perceptual, 0.5 with energy); the rest go where the dense field is bright, "
     "weighted accordingly"},
    {"--probe-spp", "candidateSamplesPerProbe",
     "greedy: samples per probe of each candidate's own capture (default 1024, the bake's; at "
     "most --field-spp: the field sample's capture)"},
    {"--swap-passes", "swapPasses",
     "greedy: passes of swaps after the additions, at most (default 4; 0: none): each probe in "
     "turn goes to the candidate, where the error is then largest or next to it "
     "(--swap-neighbours), that lowers the error most; a pass that gains less than 1 % ends "
     "them"},
    {"--swap-neighbours", "swapNeighbours",
     "greedy: field samples nearest to the probe taken out that each swap tries too (default 26; "
     "0: only the far candidates)"},
    {"--regions", "regions",
     "greedy: auto (default: one region up to 512 new probes, else one per 128), off (plain "
     "greedy) or a count: greedy runs in the regions of a k-d split of the dense field, the "
     "budget shared by the error each measured",
     false, true},
    {"--ascent-iterations", "ascentIterations", "ascent: steps per probe at most (default 8)"},
    {"--ascent-step", "ascentStepMeters",
     "ascent: first step in metres (default: half the grid spacing)"},
    {"--ascent-direct", "ascentDirect",
     "ascent: follow the full light instead of the indirect light only", true},
    {"--aggressiveness", "aggressiveness",
     "chajdas: merging strength (> 0, default 1; larger gives fewer probes)"},
};

/// The flag of a core parameter name ("budget", "method" and the method parameters).
std::string flagOf(const std::string& parameter) {
  if (parameter == "budget" || parameter == "method" || parameter == "domain")
    return "--" + parameter;
  for (const ParameterFlag& f : kParameterFlags)
    if (parameter == f.parameter) return f.flag;
  return parameter;
}

/// The core's ParameterError under the CLI's flag names.
ParameterError asFlagError(const ParameterError& e, const std::string& method) {
  if (e.parameter().empty()) return e;
  std::string problem = e.problem();
  if (problem.rfind("not a parameter of method", 0) == 0) {
    std::string flags = "--budget";
    for (std::string_view p : findPlacementMethod(method).parameters)
      flags += ", " + flagOf(std::string(p));
    problem = "not an option of --method " + method + " (its options: " + flags + ")";
  }
  return ParameterError(flagOf(e.parameter()), problem);
}

struct PlaceOpts {
  std::string scene, out, keep;
  PlaceRequest request;
  bool accept = false;
  RigOptions rig;
  DomainOptions domain;
  UnitOptions units;
};

/// Draws of the valid-space check (each of up to 1000 points, DomainPoints::draw).
constexpr size_t kValidSpaceDraws = 8;

/// Throws ps::FileError naming the scene when its domain has no room for a probe: none of
/// kValidSpaceDraws draws found a point outside geometry and clear of the lights. Without it,
/// uniform's budget search places up to 40 ever finer grids per search, each tested point by
/// point, all empty; the other methods fail later, on an empty dense field. A domain with room
/// stops at its first points; one without costs kValidSpaceDraws * 1000 * 32 rays.
void checkValidSpace(const Tracer& tracer, const ProbeSet& set, uint64_t seed,
                     const std::string& scenePath) {
  const std::vector<Bounds3> boxes = importanceBoxes(set.importanceVolumes);
  const DomainPoints domain(tracer, set.rig, boxes, kDefaultLightClearanceRelative);
  if (!domain.drawMany(kValidSpaceDraws, seed).empty()) return;
  throw FileError(scenePath, "",
                  "no valid space for probes: " + std::to_string(kValidSpaceDraws * 1000) +
                      " random points of the " +
                      (boxes.empty() ? "scene's bounds" : "importance volumes") +
                      " are all inside geometry (more than 25 % of their rays hit back faces) or "
                      "within the light clearance");
}

std::string methodNames() {
  std::string s;
  for (const std::string& name : placementMethods()) s += (s.empty() ? "" : ", ") + name;
  return s;
}

}  // namespace

void registerPlace(CLI::App& app) {
  auto o = std::make_shared<PlaceOpts>();
  CLI::App* cmd = app.add_subcommand("place", "Propose probe positions for a scene");
  cmd->add_option("scene", o->scene, "glTF scene (.gltf or .glb)")->required();
  cmd->add_option("--method", o->request.method, "Placement method: " + methodNames());
  cmd->add_option("--budget", o->request.budget,
                  "Probe count (uniform: the spacing giving it within 10 %; greedy: the total, "
                  "kept probes included)");
  for (const ParameterFlag& f : kParameterFlags) {
    const std::string parameter = f.parameter;
    if (f.isSwitch)
      cmd->add_flag_function(
          f.flag, [o, parameter](int64_t) { o->request.parameters.set(parameter, 1.0); }, f.help);
    else if (f.isText)
      cmd->add_option_function<std::string>(
          f.flag,
          [o, parameter](const std::string& v) { o->request.parameters.setText(parameter, v); },
          f.help);
    else
      cmd->add_option_function<double>(
          f.flag, [o, parameter](double v) { o->request.parameters.set(parameter, v); }, f.help);
  }
  cmd->add_option("--keep", o->keep,
                  "Existing probe set whose locked probes are kept (with their ids) and built "
                  "around, and whose rejected probes stay rejected; its rig is used when no rig "
                  "option is given");
  for (const char* flag : {"--leak-refine", "--no-leak-refine"})
    addRemovedOption(*cmd, flag, false, kLeakPlaceReplacement);
  cmd->add_flag_function(
      "--no-coverage", [o](int64_t) { o->request.cover = false; },
      "Place with the method alone: no probes first for every room and the domain's hull (the "
      "notes then count the rooms left without a probe)");
  cmd->add_flag("--accept", o->accept, "Mark the proposals accepted instead of candidates");
  cmd->add_option("--seed", o->request.seed, "Random seed");
  cmd->add_option("-o,--output", o->out, "Probe set to write (.json)")->required();
  o->rig.add(*cmd);
  o->domain.add(*cmd);
  o->units.add(*cmd);
  cmd->callback([o] {
    const auto t0 = std::chrono::steady_clock::now();
    PlaceRequest& request = o->request;
    request.domain = o->domain.build();
    request.newState = o->accept ? ProbeState::Accepted : ProbeState::Candidate;
    ProbeSet set;
    set.scenePath = fs::absolute(o->scene).string();
    // The unit: --units, else the kept set's, else metres.
    const std::optional<double> unit = o->units.given();
    std::optional<ProbeSet> old;
    if (!o->keep.empty()) old = loadProbeSet(o->keep);
    set.metresPerUnit = unit ? *unit : old ? old->metresPerUnit : 1.0;
    // The rig's positions are given in the scene's unit; the core's are metres.
    set.rig = scaledRig(o->rig.build(), set.metresPerUnit);
    if (old) {
      // The kept set's probes, importance volumes and ids; its rig unless rig options are given
      // (its captures were made with it). Its lengths are in metres in memory, whatever its unit.
      set.importanceVolumes = old->importanceVolumes;
      if (o->rig.suns.empty() && o->rig.points.empty() && o->rig.env.empty() &&
          o->rig.envMap.empty())
        set.rig = old->rig;
      set.nextId = old->nextId;
      set.probes = old->probes;
    }
    try {
      checkPlaceRequest(request, set);  // before the scene is loaded
      const Scene scene = loadSceneReporting(o->scene, set.metresPerUnit, unit || old);
      const Tracer tracer(scene);
      set.sceneHash = sceneContentHash(o->scene, set.metresPerUnit);
      checkValidSpace(tracer, set, request.seed, o->scene);
      const PlaceResult placed = placeProbeSet(
          tracer, set, request, [](const std::string& stage) { return terminalProgress(stage); });
      for (const std::string& note : placed.notes) std::printf("%s\n", note.c_str());
      saveProbeSet(placed.set, o->out);
      std::printf("placed %zu probes (method %s, %zu covering, %zu kept) in %.2f s -> %s\n",
                  placed.placed, request.method.c_str(), placed.covered, placed.kept,
                  secondsSince(t0), o->out.c_str());
    } catch (const ParameterError& e) {
      throw asFlagError(e, request.method);
    }
  });
}

}  // namespace ps::cli
