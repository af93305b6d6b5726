// probestudio place: parses its options, dispatches to one placement method (a function per
// method below, registered in kMethods), keeps the locked probes of an existing set, and writes
// the probe set with the rig; bad input surfaces as ps::Error, caught in main.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>

#include "app/cli/Common.h"
#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/placement/Ascent.h"
#include "core/placement/Chajdas.h"
#include "core/placement/DenseField.h"
#include "core/placement/Greedy.h"
#include "core/placement/LeakRefine.h"
#include "core/placement/SpawnMerge.h"
#include "core/placement/Uniform.h"

namespace ps::cli {

namespace fs = std::filesystem;

namespace {

struct PlaceOpts {
  std::string scene, out, keep, method = "uniform";
  double spacing = 0;
  int budget = 0;
  double maxError = 0;
  bool accept = false;
  uint64_t seed = 1;
  // Dense field (methods that start from it).
  double fieldSpacing = 0;
  int fieldDepth = 2;
  int fieldSpp = 64;
  size_t fieldMaxSamples = 200000;
  // Ascent.
  int ascentIterations = 8;
  double ascentStep = 0;  // 0 = half the start grid's spacing
  bool ascentDirect = false;
  // Chajdas.
  double aggressiveness = 1.0;
  // Leak refinement of the result (Sukys 3.2.2).
  bool noLeakRefine = false;
  RigOptions rig;
};

/// One proposed probe: where, and its provenance score.
struct Proposal {
  Vec3 position;
  double score = 0;
};

/// What a method gets: the scene, the options, the set being built (rig, kept probes).
struct PlaceContext {
  const Scene& scene;
  const Tracer& tracer;
  const PlaceOpts& opts;
  ProbeSet& set;
  std::vector<const Probe*> kept;  ///< locked probes of --keep, already in `set`
};

using PlaceMethod = std::function<std::vector<Proposal>(PlaceContext&)>;

/// `uniform`: the grid at --spacing, or the spacing giving --budget probes within 10 %.
std::vector<Proposal> placeWithUniform(PlaceContext& c) {
  const PlaceOpts& o = c.opts;
  if (o.maxError != 0)
    throw ParameterError(
        "--max-error: only for --method greedy (uniform takes --spacing or "
        "--budget)");
  UniformSettings us;
  us.seed = o.seed;
  std::vector<Vec3> points;
  if (o.budget != 0) {
    const int budget = o.budget - int(c.kept.size());
    if (!c.kept.empty() && budget < 4)
      throw ParameterError("--budget: " + std::to_string(o.budget) + " leaves fewer than 4 new " +
                           "probes beside the " + std::to_string(c.kept.size()) + " kept ones");
    auto r = placeUniformBudget(c.tracer, budget, us, terminalProgress("place"));
    points = std::move(r.points);
    us.spacingMeters = r.spacingMeters;
    c.set.placement.budget = o.budget;
  } else {
    us.spacingMeters = o.spacing != 0 ? o.spacing : std::max(0.25, c.scene.bounds.diagonal() / 10);
    points = placeUniform(c.tracer, us, terminalProgress("place"));
  }
  c.set.placement.spacingMeters = us.spacingMeters;
  std::vector<Proposal> out;
  for (const Vec3& p : points) {
    // Like the editor: a grid point closer than half the spacing to a kept probe is dropped.
    bool nearKept = false;
    for (const Probe* k : c.kept)
      nearKept = nearKept || length(k->position - p) < 0.5 * us.spacingMeters;
    if (!nearKept) out.push_back({p, 0.0});
  }
  return out;
}

/// `greedy`: the dense field, then error-driven additions (core/placement/Greedy.h).
std::vector<Proposal> placeWithGreedy(PlaceContext& c) {
  const PlaceOpts& o = c.opts;
  if (o.spacing != 0)
    throw ParameterError(
        "--spacing: only for --method uniform (greedy's dense field takes "
        "--field-spacing)");
  GreedySettings gs;
  gs.budget = o.budget;
  gs.maxError = o.maxError;
  checkGreedySettings(gs, c.kept.size());  // before the dense field is built
  DenseFieldSettings fs;
  fs.baseSpacingMeters = o.fieldSpacing;
  fs.maxDepth = o.fieldDepth;
  fs.samplesPerProbe = o.fieldSpp;
  fs.seed = o.seed;
  fs.maxSamples = o.fieldMaxSamples;
  fs.importanceVolumes = c.set.importanceVolumes;
  const DenseField field = buildDenseField(c.tracer, c.set.rig, fs, terminalProgress("field"));
  std::printf("dense field: %zu samples (base spacing %.3f m, %d levels%s) in %.2f s\n",
              field.samples.size(), field.baseSpacingMeters, int(field.cellsPerLevel.size()),
              field.refinementTruncated ? ", refinement truncated at --field-max-samples" : "",
              field.seconds);
  // The kept probes take part with their SH captured like the field's samples.
  std::vector<KeptProbe> kept;
  if (!c.kept.empty()) {
    std::vector<Vec3> points;
    for (const Probe* k : c.kept) points.push_back(k->position);
    CaptureSettings cs;
    cs.samplesPerProbe = o.fieldSpp;
    cs.seed = o.seed;
    const auto caps = captureProbes(c.tracer, c.set.rig, points, cs);
    for (size_t i = 0; i < points.size(); ++i) kept.push_back({points[i], caps[i].sh});
  }
  const GreedyResult r = placeGreedy(field, kept, gs, terminalProgress("greedy"));
  std::printf("greedy: field error %.4f with %zu probes\n", r.fieldError,
              r.positions.size() + kept.size());
  if (r.noImprovement)
    std::printf(
        "greedy: from %zu probes on, no candidate lowered the field error (its noise "
        "floor: a larger --field-spp lowers it)\n",
        r.probesAtNoImprovement);
  c.set.placement.budget = o.budget;
  c.set.placement.spacingMeters = field.baseSpacingMeters;
  std::vector<Proposal> out;
  for (size_t i = 0; i < r.positions.size(); ++i) out.push_back({r.positions[i], r.scores[i]});
  return out;
}

/// `ascent` (Sukys 3.1.2): the uniform grid (--budget or --spacing), each probe then climbing
/// the luminance-weighted direction field of its own cheap captures (core/placement/Ascent.h).
std::vector<Proposal> placeWithAscent(PlaceContext& c) {
  const PlaceOpts& o = c.opts;
  const std::vector<Proposal> grid = placeWithUniform(c);
  std::vector<Vec3> start;
  for (const Proposal& p : grid) start.push_back(p.position);
  AscentSettings as;
  as.iterations = o.ascentIterations;
  as.stepMeters = o.ascentStep > 0 ? o.ascentStep : 0.5 * c.set.placement.spacingMeters;
  as.minStepMeters = 0.05 * as.stepMeters;
  as.samplesPerProbe = o.fieldSpp;
  as.mode = o.ascentDirect ? CaptureMode::Full : CaptureMode::IndirectOnly;
  as.seed = o.seed;
  const AscentResult r = placeAscent(c.tracer, c.set.rig, start, as, terminalProgress("ascent"));
  std::printf("ascent: %zu steps taken, %zu reverted, %zu probes dark from the start\n", r.steps,
              r.reverted, r.darkProbes);
  std::vector<Proposal> out;
  for (size_t i = 0; i < r.positions.size(); ++i)
    out.push_back({r.positions[i], r.travelMeters[i]});
  return out;
}

/// `spawn-merge` (Sukys 3.1.1): a uniform grid of half the budget (or at --spacing), then merge
/// similar close neighbours and spawn between differing ones, up to the budget as the probe cap
/// (4 times the grid without a budget).
std::vector<Proposal> placeWithSpawnMerge(PlaceContext& c) {
  const PlaceOpts& o = c.opts;
  if (o.maxError != 0)
    throw ParameterError(
        "--max-error: only for --method greedy (spawn-merge takes --budget as "
        "its probe cap, or --spacing)");
  const int keptCount = int(c.kept.size());
  if (o.budget != 0 && o.budget - keptCount < 8)
    throw ParameterError(
        "--budget: spawn-merge needs at least 8 new probes (its grid is half "
        "the budget), got " +
        std::to_string(o.budget - keptCount));
  UniformSettings us;
  us.seed = o.seed;
  std::vector<Vec3> grid;
  if (o.budget != 0) {
    auto r = placeUniformBudget(c.tracer, (o.budget - keptCount) / 2, us, terminalProgress("grid"));
    grid = std::move(r.points);
    us.spacingMeters = r.spacingMeters;
    c.set.placement.budget = o.budget;
  } else {
    us.spacingMeters = o.spacing != 0 ? o.spacing : std::max(0.25, c.scene.bounds.diagonal() / 10);
    grid = placeUniform(c.tracer, us, terminalProgress("grid"));
  }
  c.set.placement.spacingMeters = us.spacingMeters;
  SpawnMergeSettings ss;
  ss.spacingMeters = us.spacingMeters;
  ss.maxProbes = o.budget != 0 ? size_t(o.budget) : 4 * (grid.size() + c.kept.size());
  ss.samplesPerProbe = o.fieldSpp;
  ss.seed = o.seed;
  std::vector<Vec3> kept;
  for (const Probe* k : c.kept) kept.push_back(k->position);
  const SpawnMergeResult r =
      placeSpawnMerge(c.tracer, c.set.rig, grid, kept, ss, terminalProgress("spawn-merge"));
  std::printf("spawn-merge: %zu grid probes, %zu spawned, %zu merges in %d iterations\n",
              grid.size(), r.spawned, r.merged, r.iterations);
  std::vector<Proposal> out;
  for (const SpawnMergeProbe& p : r.probes) out.push_back({p.position, p.score});
  return out;
}

/// `chajdas` (Chajdas et al.): the dense field, particles traced to its sinks, clusters cleaned
/// by probe matching, one representative each; k-means over unlit samples (Chajdas.h).
std::vector<Proposal> placeWithChajdas(PlaceContext& c) {
  const PlaceOpts& o = c.opts;
  if (o.spacing != 0 || o.maxError != 0)
    throw ParameterError(
        "--spacing, --max-error: not for --method chajdas (its probe count follows from "
        "--aggressiveness, or --budget)");
  const int budget = o.budget - int(c.kept.size());
  if (o.budget != 0 && c.kept.empty() && budget < 4)
    throw ParameterError("budget: expected at least 4 probes, got " + std::to_string(budget));
  if (o.budget != 0 && budget < 4)
    throw ParameterError("--budget: " + std::to_string(o.budget) + " leaves fewer than 4 new " +
                         "probes beside the " + std::to_string(c.kept.size()) + " kept ones");
  DenseFieldSettings fs;
  fs.baseSpacingMeters = o.fieldSpacing;
  fs.maxDepth = o.fieldDepth;
  fs.samplesPerProbe = o.fieldSpp;
  fs.seed = o.seed;
  fs.maxSamples = o.fieldMaxSamples;
  fs.importanceVolumes = c.set.importanceVolumes;
  ChajdasSettings cs;
  cs.aggressiveness = o.aggressiveness;
  cs.importanceVolumes = c.set.importanceVolumes;
  cs.seed = o.seed;
  if (!(cs.aggressiveness > 0) || !std::isfinite(cs.aggressiveness))
    throw ParameterError("--aggressiveness: expected a positive number, got " +
                         std::to_string(cs.aggressiveness));
  const DenseField field = buildDenseField(c.tracer, c.set.rig, fs, terminalProgress("field"));
  ChajdasResult r;
  if (o.budget != 0) {
    ChajdasBudgetResult b = placeChajdasBudget(field.samples, budget, cs);
    std::printf("chajdas: --budget %d gives aggressiveness %.3f\n", o.budget, b.aggressiveness);
    r = std::move(b.result);
    c.set.placement.budget = o.budget;
  } else {
    r = placeChajdas(field.samples, cs);
  }
  std::printf(
      "chajdas: %zu field samples (%zu unlit), %zu sinks, %zu candidate clusters, %zu probes "
      "(%.2f s)\n",
      field.samples.size(), r.unlitSamples, r.sinks, r.candidateClusters, r.probes.size(),
      r.seconds);
  c.set.placement.spacingMeters = field.baseSpacingMeters;
  std::vector<Proposal> out;
  for (const ChajdasProbe& p : r.probes) {
    // A kept probe within half the field spacing stands for the cluster already.
    bool nearKept = false;
    for (const Probe* k : c.kept)
      nearKept = nearKept || length(k->position - p.position) < 0.5 * field.baseSpacingMeters;
    if (!nearKept) out.push_back({p.position, p.score});
  }
  return out;
}

const std::map<std::string, PlaceMethod>& methods() {
  static const std::map<std::string, PlaceMethod> kMethods = {
      {"uniform", placeWithUniform}, {"greedy", placeWithGreedy},
      {"ascent", placeWithAscent},   {"spawn-merge", placeWithSpawnMerge},
      {"chajdas", placeWithChajdas},
  };
  return kMethods;
}

std::string methodNames() {
  std::string s;
  for (const auto& [name, fn] : methods()) s += (s.empty() ? "" : ", ") + name;
  return s;
}

}  // namespace

void registerPlace(CLI::App& app) {
  auto o = std::make_shared<PlaceOpts>();
  CLI::App* cmd = app.add_subcommand("place", "Propose probe positions for a scene");
  cmd->add_option("scene", o->scene, "glTF scene (.gltf or .glb)")->required();
  cmd->add_option("--method", o->method, "Placement method: " + methodNames());
  cmd->add_option("--spacing", o->spacing, "Grid spacing in metres (uniform)");
  cmd->add_option("--budget", o->budget,
                  "Probe count (uniform: the spacing giving it within 10 %; greedy: the total, "
                  "kept probes included)");
  cmd->add_option("--max-error", o->maxError,
                  "greedy: stop once the dense field's relative RMS irradiance error is this low");
  cmd->add_option("--keep", o->keep,
                  "Existing probe set whose locked probes are kept (with their ids) and built "
                  "around; its rig is used when no rig option is given");
  cmd->add_option("--field-spacing", o->fieldSpacing,
                  "Dense field base grid spacing in metres (default: domain diagonal / 12)");
  cmd->add_option("--field-depth", o->fieldDepth, "Dense field refinement levels (0 to 8)");
  cmd->add_option("--field-spp", o->fieldSpp,
                  "Samples per cheap probe (dense field, ascent, spawn-merge)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--field-max-samples", o->fieldMaxSamples,
                  "Dense field sample limit: a base grid above it is an error, a refinement level "
                  "above it is skipped");
  cmd->add_option("--ascent-iterations", o->ascentIterations, "ascent: steps per probe at most");
  cmd->add_option("--ascent-step", o->ascentStep,
                  "ascent: first step in metres (default: half the grid spacing)");
  cmd->add_flag("--ascent-direct", o->ascentDirect,
                "ascent: follow the full light instead of the indirect light only");
  cmd->add_option("--aggressiveness", o->aggressiveness,
                  "chajdas: merging strength (> 0, default 1; larger gives fewer probes)");
  cmd->add_flag("--no-leak-refine", o->noLeakRefine,
                "Do not add probes (method \"leak\") where the mesh's edges cross geometry");
  cmd->add_flag("--accept", o->accept, "Mark the proposals accepted instead of candidates");
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->add_option("-o,--output", o->out, "Probe set to write (.json)")->required();
  o->rig.add(*cmd);
  cmd->callback([o] {
    const auto method = methods().find(o->method);
    if (method == methods().end())
      throw ParameterError("--method: unknown method \"" + o->method +
                           "\" (available: " + methodNames() + ")");
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
    PlaceContext ctx{scene, tracer, *o, set, {}};
    if (!o->keep.empty()) {
      // The locked probes of the existing set stay, with their ids, states and captures; its
      // importance volumes too, and its rig unless rig options are given. Everything else of it
      // is replaced.
      const ProbeSet old = loadProbeSet(o->keep);
      set.importanceVolumes = old.importanceVolumes;
      // Without rig options the kept set's rig stays (its captures were made with it).
      if (o->rig.suns.empty() && o->rig.points.empty() && o->rig.env.empty()) set.rig = old.rig;
      set.nextId = old.nextId;
      for (const Probe& p : old.probes)
        if (p.locked) set.probes.push_back(p);
      for (const Probe& p : set.probes) ctx.kept.push_back(&p);
    }
    const std::vector<Proposal> proposals = method->second(ctx);
    for (const Proposal& p : proposals) {
      Probe pr;
      pr.position = p.position;
      pr.state = o->accept ? ProbeState::Accepted : ProbeState::Candidate;
      pr.method = o->method;
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
      ls.seed = o->seed;
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
    std::printf("placed %zu probes (method %s, %zu kept) in %.2f s -> %s\n", proposals.size(),
                o->method.c_str(), ctx.kept.size(), secondsSince(t0), o->out.c_str());
    if (!o->noLeakRefine) std::printf("leak refinement added %zu probes\n", leakAdded);
  });
}

}  // namespace ps::cli
