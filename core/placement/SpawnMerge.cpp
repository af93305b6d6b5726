#include "core/placement/SpawnMerge.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>

#include "core/common/Error.h"
#include "core/math/Random.h"

namespace ps {

double shRelativeDifference(const ShRgb& a, const ShRgb& b) {
  double diffSq = 0, aSq = 0, bSq = 0;
  for (int i = 0; i < kShCoeffCount; ++i) {
    const double la = luminance(a.c[size_t(i)]), lb = luminance(b.c[size_t(i)]);
    diffSq += (la - lb) * (la - lb);
    aSq += la * la;
    bSq += lb * lb;
  }
  const double scale = std::sqrt(std::max(aSq, bSq));
  return scale > 0 ? std::sqrt(diffSq) / scale : 0.0;
}

namespace {

/// A probe taking part in spawn-merge, with its SH from one cheap capture. Locked: a kept probe,
/// compared with its neighbours but never merged, moved or returned.
struct MergeProbe {
  Vec3 position;
  ShRgb sh;
  bool locked = false;
  double score = 0;  ///< as SpawnMergeProbe::score
};

/// Two neighbouring probes (indices a < b into the probes), their distance in metres and the
/// relative difference of their lighting (shRelativeDifference).
struct NeighbourEdge {
  int32_t a, b;
  double lengthMeters, difference;
};

/// A probe an iteration adds: its position and its score (0 for a merge's midpoint).
using NewProbe = std::pair<Vec3, double>;

/// The kept probes (locked) and then the start grid, each captured with `cs` (one capture of all
/// of them, kept ones first).
std::vector<MergeProbe> captureStartProbes(const Tracer& tracer, const LightingRig& rig,
                                           std::span<const Vec3> start, std::span<const Vec3> kept,
                                           const CaptureSettings& cs) {
  std::vector<MergeProbe> probes;
  std::vector<Vec3> initial(kept.begin(), kept.end());
  initial.insert(initial.end(), start.begin(), start.end());
  const std::vector<ProbeCapture> caps = captureProbes(tracer, rig, initial, cs);
  for (size_t i = 0; i < initial.size(); ++i)
    probes.push_back({initial[i], caps[i].sh, i < kept.size(), 0.0});
  return probes;
}

/// Every pair of probes at most `reach` metres apart (reach > 0), found through a hash grid of
/// that cell size, ordered by (a, b). About O(n) for probes spread at about that spacing.
std::vector<NeighbourEdge> neighbourEdges(const std::vector<MergeProbe>& probes, double reach) {
  std::unordered_map<uint64_t, std::vector<int32_t>> cells;
  auto cellKey = [&](int64_t x, int64_t y, int64_t z) {
    return (uint64_t(x & 0x1FFFFF) << 42) | (uint64_t(y & 0x1FFFFF) << 21) | uint64_t(z & 0x1FFFFF);
  };
  auto cellOf = [&](Vec3 p, int64_t c[3]) {
    for (int k = 0; k < 3; ++k) c[k] = int64_t(std::floor(p[k] / reach));
  };
  for (size_t i = 0; i < probes.size(); ++i) {
    int64_t c[3];
    cellOf(probes[i].position, c);
    cells[cellKey(c[0], c[1], c[2])].push_back(int32_t(i));
  }
  std::set<std::pair<int32_t, int32_t>> edgeSet;
  for (size_t i = 0; i < probes.size(); ++i) {
    int64_t c[3];
    cellOf(probes[i].position, c);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto cell = cells.find(cellKey(c[0] + dx, c[1] + dy, c[2] + dz));
          if (cell == cells.end()) continue;
          for (int32_t j : cell->second)
            if (j > int32_t(i) && length(probes[size_t(j)].position - probes[i].position) <= reach)
              edgeSet.emplace(int32_t(i), j);
        }
  }
  std::vector<NeighbourEdge> edges;
  for (const auto& [a, b] : edgeSet)
    edges.push_back({a, b, length(probes[size_t(a)].position - probes[size_t(b)].position),
                     shRelativeDifference(probes[size_t(a)].sh, probes[size_t(b)].sh)});
  return edges;
}

/// Merge (Sukys 3.1.1): "fairly close" and "fairly similar" neighbours (closer than
/// mergeDistance * spacing, differing by less than mergeDifference) become one probe at their
/// midpoint; closest pairs first (stable for equal lengths), each probe merged at most once,
/// locked ones never. Marks the merged probes in `consumed` (one entry per probe), appends the
/// midpoints to `newProbes` and returns how many pairs merged.
size_t mergeSimilarNeighbours(const std::vector<NeighbourEdge>& edges,
                              const std::vector<MergeProbe>& probes, const SpawnMergeSettings& s,
                              std::vector<char>& consumed, std::vector<NewProbe>& newProbes) {
  std::vector<NeighbourEdge> byLength = edges;
  std::stable_sort(byLength.begin(), byLength.end(),
                   [](const NeighbourEdge& x, const NeighbourEdge& y) {
                     return x.lengthMeters < y.lengthMeters;
                   });
  size_t merges = 0;
  for (const NeighbourEdge& e : byLength) {
    if (e.lengthMeters >= s.mergeDistance * s.spacingMeters) break;
    const MergeProbe &pa = probes[size_t(e.a)], &pb = probes[size_t(e.b)];
    if (pa.locked || pb.locked || consumed[size_t(e.a)] || consumed[size_t(e.b)]) continue;
    if (e.difference >= s.mergeDifference) continue;
    consumed[size_t(e.a)] = consumed[size_t(e.b)] = 1;
    newProbes.push_back({(pa.position + pb.position) * 0.5, 0.0});
    ++merges;
  }
  return merges;
}

/// A spawn candidate: a probe at the midpoint of the neighbours `from` and `to`.
struct SpawnCandidate {
  Vec3 from, to;
  double difference;
};

/// The neighbours that differ by more than spawnDifference and lie between spawnMinDistance and
/// spawnMaxDistance times the spacing apart, most different first (stable for equal
/// differences).
std::vector<SpawnCandidate> spawnCandidates(const std::vector<NeighbourEdge>& edges,
                                            const std::vector<MergeProbe>& probes,
                                            const SpawnMergeSettings& s) {
  std::vector<NeighbourEdge> byDifference = edges;
  std::stable_sort(
      byDifference.begin(), byDifference.end(),
      [](const NeighbourEdge& x, const NeighbourEdge& y) { return x.difference > y.difference; });
  std::vector<SpawnCandidate> candidates;
  for (const NeighbourEdge& e : byDifference) {
    if (e.difference <= s.spawnDifference) break;
    if (e.lengthMeters <= s.spawnMinDistance * s.spacingMeters ||
        e.lengthMeters > s.spawnMaxDistance * s.spacingMeters)
      continue;
    candidates.push_back(
        {probes[size_t(e.a)].position, probes[size_t(e.b)].position, e.difference});
  }
  return candidates;
}

/// Per candidate, 1 when its probe may be placed: not across a surface (the two probes differ
/// because a wall is between them: a probe in the wall would help nothing) and not inside
/// geometry (Kontkanen & Laine sec. 5: 32 rays, seeded by s.seed, the candidate's index and the
/// iteration `it`). In parallel; deterministic.
std::vector<char> validSpawns(const Tracer& tracer, const std::vector<SpawnCandidate>& candidates,
                              const SpawnMergeSettings& s, int it) {
  std::vector<char> ok(candidates.size(), 0);
  tbb::parallel_for(size_t(0), candidates.size(), [&](size_t q) {
    const SpawnCandidate& c = candidates[q];
    Ray ray;
    ray.origin = c.from;
    ray.direction = c.to - c.from;
    ray.tMax = 1.0;
    if (tracer.occluded(ray)) return;
    const Vec3 mid = (c.from + c.to) * 0.5;
    ok[q] = backfaceFraction(tracer, mid, 32, streamSeed(s.seed, q + 7919 * size_t(it))) <=
            s.invalidBackfaceFraction;
  });
  return ok;
}

/// Spawn: neighbours that differ get a probe at their midpoint (spawnCandidates, validSpawns),
/// most different first, while `after` (the probes left after the merges) plus the spawns stays
/// under s.maxProbes. Appends them to `newProbes`, scored by their difference, and returns how
/// many.
size_t spawnBetweenDifferent(const Tracer& tracer, const std::vector<NeighbourEdge>& edges,
                             const std::vector<MergeProbe>& probes, const SpawnMergeSettings& s,
                             int it, size_t after, std::vector<NewProbe>& newProbes) {
  const std::vector<SpawnCandidate> candidates = spawnCandidates(edges, probes, s);
  const std::vector<char> ok = validSpawns(tracer, candidates, s, it);
  size_t spawns = 0;
  for (size_t q = 0; q < candidates.size(); ++q) {
    if (!ok[q]) continue;
    if (after + spawns >= s.maxProbes) break;
    newProbes.push_back({(candidates[q].from + candidates[q].to) * 0.5, candidates[q].difference});
    ++spawns;
  }
  return spawns;
}

/// The probes of the next iteration: those not `consumed` (in order), then `newProbes` (in
/// order), captured with `cs`.
std::vector<MergeProbe> nextProbes(const Tracer& tracer, const LightingRig& rig,
                                   const std::vector<MergeProbe>& probes,
                                   const std::vector<char>& consumed,
                                   const std::vector<NewProbe>& newProbes,
                                   const CaptureSettings& cs) {
  std::vector<Vec3> capturePoints;
  for (const auto& np : newProbes) capturePoints.push_back(np.first);
  const std::vector<ProbeCapture> newCaps = captureProbes(tracer, rig, capturePoints, cs);
  std::vector<MergeProbe> next;
  for (size_t i = 0; i < probes.size(); ++i)
    if (!consumed[i]) next.push_back(probes[i]);
  for (size_t i = 0; i < newProbes.size(); ++i)
    next.push_back({newProbes[i].first, newCaps[i].sh, false, newProbes[i].second});
  return next;
}

}  // namespace

SpawnMergeResult placeSpawnMerge(const Tracer& tracer, const LightingRig& rig,
                                 std::span<const Vec3> start, std::span<const Vec3> kept,
                                 const SpawnMergeSettings& s, const ProgressFn& progress) {
  if (!(s.spacingMeters > 0) || !std::isfinite(s.spacingMeters))
    throw ParameterError("spawn-merge spacing: expected a positive number of metres");
  if (s.maxIterations < 1) throw ParameterError("spawn-merge iterations: expected at least 1");

  CaptureSettings cs;
  cs.samplesPerProbe = s.samplesPerProbe;
  cs.seed = streamSeed(s.seed, 0x5A3Bull);
  std::vector<MergeProbe> probes = captureStartProbes(tracer, rig, start, kept, cs);
  // Neighbours: every pair closer than spawnMaxDistance * spacing ("not too much apart").
  const double reach = std::max(s.spawnMaxDistance, s.mergeDistance) * s.spacingMeters;

  SpawnMergeResult r;
  for (int it = 0; it < s.maxIterations; ++it) {
    r.iterations = it + 1;
    const std::vector<NeighbourEdge> edges = neighbourEdges(probes, reach);
    std::vector<char> consumed(probes.size(), 0);
    std::vector<NewProbe> newProbes;  // the merges' midpoints, then the spawns'
    const size_t merges = mergeSimilarNeighbours(edges, probes, s, consumed, newProbes);
    // Each merge turns two probes into one.
    const size_t spawns =
        spawnBetweenDifferent(tracer, edges, probes, s, it, probes.size() - merges, newProbes);
    if (merges == 0 && spawns == 0) break;  // no change: done
    r.merged += merges;
    r.spawned += spawns;
    CaptureSettings stepCs = cs;
    stepCs.seed = streamSeed(s.seed, uint64_t(it) + 1);
    probes = nextProbes(tracer, rig, probes, consumed, newProbes, stepCs);
    if (progress && !progress(double(it + 1) / s.maxIterations)) throw Cancelled();
  }
  for (const MergeProbe& p : probes)
    if (!p.locked) r.probes.push_back({p.position, p.score});
  return r;
}

}  // namespace ps
