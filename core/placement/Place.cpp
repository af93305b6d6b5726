#include "core/placement/Place.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/placement/Ascent.h"
#include "core/placement/Chajdas.h"
#include "core/placement/Greedy.h"
#include "core/placement/SpawnMerge.h"
#include "core/placement/Uniform.h"

namespace ps {

namespace {

struct Context {
  const Tracer& tracer;
  const LightingRig& rig;
  const PlaceRequest& request;
  std::span<const Probe> kept;
  std::span<const ImportanceVolume> importanceVolumes;
  const StageProgress& progress;

  ProgressFn stage(const std::string& name) const { return progress ? progress(name) : nullptr; }
  double defaultSpacing() const { return std::max(0.25, tracer.scene().bounds.diagonal() / 10); }
};

std::string format(const char* fmt, auto... args) {
  char buf[512];
  std::snprintf(buf, sizeof buf, fmt, args...);
  return buf;
}

/// Drops the points closer than half the spacing to a kept probe (it stands for them already).
std::vector<PlacedProbe> awayFromKept(const Context& c, std::vector<PlacedProbe> in,
                                      double spacing) {
  std::erase_if(in, [&](const PlacedProbe& p) {
    return std::any_of(c.kept.begin(), c.kept.end(), [&](const Probe& k) {
      return length(k.position - p.position) < 0.5 * spacing;
    });
  });
  return in;
}

/// `uniform`: the grid at the spacing, or the spacing giving the budget within 10 %.
PlaceOutcome placeWithUniform(const Context& c) {
  const PlaceRequest& r = c.request;
  if (r.maxError != 0)
    throw ParameterError(
        "--max-error: only for --method greedy (uniform takes --spacing or "
        "--budget)");
  UniformSettings us;
  us.seed = r.seed;
  std::vector<Vec3> points;
  if (r.budget != 0) {
    const int budget = r.budget - int(c.kept.size());
    if (!c.kept.empty() && budget < 4)
      throw ParameterError("--budget: " + std::to_string(r.budget) + " leaves fewer than 4 new " +
                           "probes beside the " + std::to_string(c.kept.size()) + " kept ones");
    UniformBudgetResult b = placeUniformBudget(c.tracer, budget, us, c.stage("place"));
    points = std::move(b.points);
    us.spacingMeters = b.spacingMeters;
  } else {
    us.spacingMeters = r.spacingMeters != 0 ? r.spacingMeters : c.defaultSpacing();
    points = placeUniform(c.tracer, us, c.stage("place"));
  }
  PlaceOutcome out;
  out.spacingMeters = us.spacingMeters;
  std::vector<PlacedProbe> probes;
  for (const Vec3& p : points) probes.push_back({p, 0.0});
  out.probes = awayFromKept(c, std::move(probes), us.spacingMeters);
  return out;
}

/// `greedy`: the dense field, then error-driven additions (core/placement/Greedy.h).
PlaceOutcome placeWithGreedy(const Context& c) {
  const PlaceRequest& r = c.request;
  if (r.spacingMeters != 0)
    throw ParameterError(
        "--spacing: only for --method uniform (greedy's dense field takes "
        "--field-spacing)");
  GreedySettings gs;
  gs.budget = r.budget;
  gs.maxError = r.maxError;
  checkGreedySettings(gs, c.kept.size());  // before the dense field is built
  DenseFieldSettings fs = greedyFieldSettings(r);
  fs.importanceVolumes.assign(c.importanceVolumes.begin(), c.importanceVolumes.end());
  const DenseField field = buildDenseField(c.tracer, c.rig, fs, c.stage("field"));
  PlaceOutcome out;
  out.notes.push_back(
      format("dense field: %zu samples (base spacing %.3f m, %d levels%s) in "
             "%.2f s",
             field.samples.size(), field.baseSpacingMeters, int(field.cellsPerLevel.size()),
             field.refinementTruncated ? ", refinement truncated at --field-max-samples" : "",
             field.seconds));
  // The kept probes take part with their SH captured like the field's samples.
  std::vector<KeptProbe> kept;
  if (!c.kept.empty()) {
    std::vector<Vec3> points;
    for (const Probe& k : c.kept) points.push_back(k.position);
    CaptureSettings cs;
    cs.samplesPerProbe = fs.samplesPerProbe;
    cs.seed = r.seed;
    const auto caps = captureProbes(c.tracer, c.rig, points, cs);
    for (size_t i = 0; i < points.size(); ++i) kept.push_back({points[i], caps[i].sh});
  }
  // The light clearance eval keeps its queries out of (kDefaultLightClearanceRelative).
  gs.avoid = punctualLightPositions(c.tracer.scene(), c.rig);
  gs.avoidRadius = kDefaultLightClearanceRelative * field.domain.diagonal();
  const GreedyResult g = placeGreedy(field, kept, gs, c.stage("greedy"));
  out.notes.push_back(format("greedy: field error %.4f with %zu probes", g.fieldError,
                             g.positions.size() + kept.size()));
  if (g.noImprovement) {
    // Additions that raised the field error: those where no candidate lowered it and the least
    // harmful one went in. Greedy goes on lowering it with the others.
    size_t raised = 0;
    for (size_t k = 1; k < g.errorHistory.size(); ++k)
      raised += g.errorHistory[k] > g.errorHistory[k - 1] ? 1 : 0;
    out.notes.push_back(format(
        "greedy: at %zu probes no candidate lowered the field error for the first time; %zu of "
        "the %zu additions found none and added the least harmful one (eval measures what they "
        "bring)",
        g.probesAtNoImprovement, raised, g.errorHistory.size() - 1));
  }
  out.spacingMeters = field.baseSpacingMeters;
  for (size_t i = 0; i < g.positions.size(); ++i)
    out.probes.push_back({g.positions[i], g.scores[i]});
  return out;
}

/// `ascent` (Sukys 3.1.2): the uniform grid (budget or spacing), each probe then climbing the
/// luminance-weighted direction field of its own cheap captures (core/placement/Ascent.h).
PlaceOutcome placeWithAscent(const Context& c) {
  const PlaceRequest& r = c.request;
  PlaceOutcome out = placeWithUniform(c);
  std::vector<Vec3> start;
  for (const PlacedProbe& p : out.probes) start.push_back(p.position);
  AscentSettings as;
  as.iterations = r.ascentIterations;
  as.stepMeters = r.ascentStepMeters > 0 ? r.ascentStepMeters : 0.5 * out.spacingMeters;
  as.minStepMeters = 0.05 * as.stepMeters;
  as.samplesPerProbe = r.field.samplesPerProbe;
  as.mode = r.ascentDirect ? CaptureMode::Full : CaptureMode::IndirectOnly;
  as.seed = r.seed;
  const AscentResult a = placeAscent(c.tracer, c.rig, start, as, c.stage("ascent"));
  out.notes.push_back(
      format("ascent: %zu steps taken, %zu reverted, %zu probes dark from the "
             "start",
             a.steps, a.reverted, a.darkProbes));
  out.probes.clear();
  for (size_t i = 0; i < a.positions.size(); ++i)
    out.probes.push_back({a.positions[i], a.travelMeters[i]});
  return out;
}

/// `spawn-merge` (Sukys 3.1.1): a uniform grid of half the budget (or at the spacing), then
/// merge similar close neighbours and spawn between differing ones, up to the budget as the
/// probe cap (4 times the grid without a budget).
PlaceOutcome placeWithSpawnMerge(const Context& c) {
  const PlaceRequest& r = c.request;
  if (r.maxError != 0)
    throw ParameterError(
        "--max-error: only for --method greedy (spawn-merge takes --budget as "
        "its probe cap, or --spacing)");
  const int keptCount = int(c.kept.size());
  if (r.budget != 0 && r.budget - keptCount < 8)
    throw ParameterError(
        "--budget: spawn-merge needs at least 8 new probes (its grid is half "
        "the budget), got " +
        std::to_string(r.budget - keptCount));
  UniformSettings us;
  us.seed = r.seed;
  std::vector<Vec3> grid;
  if (r.budget != 0) {
    UniformBudgetResult b =
        placeUniformBudget(c.tracer, (r.budget - keptCount) / 2, us, c.stage("grid"));
    grid = std::move(b.points);
    us.spacingMeters = b.spacingMeters;
  } else {
    us.spacingMeters = r.spacingMeters != 0 ? r.spacingMeters : c.defaultSpacing();
    grid = placeUniform(c.tracer, us, c.stage("grid"));
  }
  SpawnMergeSettings ss;
  ss.spacingMeters = us.spacingMeters;
  ss.maxProbes = r.budget != 0 ? size_t(r.budget) : 4 * (grid.size() + c.kept.size());
  ss.samplesPerProbe = r.field.samplesPerProbe;
  ss.seed = r.seed;
  std::vector<Vec3> kept;
  for (const Probe& k : c.kept) kept.push_back(k.position);
  const SpawnMergeResult s =
      placeSpawnMerge(c.tracer, c.rig, grid, kept, ss, c.stage("spawn-merge"));
  PlaceOutcome out;
  out.spacingMeters = us.spacingMeters;
  out.notes.push_back(
      format("spawn-merge: %zu grid probes, %zu spawned, %zu merges in %d "
             "iterations",
             grid.size(), s.spawned, s.merged, s.iterations));
  for (const SpawnMergeProbe& p : s.probes) out.probes.push_back({p.position, p.score});
  return out;
}

using Method = PlaceOutcome (*)(const Context&);

/// `chajdas` (Chajdas et al.): the dense field, particles traced to its sinks, clusters cleaned
/// by probe matching, one representative each; k-means over unlit samples (Chajdas.h).
// How far a chajdas probe stays from a point or spot light, in base field spacings (see
// ChajdasSettings::lightClearanceMeters).
constexpr double kLightClearance = 0.5;

PlaceOutcome placeWithChajdas(const Context& c) {
  const PlaceRequest& r = c.request;
  if (r.spacingMeters != 0 || r.maxError != 0)
    throw ParameterError(
        "--spacing, --max-error: not for --method chajdas (its probe count follows from "
        "--aggressiveness, or --budget)");
  const int budget = r.budget - int(c.kept.size());
  if (r.budget != 0 && c.kept.empty() && budget < 4)
    throw ParameterError("budget: expected at least 4 probes, got " + std::to_string(budget));
  if (r.budget != 0 && budget < 4)
    throw ParameterError("--budget: " + std::to_string(r.budget) + " leaves fewer than 4 new " +
                         "probes beside the " + std::to_string(c.kept.size()) + " kept ones");
  ChajdasSettings cs;
  cs.aggressiveness = r.aggressiveness;
  cs.importanceVolumes.assign(c.importanceVolumes.begin(), c.importanceVolumes.end());
  cs.seed = r.seed;
  if (!(cs.aggressiveness > 0) || !std::isfinite(cs.aggressiveness))
    throw ParameterError("--aggressiveness: expected a positive number, got " +
                         std::to_string(cs.aggressiveness));
  DenseFieldSettings fs = r.field;
  fs.seed = r.seed;
  if (r.fieldDepth != -1) fs.maxDepth = r.fieldDepth;
  fs.importanceVolumes = cs.importanceVolumes;
  const DenseField field = buildDenseField(c.tracer, c.rig, fs, c.stage("field"));
  cs.punctualLights = punctualLightPositions(c.tracer.scene(), c.rig);
  cs.lightClearanceMeters = kLightClearance * field.baseSpacingMeters;
  PlaceOutcome out;
  ChajdasResult ch;
  if (r.budget != 0) {
    ChajdasBudgetResult b = placeChajdasBudget(field.samples, budget, cs);
    out.notes.push_back(
        format("chajdas: --budget %d gives aggressiveness %.3f", r.budget, b.aggressiveness));
    ch = std::move(b.result);
  } else {
    ch = placeChajdas(field.samples, cs);
  }
  out.notes.push_back(
      format("chajdas: %zu field samples (%zu unlit), %zu sinks, %zu candidate clusters, %zu "
             "probes (%.2f s)",
             field.samples.size(), ch.unlitSamples, ch.sinks, ch.candidateClusters,
             ch.probes.size(), ch.seconds));
  out.spacingMeters = field.baseSpacingMeters;
  std::vector<PlacedProbe> placed;
  for (const ChajdasProbe& p : ch.probes) placed.push_back({p.position, p.score});
  out.probes = awayFromKept(c, std::move(placed), field.baseSpacingMeters);
  return out;
}

const std::map<std::string, Method>& methods() {
  static const std::map<std::string, Method> kMethods = {
      {"uniform", placeWithUniform},        {"greedy", placeWithGreedy},
      {"ascent", placeWithAscent},          {"chajdas", placeWithChajdas},
      {"spawn-merge", placeWithSpawnMerge},
  };
  return kMethods;
}

}  // namespace

DenseFieldSettings greedyFieldSettings(const PlaceRequest& r) {
  DenseFieldSettings fs = r.field;
  fs.seed = r.seed;
  fs.boundarySamples = true;
  fs.maxDepth = r.fieldDepth != -1 ? r.fieldDepth : kGreedyFieldDepth;  // range: buildDenseField
  if (fs.maxSurfaceDepth < 0)
    fs.maxSurfaceDepth = std::clamp(fs.maxDepth, 0, kGreedyFieldSurfaceDepth);
  return fs;
}

std::vector<std::string> placementMethods() {
  std::vector<std::string> names;
  for (const auto& entry : methods()) names.push_back(entry.first);
  return names;
}

PlaceOutcome placeProbes(const Tracer& tracer, const LightingRig& rig, const PlaceRequest& request,
                         std::span<const Probe> kept,
                         std::span<const ImportanceVolume> importanceVolumes,
                         const StageProgress& progress) {
  const auto method = methods().find(request.method);
  if (method == methods().end()) {
    std::string names;
    for (const std::string& n : placementMethods()) names += (names.empty() ? "" : ", ") + n;
    throw ParameterError("--method: unknown method \"" + request.method +
                         "\" (available: " + names + ")");
  }
  if (request.spacingMeters != 0 && request.budget != 0)
    throw ParameterError("--spacing and --budget: give one, not both");
  return method->second(Context{tracer, rig, request, kept, importanceVolumes, progress});
}

}  // namespace ps
