#include "core/placement/PlacementMethod.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <limits>

#include "core/common/Error.h"
#include "core/placement/Uniform.h"

namespace ps {

double PlaceParameters::number(const std::string& name, double fallback) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  if (!std::isfinite(it->second))
    throw ParameterError(name, "expected a finite number, got " + std::to_string(it->second));
  return it->second;
}

int PlaceParameters::integer(const std::string& name, int fallback) const {
  const double v = number(name, fallback);
  if (v != std::floor(v) || v < double(std::numeric_limits<int>::min()) ||
      v > double(std::numeric_limits<int>::max()))
    throw ParameterError(name, "expected a whole number, got " + std::to_string(v));
  return int(v);
}

bool PlaceParameters::flag(const std::string& name, bool fallback) const {
  const double v = number(name, fallback ? 1.0 : 0.0);
  if (v != 0 && v != 1) throw ParameterError(name, "expected 0 or 1, got " + std::to_string(v));
  return v == 1;
}

std::string PlaceParameters::choice(const std::string& name, std::string_view fallback,
                                    std::span<const std::string_view> options) const {
  std::string list;
  for (std::string_view o : options) list += (list.empty() ? "" : ", ") + std::string(o);
  if (values_.count(name) != 0)
    throw ParameterError(name, "expected one of " + list + ", got a number");
  const auto it = texts_.find(name);
  if (it == texts_.end()) return std::string(fallback);
  if (std::find(options.begin(), options.end(), it->second) == options.end())
    throw ParameterError(name, "expected one of " + list + ", got \"" + it->second + "\"");
  return it->second;
}

double PlaceContext::defaultSpacingMeters() const {
  return std::max(0.25, tracer.scene().bounds.diagonal() / 10);
}

std::span<const PlacementMethod> placementMethodTable() {
  static const PlacementMethod kTable[] = {
      ascentPlacementMethod(),     chajdasPlacementMethod(), greedyPlacementMethod(),
      spawnMergePlacementMethod(), uniformPlacementMethod(),
  };
  return kTable;
}

const PlacementMethod& findPlacementMethod(std::string_view name) {
  for (const PlacementMethod& m : placementMethodTable())
    if (m.name == name) return m;
  std::string names;
  for (const PlacementMethod& m : placementMethodTable())
    names += (names.empty() ? "" : ", ") + std::string(m.name);
  throw ParameterError("method",
                       "unknown method \"" + std::string(name) + "\" (available: " + names + ")");
}

std::unique_ptr<Placer> createPlacer(const PlacementMethod& method,
                                     const PlaceParameters& parameters, const PlaceBasics& basics) {
  auto refuseForeign = [&](const std::string& name) {
    if (std::find(method.parameters.begin(), method.parameters.end(), name) ==
        method.parameters.end())
      throw ParameterError(name, "not a parameter of method " + std::string(method.name));
  };
  for (const auto& [name, value] : parameters.values()) refuseForeign(name);
  for (const auto& [name, text] : parameters.texts()) refuseForeign(name);
  if (basics.budget < 0)
    throw ParameterError(
        "budget", "expected 0 (none) or a probe count, got " + std::to_string(basics.budget));
  return method.create(parameters, basics);
}

std::vector<std::string> placementMethods() {
  std::vector<std::string> names;
  for (const PlacementMethod& m : placementMethodTable()) names.emplace_back(m.name);
  return names;
}

std::string formatNote(const char* fmt, ...) {
  char buf[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, args);
  va_end(args);
  return buf;
}

bool withinAny(std::span<const Vec3> points, Vec3 p, double meters) {
  return std::any_of(points.begin(), points.end(),
                     [&](const Vec3& q) { return length(q - p) < meters; });
}

std::vector<PlacedProbe> awayFromKept(const PlaceContext& c, std::vector<PlacedProbe> in,
                                      double spacing) {
  std::erase_if(in, [&](const PlacedProbe& p) {
    return std::any_of(c.kept.begin(), c.kept.end(), [&](const Probe& k) {
      return length(k.position - p.position) < 0.5 * spacing;
    });
  });
  return in;
}

FieldParameters readFieldParameters(const PlaceParameters& p) {
  FieldParameters out;
  DenseFieldSettings& f = out.field;
  f.baseSpacingMeters = p.number("fieldSpacingMeters", f.baseSpacingMeters);
  if (f.baseSpacingMeters < 0)
    throw ParameterError("fieldSpacingMeters",
                         "expected 0 (the default) or a positive number of metres, got " +
                             std::to_string(f.baseSpacingMeters));
  out.depth = p.integer("fieldDepth", -1);
  if (out.depth < -1 || out.depth > 8)
    throw ParameterError("fieldDepth",
                         "expected 0 to 8 refinement levels (or -1: the method's "
                         "default), got " +
                             std::to_string(out.depth));
  f.maxSurfaceDepth = p.integer("fieldSurfaceDepth", f.maxSurfaceDepth);
  if (f.maxSurfaceDepth < -1 || f.maxSurfaceDepth > 8)
    throw ParameterError("fieldSurfaceDepth",
                         "expected 0 to 8 levels (or -1: the method's default), got " +
                             std::to_string(f.maxSurfaceDepth));
  f.samplesPerProbe = p.integer("fieldSamplesPerProbe", f.samplesPerProbe);
  if (f.samplesPerProbe < 1)
    throw ParameterError("fieldSamplesPerProbe", "expected at least 1 sample per probe, got " +
                                                     std::to_string(f.samplesPerProbe));
  f.prefilter = p.flag("prefilter", f.prefilter);
  const double maxSamples = p.number("fieldMaxSamples", double(f.maxSamples));
  if (!(maxSamples >= 1) || maxSamples != std::floor(maxSamples) || maxSamples > 1e12)
    throw ParameterError(
        "fieldMaxSamples",
        "expected a whole number of samples from 1 to 1e12, got " + std::to_string(maxSamples));
  f.maxSamples = size_t(maxSamples);
  return out;
}

double readGridSpacing(const PlaceParameters& p, const PlaceBasics& b) {
  const double spacing = p.number("spacingMeters", 0.0);
  if (spacing < 0)
    throw ParameterError(
        "spacingMeters",
        "expected 0 (the default) or a positive number of metres, got " + std::to_string(spacing));
  if (spacing != 0 && b.budget != 0)
    throw ParameterError("spacingMeters", "give a spacing or a budget, not both");
  return spacing;
}

void checkUniformGridBudget(const PlaceBasics& b) {
  if (b.budget != 0 && b.keptCount > 0 && b.budget - int(b.keptCount) < 4)
    throw ParameterError("budget", std::to_string(b.budget) + " leaves fewer than 4 new probes " +
                                       "beside the " + std::to_string(b.keptCount) + " kept ones");
}

Domain PlaceContext::domainOf() const {
  return domain ? *domain : Domain{importanceBoxes(importanceVolumes), nullptr};
}

PlaceOutcome placeUniformGrid(const PlaceContext& c, double spacingMeters) {
  UniformSettings us;
  us.seed = c.seed;
  if (c.domain && c.domain->rule == DomainRule::Reachable) us.domain = c.domain;
  PlaceOutcome out;
  auto placed = [&](const std::vector<Vec3>& points, double spacing) {
    std::vector<PlacedProbe> probes;
    for (const Vec3& p : points) probes.push_back({p, 0.0});
    return awayFromKept(c, std::move(probes), spacing);
  };
  if (c.budget != 0) {
    // The grid's points beside kept probes are dropped (the kept probe stands for them), so the
    // grid searched for is as much larger as that drops: up to 6 searches, each aiming at the
    // budget plus what the last one lost, or between the last aim short of it and the last
    // beyond it (grids jump in count, so the count is not monotone in the aim).
    const int want = c.budget - int(c.kept.size());
    int target = want, below = 0, above = 0;
    for (int attempt = 0; attempt < 6; ++attempt) {
      const UniformBudgetResult b = placeUniformBudget(c.tracer, target, us, c.stage("place"));
      std::vector<PlacedProbe> probes = placed(b.points, b.spacingMeters);
      const int missing = want - int(probes.size());
      if (attempt == 0 || std::abs(missing) < std::abs(want - int(out.probes.size()))) {
        out.probes = std::move(probes);
        out.spacingMeters = b.spacingMeters;
      }
      if (c.kept.empty() || 10 * std::abs(missing) <= c.budget) break;
      (missing > 0 ? below : above) = target;
      const int next = below > 0 && above > 0 ? (below + above) / 2 : target + missing;
      if (next == target || next < 4 || next > kMaxProbeBudget) break;
      target = next;
    }
    // Methods are compared at equal probe counts: say when the set is not one (a box whose
    // grids of the budget are far from cubic may get no grid within 10 %).
    const size_t total = c.kept.size() + out.probes.size();
    if (std::abs(double(total) - c.budget) > 0.1 * c.budget)
      out.notes.push_back(formatNote(
          "uniform: no grid of the search gives %d probes within 10 %%%s; the closest gives %zu",
          c.budget, c.kept.empty() ? "" : " (kept and covering probes included)", total));
  } else {
    us.spacingMeters = spacingMeters != 0 ? spacingMeters : c.defaultSpacingMeters();
    out.probes = placed(placeUniform(c.tracer, us, c.stage("place")), us.spacingMeters);
    out.spacingMeters = us.spacingMeters;
  }
  return out;
}

}  // namespace ps
