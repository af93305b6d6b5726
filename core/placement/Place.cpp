#include "core/placement/Place.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/capture/Capture.h"
#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/eval/DomainPoints.h"
#include "core/math/Random.h"
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
  PlaceOutcome out;
  if (r.budget != 0) {
    const int budget = r.budget - int(c.kept.size());
    if (!c.kept.empty() && budget < 4)
      throw ParameterError("--budget: " + std::to_string(r.budget) + " leaves fewer than 4 new " +
                           "probes beside the " + std::to_string(c.kept.size()) + " kept ones");
    UniformBudgetResult b = placeUniformBudget(c.tracer, budget, us, c.stage("place"));
    points = std::move(b.points);
    us.spacingMeters = b.spacingMeters;
    // Methods are compared at equal probe counts: say when the grid is not one (two-rooms at
    // 32 gets 36, its grids of 32 being too far from cubic).
    if (std::abs(double(points.size()) - budget) > 0.1 * budget)
      out.notes.push_back(
          format("uniform: no grid of the search has %d valid points within 10 %%; "
                 "the closest has %zu",
                 budget, points.size()));
  } else {
    us.spacingMeters = r.spacingMeters != 0 ? r.spacingMeters : c.defaultSpacing();
    points = placeUniform(c.tracer, us, c.stage("place"));
  }
  out.spacingMeters = us.spacingMeters;
  std::vector<PlacedProbe> probes;
  for (const Vec3& p : points) probes.push_back({p, 0.0});
  out.probes = awayFromKept(c, std::move(probes), us.spacingMeters);
  return out;
}

}  // namespace

std::vector<HeldOutSample> drawGreedyHeldOut(const Tracer& tracer, const LightingRig& rig,
                                             const PlaceRequest& r,
                                             std::span<const ImportanceVolume> importanceVolumes,
                                             const DenseField& field, const ProgressFn& progress) {
  checkGreedyRequest(r);
  const std::vector<Bounds3> boxes = importanceBoxes(importanceVolumes);
  const DomainPoints domain(tracer, rig, boxes, kDefaultLightClearanceRelative);
  const Bounds3 box = domainBounds(tracer, boxes);
  const Vec3 ext = box.extent();
  const double wanted = double(greedyHeldOutPoints(r));
  const double volume = ext.x * ext.y * ext.z;
  if (!(volume > 0) || !(wanted > 0)) return {};
  // Cells about cubic, about wanted / 8 of them: an axis shorter than the cell side gets one
  // cell, and the side is found again over the other axes (a thin domain).
  const double target = std::max(1.0, wanted / 8);
  std::array<double, 3> axisExt = {ext.x, ext.y, ext.z};
  std::array<int, 3> perAxis = {1, 1, 1};
  for (int round = 0; round < 3; ++round) {
    double span = 1;
    int axes = 0;
    for (int a = 0; a < 3; ++a)
      if (perAxis[size_t(a)] != 0) {
        span *= axisExt[size_t(a)];
        ++axes;
      }
    const double side = std::pow(span / target, 1.0 / std::max(axes, 1));
    bool collapsed = false;
    for (int a = 0; a < 3; ++a)
      if (perAxis[size_t(a)] != 0 && axisExt[size_t(a)] < side) {
        perAxis[size_t(a)] = 0;  // one cell, taken out of the side's span
        collapsed = true;
      }
    if (!collapsed) {
      for (int a = 0; a < 3; ++a)
        if (perAxis[size_t(a)] != 0)
          perAxis[size_t(a)] = int(std::clamp(std::round(axisExt[size_t(a)] / side), 1.0, target));
      break;
    }
  }
  for (int& k : perAxis) k = std::max(k, 1);
  const int nx = perAxis[0], ny = perAxis[1], nz = perAxis[2];
  const size_t cells = size_t(nx) * size_t(ny) * size_t(nz);
  PS_CHECK_LE(double(cells), 8 * target);
  const Vec3 cellExt(ext.x / nx, ext.y / ny, ext.z / nz);
  auto cellRange = [&](double lo, double hi, double origin, double size, int n) {
    return std::pair<int, int>(std::clamp(int(std::floor((lo - origin) / size)), 0, n - 1),
                               std::clamp(int(std::floor((hi - origin) / size)), 0, n - 1));
  };
  std::vector<double> bright(cells, 0.0);
  for (const FieldSample& f : field.samples) {
    // A split cell's children are there; inside the light clearance no point is kept.
    if (f.refined || !domain.clearOfLights(f.position)) continue;
    const auto irr = greedyErrorNormalsIrradiance(f.sh);
    double sq = 0;
    for (double e : irr) sq += e * e / double(irr.size());
    const double half = f.boundary ? 0.0 : 0.5 * f.cellSize;
    const auto [x0, x1] =
        cellRange(f.position.x - half, f.position.x + half, box.lo.x, cellExt.x, nx);
    const auto [y0, y1] =
        cellRange(f.position.y - half, f.position.y + half, box.lo.y, cellExt.y, ny);
    const auto [z0, z1] =
        cellRange(f.position.z - half, f.position.z + half, box.lo.z, cellExt.z, nz);
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          double& b = bright[(size_t(z) * size_t(ny) + size_t(y)) * size_t(nx) + size_t(x)];
          b = std::max(b, sq);
        }
  }
  double brightSum = 0;
  for (double b : bright) brightSum += b;
  const double uniformShare = brightSum > 0 ? r.heldOutUniformShare : 1.0;
  const uint64_t seed = r.seed ^ 0x4E1D0C7ull;
  std::vector<std::vector<std::pair<Vec3, double>>> perCell(cells);
  tbb::parallel_for(size_t(0), cells, [&](size_t k) {
    uint64_t rng = streamSeed(seed, k);
    const double expected =
        wanted * (uniformShare / double(cells) +
                  (brightSum > 0 ? (1 - uniformShare) * bright[k] / brightSum : 0.0));
    // The count: expected, its fraction drawn; at least 1 so that no cell goes unmeasured.
    const double whole = std::floor(expected);
    const int count = std::max(1, int(whole) + (uniform01(rng) < expected - whole ? 1 : 0));
    const size_t x = k % size_t(nx), y = (k / size_t(nx)) % size_t(ny),
                 z = k / (size_t(nx) * size_t(ny));
    const Vec3 lo =
        box.lo + Vec3(cellExt.x * double(x), cellExt.y * double(y), cellExt.z * double(z));
    const double w = cellExt.x * cellExt.y * cellExt.z / count;
    for (int i = 0; i < count; ++i) {
      const Vec3 p = lo + Vec3(cellExt.x * uniform01(rng), cellExt.y * uniform01(rng),
                               cellExt.z * uniform01(rng));
      if (domain.valid(p, splitMix64(rng))) perCell[k].push_back({p, w});
    }
  });
  std::vector<Vec3> points;
  std::vector<double> weights;
  for (const auto& cell : perCell)
    for (const auto& [p, w] : cell) {
      points.push_back(p);
      weights.push_back(w);
    }
  const DenseFieldSettings fs = greedyFieldSettings(r);
  CaptureSettings cs;
  cs.samplesPerProbe = fs.samplesPerProbe;
  cs.seed = seed ^ 0xCA97u;  // not the draws' streams
  cs.mode = fs.mode;
  const auto caps = captureProbes(tracer, rig, points, cs, progress);
  std::vector<HeldOutSample> out;
  out.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i)
    out.push_back({points[i], caps[i].sh, caps[i].shStdError, weights[i]});
  return out;
}

namespace {

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
  gs.swapPasses = r.swapPasses;
  gs.swapNeighbours = r.swapNeighbours;
  checkGreedyRequest(r);                   // the options by their names first
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
  // A probe's value: its own capture at probeSpp (as the bake will capture it) when that has
  // more samples than the field's; each batch of candidates from another stream.
  const int probeSpp = r.probeSpp > fs.samplesPerProbe ? r.probeSpp : 0;
  uint64_t batch = 0;
  auto captureAt = [&](std::span<const Vec3> at, int spp) {
    CaptureSettings cs;
    cs.samplesPerProbe = spp;
    cs.seed = (r.seed ^ 0x9B0BE5ull) + 0x100000000ull * batch++;
    cs.mode = fs.mode;
    const auto caps = captureProbes(c.tracer, c.rig, at, cs);
    std::vector<ShRgb> sh;
    for (const ProbeCapture& cap : caps) sh.push_back(cap.sh);
    return sh;
  };
  if (probeSpp > 0)
    gs.captureProbeValues = [&](std::span<const Vec3> at) { return captureAt(at, probeSpp); };
  // The kept probes take part with their SH captured like the candidates'.
  std::vector<KeptProbe> kept;
  if (!c.kept.empty()) {
    std::vector<Vec3> points;
    for (const Probe& k : c.kept) points.push_back(k.position);
    const auto sh = captureAt(points, probeSpp > 0 ? probeSpp : fs.samplesPerProbe);
    for (size_t i = 0; i < points.size(); ++i) kept.push_back({points[i], sh[i]});
  }
  // The light clearance eval keeps its queries out of (kDefaultLightClearanceRelative).
  gs.avoid = punctualLightPositions(c.tracer.scene(), c.rig);
  gs.avoidRadius = kDefaultLightClearanceRelative * field.domain.diagonal();
  if (r.heldOutPerProbe > 0)
    gs.heldOut =
        drawGreedyHeldOut(c.tracer, c.rig, r, c.importanceVolumes, field, c.stage("held-out"));
  const GreedyResult g = placeGreedy(field, kept, gs, c.stage("greedy"));
  out.notes.push_back(gs.heldOut.empty()
                          ? format("greedy: error %.4f on the field's samples with %zu probes",
                                   g.fieldError, g.positions.size() + kept.size())
                          : format("greedy: error %.4f at %zu held-out points with %zu probes",
                                   g.fieldError, gs.heldOut.size(),
                                   g.positions.size() + kept.size()));
  if (g.swapPasses > 0) {
    std::string errors;
    for (double e : g.swapErrorHistory) errors += format(" %.4f", e);
    out.notes.push_back(
        format("greedy: %zu swap pass%s took out %zu probes and made %zu moves, %zu of them to a "
               "neighbouring sample (%zu trials, against %zu for the additions); error %.4f "
               "after the additions, then%s",
               g.swapPasses, g.swapPasses == 1 ? "" : "es", g.swapTries, g.swaps, g.localSwaps,
               g.swapTrials, g.trials - g.swapTrials, g.errorHistory.back(), errors.c_str()));
  }
  if (g.noImprovement) {
    // Additions that raised the error: those where no candidate lowered it and the least
    // harmful one went in. Greedy goes on lowering it with the others.
    size_t raised = 0;
    for (size_t k = 1; k < g.errorHistory.size(); ++k)
      raised += g.errorHistory[k] > g.errorHistory[k - 1] ? 1 : 0;
    out.notes.push_back(format(
        "greedy: at %zu probes no candidate lowered the error for the first time; %zu of "
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

size_t greedyHeldOutPoints(const PlaceRequest& r) {
  return size_t(std::max(r.heldOutPerProbe, 0)) * size_t(std::max(r.budget, 64));
}

void checkGreedyRequest(const PlaceRequest& r) {
  if (!(r.heldOutUniformShare >= 0 && r.heldOutUniformShare <= 1))
    throw ParameterError("--held-out-uniform: expected a share from 0 to 1, got " +
                         std::to_string(r.heldOutUniformShare));
  if (r.heldOutPerProbe < 0)
    throw ParameterError("--held-out: expected 0 or more points per probe, got " +
                         std::to_string(r.heldOutPerProbe));
  if (greedyHeldOutPoints(r) > kMaxGreedyHeldOutPoints)
    throw ParameterError("--held-out: " + std::to_string(r.heldOutPerProbe) +
                         " points per probe of the budget make " +
                         std::to_string(greedyHeldOutPoints(r)) + " points, above the limit of " +
                         std::to_string(kMaxGreedyHeldOutPoints) +
                         "; lower --held-out or the budget");
  if (r.probeSpp < 0)
    throw ParameterError("--probe-spp: expected 0 or more samples per probe, got " +
                         std::to_string(r.probeSpp));
  if (r.swapPasses < 0)
    throw ParameterError("--swap-passes: expected 0 or more passes, got " +
                         std::to_string(r.swapPasses));
  if (r.swapNeighbours < 0)
    throw ParameterError("--swap-neighbours: expected 0 or more samples, got " +
                         std::to_string(r.swapNeighbours));
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
