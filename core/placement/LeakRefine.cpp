#include "core/placement/LeakRefine.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <unordered_map>

#include "core/capture/Capture.h"
#include "core/capture/ParallelProbes.h"
#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/common/Tolerances.h"
#include "core/domain/DomainPoints.h"
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

double tetVolume(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
  return std::abs(dot(b - a, cross(c - a, d - a))) / 6;
}

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
    const double vol =
        tetVolume(t.vertices[tet[0]], t.vertices[tet[1]], t.vertices[tet[2]], t.vertices[tet[3]]);
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

namespace {

using PlaneCoeffs = std::array<float, 4>;  ///< (nx, ny, nz, d), as ProbeVolume::CutPlane

/// A point drawn for a tet's cuts.
struct CutSample {
  Vec3 p;
  uint32_t hidden = 0;        ///< bit k: vertex k cannot be seen
  uint32_t active = 0;        ///< bit k: vertex k has a weight (outside the hull: the face's)
  uint32_t kept = 0xF;        ///< the vertices the cuts chosen so far keep
  std::array<double, 4> w{};  ///< its barycentric weights (outside the hull: on the face)
  /// The points of the nominal density it stands for: queries are uniform in the domain, so a
  /// cut's cost counts volume (1 for the points drawn in and beyond the tet; more for those
  /// drawn sparser over the domain, ClampedPoint).
  double weight = 1;
};

/// Points drawn over the domain for the clamps beyond the hull's edges and corners, at most
/// (whatever LeakCutSettings::samplesTotal is: each is held until they are shared out).
constexpr size_t kMaxClampedDraws = size_t(1) << 22;

/// A point outside the hull, with the weights locate() gives it (those of its clamp to the hull).
struct ClampedPoint {
  Vec3 p;
  std::array<float, 4> weights;
  double weight = 1;  ///< as CutSample::weight
};

/// A candidate cut: plane `plane` hides the vertices `mask` from the queries on side
/// `positive` (the side of a point that found them hidden by that plane's surface).
struct CutTriple {
  uint32_t plane;
  bool positive;
  uint32_t mask;
  bool operator==(const CutTriple&) const = default;
};

/// Whether a point interpolates a vertex it cannot see, given the vertices kept for it.
bool cutSampleLeaks(const CutSample& smp, uint32_t kept) {
  if (kept == 0) return (smp.active & smp.hidden) != 0;  // applyCuts keeps the weights as they were
  // The vertices with weight; applyCuts shares it equally when the kept ones have none.
  const uint32_t weighted = (kept & smp.active) ? kept & smp.active : kept;
  return (weighted & smp.hidden) != 0;
}

/// How far the cuts move the weights of a point that sees every vertex it interpolates: the total
/// variation distance (half the sum of |change|, in [0, 1]) between its barycentric weights and
/// those applyCuts gives it with `kept` (renormalised over the kept vertices, shared equally
/// when they have none, unchanged when none or all are kept).
double cutWeightChange(const CutSample& smp, uint32_t kept) {
  if (kept == 0 || kept == 0xF) return 0;
  double sum = 0;
  for (int k = 0; k < 4; ++k)
    if (kept >> k & 1) sum += smp.w[size_t(k)];
  const double equal = 1.0 / std::popcount(kept);
  double change = 0;
  for (int k = 0; k < 4; ++k) {
    const double after = (kept >> k & 1) ? (sum > 0 ? smp.w[size_t(k)] / sum : equal) : 0.0;
    change += std::abs(after - smp.w[size_t(k)]);
  }
  return 0.5 * change;
}

/// Distance from p along `normal` to the far side of the domain boxes holding p (0 if none).
double reachInDomain(std::span<const Bounds3> domain, Vec3 p, Vec3 normal) {
  double reach = 0;
  for (const Bounds3& box : domain) {
    if (!box.contains(p)) continue;
    double exit = std::numeric_limits<double>::infinity();
    for (int axis = 0; axis < 3; ++axis) {
      const double d = normal[axis];
      if (d > 1e-12) exit = std::min(exit, (box.hi[axis] - p[axis]) / d);
      if (d < -1e-12) exit = std::min(exit, (box.lo[axis] - p[axis]) / d);
    }
    if (std::isfinite(exit)) reach = std::max(reach, exit);
  }
  return reach;
}

/// One tet's cuts: the points drawn in and beyond it, the candidate planes of the surfaces that
/// hide vertices from them, and the planes chosen.
class TetCutter {
 public:
  TetCutter(const Tracer& tracer, const LeakCutSettings& s, std::span<const Bounds3> domain,
            double samePlane, const Vec3 (&corner)[4], uint64_t seed)
      : tracer_(tracer), s_(s), domain_(domain), samePlane_(samePlane), rng_(seed) {
    std::copy(corner, corner + 4, corner_);
  }

  /// A hull face of the tet (the local index of the vertex opposite it): queries beyond it are
  /// clamped to it. `perVolume`: points per cubic metre, for the count drawn beyond it.
  /// `inside`: a point inside the hull (the mean of the probes), which gives the face its outward
  /// side. Not the opposite vertex: a sliver on the hull, flat once its corners are floats, has
  /// that vertex in the face's plane, which would turn the face's prism inwards across the whole
  /// domain and draw points far from the face.
  void addHullFace(int opposite, double perVolume, Vec3 inside) {
    Face face{opposite, {0, 0, 0}, {}, 0};
    for (int k = 0, m = 0; k < 4; ++k)
      if (k != opposite) face.f[m++] = k;
    const Vec3* c = corner_;
    const Vec3 n = cross(c[face.f[1]] - c[face.f[0]], c[face.f[2]] - c[face.f[0]]);
    if (!(length(n) > 0)) return;
    face.normal = normalize(n);
    if (dot(face.normal, inside - c[face.f[0]]) > 0) face.normal = -face.normal;
    const Vec3 centre = (c[face.f[0]] + c[face.f[1]] + c[face.f[2]]) / 3;
    const double prism = 0.5 * length(n) * reachInDomain(domain_, centre, face.normal);
    face.count =
        int(std::clamp(std::round(perVolume * prism), double(s_.samplesPerTet), double(1 << 20)));
    faces_.push_back(face);
  }

  /// Points of the domain outside the hull that locate() clamps to an edge or a corner of one of
  /// this tet's hull faces (no face's prism holds them; draw() covers the prisms): each with
  /// the weights the clamp gives it, on two vertices or one.
  void testClamped(std::span<const ClampedPoint> points) {
    for (const ClampedPoint& c : points) {
      uint32_t active = 0;
      std::array<double, 4> bary{};
      for (int k = 0; k < 4; ++k) {
        bary[size_t(k)] = c.weights[size_t(k)];
        if (c.weights[size_t(k)] > 0) active |= 1u << k;
      }
      test(c.p, active, bary, c.weight);
    }
  }

  /// `share` times `count` points uniform in the tet, and as many in proportion beyond each hull
  /// face (a point of the face moved out along its normal, up to where the domain ends).
  void draw(int count, double share) {
    for (int i = 0, n = int(std::round(count * share)); i < n; ++i) {
      // Uniform in the tetrahedron: barycentrics from a flat Dirichlet (normalised exponentials).
      double w[4], sum = 0;
      for (double& x : w) sum += x = -std::log(1.0 - uniform01(rng_));
      Vec3 p;
      std::array<double, 4> bary;
      for (int k = 0; k < 4; ++k) {
        bary[size_t(k)] = w[k] / sum;
        p += corner_[k] * bary[size_t(k)];
      }
      test(p, 0xF, bary);
    }
    for (const Face& face : faces_)
      for (int i = 0, n = int(std::round(face.count * share)); i < n; ++i) {
        double a = uniform01(rng_), b = uniform01(rng_);
        if (a + b > 1) a = 1 - a, b = 1 - b;
        const Vec3* c = corner_;
        const Vec3 onFace =
            c[face.f[0]] + (c[face.f[1]] - c[face.f[0]]) * a + (c[face.f[2]] - c[face.f[0]]) * b;
        const double reach = reachInDomain(domain_, onFace, face.normal);
        if (!(reach > 0)) continue;
        // locate() clamps the point back to onFace: the face's barycentrics are its weights.
        std::array<double, 4> bary{};
        bary[size_t(face.f[0])] = 1 - a - b;
        bary[size_t(face.f[1])] = a;
        bary[size_t(face.f[2])] = b;
        test(onFace + face.normal * (uniform01(rng_) * reach), 0xFu & ~(1u << face.opposite), bary);
      }
  }

  /// Greedily: the (plane, side, vertices) that most lowers the cost, while one does and the tet
  /// has room for its plane. The cost is the count of leaking points plus overCutWeight times
  /// how far the cuts move the weights of the points that see every vertex (cutWeightChange): a
  /// plane is infinite, and one through a pillar's face would otherwise cut off probes in plain
  /// view of the points beside the pillar. A point behind two surfaces (a wall and a cabinet)
  /// needs a plane for each before it stops leaking, so when no cut lowers the cost, one that
  /// ends no leak but hides more (point, hidden vertex) pairs is taken (the one that costs
  /// least). The shortest run of picks with the lowest cost is kept. Returns the points still
  /// leaking.
  size_t choose(std::vector<ProbeVolume::CutPlane>& planes) {
    const double alpha = s_.overCutWeight;
    const size_t n = points_.size();
    std::vector<std::vector<char>> sideOf(candidates_.size());
    for (size_t c = 0; c < candidates_.size(); ++c) {
      sideOf[c].resize(n);
      for (size_t i = 0; i < n; ++i) sideOf[c][i] = detail::cutSide(candidates_[c], points_[i].p);
    }
    std::vector<int> slot(candidates_.size(), -1);  // index in `planes`, once chosen
    // Adds the triple's plane (if new) and its mask on its side to `planes`.
    auto addToPlanes = [&](const CutTriple& tr) {
      if (slot[tr.plane] < 0) {
        slot[tr.plane] = int(planes.size());
        planes.push_back({candidates_[tr.plane], 0});
      }
      planes[size_t(slot[tr.plane])].hide |= tr.mask << (tr.positive ? 0 : 4);
    };
    std::vector<char> applied(triples_.size(), 0);
    // The points leaking (a count), and the cost: their weight (CutSample::weight), plus the
    // weight moved at points that see every probe.
    size_t leaking = leakingCount();
    double cost = leakingWeight();  // no cut moves a weight yet
    // The picks in order, with the cost after each; the shortest prefix with the lowest is kept
    // (picks that only hid more pairs and never led to a lower cost are dropped).
    std::vector<size_t> picks;
    double bestCost = cost;
    size_t bestPicks = 0, bestLeaking = leaking;
    constexpr double kEps = 1e-9;
    while (leaking > 0) {
      // Best by cost lowered (ties: more pairs hidden); else the exploring pick.
      double bestGain = 0, exploreGain = 0;
      long bestPairs = 0, explorePairs = 0, bestLeakCount = 0;
      size_t best = triples_.size(), explore = triples_.size();
      for (size_t j = 0; j < triples_.size(); ++j) {
        const CutTriple& tr = triples_[j];
        if (applied[j] || (slot[tr.plane] < 0 && planes.size() >= size_t(s_.maxPlanesPerTet)))
          continue;
        const std::vector<char>& side = sideOf[tr.plane];
        long leakCount = 0, pairs = 0;  // points that stop leaking (less those that start)
        double leakGain = 0, moved = 0;
        for (size_t i = 0; i < n; ++i) {
          const CutSample& smp = points_[i];
          if (bool(side[i]) != tr.positive || !(smp.kept & tr.mask)) continue;
          const long d =
              long(cutSampleLeaks(smp, smp.kept)) - long(cutSampleLeaks(smp, smp.kept & ~tr.mask));
          leakCount += d;
          leakGain += smp.weight * double(d);
          pairs += std::popcount(smp.kept & tr.mask & smp.hidden);
          // A point that sees every probe it interpolates (beyond a hull face, the face's three:
          // the one opposite has no weight there) is harmed by any weight a cut moves.
          if (alpha > 0 && !(smp.hidden & smp.active))
            moved += smp.weight *
                     (cutWeightChange(smp, smp.kept & ~tr.mask) - cutWeightChange(smp, smp.kept));
        }
        const double gain = leakGain - alpha * moved;
        // Ties go to the first: a vertex alone comes before the masks that hold it.
        if (gain > bestGain + kEps ||
            (gain > kEps && gain >= bestGain - kEps && pairs > bestPairs)) {
          bestGain = gain;
          bestPairs = pairs;
          bestLeakCount = leakCount;
          best = j;
        }
        if (leakCount == 0 && pairs > 0 &&
            (explore == triples_.size() || pairs > explorePairs ||
             (pairs == explorePairs && gain > exploreGain + kEps))) {
          explorePairs = pairs;
          exploreGain = gain;
          explore = j;
        }
      }
      if (best == triples_.size()) {
        if (explore == triples_.size()) break;  // no cut helps
        best = explore;
        bestGain = exploreGain;
        bestLeakCount = 0;  // the exploring pick ends no leak and starts none
      }
      const CutTriple& tr = triples_[best];
      applied[best] = 1;
      addToPlanes(tr);
      for (size_t i = 0; i < n; ++i)
        if (bool(sideOf[tr.plane][i]) == tr.positive) points_[i].kept &= ~tr.mask;
      leaking = size_t(long(leaking) - bestLeakCount);
      cost -= bestGain;
      picks.push_back(best);
      if (cost < bestCost - kEps) {
        bestCost = cost;
        bestPicks = picks.size();
        bestLeaking = leaking;
      }
    }
    if (bestPicks < picks.size()) {  // replay the best prefix
      planes.clear();
      std::fill(slot.begin(), slot.end(), -1);
      for (size_t k = 0; k < bestPicks; ++k) addToPlanes(triples_[picks[k]]);
      for (CutSample& smp : points_)
        smp.kept = detail::cutKeptVertices(planes.data(), planes.size(), smp.p);
    }
    PS_CHECK_EQ(leakingCount(), bestLeaking);
    return bestLeaking;
  }

  /// Points that interpolate a vertex they cannot see, with the vertices kept for them now.
  size_t leakingCount() const {
    size_t n = 0;
    for (const CutSample& smp : points_) n += cutSampleLeaks(smp, smp.kept);
    return n;
  }
  /// The same, each point weighed by CutSample::weight.
  double leakingWeight() const {
    double w = 0;
    for (const CutSample& smp : points_) w += cutSampleLeaks(smp, smp.kept) ? smp.weight : 0.0;
    return w;
  }

  /// Up to `count` points still leaking, spread out: each the farthest from the vertices and the
  /// points taken before it.
  std::vector<Vec3> leakingPoints(size_t count) const {
    std::vector<Vec3> taken(corner_, corner_ + 4), out;
    for (size_t pick = 0; pick < count; ++pick) {
      double farthest = -1;
      Vec3 best;
      for (const CutSample& smp : points_) {
        if (!cutSampleLeaks(smp, smp.kept)) continue;
        double nearest = std::numeric_limits<double>::infinity();
        for (const Vec3& c : taken) nearest = std::min(nearest, length(c - smp.p));
        if (nearest > farthest) {
          farthest = nearest;
          best = smp.p;
        }
      }
      if (!(farthest > 0)) break;
      taken.push_back(best);
      out.push_back(best);
    }
    return out;
  }

  size_t samples() const { return samples_; }  ///< valid points drawn
  size_t hiddenSamples() const { return hiddenSamples_; }

 private:
  struct Face {
    int opposite, f[3];
    Vec3 normal;
    int count;  ///< points drawn beyond it, by the volume there (area x reach at its centre)
  };

  /// Traces from p to the active vertices; keeps p, with the candidate cuts it asks for, when a
  /// vertex is hidden and p is valid.
  void test(Vec3 p, uint32_t active, const std::array<double, 4>& bary, double weight = 1) {
    CutSample smp{p, 0, active, 0xF, bary, weight};
    PlaneCoeffs hitPlanes[4];
    // Every vertex, also one without weight (beyond a hull face): a cut that hides the face's
    // vertices gives it the weight (applyCuts).
    for (int k = 0; k < 4; ++k) {
      const Vec3 d = corner_[k] - p;
      const double len = length(d);
      if (len <= 2 * tracer_.rayEpsilon()) continue;
      const std::optional<Hit> hit =
          tracer_.intersect(Ray{p, d / len, tracer_.rayEpsilon(), len - tracer_.rayEpsilon()});
      if (!hit) continue;
      // The plane of the surface in the way: p and the vertex are on either side of it.
      const Vec3 n = hit->geometricNormal, at = p + d / len * hit->t;
      hitPlanes[k] = {float(n.x), float(n.y), float(n.z), float(dot(n, at))};
      smp.hidden |= 1u << k;
    }
    const uint64_t validitySeed = splitMix64(rng_);
    if (!smp.hidden) {
      ++samples_;
      // A cut may yet reach it: what it moves of its weights counts against the cut.
      if (s_.overCutWeight > 0) points_.push_back(smp);
      return;
    }
    // A point inside geometry is no query's; its "hidden" vertices are no leak.
    if (backfaceFraction(tracer_, p, s_.validityRays, validitySeed) > s_.invalidBackfaceFraction)
      return;
    ++samples_;
    points_.push_back(smp);
    ++hiddenSamples_;
    uint32_t planeOf[4] = {0, 0, 0, 0};
    for (int k = 0; k < 4; ++k) {
      if (!(smp.hidden >> k & 1)) continue;
      // One plane per surface: hits on one wall give one plane to within rounding.
      const PlaneCoeffs& h = hitPlanes[k];
      auto same = std::find_if(candidates_.begin(), candidates_.end(), [&](const PlaneCoeffs& c) {
        return double(c[0]) * h[0] + double(c[1]) * h[1] + double(c[2]) * h[2] > 1 - 1e-6 &&
               std::abs(double(c[3]) - h[3]) <= samePlane_;
      });
      planeOf[k] = uint32_t(same - candidates_.begin());
      if (same == candidates_.end()) candidates_.push_back(h);
    }
    // Per plane, each vertex it hides from p alone and all of them together (a point behind a
    // wall usually has two or three vertices across it, and needs them all hidden).
    auto add = [&](const CutTriple& triple) {
      if (std::find(triples_.begin(), triples_.end(), triple) == triples_.end())
        triples_.push_back(triple);
    };
    for (int k = 0; k < 4; ++k) {
      if (!(smp.hidden >> k & 1)) continue;
      uint32_t together = 0;
      for (int j = 0; j < 4; ++j)
        if ((smp.hidden >> j & 1) && planeOf[j] == planeOf[k]) together |= 1u << j;
      const bool side = detail::cutSide(candidates_[planeOf[k]], p);
      add({planeOf[k], side, 1u << k});
      add({planeOf[k], side, together});
    }
  }

  const Tracer& tracer_;
  const LeakCutSettings& s_;
  std::span<const Bounds3> domain_;
  double samePlane_;
  uint64_t rng_;
  Vec3 corner_[4];
  std::vector<Face> faces_;
  /// The valid points that cannot see some vertex, and (with overCutWeight > 0) the points that
  /// see every vertex, which are not validity-tested (a point inside a solid would hit its
  /// inside), in the order drawn.
  std::vector<CutSample> points_;
  size_t hiddenSamples_ = 0;  ///< of points_, those that cannot see some vertex
  std::vector<PlaneCoeffs> candidates_;
  std::vector<CutTriple> triples_;
  size_t samples_ = 0;
};

/// Throws ps::ParameterError unless samplesPerTet, validityRays and denseFactor are >= 1,
/// maxPlanesPerTet is in [1, ProbeVolume::kMaxCutsPerTet] and overCutWeight is finite and >= 0.
void checkLeakCutSettings(const LeakCutSettings& s) {
  if (s.samplesPerTet < 1 || s.maxPlanesPerTet < 1 ||
      s.maxPlanesPerTet > int(ProbeVolume::kMaxCutsPerTet) || s.validityRays < 1 ||
      s.denseFactor < 1 || !(s.overCutWeight >= 0) || !std::isfinite(s.overCutWeight))
    throw ParameterError(
        "leak cuts: samples per tetrahedron, validity rays and the dense factor must be >= 1, "
        "planes per tetrahedron in [1, " +
        std::to_string(ProbeVolume::kMaxCutsPerTet) + "], the over-cut weight finite and >= 0");
}

/// Per tet of v, the local indices of the vertices opposite its hull faces (empty for an inner
/// tet): queries outside the hull are clamped to those faces (locate()).
std::vector<std::vector<int>> hullFacesByTet(const ProbeVolume& v) {
  std::vector<std::vector<int>> hullFacesOf(v.tets.size());
  for (const auto& [t, opposite] : v.hullFaces) hullFacesOf[size_t(t)].push_back(opposite);
  return hullFacesOf;
}

/// The mean of v's probe positions (the origin when it has none): a convex combination of the
/// probes, so inside their convex hull (strictly, unless it is flat).
Vec3 meanProbePosition(const ProbeVolume& v) {
  Vec3 inside;
  for (size_t i = 0; i < v.probeCount(); ++i) inside += v.position(int32_t(i));
  return inside / double(std::max<size_t>(v.probeCount(), 1));
}

/// Each tet's volume (m^3), and in `total` their sum in tet order. From vertex 3, as the
/// barycentric matrices are: the operand order fixes the rounding of the volumes, and with it
/// the points each tet draws.
std::vector<double> tetVolumes(const ProbeVolume& v, double& total) {
  std::vector<double> volume(v.tets.size());
  total = 0;
  for (size_t t = 0; t < v.tets.size(); ++t) {
    const auto& tet = v.tets[t];
    volume[t] =
        tetVolume(v.position(tet[3]), v.position(tet[0]), v.position(tet[1]), v.position(tet[2]));
    total += volume[t];
  }
  return volume;
}

/// Puts a volume's leak cuts aside while it lives, so that locate() gives the uncut location,
/// and puts them back when it ends (also through an exception) unless the caller has stored new
/// ones (keepReplacement).
class CutsAside {
 public:
  explicit CutsAside(ProbeVolume& v)
      : v_(v), start_(std::move(v.cutStart)), planes_(std::move(v.cutPlanes)) {
    v_.cutStart.clear();
    v_.cutPlanes.clear();
  }
  CutsAside(const CutsAside&) = delete;
  CutsAside& operator=(const CutsAside&) = delete;
  ~CutsAside() {
    if (replaced_) return;
    v_.cutStart = std::move(start_);
    v_.cutPlanes = std::move(planes_);
  }
  /// The cuts put aside are dropped: the volume keeps the ones it holds when this ends.
  void keepReplacement() { replaced_ = true; }

 private:
  ProbeVolume& v_;
  std::vector<uint32_t> start_;
  std::vector<ProbeVolume::CutPlane> planes_;
  bool replaced_ = false;
};

/// Per tet of v (which must hold no cuts: locate() is the uncut volume's), the points of
/// `domain` (boxes, not empty) outside the hull that locate() clamps into it onto an edge or a
/// corner of the hull (two or one weighted vertices; those clamped onto a face are left to the
/// face's prism, TetCutter::draw). They are drawn uniformly over the domain at the tets'
/// density `perVolume` (points per cubic metre), but at most s.samplesTotal and
/// kMaxClampedDraws of them, each weighing as many points of that density as it stands for
/// (at least 1). Empty lists when v has no hull faces or the density or the domain's volume is
/// 0. In parallel, one seeded stream per draw, gathered in draw order: deterministic. Each draw
/// costs a locate().
std::vector<std::vector<ClampedPoint>> clampedPointsByTet(const Tracer& tracer,
                                                          const ProbeVolume& v,
                                                          std::span<const Bounds3> domain,
                                                          const LeakCutSettings& s,
                                                          double perVolume) {
  std::vector<std::vector<ClampedPoint>> clampedOf(v.tets.size());
  double domainVolume = 0;
  for (const Bounds3& b : domain) domainVolume += b.volume();
  if (v.hullFaces.empty() || !(perVolume > 0) || !(domainVolume > 0)) return clampedOf;
  const DomainPoints boxes(tracer, LightingRig{}, domain, 0.0);
  const HullClamp hullClamp(v);  // locate()'s own clamp, faster
  // The tets' density over the domain, but at most samplesTotal points (as many again as the
  // tets get; each costs a locate(), and rays only where it clamps to an edge or a corner),
  // each then weighing more.
  const size_t count = size_t(
      std::min({perVolume * domainVolume, double(s.samplesTotal), double(kMaxClampedDraws)}));
  // Each stands for as many points of the nominal density (perVolume, that of the tets'
  // draws and the faces' prisms before their minimums and the denser draw where a leak
  // shows) as its own is lower (CutSample::weight).
  const double clampedWeight =
      count > 0 ? std::max(1.0, perVolume * domainVolume / double(count)) : 1.0;
  std::vector<ClampedPoint> drawn(count);
  std::vector<int32_t> tetOf(count, -1);
  tbb::parallel_for(size_t(0), count, [&](size_t i) {
    uint64_t rng = streamSeed(s.seed ^ 0x636c616d70ull, i);
    const std::optional<Vec3> p = boxes.drawInBoxes(rng);
    if (!p) return;
    const VolumeLocation loc = locate(v, *p, -1, &hullClamp);
    if (!loc.outside || loc.tet < 0) return;
    int weighted = 0;
    for (float w : loc.weights) weighted += w > 0 ? 1 : 0;
    if (weighted > 2) return;  // on a face: its prism's points stand for it
    drawn[i] = {*p, loc.weights, clampedWeight};
    tetOf[i] = loc.tet;
  });
  for (size_t i = 0; i < count; ++i)
    if (tetOf[i] >= 0) clampedOf[size_t(tetOf[i])].push_back(drawn[i]);
  return clampedOf;
}

/// What every tet's cuts share.
struct CutShared {
  const Tracer& tracer;
  const LeakCutSettings& s;
  std::span<const Bounds3> domain;  ///< where queries can be (not empty)
  double samePlane;                 ///< parallel planes closer than this (m) are one surface's
  double perVolume;                 ///< points drawn per cubic metre
  Vec3 inside;                      ///< a point inside the probes' hull
};

/// One tet's cuts, and what its points found.
struct TetCuts {
  std::vector<ProbeVolume::CutPlane> planes;
  size_t samples = 0, hiddenBefore = 0, hiddenAfter = 0;
  std::vector<Vec3> unresolved;  ///< up to unresolvedPerTet points still leaking
};

/// Tet t of v's cuts (TetCutter, seeded by s.seed and t): points in the tet (by its `volume` in
/// m^3 at the shared density, within [samplesPerTet, 2^20]), beyond its `hullFaces` (the local
/// indices of the vertices opposite them) and the domain's `clamped` points; where a point
/// finds a hidden vertex, more: up to samplesPerTet x denseFactor in the tet, and beyond its
/// faces in proportion. Reads only v's positions and tets: tets may be cut in parallel.
TetCuts cutTet(const CutShared& in, const ProbeVolume& v, size_t t, std::span<const int> hullFaces,
               double volume, std::span<const ClampedPoint> clamped) {
  const LeakCutSettings& s = in.s;
  Vec3 corner[4];
  for (int k = 0; k < 4; ++k) corner[k] = v.position(v.tets[t][k]);
  TetCutter cutter(in.tracer, s, in.domain, in.samePlane, corner, streamSeed(s.seed, t));
  for (int opposite : hullFaces) cutter.addHullFace(opposite, in.perVolume, in.inside);
  const int count =
      int(std::clamp(std::round(in.perVolume * volume), double(s.samplesPerTet), double(1 << 20)));
  cutter.draw(count, 1.0);
  cutter.testClamped(clamped);
  // Where a leak shows, look closer: the cut must hold for the whole tet, not only the points
  // that found it.
  if (cutter.hiddenSamples() > 0)
    cutter.draw(count, std::max(1.0, double(s.samplesPerTet) * s.denseFactor / count) - 1.0);
  TetCuts r;
  r.hiddenBefore = cutter.leakingCount();
  r.hiddenAfter = cutter.choose(r.planes);
  r.samples = cutter.samples();
  if (r.hiddenAfter > 0) r.unresolved = cutter.leakingPoints(s.unresolvedPerTet);
  return r;
}

/// Stores the tets' cuts (`out`, one per tet of v, in tet order) in v.cutStart and v.cutPlanes,
/// both left empty when no tet has a plane, and adds their counts and unresolved points (in tet
/// order) to `result`.
void storeCuts(const std::vector<TetCuts>& out, ProbeVolume& v, LeakCutResult& result) {
  v.cutStart.assign(v.tets.size() + 1, 0);
  v.cutPlanes.clear();
  for (size_t t = 0; t < out.size(); ++t) {
    v.cutPlanes.insert(v.cutPlanes.end(), out[t].planes.begin(), out[t].planes.end());
    v.cutStart[t + 1] = uint32_t(v.cutPlanes.size());
    result.tetsCut += !out[t].planes.empty();
    result.samples += out[t].samples;
    result.hiddenSamplesBefore += out[t].hiddenBefore;
    result.hiddenSamplesAfter += out[t].hiddenAfter;
    result.unresolved.insert(result.unresolved.end(), out[t].unresolved.begin(),
                             out[t].unresolved.end());
    result.tetsUnresolved += !out[t].unresolved.empty();
  }
  result.planes = v.cutPlanes.size();
  if (v.cutPlanes.empty()) v.cutStart.clear();
}

}  // namespace

// Sukys 3.2.2 detects the leaks (edges crossing geometry); refinement alone cannot end them, as
// any tetrahedralization of probes on both sides of a wall has tetrahedra across it. The cuts
// split those tetrahedra along the surfaces that hide a vertex.
LeakCutResult computeLeakCuts(const Tracer& tracer, ProbeVolume& v, std::span<const Bounds3> domain,
                              const LeakCutSettings& s, const ProgressFn& progress) {
  checkLeakCutSettings(s);
  if (domain.empty()) domain = std::span<const Bounds3>(&tracer.scene().bounds, 1);
  // Planes closer than this (and parallel) are one surface's.
  const double samePlane = 1e-5 * tracer.scene().bounds.diagonal();
  const auto start = std::chrono::steady_clock::now();
  const std::vector<std::vector<int>> hullFacesOf = hullFacesByTet(v);
  const Vec3 inside = meanProbePosition(v);
  // Points per cubic metre: the total shared out by volume (a tet gets at least samplesPerTet).
  double totalVolume = 0;
  const std::vector<double> volume = tetVolumes(v, totalVolume);
  const double perVolume = totalVolume > 0 ? double(s.samplesTotal) / totalVolume : 0.0;
  // Beyond an edge or a corner of the hull, queries are clamped onto it (two probes or one
  // interpolated) and lie in no face's prism: where the hull is small against the domain, most
  // of the domain is there. Points uniform in the domain are located as queries are and given
  // to the tet they clamp into, by locate() as the uncut volume.
  CutsAside aside(v);
  const std::vector<std::vector<ClampedPoint>> clampedOf =
      clampedPointsByTet(tracer, v, domain, s, perVolume);
  const CutShared shared{tracer, s, domain, samePlane, perVolume, inside};
  std::vector<TetCuts> out(v.tets.size());
  // A cancel leaves `aside` to put v back as it was.
  forEachProbeInParallel(v.tets.size(), 0, progress, [&](size_t t, const std::atomic<bool>&) {
    out[t] = cutTet(shared, v, t, hullFacesOf[t], volume[t], clampedOf[t]);
  });
  LeakCutResult result;
  aside.keepReplacement();
  storeCuts(out, v, result);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

LeakCutRefineResult refineForLeakCuts(const Tracer& tracer, const LightingRig& rig,
                                      std::span<const Vec3> probes, std::span<const Bounds3> domain,
                                      const LeakCutSettings& s) {
  if (s.refineRounds < 0)
    throw ParameterError("leak cuts: refinement rounds must be >= 0, got " +
                         std::to_string(s.refineRounds));
  const auto start = std::chrono::steady_clock::now();
  const DomainPoints clearance(tracer, rig, domain, kDefaultLightClearanceRelative);
  LeakCutRefineResult r;
  std::vector<Vec3> all(probes.begin(), probes.end());
  // Two probes closer than this are one (a millimetre in a 10 m scene).
  const double minSpacing = 1e-4 * tracer.scene().bounds.diagonal();
  // Each round's cuts are those bake computes on the same probes (same seed), so the round
  // with the fewest points still leaking is kept: a probe added for one leak can make another.
  double bestLeaking = std::numeric_limits<double>::infinity();
  size_t bestAdded = 0;
  PointGrid grid(std::max(minSpacing, 1e-12));
  for (size_t i = 0; i < all.size(); ++i) grid.insert(all[i], int32_t(i));
  for (int round = 0; round <= s.refineRounds; ++round) {
    const Tetrahedralization t = tetrahedralize(all);
    ProbeVolume v = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
    const LeakCutResult cuts = computeLeakCuts(tracer, v, domain, s);
    ++r.rounds;
    // A fraction: each round's mesh draws its own number of points.
    const double leakingFraction =
        cuts.samples > 0 ? double(cuts.hiddenSamplesAfter) / double(cuts.samples) : 0.0;
    if (leakingFraction < bestLeaking) {
      bestLeaking = leakingFraction;
      bestAdded = r.added.size();
      r.unresolvedTets = cuts.tetsUnresolved;
    }
    if (cuts.unresolved.empty() || round == s.refineRounds || r.added.size() >= s.maxAdded) break;
    size_t addedThisRound = 0;
    for (const Vec3& p : cuts.unresolved) {
      if (r.added.size() >= s.maxAdded) break;
      if (!clearance.clearOfLights(p)) continue;
      if (grid.nearestWithin(p, minSpacing, [](Vec3) { return true; }) >= 0) continue;
      grid.insert(p, int32_t(all.size()));
      all.push_back(p);
      r.added.push_back(p);
      ++addedThisRound;
    }
    if (addedThisRound == 0) break;
  }
  r.added.resize(bestAdded);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace ps
