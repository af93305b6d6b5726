#include "core/placement/LeakRefine.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <unordered_map>

#include "core/capture/Capture.h"
#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/common/Tolerances.h"
#include "core/math/Random.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps {

namespace {

/// Unique edges (i < j) of the tetrahedralization, sorted.
std::vector<std::pair<int32_t, int32_t>> meshEdges(const Tetrahedralization& t) {
  std::vector<uint64_t> keys;
  keys.reserve(t.tets.size() * 6);
  for (const auto& tet : t.tets)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        const uint32_t a = uint32_t(std::min(tet[i], tet[j]));
        const uint32_t b = uint32_t(std::max(tet[i], tet[j]));
        keys.push_back(uint64_t(a) << 32 | b);
      }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  std::vector<std::pair<int32_t, int32_t>> edges(keys.size());
  for (size_t i = 0; i < keys.size(); ++i)
    edges[i] = {int32_t(keys[i] >> 32), int32_t(keys[i] & 0xffffffffu)};
  return edges;
}

struct EdgeTrace {
  std::optional<Hit> fromA;  ///< first front-facing hit from a towards b (t in metres)
  std::optional<Hit> fromB;  ///< the same from b towards a
  bool leaks() const { return fromA || fromB; }
};

std::vector<EdgeTrace> traceEdges(const Tracer& tracer, const std::vector<Vec3>& v,
                                  const std::vector<std::pair<int32_t, int32_t>>& edges) {
  std::vector<EdgeTrace> out(edges.size());
  tbb::parallel_for(size_t(0), edges.size(), [&](size_t e) {
    const Vec3 a = v[edges[e].first], b = v[edges[e].second];
    Hit h;
    // Sukys 3.2.2: "a ray is cast from one vertex to another and vice versa" (thick walls have
    // a front face on each side).
    if (segmentEntersGeometry(tracer, a, b, &h)) out[e].fromA = h;
    if (segmentEntersGeometry(tracer, b, a, &h)) out[e].fromB = h;
  });
  return out;
}

/// Points in a hash grid, for "is any point closer than r" with r at most the cell size.
class PointGrid {
 public:
  explicit PointGrid(double cell) : cell_(cell) {}
  void insert(Vec3 p, int32_t id) { cells_[key(cellOf(p))].push_back({p, id}); }
  /// Id of the nearest point closer than r (r <= cell size) for which `accept(point)` holds, or
  /// -1.
  template <class Accept>
  int32_t nearestWithin(Vec3 p, double r, const Accept& accept) const {
    const std::array<int64_t, 3> c = cellOf(p);
    int32_t best = -1;
    double bestD2 = r * r;
    for (int64_t dz = -1; dz <= 1; ++dz)
      for (int64_t dy = -1; dy <= 1; ++dy)
        for (int64_t dx = -1; dx <= 1; ++dx) {
          auto it = cells_.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == cells_.end()) continue;
          for (const auto& [q, id] : it->second) {
            const double d2 = dot(q - p, q - p);
            if (d2 < bestD2 && accept(q)) {
              bestD2 = d2;
              best = id;
            }
          }
        }
    return best;
  }

 private:
  std::array<int64_t, 3> cellOf(Vec3 p) const {
    return {int64_t(std::floor(p.x / cell_)), int64_t(std::floor(p.y / cell_)),
            int64_t(std::floor(p.z / cell_))};
  }
  static uint64_t key(std::array<int64_t, 3> c) {
    uint64_t h = 1469598103934665603ull;
    for (int64_t x : c) h = (h ^ uint64_t(x)) * 1099511628211ull;
    return h;
  }
  double cell_;
  std::unordered_map<uint64_t, std::vector<std::pair<Vec3, int32_t>>> cells_;
};

/// Volume of the tets with a leaking edge over the volume of all tets.
double leakingVolumeFraction(const Tetrahedralization& t,
                             const std::vector<std::pair<int32_t, int32_t>>& edges,
                             const std::vector<EdgeTrace>& traces) {
  auto leaks = [&](int32_t a, int32_t b) {
    const std::pair<int32_t, int32_t> key{std::min(a, b), std::max(a, b)};
    const auto it = std::lower_bound(edges.begin(), edges.end(), key);
    PS_CHECK(it != edges.end() && *it == key);
    return traces[size_t(it - edges.begin())].leaks();
  };
  double total = 0, leaking = 0;
  for (const auto& tet : t.tets) {
    const Vec3 a = t.vertices[tet[0]];
    const double vol = std::abs(dot(t.vertices[tet[1]] - a,
                                    cross(t.vertices[tet[2]] - a, t.vertices[tet[3]] - a))) /
                       6;
    total += vol;
    bool any = false;
    for (int i = 0; i < 4 && !any; ++i)
      for (int j = i + 1; j < 4 && !any; ++j) any = leaks(tet[i], tet[j]);
    if (any) leaking += vol;
  }
  return total > 0 ? leaking / total : 0.0;
}

}  // namespace

bool segmentEntersGeometry(const Tracer& tracer, Vec3 a, Vec3 b, Hit* hitOut) {
  const Vec3 d = b - a;
  const double len = length(d);
  if (!(len > 2 * tracer.rayEpsilon())) return false;
  const Vec3 u = d / len;
  Ray ray{a, u, tracer.rayEpsilon(), len - tracer.rayEpsilon()};
  // Back faces (the ray leaving a solid it started in) are stepped over: what counts is
  // entering the outside of a solid between a and b.
  for (int step = 0; step < 64 && ray.tMin < ray.tMax; ++step) {
    const std::optional<Hit> hit = tracer.intersect(ray);
    if (!hit) return false;
    if (hit->frontFace && std::abs(dot(u, hit->geometricNormal)) > tol::kLeakGrazingCos) {
      if (hitOut) *hitOut = *hit;
      return true;
    }
    ray.tMin = hit->t + tracer.rayEpsilon();
  }
  return false;
}

size_t countLeakingEdges(const Tracer& tracer, std::span<const Vec3> probes) {
  const Tetrahedralization t = tetrahedralize(probes);
  const auto edges = meshEdges(t);
  const auto traces = traceEdges(tracer, t.vertices, edges);
  return size_t(
      std::count_if(traces.begin(), traces.end(), [](const EdgeTrace& e) { return e.leaks(); }));
}

LeakRefineResult refineLeaks(const Tracer& tracer, std::span<const Vec3> probes,
                             const LeakRefineSettings& s, const ProgressFn& progress) {
  if (s.maxIterations < 0)
    throw ParameterError("leak refinement: max iterations must be >= 0, got " +
                         std::to_string(s.maxIterations));
  if (!(s.minHitDistanceRelative >= 0 && s.offsetRelative > 0 && s.minSpacingRelative > 0 &&
        s.offsetRelative < 1 && s.minSpacingRelative < 1))
    throw ParameterError(
        "leak refinement: the relative distances must lie in (0, 1) (hit distance in [0, 1))");
  const auto start = std::chrono::steady_clock::now();
  LeakRefineResult r;
  std::vector<Vec3> all(probes.begin(), probes.end());
  for (int round = 0;; ++round) {
    const Tetrahedralization t = tetrahedralize(all);
    const std::vector<Vec3>& v = t.vertices;
    const auto edges = meshEdges(t);
    const auto traces = traceEdges(tracer, v, edges);
    const size_t leaking = size_t(
        std::count_if(traces.begin(), traces.end(), [](const EdgeTrace& e) { return e.leaks(); }));
    const double leakingVolume = leakingVolumeFraction(t, edges, traces);
    if (round == 0) {
      r.leakingEdgesBefore = leaking;
      r.leakingVolumeFractionBefore = leakingVolume;
    }
    r.leakingEdgesAfter = leaking;
    r.leakingVolumeFractionAfter = leakingVolume;
    r.edgesAfter = edges.size();
    if (progress && !progress(std::min(1.0, double(round + 1) / (s.maxIterations + 1))))
      throw Cancelled();
    if (leaking == 0 || round >= s.maxIterations || r.added.size() >= s.maxAdded) break;
    ++r.iterations;

    // Local scale of each vertex: the mean length of its edges.
    std::vector<double> scale(v.size(), 0.0);
    std::vector<int> degree(v.size(), 0);
    for (const auto& [a, b] : edges) {
      const double len = length(v[b] - v[a]);
      scale[a] += len;
      scale[b] += len;
      ++degree[a];
      ++degree[b];
    }
    for (size_t i = 0; i < v.size(); ++i)
      if (degree[i] > 0) scale[i] /= degree[i];

    // Candidates in edge order (deterministic): on each side whose vertex is far enough from
    // the hit, a point `offset` before the hit along the edge (Sukys 3.2.2: "an additional point
    // is inserted at the point of intersection ... offset"). The segment from the vertex to the
    // hit is free, so the candidate is not inside the wall it was made for.
    struct Candidate {
      Vec3 p;
      double spacing;
    };
    std::vector<Candidate> cand;
    double maxSpacing = 0;
    auto consider = [&](int32_t from, int32_t to, const std::optional<Hit>& hit) {
      if (!hit || hit->t <= s.minHitDistanceRelative * scale[from]) return;
      const double offset = std::min(s.offsetRelative * scale[from], 0.5 * hit->t);
      const Vec3 u = normalize(v[to] - v[from]);
      const Vec3 hitPoint = v[from] + u * hit->t;
      Vec3 p = hitPoint - u * offset;
      if (s.offsetAlongNormal) {
        // Off the surface along its normal (towards `from`, the front side), stopping half-way
        // to anything in the way.
        const Vec3 n = hit->geometricNormal;
        const Ray up{hitPoint, n, tracer.rayEpsilon(), 2 * offset};
        const std::optional<Hit> block = tracer.intersect(up);
        p = hitPoint + n * (block ? 0.5 * block->t : offset);
      }
      cand.push_back({p, s.minSpacingRelative * scale[from]});
      maxSpacing = std::max(maxSpacing, cand.back().spacing);
    };
    for (size_t e = 0; e < edges.size(); ++e) {
      consider(edges[e].first, edges[e].second, traces[e].fromA);
      consider(edges[e].second, edges[e].first, traces[e].fromB);
    }
    if (cand.empty()) break;

    // Validity (Kontkanen & Laine sec. 5), in parallel; the choice below is sequential.
    std::vector<char> valid(cand.size(), 0);
    tbb::parallel_for(size_t(0), cand.size(), [&](size_t i) {
      valid[i] = backfaceFraction(tracer, cand[i].p, s.validityRays,
                                  streamSeed(s.seed, uint64_t(round) << 40 | i)) <=
                 s.invalidBackfaceFraction;
    });

    // No two probes closer than the spacing: a candidate near an existing probe is dropped, one
    // near a probe added by refinement adds to that probe's score.
    PS_CHECK_OP(maxSpacing, >, 0.0);
    PointGrid grid(maxSpacing);
    for (size_t i = 0; i < all.size(); ++i) grid.insert(all[i], int32_t(i));
    size_t addedThisRound = 0;
    for (size_t i = 0; i < cand.size(); ++i) {
      if (!valid[i]) continue;
      // Only a probe on the candidate's side of the wall samples that side: one behind the wall
      // (a probe hugging its other face) does not.
      const int32_t near = grid.nearestWithin(cand[i].p, cand[i].spacing, [&](Vec3 q) {
        const Vec3 d = q - cand[i].p;
        const double len = length(d);
        return len <= 2 * tracer.rayEpsilon() ||
               !tracer.occluded(
                   Ray{cand[i].p, d / len, tracer.rayEpsilon(), len - tracer.rayEpsilon()});
      });
      if (near >= 0) {
        if (size_t(near) >= probes.size()) r.addedScore[size_t(near) - probes.size()] += 1;
        continue;
      }
      if (r.added.size() >= s.maxAdded) break;
      grid.insert(cand[i].p, int32_t(all.size()));
      all.push_back(cand[i].p);
      r.added.push_back(cand[i].p);
      r.addedScore.push_back(1);
      ++addedThisRound;
    }
    if (addedThisRound == 0) break;
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace ps
