#include "core/placement/GreedyMethod.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <memory>

#include "core/capture/Capture.h"
#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/common/Tolerances.h"
#include "core/domain/DomainPoints.h"
#include "core/math/Random.h"
#include "core/placement/PlacementMethod.h"
#include "core/placement/RegionalGreedy.h"

namespace ps {

namespace {

/// GreedySettings for the method's settings and `budget`.
GreedySettings greedySettings(const GreedyMethodSettings& r, int budget) {
  GreedySettings gs;
  gs.objective = r.objective;
  gs.budget = budget;
  gs.maxError = r.maxError;
  gs.swapPasses = r.swapPasses;
  gs.swapNeighbours = r.swapNeighbours;
  return gs;
}

}  // namespace

void checkGreedyMethodSettings(const GreedyMethodSettings& r, int budget, size_t keptCount) {
  // The budget, maxError and the swaps: the algorithm's own checks, which name them.
  checkGreedySettings(greedySettings(r, budget), keptCount);
  if (!(r.heldOutUniformShare == -1 || (r.heldOutUniformShare >= 0 && r.heldOutUniformShare <= 1)))
    throw ParameterError("heldOutUniformShare",
                         "expected a share from 0 to 1 (or -1: by the objective), got " +
                             std::to_string(r.heldOutUniformShare));
  if (r.heldOutPerProbe < 0)
    throw ParameterError("heldOutPerProbe", "expected 0 or more points per probe, got " +
                                                std::to_string(r.heldOutPerProbe));
  if (greedyHeldOutPoints(r, budget) > kMaxGreedyHeldOutPoints)
    throw ParameterError("heldOutPerProbe",
                         std::to_string(r.heldOutPerProbe) + " points per probe of the budget " +
                             "make " + std::to_string(greedyHeldOutPoints(r, budget)) +
                             " points, above the limit of " +
                             std::to_string(kMaxGreedyHeldOutPoints) + "; lower it or the budget");
  if (r.probeSpp < 0)
    throw ParameterError("candidateSamplesPerProbe",
                         "expected 0 or more samples per probe, got " + std::to_string(r.probeSpp));
  if (!(r.regions == -1 || (r.regions >= 1 && r.regions <= kMaxGreedyRegions)))
    throw ParameterError("regions", "expected auto, off or a region count from 2 to " +
                                        std::to_string(kMaxGreedyRegions) + ", got " +
                                        std::to_string(r.regions));
  if (r.regions >= 2 && budget == 0)
    throw ParameterError("regions", "regions share a probe budget: give one");
  if (r.regions >= 2 && size_t(budget) < keptCount + 8 * size_t(r.regions))
    throw ParameterError("regions", std::to_string(r.regions) +
                                        " regions need at least 8 new probes each; the budget "
                                        "leaves " +
                                        std::to_string(size_t(budget) - keptCount));
}

int greedyRegions(const GreedyMethodSettings& r, int budget, size_t keptCount) {
  if (r.regions != -1) return r.regions;
  if (budget == 0 || size_t(budget) <= keptCount) return 1;
  return regionalGreedyRegions(size_t(budget) - keptCount);
}

DenseFieldSettings greedyFieldSettings(const GreedyMethodSettings& r, uint64_t seed) {
  DenseFieldSettings fs = r.field;
  fs.seed = seed;
  fs.boundarySamples = true;
  fs.maxDepth = r.fieldDepth != -1 ? r.fieldDepth : kGreedyFieldDepth;  // range: buildDenseField
  if (fs.maxSurfaceDepth < 0)
    fs.maxSurfaceDepth = std::clamp(fs.maxDepth, 0, kGreedyFieldSurfaceDepth);
  return fs;
}

double greedyHeldOutUniformShare(const GreedyMethodSettings& r) {
  if (r.heldOutUniformShare != -1) return r.heldOutUniformShare;
  return r.objective == GreedyObjective::kPerceptual ? 1.0 : 0.5;
}

size_t greedyHeldOutPoints(const GreedyMethodSettings& r, int budget) {
  return size_t(std::max(r.heldOutPerProbe, 0)) * size_t(std::max(budget, 64));
}

std::vector<HeldOutSample> drawGreedyHeldOut(const Tracer& tracer, const LightingRig& rig,
                                             const GreedyMethodSettings& r, int budget,
                                             uint64_t seed, const Domain& domainOfInterest,
                                             const DenseField& field, const ProgressFn& progress) {
  checkGreedyMethodSettings(r, budget);
  const DomainPoints domain(tracer, rig, domainOfInterest, kDefaultLightClearanceRelative);
  const Bounds3 box = domainBounds(tracer, domainOfInterest.boxes);
  const Vec3 ext = box.extent();
  const double volume = ext.x * ext.y * ext.z;
  // Drawn over the box and kept in the domain: as many more as the reachable space is smaller.
  const double reachableShare =
      domainOfInterest.reachable
          ? std::min(1.0, domainOfInterest.reachable->reachableCubicMeters() / volume)
          : 1.0;
  const double wanted = double(greedyHeldOutPoints(r, budget)) / reachableShare;
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
  const double uniformShare = brightSum > 0 ? greedyHeldOutUniformShare(r) : 1.0;
  const uint64_t drawSeed = seed ^ 0x4E1D0C7ull;
  std::vector<std::vector<std::pair<Vec3, double>>> perCell(cells);
  tbb::parallel_for(size_t(0), cells, [&](size_t k) {
    uint64_t rng = streamSeed(drawSeed, k);
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
  const DenseFieldSettings fs = greedyFieldSettings(r, seed);
  CaptureSettings cs;
  cs.samplesPerProbe = fs.samplesPerProbe;
  cs.seed = drawSeed ^ 0xCA97u;  // not the draws' streams
  cs.mode = fs.mode;
  const auto caps = captureProbes(tracer, rig, points, cs, progress);
  std::vector<HeldOutSample> out;
  out.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i)
    out.push_back({points[i], caps[i].sh, caps[i].shStdError, weights[i]});
  return out;
}

namespace {

/// The note for a run whose held-out points' captures mostly resolve no light (`share` of
/// them, above kGreedyUnresolvedShareLimit).
std::string unresolvedWarning(double share, const DenseFieldSettings& fs) {
  return formatNote(
      "warning: the captures of %.0f %% of the held-out points resolve no light (at %d "
      "samples each); the perceptual objective, a ratio, then measures their noise and "
      "can leave the volume too dark: raise the field's samples per probe, or use the "
      "energy objective",
      100 * share, fs.samplesPerProbe);
}

/// `greedy`: the dense field, then error-driven additions and swaps (core/placement/Greedy.h).
class GreedyPlacer : public Placer {
 public:
  explicit GreedyPlacer(const GreedyMethodSettings& s) : s_(s) {}

  PlaceOutcome place(const PlaceContext& c) const override {
    const GreedyMethodSettings& r = s_;
    GreedySettings gs = greedySettings(r, c.budget);
    DenseFieldSettings fs = greedyFieldSettings(r, c.seed);
    fs.importanceVolumes.assign(c.importanceVolumes.begin(), c.importanceVolumes.end());
    fs.reachable = c.domainOf().reachable;
    const DenseField field = buildDenseField(c.tracer, c.rig, fs, c.stage("field"));
    PlaceOutcome out;
    out.notes.push_back(
        formatNote("dense field: %zu samples (base spacing %.3f m, %d levels%s) in "
                   "%.2f s",
                   field.samples.size(), field.baseSpacingMeters, int(field.cellsPerLevel.size()),
                   field.refinementTruncated ? ", refinement truncated at the sample limit" : "",
                   field.seconds));
    // A probe's value: its own capture at probeSpp (as the bake will capture it) when that has
    // more samples than the field's; each batch of candidates from another stream.
    // With the visible interpolant every probe needs its own capture's map, at the field's
    // samples per probe at least.
    const int probeSpp = r.probeSpp > fs.samplesPerProbe ? r.probeSpp
                         : r.visibility                  ? fs.samplesPerProbe
                                                         : 0;
    gs.visibility = r.visibility;
    uint64_t batch = 0;
    auto captureAt = [&](std::span<const Vec3> at, int spp) {
      CaptureSettings cs;
      cs.samplesPerProbe = spp;
      cs.seed = (c.seed ^ 0x9B0BE5ull) + 0x100000000ull * batch++;
      cs.mode = fs.mode;
      cs.visibilityMaps = r.visibility;
      std::vector<ProbeCapture> caps = captureProbes(c.tracer, c.rig, at, cs);
      std::vector<GreedyProbeValue> values;
      for (ProbeCapture& cap : caps)
        values.push_back({cap.sh, std::move(cap.distanceMoments),
                          cap.backfaceFraction > tol::kDefaultInvalidBackfaceFraction});
      return values;
    };
    if (probeSpp > 0)
      gs.captureProbeValues = [&](std::span<const Vec3> at) { return captureAt(at, probeSpp); };
    // The kept probes take part with their SH (and maps) captured like the candidates'.
    std::vector<KeptProbe> kept;
    if (!c.kept.empty()) {
      std::vector<Vec3> points;
      for (const Probe& k : c.kept) points.push_back(k.position);
      std::vector<GreedyProbeValue> values =
          captureAt(points, probeSpp > 0 ? probeSpp : fs.samplesPerProbe);
      for (size_t i = 0; i < points.size(); ++i)
        kept.push_back(
            {points[i], values[i].sh, std::move(values[i].distanceMoments), values[i].inside});
    }
    // The light clearance eval keeps its queries out of (kDefaultLightClearanceRelative).
    gs.avoid = punctualLightPositions(c.tracer.scene(), c.rig);
    gs.avoidRadius = kDefaultLightClearanceRelative * field.domain.diagonal();
    if (r.heldOutPerProbe > 0)
      gs.heldOut = drawGreedyHeldOut(c.tracer, c.rig, r, c.budget, c.seed, c.domainOf(), field,
                                     c.stage("held-out"));
    const int regions = greedyRegions(r, c.budget, kept.size());
    if (regions >= 2) {
      placeRegional(c, field, gs, kept, regions, probeSpp, fs, out);
      return out;
    }
    const GreedyResult g = placeGreedy(field, kept, gs, c.stage("greedy"));
    out.notes.push_back(
        gs.heldOut.empty()
            ? formatNote("greedy: error %.4f on the field's samples with %zu probes", g.fieldError,
                         g.positions.size() + kept.size())
            : formatNote("greedy: error %.4f at %zu held-out points with %zu probes", g.fieldError,
                         gs.heldOut.size(), g.positions.size() + kept.size()));
    // Half the held-out points unresolved: the objective measures their noise (the Cornell box,
    // lit by a small emissive panel, 99 % at 64 samples; two-rooms 37 %).
    if (g.unresolvedShare > kGreedyUnresolvedShareLimit)
      out.notes.push_back(unresolvedWarning(g.unresolvedShare, fs));
    if (g.swapsSkipped)
      out.notes.push_back(
          "greedy: no swaps: most held-out points resolve no light, so a move's measured gain "
          "would be mostly their noise");
    if (g.swapPasses > 0) {
      std::string errors;
      for (double e : g.swapErrorHistory) errors += formatNote(" %.4f", e);
      out.notes.push_back(formatNote(
          "greedy: %zu swap pass%s took out %zu probes and made %zu moves, %zu of them to a "
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
      out.notes.push_back(formatNote(
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

 private:
  /// Regional greedy (placeRegionalGreedy) with `regions` regions; its probes and notes go to
  /// `out`. Each region's candidates are captured at probeSpp (0: their field captures) from
  /// streams of the run's seed, the region and the pass.
  void placeRegional(const PlaceContext& c, const DenseField& field, const GreedySettings& gs,
                     std::span<const KeptProbe> kept, int regions, int probeSpp,
                     const DenseFieldSettings& fs, PlaceOutcome& out) const {
    RegionCaptureFactory captureFor;
    if (probeSpp > 0)
      captureFor = [&c, &fs, probeSpp, visibility = gs.visibility](size_t region, int pass) {
        const uint64_t base =
            streamSeed(c.seed ^ 0x9B0BE5ull, 2 * uint64_t(region) + uint64_t(pass));
        auto batch = std::make_shared<uint64_t>(0);
        return [&c, &fs, probeSpp, base, batch, visibility](std::span<const Vec3> at) {
          CaptureSettings cs;
          cs.samplesPerProbe = probeSpp;
          cs.seed = base + 0x100000000ull * (*batch)++;
          cs.mode = fs.mode;
          cs.visibilityMaps = visibility;
          std::vector<GreedyProbeValue> values;
          for (ProbeCapture& cap : captureProbes(c.tracer, c.rig, at, cs))
            values.push_back({cap.sh, std::move(cap.distanceMoments),
                              cap.backfaceFraction > tol::kDefaultInvalidBackfaceFraction});
          return values;
        };
      };
    GreedySettings settings = gs;
    settings.captureProbeValues = nullptr;
    const RegionalGreedyResult g = placeRegionalGreedy(field, kept, settings, regions, captureFor,
                                                       c.stage("greedy"), c.rooms.get());
    size_t fewest = std::numeric_limits<size_t>::max(), most = 0, unswapped = 0;
    for (const GreedyRegion& region : g.regions) {
      fewest = std::min(fewest, region.probes);
      most = std::max(most, region.probes);
      unswapped += region.swapsSkipped ? 1 : 0;
    }
    out.notes.push_back(formatNote(
        "greedy: %d regions of the dense field%s, %zu to %zu new probes each (shared by the "
        "error they measured); error %.4f at %zu held-out points with %zu probes, each point "
        "interpolated from its region's probes; %zu trials, %zu swap moves",
        regions, c.rooms ? " made of whole rooms" : "", fewest, most, g.fieldError,
        gs.heldOut.size(), g.positions.size() + kept.size(), g.trials, g.swaps));
    if (g.unresolvedShare > kGreedyUnresolvedShareLimit)
      out.notes.push_back(unresolvedWarning(g.unresolvedShare, fs));
    if (unswapped > 0)
      out.notes.push_back(formatNote(
          "greedy: no swaps in %zu of the %d regions: most of their held-out points resolve no "
          "light, so a move's measured gain would be mostly their noise",
          unswapped, regions));
    for (const GreedyRegion& region : g.regions)
      if (!region.refused.empty())
        out.notes.push_back(formatNote("greedy: a region of %zu samples got no new probes: %s",
                                       region.samples, region.refused.c_str()));
    out.spacingMeters = field.baseSpacingMeters;
    for (size_t i = 0; i < g.positions.size(); ++i)
      out.probes.push_back({g.positions[i], g.scores[i]});
  }

  GreedyMethodSettings s_;
};

constexpr std::string_view kParameters[] = {"objective",
                                            "interpolant",
                                            "maxError",
                                            "fieldSpacingMeters",
                                            "fieldDepth",
                                            "fieldSurfaceDepth",
                                            "fieldSamplesPerProbe",
                                            "prefilter",
                                            "fieldMaxSamples",
                                            "heldOutPerProbe",
                                            "heldOutUniformShare",
                                            "candidateSamplesPerProbe",
                                            "swapPasses",
                                            "swapNeighbours",
                                            "regions"};

/// The regions parameter: the word auto (-1) or off (1), or a count (as a word or a number).
/// Throws ps::ParameterError for anything else.
int readRegions(const PlaceParameters& p) {
  const auto text = p.texts().find("regions");
  if (text == p.texts().end()) return p.integer("regions", -1);
  if (text->second == "auto") return -1;
  if (text->second == "off") return 1;
  int n = 0;
  const auto [end, ec] =
      std::from_chars(text->second.data(), text->second.data() + text->second.size(), n);
  if (ec != std::errc() || end != text->second.data() + text->second.size() || n < 1)
    throw ParameterError("regions", "expected auto, off or a region count from 2 to " +
                                        std::to_string(kMaxGreedyRegions) + ", got \"" +
                                        text->second + "\"");
  return n;
}

std::unique_ptr<Placer> create(const PlaceParameters& p, const PlaceBasics& b) {
  GreedyMethodSettings s;
  constexpr std::string_view kObjectives[] = {"perceptual", "energy"};
  s.objective = p.choice("objective", greedyObjectiveName(s.objective), kObjectives) == "energy"
                    ? GreedyObjective::kEnergy
                    : GreedyObjective::kPerceptual;
  constexpr std::string_view kInterpolants[] = {"visible", "barycentric"};
  s.visibility = p.choice("interpolant", "visible", kInterpolants) == "visible";
  s.maxError = p.number("maxError", s.maxError);
  const FieldParameters field = readFieldParameters(p);
  s.field = field.field;
  s.fieldDepth = field.depth;
  s.heldOutPerProbe = p.integer("heldOutPerProbe", s.heldOutPerProbe);
  s.heldOutUniformShare = p.number("heldOutUniformShare", s.heldOutUniformShare);
  s.probeSpp = p.integer("candidateSamplesPerProbe", s.probeSpp);
  s.swapPasses = p.integer("swapPasses", s.swapPasses);
  s.swapNeighbours = p.integer("swapNeighbours", s.swapNeighbours);
  s.regions = readRegions(p);
  checkGreedyMethodSettings(s, b.budget, b.keptCount);
  return std::make_unique<GreedyPlacer>(s);
}

}  // namespace

const PlacementMethod& greedyPlacementMethod() {
  static const PlacementMethod kMethod = {
      "greedy",
      "error-driven: adds the probe that lowers the measured error most, then swaps (ours)",
      kParameters, create};
  return kMethod;
}

}  // namespace ps
