#include "core/placement/Coverage.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>
#include <tuple>
#include <utility>

#include "core/common/Error.h"
#include "core/math/Random.h"
#include "core/placement/PlacementMethod.h"

namespace ps {

namespace {

/// A hull probe keeps this far from every surface along the axes: a probe on the floor captures
/// a hemisphere of it, and its SH rings in the directions along the floor.
constexpr double kHullClearanceMeters = 0.15;

/// The distance from p to the nearest of `lights` (infinite without lights), metres.
double nearestLight(const std::vector<Vec3>& lights, Vec3 p) {
  double d = std::numeric_limits<double>::infinity();
  for (const Vec3& l : lights) d = std::min(d, length(l - p));
  return d;
}

/// True when the segment between a and b crosses no geometry.
bool sees(const Tracer& tracer, Vec3 a, Vec3 b) {
  const Vec3 d = b - a;
  const double len = length(d);
  if (len < 1e-9) return true;
  const double eps = std::min(0.25, tracer.rayEpsilon() / len);
  return !tracer.occluded(Ray{a, d, eps, 1 - eps});
}

/// The 26 directions of a cube's corners, edges and faces, corners first: a box's corner probes
/// reach as far as its edges' and faces' extremes, so those then need none of their own.
std::vector<Vec3> hullDirections() {
  std::vector<Vec3> dirs;
  for (int kind = 3; kind >= 1; --kind)  // non-zero components: corners, edges, faces
    for (int z = -1; z <= 1; ++z)
      for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x)
          if (std::abs(x) + std::abs(y) + std::abs(z) == kind)
            dirs.push_back(normalize(Vec3{double(x), double(y), double(z)}));
  return dirs;
}

struct RoomOutcome {
  std::vector<Vec3> probes;
  bool coveredByKept = false;
  bool partly = false;
};

/// The covering of one room (Coverage.h step 1): `cells` its cells in the domain (centres),
/// `kept` the kept probes in it.
RoomOutcome coverRoom(const Tracer& tracer, const std::vector<Vec3>& cells,
                      const std::vector<Vec3>& kept, std::span<const Vec3> avoid,
                      double avoidMeters, const CoverageSettings& s, uint64_t rng) {
  RoomOutcome out;
  std::vector<Vec3> tested;
  const size_t stride =
      (cells.size() + size_t(s.testedCellsPerRoom) - 1) / size_t(s.testedCellsPerRoom);
  for (size_t i = 0; i < cells.size(); i += stride) tested.push_back(cells[i]);
  std::vector<char> seen(tested.size(), 0);
  auto markSeenFrom = [&](Vec3 p) {
    for (size_t i = 0; i < tested.size(); ++i)
      if (!seen[i] && sees(tracer, p, tested[i])) seen[i] = 1;
  };
  for (const Vec3& k : kept) markSeenFrom(k);
  auto unseenIndices = [&] {
    std::vector<size_t> u;
    for (size_t i = 0; i < tested.size(); ++i)
      if (!seen[i]) u.push_back(i);
    return u;
  };
  // Candidates keep off the rejected spots and out of the lights' clearance; where no cell of
  // the room is out of it, the clearance shrinks to the farthest any cell gets.
  std::vector<double> lightDistance(tested.size());
  for (size_t i = 0; i < tested.size(); ++i) lightDistance[i] = nearestLight(s.lights, tested[i]);
  double clearance = s.lightClearanceMeters;
  if (clearance > 0 && !s.lights.empty())
    clearance = std::min(clearance, *std::max_element(lightDistance.begin(), lightDistance.end()));
  auto allowed = [&](size_t i) {
    return lightDistance[i] >= clearance && !withinAny(avoid, tested[i], avoidMeters);
  };
  std::vector<size_t> unseen = unseenIndices();
  const double limit = s.unseenShare * double(tested.size());
  if (!kept.empty() && double(unseen.size()) <= limit) {
    out.coveredByKept = true;
    return out;
  }
  while (double(unseen.size()) > limit && int(out.probes.size()) < s.maxProbesPerRoom) {
    Vec3 centroid{0, 0, 0};
    for (size_t i : unseen) centroid += tested[i];
    centroid *= 1.0 / double(unseen.size());
    // Candidates: the unseen cell nearest the centroid, then unseen cells drawn at random.
    std::vector<Vec3> candidates;
    size_t nearest = unseen.size();
    double best = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < unseen.size(); ++k) {
      const double d = length(tested[unseen[k]] - centroid);
      if (d < best && allowed(unseen[k])) best = d, nearest = k;
    }
    if (nearest < unseen.size()) candidates.push_back(tested[unseen[nearest]]);
    for (int tries = 0; int(candidates.size()) < s.candidates && tries < 4 * s.candidates;
         ++tries) {
      const size_t i =
          unseen[std::min(unseen.size() - 1, size_t(uniform01(rng) * double(unseen.size())))];
      if (allowed(i)) candidates.push_back(tested[i]);
    }
    if (candidates.empty()) break;  // every unseen cell is beside a rejected probe
    // Scored against an even subsample of the unseen cells; among those within 90 % of the best
    // score, the one nearest the centroid (away from walls and corners).
    const size_t scoreStride = (unseen.size() + size_t(s.scoredCells) - 1) / size_t(s.scoredCells);
    std::vector<int> score(candidates.size(), 0);
    for (size_t c = 0; c < candidates.size(); ++c)
      for (size_t k = 0; k < unseen.size(); k += scoreStride)
        score[c] += sees(tracer, candidates[c], tested[unseen[k]]) ? 1 : 0;
    const int top = *std::max_element(score.begin(), score.end());
    size_t pick = 0;
    double pickDistance = std::numeric_limits<double>::infinity();
    for (size_t c = 0; c < candidates.size(); ++c) {
      const double d = length(candidates[c] - centroid);
      if (double(score[c]) >= 0.9 * double(top) && d < pickDistance) pick = c, pickDistance = d;
    }
    out.probes.push_back(candidates[pick]);
    markSeenFrom(candidates[pick]);
    unseen = unseenIndices();
  }
  out.partly = double(unseen.size()) > limit;
  return out;
}

}  // namespace

CoverageResult coverDomain(const Tracer& tracer, const Domain& domain, std::span<const Vec3> kept,
                           std::span<const Vec3> avoid, double avoidMeters,
                           const CoverageSettings& s, const ProgressFn& progress) {
  if (!(s.unseenShare >= 0 && s.unseenShare < 1))
    throw ParameterError("unseenShare",
                         "expected a share in [0, 1), got " + std::to_string(s.unseenShare));
  if (s.maxProbesPerRoom < 1 || s.testedCellsPerRoom < 1 || s.candidates < 1 || s.scoredCells < 1)
    throw ParameterError("coverage", "expected counts of at least 1");
  RoomSettings rs = s.rooms;
  rs.seed = s.seed;
  CoverageResult out;
  out.roomMap = std::make_shared<const RoomMap>(tracer, domain.boxes, rs);
  const RoomMap& rooms = *out.roomMap;
  out.roomNote = rooms.note();

  // Each room's cells in the domain, and the domain's extreme cells for the hull.
  const std::vector<Vec3> dirs = hullDirections();
  std::vector<double> extremeDot(dirs.size(), -std::numeric_limits<double>::infinity());
  std::vector<std::vector<Vec3>> cells(size_t(rooms.roomCount()));
  for (size_t c = 0; c < rooms.cellCount(); ++c) {
    const int r = rooms.roomOfCell(c);
    if (r < 0) continue;
    const Vec3 p = rooms.cellCentre(c);
    if (!domain.contains(p)) continue;
    cells[size_t(r)].push_back(p);
    for (size_t d = 0; d < dirs.size(); ++d) {
      const double v = dot(dirs[d], p);
      extremeDot[d] = std::max(extremeDot[d], v);
    }
  }
  std::vector<std::vector<Vec3>> keptIn(cells.size());
  for (const Vec3& k : kept) {
    const int r = rooms.roomOf(k);
    if (r >= 0) keptIn[size_t(r)].push_back(k);
  }

  std::vector<RoomOutcome> outcomes(cells.size());
  std::atomic<bool> cancelled{false};
  std::atomic<size_t> done{0};
  std::mutex progressMutex;
  tbb::parallel_for(size_t(0), cells.size(), [&](size_t r) {
    if (cancelled.load() || cells[r].empty()) return;
    outcomes[r] =
        coverRoom(tracer, cells[r], keptIn[r], avoid, avoidMeters, s, streamSeed(s.seed, r));
    const size_t n = ++done;
    if (progress) {
      std::lock_guard<std::mutex> lock(progressMutex);
      if (!progress(0.95 * double(n) / double(cells.size()))) cancelled = true;
    }
  });
  if (cancelled) throw Cancelled();
  std::vector<Vec3> all(kept.begin(), kept.end());
  for (size_t r = 0; r < cells.size(); ++r) {
    if (cells[r].empty()) continue;
    ++out.rooms;
    out.roomsCoveredByKept += outcomes[r].coveredByKept ? 1 : 0;
    out.roomsPartlyCovered += outcomes[r].partly ? 1 : 0;
    for (const Vec3& p : outcomes[r].probes) {
      out.probes.push_back(p);
      all.push_back(p);
    }
  }
  out.roomProbes = out.probes.size();

  if (s.hull) {
    // Each direction's extreme cells, most extreme first; the first one clear of surfaces.
    const double reach = rooms.cellMeters();
    auto axis = [](int a, double sign) {
      Vec3 d{0, 0, 0};
      (a == 0 ? d.x : a == 1 ? d.y : d.z) = sign;
      return d;
    };
    // p moved away from the surfaces nearer than the clearance along each axis, or nothing when
    // it then is not clear on every axis (a gap narrower than twice the clearance) or has left
    // the domain.
    auto clearOf = [&](Vec3 p) -> std::optional<Vec3> {
      Vec3 q = p;
      for (int a = 0; a < 3; ++a)
        for (double sign : {-1.0, 1.0})
          if (const auto hit = tracer.intersect(Ray{p, axis(a, sign), 0, kHullClearanceMeters}))
            q -= axis(a, sign) * (kHullClearanceMeters - hit->t);
      for (int a = 0; a < 3; ++a)
        for (double sign : {-1.0, 1.0})
          if (tracer.occluded(Ray{q, axis(a, sign), 0, kHullClearanceMeters - 1e-6}))
            return std::nullopt;
      if (!domain.contains(q)) return std::nullopt;
      return q;
    };
    for (size_t d = 0; d < dirs.size(); ++d) {
      if (!std::isfinite(extremeDot[d])) continue;  // no cell in the domain
      const bool reached = std::any_of(all.begin(), all.end(), [&](const Vec3& p) {
        return dot(dirs[d], p) >= extremeDot[d] - reach - kHullClearanceMeters;
      });
      if (reached) continue;
      // The domain's cells within a cell and the clearance of the extreme, most extreme first.
      std::vector<std::pair<double, Vec3>> near;
      for (const std::vector<Vec3>& room : cells)
        for (const Vec3& p : room)
          if (dot(dirs[d], p) >= extremeDot[d] - reach - kHullClearanceMeters)
            near.push_back({-dot(dirs[d], p), p});
      std::sort(near.begin(), near.end(), [](const auto& a, const auto& b) {
        return a.first < b.first ||
               (a.first == b.first && std::tie(a.second.x, a.second.y, a.second.z) <
                                          std::tie(b.second.x, b.second.y, b.second.z));
      });
      for (const auto& [negDot, cell] : near) {
        const std::optional<Vec3> p = clearOf(cell);
        if (!p || nearestLight(s.lights, *p) < s.lightClearanceMeters ||
            withinAny(avoid, *p, avoidMeters))
          continue;
        out.probes.push_back(*p);
        all.push_back(*p);
        ++out.hullProbes;
        break;
      }
    }
  }
  if (progress && !progress(1.0)) throw Cancelled();
  return out;
}

RoomCount roomsWithoutProbes(const Tracer& tracer, const Domain& domain,
                             std::span<const Vec3> probes, const RoomSettings& settings) {
  const RoomMap rooms(tracer, domain.boxes, settings);
  std::vector<char> inDomain(size_t(rooms.roomCount()), 0), holds(inDomain.size(), 0);
  for (size_t c = 0; c < rooms.cellCount(); ++c) {
    const int r = rooms.roomOfCell(c);
    if (r >= 0 && !inDomain[size_t(r)] && domain.contains(rooms.cellCentre(c)))
      inDomain[size_t(r)] = 1;
  }
  for (const Vec3& p : probes) {
    const int r = rooms.roomOf(p);
    if (r >= 0) holds[size_t(r)] = 1;
  }
  RoomCount out;
  for (size_t r = 0; r < inDomain.size(); ++r)
    if (inDomain[r]) {
      ++out.rooms;
      out.empty += holds[r] ? 0 : 1;
    }
  return out;
}

}  // namespace ps
