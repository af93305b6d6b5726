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

SpawnMergeResult placeSpawnMerge(const Tracer& tracer, const LightingRig& rig,
                                 std::span<const Vec3> start, std::span<const Vec3> kept,
                                 const SpawnMergeSettings& s, const ProgressFn& progress) {
  if (!(s.spacingMeters > 0) || !std::isfinite(s.spacingMeters))
    throw ParameterError("spawn-merge spacing: expected a positive number of metres");
  if (s.maxIterations < 1) throw ParameterError("spawn-merge iterations: expected at least 1");

  // Probes: kept ones first (locked), then the grid. SH from one cheap capture each.
  struct P {
    Vec3 position;
    ShRgb sh;
    bool locked = false;
    double score = 0;
  };
  std::vector<P> probes;
  std::vector<Vec3> initial(kept.begin(), kept.end());
  initial.insert(initial.end(), start.begin(), start.end());
  CaptureSettings cs;
  cs.samplesPerProbe = s.samplesPerProbe;
  cs.seed = streamSeed(s.seed, 0x5A3Bull);
  const std::vector<ProbeCapture> caps = captureProbes(tracer, rig, initial, cs);
  for (size_t i = 0; i < initial.size(); ++i)
    probes.push_back({initial[i], caps[i].sh, i < kept.size(), 0.0});

  SpawnMergeResult r;
  for (int it = 0; it < s.maxIterations; ++it) {
    r.iterations = it + 1;
    // Neighbours: every pair closer than spawnMaxDistance * spacing ("not too much apart"),
    // found through a hash grid of that cell size.
    const double reach = std::max(s.spawnMaxDistance, s.mergeDistance) * s.spacingMeters;
    std::unordered_map<uint64_t, std::vector<int32_t>> cells;
    auto cellKey = [&](int64_t x, int64_t y, int64_t z) {
      return (uint64_t(x & 0x1FFFFF) << 42) | (uint64_t(y & 0x1FFFFF) << 21) |
             uint64_t(z & 0x1FFFFF);
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
              if (j > int32_t(i) &&
                  length(probes[size_t(j)].position - probes[i].position) <= reach)
                edgeSet.emplace(int32_t(i), j);
          }
    }
    struct Edge {
      int32_t a, b;
      double lengthMeters, difference;
    };
    std::vector<Edge> edges;
    for (const auto& [a, b] : edgeSet)
      edges.push_back({a, b, length(probes[size_t(a)].position - probes[size_t(b)].position),
                       shRelativeDifference(probes[size_t(a)].sh, probes[size_t(b)].sh)});

    // Merge (Sukys 3.1.1): "fairly close" and "fairly similar" neighbours become one probe at
    // their midpoint; closest pairs first, each probe merged at most once per iteration.
    std::vector<Edge> byLength = edges;
    std::stable_sort(byLength.begin(), byLength.end(),
                     [](const Edge& x, const Edge& y) { return x.lengthMeters < y.lengthMeters; });
    std::vector<char> consumed(probes.size(), 0);
    std::vector<std::pair<Vec3, double>> newPoints;  // midpoint, score
    size_t merges = 0;
    for (const Edge& e : byLength) {
      if (e.lengthMeters >= s.mergeDistance * s.spacingMeters) break;
      const P &pa = probes[size_t(e.a)], &pb = probes[size_t(e.b)];
      if (pa.locked || pb.locked || consumed[size_t(e.a)] || consumed[size_t(e.b)]) continue;
      if (e.difference >= s.mergeDifference) continue;
      consumed[size_t(e.a)] = consumed[size_t(e.b)] = 1;
      newPoints.push_back({(pa.position + pb.position) * 0.5, 0.0});
      ++merges;
    }
    // Spawn: neighbours that differ get a probe between them; most different first, within the
    // probe cap.
    std::vector<Edge> byDifference = edges;
    std::stable_sort(byDifference.begin(), byDifference.end(),
                     [](const Edge& x, const Edge& y) { return x.difference > y.difference; });
    struct Spawn {
      Vec3 from, to;
      double difference;
    };
    std::vector<Spawn> spawnCandidates;
    for (const Edge& e : byDifference) {
      if (e.difference <= s.spawnDifference) break;
      if (e.lengthMeters <= s.spawnMinDistance * s.spacingMeters ||
          e.lengthMeters > s.spawnMaxDistance * s.spacingMeters)
        continue;
      spawnCandidates.push_back(
          {probes[size_t(e.a)].position, probes[size_t(e.b)].position, e.difference});
    }
    // Not across a surface (the two probes differ because a wall is between them: a probe in
    // the wall would help nothing) and not inside geometry (Kontkanen & Laine sec. 5).
    std::vector<char> ok(spawnCandidates.size(), 0);
    tbb::parallel_for(size_t(0), spawnCandidates.size(), [&](size_t q) {
      const Spawn& c = spawnCandidates[q];
      Ray ray;
      ray.origin = c.from;
      ray.direction = c.to - c.from;
      ray.tMax = 1.0;
      if (tracer.occluded(ray)) return;
      const Vec3 mid = (c.from + c.to) * 0.5;
      ok[q] = backfaceFraction(tracer, mid, 32, streamSeed(s.seed, q + 7919 * size_t(it))) <=
              s.invalidBackfaceFraction;
    });
    size_t spawns = 0;
    const size_t after = probes.size() - merges;  // each merge turns two probes into one
    for (size_t q = 0; q < spawnCandidates.size(); ++q) {
      if (!ok[q]) continue;
      if (after + spawns >= s.maxProbes) break;
      newPoints.push_back(
          {(spawnCandidates[q].from + spawnCandidates[q].to) * 0.5, spawnCandidates[q].difference});
      ++spawns;
    }
    if (merges == 0 && spawns == 0) break;  // no change: done
    r.merged += merges;
    r.spawned += spawns;
    std::vector<Vec3> capturePoints;
    for (const auto& np : newPoints) capturePoints.push_back(np.first);
    CaptureSettings stepCs = cs;
    stepCs.seed = streamSeed(s.seed, uint64_t(it) + 1);
    const std::vector<ProbeCapture> newCaps = captureProbes(tracer, rig, capturePoints, stepCs);
    std::vector<P> next;
    for (size_t i = 0; i < probes.size(); ++i)
      if (!consumed[i]) next.push_back(probes[i]);
    for (size_t i = 0; i < newPoints.size(); ++i)
      next.push_back({newPoints[i].first, newCaps[i].sh, false, newPoints[i].second});
    probes = std::move(next);
    if (progress && !progress(double(it + 1) / s.maxIterations)) throw Cancelled();
  }
  for (const P& p : probes)
    if (!p.locked) r.probes.push_back({p.position, p.score});
  return r;
}

}  // namespace ps
