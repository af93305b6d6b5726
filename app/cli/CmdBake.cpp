// probestudio bake: parses its options, calls the core stages and prints what it did; bad
// input surfaces as ps::Error, caught in main.
#include <chrono>
#include <cmath>
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
#include "core/placement/Uniform.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps::cli {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {
constexpr int kMaxSamplesPerProbe = 1 << 24;
}  // namespace

void registerBake(CLI::App& app) {
  struct Opts {
    std::string set, out;
    SamplingOptions sampling{1024};
    DomainOptions domain;
    uint64_t seed = 1;
    std::string cacheDir;
    bool noCache = false;
    bool fit = false;
    FitSettings fitSettings;
    UnitOptions units;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd =
      app.add_subcommand("bake", "Capture the accepted probes and write the runtime volume");
  cmd->add_option("probe_set", o->set, "Probe set (.json)")->required();
  cmd->add_option("-o,--output", o->out, "Volume to write (.psv)")->required();
  o->sampling.add(*cmd);
  o->domain.add(*cmd);
  o->units.add(*cmd);
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->add_option("--cache", o->cacheDir,
                  "Capture cache folder (default: SET.capture-cache beside the probe set)");
  cmd->add_flag("--no-cache", o->noCache,
                "Capture every probe, neither reading nor writing a cache");
  for (const char* flag : {"--leak-refine", "--no-leak-refine", "--no-leak-cuts",
                           "--leak-cuts-only", "--leak-cut-probes"})
    addRemovedOption(*cmd, flag, false, kLeakBakeReplacement);
  addRemovedOption(*cmd, "--over-cut-weight", true, kLeakBakeReplacement);
  cmd->add_flag("--fit", o->fit,
                "Least-squares probe values: fit the volume's interpolation to captures at random "
                "points of the domain instead of keeping each probe's own capture (lower error, "
                "more capture time: see the next options)");
  cmd->add_option("--fit-points", o->fitSettings.pointsPerProbe,
                  "With --fit: random points of the domain per probe (default 128)");
  cmd->add_option("--fit-spp", o->fitSettings.samplesPerPoint,
                  "With --fit: samples per fit point (default 64)");
  cmd->add_option("--fit-regularization", o->fitSettings.regularization,
                  "With --fit: pull of each probe towards its own capture, relative to the fit "
                  "points' (default 0.01)");
  cmd->callback([o, cmd] {
    // The fit's options, named, before anything is read or traced.
    if (!o->fit && (cmd->count("--fit-points") || cmd->count("--fit-spp") ||
                    cmd->count("--fit-regularization")))
      throw ParameterError("--fit-points, --fit-spp, --fit-regularization: give --fit too");
    try {
      checkFitSettings(o->fitSettings);
    } catch (const ParameterError& e) {  // under the flag of the parameter it names
      const std::string flag = e.parameter() == "pointsPerProbe"    ? "--fit-points"
                               : e.parameter() == "samplesPerPoint" ? "--fit-spp"
                               : e.parameter() == "regularization"  ? "--fit-regularization"
                                                                    : e.parameter();
      if (flag.empty()) throw;
      throw ParameterError(flag, e.problem());
    }
    if (o->sampling.spp > kMaxSamplesPerProbe)
      throw ParameterError("--spp: " + std::to_string(o->sampling.spp) +
                           " samples per probe is above the " + "limit of " +
                           std::to_string(kMaxSamplesPerProbe));
    const DomainSettings domainSettings = o->domain.build();
    const ProbeSet set = loadProbeSet(o->set);
    if (set.scenePath.empty()) throw FileError(o->set, "scene", "the probe set names no scene");
    // The scene in the set's unit; the volume is written in it too.
    const double unit = o->units.agreeWith(set.metresPerUnit, o->set);
    const Scene scene = loadSceneReporting(set.scenePath, unit, o->units.given().has_value());
    const Tracer tracer(scene);
    BakeSettings bs;
    o->sampling.apply(bs.capture);
    bs.capture.seed = o->seed;
    bs.sceneHash = sceneContentHash(set.scenePath, unit);
    bs.domain = domainSettings;
    if (o->fit) {
      bs.fit = o->fitSettings;
      bs.fit->seed = o->seed;
    }
    if (set.sceneHash != 0 && set.sceneHash != bs.sceneHash)
      std::printf("note: the scene changed since %s was saved (hash %s, now %s)\n", o->set.c_str(),
                  sceneHashText(set.sceneHash).c_str(), sceneHashText(bs.sceneHash).c_str());
    if (!o->noCache)
      bs.cacheDir =
          o->cacheDir.empty() ? fs::path(o->set + ".capture-cache") : fs::path(o->cacheDir);
    BakeResult r = bakeProbeSet(set, tracer, bs, terminalProgress("bake"));
    // Store the scene path relative to the volume, like the probe set does.
    ojson meta = ojson::parse(r.file.metadataJson);
    std::error_code ec;
    const fs::path rel = fs::relative(set.scenePath, fs::absolute(o->out).parent_path(), ec);
    if (!ec && !rel.empty()) meta["scene"] = rel.generic_string();
    r.file.metadataJson = meta.dump();
    saveVolume(r.file, o->out);
    const std::string quality = o->sampling.describe();
    std::printf(
        "baked %zu probes (%zu captured, %zu from the cache), %zu tetrahedra (capture %.2f s at "
        "%s, tetrahedralize %.3f s) -> %s\n",
        r.probes, r.captured, r.cacheHits, r.file.volume.tets.size(), r.captureSeconds,
        quality.c_str(), r.tetraSeconds, o->out.c_str());
    if (r.fit)
      std::printf(
          "least-squares fit: %zu points at %d spp, %d iterations, misfit at the points %.4f -> "
          "%.4f (%.2f s)\n",
          r.fit->points, o->fitSettings.samplesPerPoint, r.fit->iterations, r.fit->residualBefore,
          r.fit->residualAfter, r.fit->seconds);
  });
}

}  // namespace ps::cli
