// probestudio place: parses its options, calls the core stages and prints what it did; bad
// input surfaces as ps::Error, caught in main.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/cli/Common.h"
#include "core/bake/Bake.h"
#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/eval/Evaluate.h"
#include "core/io/JsonFields.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/io/VolumeFile.h"
#include "core/placement/LeakRefine.h"
#include "core/placement/Uniform.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps::cli {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

void registerPlace(CLI::App& app) {
  struct Opts {
    std::string scene, out, method = "uniform";
    double spacing = 0;
    int budget = 0;
    bool accept = false;
    bool noLeakRefine = false;
    uint64_t seed = 1;
    RigOptions rig;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand("place", "Propose probe positions for a scene");
  cmd->add_option("scene", o->scene, "glTF scene (.gltf or .glb)")->required();
  cmd->add_option("--method", o->method, "Placement method: uniform");
  cmd->add_option("--spacing", o->spacing, "Grid spacing in metres (uniform)");
  cmd->add_option("--budget", o->budget,
                  "Target probe count (uniform: the spacing giving it within 10 %)");
  cmd->add_flag("--accept", o->accept, "Mark the proposals accepted instead of candidates");
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->add_flag("--no-leak-refine", o->noLeakRefine,
                "Do not add probes (method \"leak\") where the mesh's edges cross geometry");
  cmd->add_option("-o,--output", o->out, "Probe set to write (.json)")->required();
  o->rig.add(*cmd);
  cmd->callback([o] {
    if (o->method != "uniform")
      throw ParameterError("--method: unknown method \"" + o->method + "\" (available: uniform)");
    if (o->spacing != 0 && o->budget != 0)
      throw ParameterError("--spacing and --budget: give one, not both");
    const auto t0 = std::chrono::steady_clock::now();
    const Scene scene = loadScene(o->scene);
    const Tracer tracer(scene);
    ProbeSet set;
    set.scenePath = fs::absolute(o->scene).string();
    set.sceneHash = sceneContentHash(o->scene);
    set.rig = o->rig.build();
    set.placement.method = o->method;
    UniformSettings us;
    us.seed = o->seed;
    std::vector<Vec3> points;
    if (o->budget != 0) {
      auto r = placeUniformBudget(tracer, o->budget, us, terminalProgress("place"));
      points = std::move(r.points);
      us.spacingMeters = r.spacingMeters;
      set.placement.budget = o->budget;
    } else {
      us.spacingMeters =
          o->spacing != 0 ? o->spacing : std::max(0.25, scene.bounds.diagonal() / 10);
      points = placeUniform(tracer, us, terminalProgress("place"));
    }
    set.placement.spacingMeters = us.spacingMeters;
    for (const Vec3& p : points) {
      Probe pr;
      pr.position = p;
      pr.state = o->accept ? ProbeState::Accepted : ProbeState::Candidate;
      pr.method = o->method;
      set.add(pr);
    }
    // Leak refinement (Sukys 3.2.2) of the proposals: probes with provenance "leak", score =
    // the edge crossings that asked for them.
    size_t leakAdded = 0;
    if (!o->noLeakRefine && points.size() >= 4) {
      LeakRefineSettings ls;
      ls.seed = o->seed;
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
    }
    saveProbeSet(set, o->out);
    if (!o->noLeakRefine) std::printf("leak refinement added %zu probes\n", leakAdded);
    std::printf("placed %zu probes (method %s, spacing %.3f m) in %.2f s -> %s\n", points.size(),
                o->method.c_str(), us.spacingMeters, secondsSince(t0), o->out.c_str());
  });
}

}  // namespace ps::cli
