#include "core/placement/RegionalGreedy.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <mutex>
#include <numeric>
#include <string>

#include "core/common/Check.h"
#include "core/common/Error.h"

namespace ps {

namespace {

/// A cut of the k-d split: points with coordinate `axis` below `at` go to `left`, the others
/// to `right` (node indices; a leaf has region >= 0).
struct KdNode {
  int axis = 0;
  double at = 0;
  int left = -1, right = -1;
  int region = -1;
};

/// Splits `idx` (field sample indices) into `regions` leaves, appending nodes to `nodes` and
/// each leaf's samples to `leaves` in region order; returns the node's index. A cut parts the
/// held-out points `held` (indices into `heldOut`) in the ratio of the regions on either side by
/// weight, as the first pass shares the budget by it, so that the regions' budgets, and their
/// cost (a region's trials re-mesh its probes: its time grows faster than its probe count), come
/// out alike; without held-out points, the samples in that ratio. O((S + H) log (S + H)) per
/// level, log2(regions) levels.
int splitSamples(const DenseField& field, std::span<const HeldOutSample> heldOut,
                 std::vector<size_t> idx, std::vector<size_t> held, int regions,
                 std::vector<KdNode>& nodes, std::vector<std::vector<size_t>>& leaves) {
  const int self = int(nodes.size());
  nodes.emplace_back();
  if (regions <= 1 || idx.size() < 2) {
    nodes[size_t(self)].region = int(leaves.size());
    leaves.push_back(std::move(idx));
    return self;
  }
  Bounds3 box;
  for (size_t i : idx) box.extend(field.samples[i].position);
  const Vec3 e = box.extent();
  const int axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
  auto coord = [&](size_t i) { return field.samples[i].position[axis]; };
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) {
    return coord(a) < coord(b) || (coord(a) == coord(b) && a < b);
  });
  const int leftRegions = regions / 2;
  size_t target = idx.size() * size_t(leftRegions) / size_t(regions);
  double heldWeight = 0;
  for (size_t h : held) heldWeight += heldOut[h].weight;
  if (heldWeight > 0) {
    // The coordinate below which the held-out points hold the left regions' share of the
    // weight; the target is the samples below it.
    auto hcoord = [&](size_t h) { return heldOut[h].position[axis]; };
    std::sort(held.begin(), held.end(), [&](size_t a, size_t b) {
      return hcoord(a) < hcoord(b) || (hcoord(a) == hcoord(b) && a < b);
    });
    const double want = heldWeight * double(leftRegions) / double(regions);
    double below = 0, at = hcoord(held.back());
    for (size_t h : held) {
      below += heldOut[h].weight;
      if (below >= want) {
        at = hcoord(h);
        break;
      }
    }
    target = size_t(std::lower_bound(idx.begin(), idx.end(), at,
                                     [&](size_t i, double x) { return coord(i) < x; }) -
                    idx.begin());
  }
  target = std::clamp<size_t>(target, 1, idx.size() - 1);
  // The nearest place to the target where the coordinate changes: a plane between the halves.
  size_t cut = target;
  for (size_t d = 0; d < idx.size(); ++d) {
    if (target >= d && target - d >= 1 && coord(idx[target - d - 1]) < coord(idx[target - d])) {
      cut = target - d;
      break;
    }
    if (target + d < idx.size() && coord(idx[target + d - 1]) < coord(idx[target + d])) {
      cut = target + d;
      break;
    }
  }
  const double at = coord(idx[cut - 1]) < coord(idx[cut])
                        ? 0.5 * (coord(idx[cut - 1]) + coord(idx[cut]))
                        : coord(idx[cut]);
  std::vector<size_t> right(idx.begin() + std::ptrdiff_t(cut), idx.end());
  idx.resize(cut);
  std::vector<size_t> heldLeft, heldRight;
  for (size_t h : held) (heldOut[h].position[axis] < at ? heldLeft : heldRight).push_back(h);
  const int l =
      splitSamples(field, heldOut, std::move(idx), std::move(heldLeft), leftRegions, nodes, leaves);
  const int r = splitSamples(field, heldOut, std::move(right), std::move(heldRight),
                             regions - leftRegions, nodes, leaves);
  nodes[size_t(self)].axis = axis;
  nodes[size_t(self)].at = at;
  nodes[size_t(self)].left = l;
  nodes[size_t(self)].right = r;
  return self;
}

/// The region of the leaf holding `p`.
size_t regionOf(const std::vector<KdNode>& nodes, Vec3 p) {
  size_t n = 0;
  while (nodes[n].region < 0)
    n = size_t(p[nodes[n].axis] < nodes[n].at ? nodes[n].left : nodes[n].right);
  return size_t(nodes[n].region);
}

/// A region's own inputs: its field (its samples, the whole field's domain), held-out points
/// and kept probes, and its samples' indices in the whole field.
struct RegionInput {
  DenseField field;
  std::vector<size_t> sampleIndex;
  std::vector<HeldOutSample> heldOut;
  std::vector<KeptProbe> kept;
  double shareWeight = 0;  ///< held-out weight (or samples) it stands for
  size_t free = 0;         ///< samples a new probe may go on (outside the light clearance)
};

/// A step of a region's lower convex hull of (new probes, weighted squared error): from
/// `from` to `to` new probes, dropping the error by `drop` per probe.
struct HullStep {
  size_t region = 0, from = 0, to = 0;
  double drop = 0;
};

/// The lower convex hull's steps of `err` (weighted squared error with k additions at index k,
/// k from 0), offset by `base` probes. O(k).
std::vector<HullStep> hullSteps(size_t region, size_t base, const std::vector<double>& err) {
  std::vector<size_t> hull;  // indices into err, the lower convex hull's vertices
  for (size_t k = 0; k < err.size(); ++k) {
    while (hull.size() >= 2) {
      const size_t a = hull[hull.size() - 2], b = hull.back();
      // b lies on or above the segment a..k: not a vertex of the lower hull.
      if ((err[b] - err[a]) * double(k - a) >= (err[k] - err[a]) * double(b - a))
        hull.pop_back();
      else
        break;
    }
    hull.push_back(k);
  }
  std::vector<HullStep> steps;
  for (size_t m = 1; m < hull.size(); ++m)
    steps.push_back({region, base + hull[m - 1], base + hull[m],
                     (err[hull[m - 1]] - err[hull[m]]) / double(hull[m] - hull[m - 1])});
  return steps;
}

/// The budget each region gets (new probes): its initial ones, then the hull steps with the
/// largest drop per probe, whole while they fit, the last one in part. `initial[r]` and
/// `steps` (all regions') as measured; `newBudget` at least the sum of `initial`.
std::vector<size_t> shareBudget(const std::vector<size_t>& initial, std::vector<HullStep> steps,
                                size_t newBudget) {
  std::vector<size_t> take = initial;
  size_t left = newBudget - std::accumulate(initial.begin(), initial.end(), size_t(0));
  std::sort(steps.begin(), steps.end(), [](const HullStep& a, const HullStep& b) {
    return a.drop > b.drop ||
           (a.drop == b.drop && (a.region < b.region || (a.region == b.region && a.from < b.from)));
  });
  for (const HullStep& s : steps) {
    if (left == 0) break;
    // The hull's steps of a region fall in drop, so a region's steps come in order.
    PS_CHECK_EQ(take[s.region], s.from);
    const size_t n = std::min(left, s.to - s.from);
    take[s.region] += n;
    left -= n;
    if (n < s.to - s.from) break;  // the rest of the budget goes to no later step
  }
  return take;
}

/// `m` (a region's first pass, additions only) cut to its first `newProbes` new probes, as
/// placeGreedy with that budget (and `keptCount` kept probes) would have placed them: the same
/// initial samples and additions in order, the error history and error up to there.
GreedyResult prefixOf(GreedyResult m, size_t newProbes, size_t keptCount) {
  PS_CHECK_LE(newProbes, m.positions.size());
  PS_CHECK_GE(newProbes, m.initialCount);
  m.positions.resize(newProbes);
  m.sampleIndex.resize(newProbes);
  m.scores.resize(newProbes);
  m.errorHistory.resize(newProbes - m.initialCount + 1);
  m.fieldError = m.errorHistory.back();
  if (m.noImprovement && m.probesAtNoImprovement > keptCount + newProbes) {
    m.noImprovement = false;
    m.probesAtNoImprovement = 0;
  }
  m.trials = 0;  // counted with the first pass
  return m;
}

}  // namespace

int regionalGreedyRegions(size_t newProbes) {
  if (newProbes <= size_t(kRegionalMinNewProbes)) return 1;
  return int(newProbes / size_t(kRegionalProbesPerRegion));
}

RegionalGreedyResult placeRegionalGreedy(const DenseField& field, std::span<const KeptProbe> kept,
                                         const GreedySettings& settings, int regionCount,
                                         const RegionCaptureFactory& captureFor,
                                         const ProgressFn& progress, const RoomMap* rooms) {
  checkGreedySettings(settings, kept.size());
  if (settings.budget == 0) throw ParameterError("budget", "regional greedy needs a probe budget");
  PS_CHECK_GE(regionCount, 2);
  const size_t R = size_t(regionCount);
  const size_t newBudget = size_t(settings.budget) - kept.size();
  if (newBudget < 8 * R)
    throw ParameterError("regions", std::to_string(R) + " regions need at least 8 new probes " +
                                        "each, and the budget leaves " + std::to_string(newBudget));
  // 1. Split.
  std::vector<size_t> all(field.samples.size());
  std::iota(all.begin(), all.end(), size_t(0));
  std::vector<KdNode> nodes;
  std::vector<std::vector<size_t>> leaves;
  std::vector<size_t> held(settings.heldOut.size());
  std::iota(held.begin(), held.end(), size_t(0));
  splitSamples(field, settings.heldOut, std::move(all), std::move(held), regionCount, nodes,
               leaves);
  PS_CHECK_EQ(leaves.size(), R);
  // With rooms, each room goes whole to the region holding most of its samples, so that the
  // regions' borders run along walls: a point is then interpolated from the probes of its own
  // room's region, as the volume's visibility will read it. A room that would weigh more than
  // a region (by held-out weight, or samples without held-out points: a storey's corridors
  // joined into one space) keeps the k-d cuts, which part it through open space, so that no
  // region takes several regions' budget and time. Points in no room keep the k-d region.
  std::vector<int> roomRegion;
  if (rooms != nullptr) {
    const size_t roomCount = size_t(rooms->roomCount());
    std::vector<std::vector<size_t>> count(roomCount, std::vector<size_t>(R, 0));
    std::vector<double> roomWeight(roomCount, 0.0);
    double totalWeight = 0;
    for (size_t r = 0; r < R; ++r)
      for (size_t i : leaves[r]) {
        const int room = rooms->roomOf(field.samples[i].position);
        if (room >= 0) ++count[size_t(room)][r];
        if (room >= 0 && settings.heldOut.empty()) roomWeight[size_t(room)] += 1;
        if (settings.heldOut.empty()) totalWeight += 1;
      }
    for (const HeldOutSample& h : settings.heldOut) {
      const int room = rooms->roomOf(h.position);
      if (room >= 0) roomWeight[size_t(room)] += h.weight;
      totalWeight += h.weight;
    }
    for (size_t room = 0; room < roomCount; ++room) {
      const std::vector<size_t>& c = count[room];
      const auto most = std::max_element(c.begin(), c.end());
      const bool whole = *most > 0 && roomWeight[room] <= totalWeight / double(R);
      roomRegion.push_back(whole ? int(most - c.begin()) : -1);
    }
  }
  auto regionAt = [&](Vec3 p) {
    const int room = rooms != nullptr ? rooms->roomOf(p) : -1;
    return room >= 0 && roomRegion[size_t(room)] >= 0 ? size_t(roomRegion[size_t(room)])
                                                      : regionOf(nodes, p);
  };
  if (rooms != nullptr) {
    for (std::vector<size_t>& leaf : leaves) leaf.clear();
    for (size_t i = 0; i < field.samples.size(); ++i)
      leaves[regionAt(field.samples[i].position)].push_back(i);
  }
  std::vector<RegionInput> in(R);
  const double avoidSq = settings.avoidRadius * settings.avoidRadius;
  for (size_t r = 0; r < R; ++r) {
    RegionInput& g = in[r];
    g.field.domain = field.domain;
    g.field.baseSpacingMeters = field.baseSpacingMeters;
    g.sampleIndex = leaves[r];
    for (size_t i : leaves[r]) {
      g.field.samples.push_back(field.samples[i]);
      bool avoided = false;
      for (const Vec3& a : settings.avoid) {
        const Vec3 d = field.samples[i].position - a;
        avoided = avoided || dot(d, d) < avoidSq;
      }
      g.free += avoided ? 0 : 1;
    }
    if (settings.heldOut.empty()) g.shareWeight = double(leaves[r].size());
  }
  for (const HeldOutSample& h : settings.heldOut) {
    RegionInput& g = in[regionAt(h.position)];
    g.heldOut.push_back(h);
    g.shareWeight += h.weight;
  }
  for (const KeptProbe& k : kept) in[regionAt(k.position)].kept.push_back(k);
  double totalWeight = 0;
  for (const RegionInput& g : in) totalWeight += g.shareWeight;
  size_t freeTotal = 0;
  for (const RegionInput& g : in) freeTotal += g.free;
  if (newBudget > freeTotal)
    throw ParameterError("budget", "expected at most " + std::to_string(kept.size() + freeTotal) +
                                       " probes: the dense field has " + std::to_string(freeTotal) +
                                       " samples to place new probes on (a finer field has "
                                       "more), got " +
                                       std::to_string(settings.budget));

  RegionalGreedyResult out;
  out.regions.resize(R);
  std::vector<GreedyResult> results(R);
  std::mutex progressMutex;
  std::atomic<bool> cancelled{false};
  size_t done = 0;
  auto regionDone = [&](double pass0, double passShare) {
    const std::lock_guard<std::mutex> lock(progressMutex);
    ++done;
    if (progress && !progress(pass0 + passShare * double(done) / double(R))) cancelled = true;
  };
  const ProgressFn regionProgress = [&](double) { return !cancelled.load(); };
  // Runs greedy in every region at once with `budgetOf(r)` new probes and `swapPasses`; a
  // region whose `reuse(r)` is true keeps the first budgetOf(r) new probes of its result.
  auto runRegions = [&](int pass, const std::vector<size_t>& budgetOf, int swapPasses, double pass0,
                        double passShare, const std::function<bool(size_t)>& reuse) {
    done = 0;
    tbb::parallel_for(size_t(0), R, [&](size_t r) {
      RegionInput& g = in[r];
      GreedyRegion& info = out.regions[r];
      if (reuse && reuse(r)) {
        results[r] = prefixOf(std::move(results[r]), budgetOf[r], g.kept.size());
        results[r].swapsSkipped = greedySwapsSkipped(swapPasses, results[r].unresolvedShare);
        regionDone(pass0, passShare);
        return;
      }
      results[r] = GreedyResult();
      if (!info.refused.empty() || budgetOf[r] == 0) {
        regionDone(pass0, passShare);
        return;
      }
      GreedySettings s = settings;
      s.budget = int(g.kept.size() + budgetOf[r]);
      s.maxError = 0;
      s.swapPasses = swapPasses;
      s.heldOut = g.heldOut;
      if (captureFor) s.captureProbeValues = captureFor(r, pass);
      try {
        results[r] = placeGreedy(g.field, g.kept, s, regionProgress);
      } catch (const ParameterError& e) {
        info.refused = e.what();
      }
      regionDone(pass0, passShare);
    });
    if (cancelled) throw Cancelled();
  };

  // 2. Measure.
  std::vector<size_t> measureBudget(R);
  for (size_t r = 0; r < R; ++r) {
    const RegionInput& g = in[r];
    const double share = totalWeight > 0 ? g.shareWeight / totalWeight : 1.0 / double(R);
    const size_t wanted = size_t(std::ceil(kRegionalOvershoot * double(newBudget) * share));
    measureBudget[r] = std::min(g.free, std::max<size_t>(wanted, 8));
    if (measureBudget[r] < 4) measureBudget[r] = 0;  // no room for a mesh: no new probes
    out.regions[r].box = Bounds3();
    for (const FieldSample& f : g.field.samples) out.regions[r].box.extend(f.position);
    out.regions[r].samples = g.field.samples.size();
    out.regions[r].heldOut = g.heldOut.size();
    out.regions[r].kept = g.kept.size();
  }
  runRegions(0, measureBudget, 0, 0.0, 0.4, nullptr);

  // 3. Share.
  std::vector<size_t> initial(R, 0);
  std::vector<HullStep> steps;
  for (size_t r = 0; r < R; ++r) {
    const GreedyResult& m = results[r];
    out.trials += m.trials;
    out.regions[r].measuredProbes = m.positions.size();
    if (m.positions.empty()) continue;
    initial[r] = m.initialCount;
    std::vector<double> err;
    for (double e : m.errorHistory) err.push_back(e * e * m.errorNorm);
    const std::vector<HullStep> own = hullSteps(r, m.initialCount, err);
    steps.insert(steps.end(), own.begin(), own.end());
  }
  size_t initialSum = std::accumulate(initial.begin(), initial.end(), size_t(0));
  PS_CHECK_LE(initialSum, newBudget);
  std::vector<size_t> take = shareBudget(initial, steps, newBudget);
  // Past every region's measured curve (its free samples capped it): the rest in region order
  // to the regions with free samples left.
  size_t taken = std::accumulate(take.begin(), take.end(), size_t(0));
  for (size_t r = 0; r < R && taken < newBudget; ++r) {
    if (take[r] == 0) continue;
    const size_t more = std::min(newBudget - taken, in[r].free - take[r]);
    take[r] += more;
    taken += more;
  }
  if (taken < newBudget)
    throw ParameterError(
        "budget", "the regions greedy can place in hold " + std::to_string(taken + kept.size()) +
                      " probes, fewer than the budget of " + std::to_string(settings.budget));

  // 4. Place.
  // A region that will not swap (no passes asked, or its light mostly unresolved: placeGreedy
  // skips them) and whose share the first pass reached keeps that pass's first probes: its
  // additions are the same, in the same order, for the same captures and any budget that
  // starts from the same 8 corners (addInitialSamples). The others run again, with the swaps.
  runRegions(1, take, settings.swapPasses, 0.4, 0.6, [&](size_t r) {
    const GreedyResult& m = results[r];
    const bool swaps =
        settings.swapPasses > 0 && !greedySwapsSkipped(settings.swapPasses, m.unresolvedShare);
    return !swaps && take[r] >= 8 && m.initialCount == 8 && take[r] <= m.positions.size();
  });
  double errSum = 0, normSum = 0, unresolvedSum = 0;
  for (size_t r = 0; r < R; ++r) {
    const GreedyResult& g = results[r];
    GreedyRegion& info = out.regions[r];
    info.probes = g.positions.size();
    info.errorNorm = g.errorNorm;
    info.weightedErrSq = g.fieldError * g.fieldError * g.errorNorm;
    errSum += info.weightedErrSq;
    normSum += info.errorNorm;
    unresolvedSum += g.unresolvedShare * info.errorNorm;
    out.trials += g.trials;
    out.swaps += g.swaps;
    info.swapsSkipped = g.swapsSkipped;
    for (size_t i = 0; i < g.positions.size(); ++i) {
      out.positions.push_back(g.positions[i]);
      out.sampleIndex.push_back(in[r].sampleIndex[g.sampleIndex[i]]);
      out.scores.push_back(g.scores[i]);
    }
  }
  out.fieldError = normSum > 0 ? std::sqrt(errSum / normSum) : 0.0;
  out.unresolvedShare = normSum > 0 ? unresolvedSum / normSum : 0.0;
  return out;
}

}  // namespace ps
