// probestudio place: parses its options, keeps the locked probes of an existing set, runs the
// method (core/placement/Place.h, shared with the editor) and writes the probe set with the rig;
// bad input surfaces as ps::Error, caught in main.
#include <chrono>
#include <cstdio>
#include <memory>

#include "app/cli/Common.h"
#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/placement/LeakRefine.h"
#include "core/placement/Place.h"

namespace ps::cli {

namespace fs = std::filesystem;

namespace {

struct PlaceOpts {
  std::string scene, out, keep;
  PlaceRequest request;
  bool accept = false;
  bool noLeakRefine = false;
  RigOptions rig;
};

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
  cmd->add_option("--spacing", o->request.spacingMeters, "Grid spacing in metres (uniform)");
  cmd->add_option("--budget", o->request.budget,
                  "Probe count (uniform: the spacing giving it within 10 %; greedy: the total, "
                  "kept probes included)");
  cmd->add_option("--max-error", o->request.maxError,
                  "greedy: stop once the dense field's relative RMS irradiance error is this low");
  cmd->add_option("--keep", o->keep,
                  "Existing probe set whose locked probes are kept (with their ids) and built "
                  "around; its rig is used when no rig option is given");
  cmd->add_option("--field-spacing", o->request.field.baseSpacingMeters,
                  "Dense field base grid spacing in metres (default: domain diagonal / 12)");
  cmd->add_option("--field-depth", o->request.fieldDepth,
                  "Dense field refinement levels, 0 to 8 (default, or -1: greedy 4, chajdas 2)");
  cmd->add_option("--field-surface-depth", o->request.field.maxSurfaceDepth,
                  "Dense field levels at which a surface splits a cell (default: greedy 2, at most "
                  "--field-depth; others --field-depth); "
                  "deeper levels split only where neighbouring samples differ");
  cmd->add_option("--field-spp", o->request.field.samplesPerProbe,
                  "Samples per cheap probe (dense field, ascent, spawn-merge)")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--prefilter", o->request.field.prefilter,
                "Pre-filtered dense field: each sample averages the light over its cell's "
                "trilinear support, from origins inside the domain (Kontkanen & Laine sec. 4, 6)");
  cmd->add_option("--field-max-samples", o->request.field.maxSamples,
                  "Dense field sample limit: a base grid above it is an error, a refinement level "
                  "above it is skipped");
  cmd->add_option("--held-out", o->request.heldOutPerProbe,
                  "greedy: points per probe of the budget (at least 64 probes' worth) in the "
                  "domain, captured at --field-spp, where the error is measured (default 128; 0: "
                  "on the dense field's own samples)");
  cmd->add_option("--held-out-uniform", o->request.heldOutUniformShare,
                  "greedy: the share of the held-out points spread by volume, 0 to 1 (default "
                  "0.5); the rest go where the dense field is bright, weighted accordingly");
  cmd->add_option("--probe-spp", o->request.probeSpp,
                  "greedy: samples per probe of each candidate's own capture (default 1024, the "
                  "bake's; at most --field-spp: the field sample's capture)");
  cmd->add_option("--swap-passes", o->request.swapPasses,
                  "greedy: passes of swaps after the additions, at most (default 4; 0: none): "
                  "each probe in turn goes to the candidate, where the error is then largest or "
                  "next to it (--swap-neighbours), that lowers the error most; a pass that gains "
                  "less than 1 % ends them");
  cmd->add_option("--swap-neighbours", o->request.swapNeighbours,
                  "greedy: field samples nearest to the probe taken out that each swap tries too "
                  "(default 26; 0: only the far candidates)");
  cmd->add_option("--ascent-iterations", o->request.ascentIterations,
                  "ascent: steps per probe at most");
  cmd->add_option("--ascent-step", o->request.ascentStepMeters,
                  "ascent: first step in metres (default: half the grid spacing)");
  cmd->add_flag("--ascent-direct", o->request.ascentDirect,
                "ascent: follow the full light instead of the indirect light only");
  cmd->add_option("--aggressiveness", o->request.aggressiveness,
                  "chajdas: merging strength (> 0, default 1; larger gives fewer probes)");
  cmd->add_flag("--no-leak-refine", o->noLeakRefine,
                "Do not add probes (method \"leak\") where the mesh's edges cross geometry");
  cmd->add_flag("--accept", o->accept, "Mark the proposals accepted instead of candidates");
  cmd->add_option("--seed", o->request.seed, "Random seed");
  cmd->add_option("-o,--output", o->out, "Probe set to write (.json)")->required();
  o->rig.add(*cmd);
  cmd->callback([o] {
    const auto t0 = std::chrono::steady_clock::now();
    const Scene scene = loadScene(o->scene);
    for (const std::string& w : scene.warnings) std::cerr << "warning: " << w << "\n";
    const Tracer tracer(scene);
    ProbeSet set;
    set.scenePath = fs::absolute(o->scene).string();
    set.sceneHash = sceneContentHash(o->scene);
    set.rig = o->rig.build();
    set.placement.method = o->request.method;
    set.placement.budget = o->request.budget;
    if (!o->keep.empty()) {
      // The locked probes of the existing set stay, with their ids, states and captures; its
      // importance volumes too, and its rig unless rig options are given. Everything else of it
      // is replaced.
      const ProbeSet old = loadProbeSet(o->keep);
      set.importanceVolumes = old.importanceVolumes;
      // Without rig options the kept set's rig stays (its captures were made with it).
      if (o->rig.suns.empty() && o->rig.points.empty() && o->rig.env.empty() &&
          o->rig.envMap.empty())
        set.rig = old.rig;
      set.nextId = old.nextId;
      for (const Probe& p : old.probes)
        if (p.locked) set.probes.push_back(p);
    }
    const size_t keptCount = set.probes.size();
    const PlaceOutcome placed =
        placeProbes(tracer, set.rig, o->request, set.probes, set.importanceVolumes,
                    [](const std::string& stage) { return terminalProgress(stage); });
    for (const std::string& note : placed.notes) std::printf("%s\n", note.c_str());
    set.placement.spacingMeters = placed.spacingMeters;
    for (const PlacedProbe& p : placed.probes) {
      Probe pr;
      pr.position = p.position;
      pr.state = o->accept ? ProbeState::Accepted : ProbeState::Candidate;
      pr.method = o->request.method;
      pr.score = p.score;
      set.add(pr);
    }
    // Leak refinement (Sukys 3.2.2) of kept + proposed probes: probes with provenance "leak",
    // score = the edge crossings that asked for them.
    size_t leakAdded = 0;
    if (!o->noLeakRefine && set.probes.size() >= 4) {
      std::vector<Vec3> points;
      for (const Probe& p : set.probes) points.push_back(p.position);
      LeakRefineSettings ls;
      ls.seed = o->request.seed;
      try {
        const LeakRefineResult leak = refineLeaks(tracer, points, ls);
        for (size_t i = 0; i < leak.added.size(); ++i) {
          Probe pr;
          pr.position = leak.added[i];
          pr.state = o->accept ? ProbeState::Accepted : ProbeState::Candidate;
          pr.method = "leak";
          pr.score = leak.addedScore[i];
          set.add(pr);
        }
        leakAdded = leak.added.size();
      } catch (const ParameterError& e) {  // e.g. a flat set: nothing to tetrahedralize
        std::printf("leak refinement skipped: %s\n", e.what());
      }
    }
    saveProbeSet(set, o->out);
    std::printf("placed %zu probes (method %s, %zu kept) in %.2f s -> %s\n", placed.probes.size(),
                o->request.method.c_str(), keptCount, secondsSince(t0), o->out.c_str());
    if (!o->noLeakRefine) std::printf("leak refinement added %zu probes\n", leakAdded);
  });
}

}  // namespace ps::cli
