// Tessellation and traversal (Sukys 3.2.1): construction against a bare CGAL
// Delaunay_triangulation_3 insertion of the same points, and point location (warm walk from the
// last tet, cold start from the locator, brute-force scan, CGAL's locate), all in the same
// process, ratios reported as counters. Figures: BENCHMARKS.md, "Tessellation and queries".
#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <vector>

#include "core/tessellation/EditableTetrahedralization.h"
#include "core/tessellation/Tetrahedralization.h"
#include "core/traversal/EditableProbeVolume.h"
#include "core/traversal/ProbeVolume.h"
#include "core/traversal/VisibleInterpolation.h"
#include "tests/core/PointSets.h"

using namespace ps;
using ps::testing::gridPoints;
using ps::testing::randomFloatPoints;
using ps::testing::randomPoints;

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalDelaunay = CGAL::Delaunay_triangulation_3<K>;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Bare CGAL: range insertion (spatially sorted, as tetrahedralize() does) of the same points.
size_t cgalInsert(const std::vector<Vec3>& pts) {
  std::vector<K::Point_3> cp;
  cp.reserve(pts.size());
  for (Vec3 p : pts) cp.emplace_back(p.x, p.y, p.z);
  CgalDelaunay dt(cp.begin(), cp.end());
  return dt.number_of_finite_cells();
}

// Per iteration: tetrahedralize() (the reported time, manual) and the bare CGAL insertion of the
// same points; counter "vs_cgal" = our time / CGAL's (goal <= 1.2).
void constructVsCgal(benchmark::State& state, const std::vector<Vec3>& pts) {
  double ours = 0, cgal = 0;
  size_t tets = 0;
  for (auto _ : state) {
    auto t0 = Clock::now();
    const Tetrahedralization t = tetrahedralize(pts);
    const double a = secondsSince(t0);
    t0 = Clock::now();
    const size_t cells = cgalInsert(pts);
    const double b = secondsSince(t0);
    benchmark::DoNotOptimize(cells);
    tets = t.tets.size();
    ours += a;
    cgal += b;
    state.SetIterationTime(a);
  }
  state.counters["tets"] = double(tets);
  state.counters["cgal_ms"] = 1e3 * cgal / double(state.iterations());
  state.counters["vs_cgal"] = ours / cgal;
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(pts.size()));
}

void BM_TetrahedralizeRandom10k(benchmark::State& state) {
  static const auto pts = randomPoints(10000, 37);
  constructVsCgal(state, pts);
}
BENCHMARK(BM_TetrahedralizeRandom10k)->UseManualTime()->Unit(benchmark::kMillisecond);

void BM_TetrahedralizeGrid20(benchmark::State& state) {
  static const auto pts = gridPoints(20);
  constructVsCgal(state, pts);
}
BENCHMARK(BM_TetrahedralizeGrid20)->UseManualTime()->Unit(benchmark::kMillisecond);

void BM_TetrahedralizeRandom100k(benchmark::State& state) {
  static const auto pts = randomPoints(100000, 37);
  constructVsCgal(state, pts);
}
BENCHMARK(BM_TetrahedralizeRandom100k)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

// --- Queries on a 10k-probe volume -------------------------------------------------------------

constexpr int kProbes = 10000;
constexpr int kQueries = 1 << 16;

struct QueryFixture {
  std::vector<Vec3> probes;
  ProbeVolume volume;
  CgalDelaunay cgal;
  std::vector<Vec3> random;    // uniform in the hull's inner 90 %
  std::vector<Vec3> coherent;  // a moving object: steps of 1 % of a tet's edge
};

const QueryFixture& queries() {
  static const QueryFixture* f = [] {
    auto* q = new QueryFixture;
    q->probes = randomFloatPoints(kProbes, 41);
    const Tetrahedralization t = tetrahedralize(q->probes);
    q->volume = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
    std::vector<K::Point_3> cp;
    for (Vec3 p : q->probes) cp.emplace_back(p.x, p.y, p.z);
    q->cgal.insert(cp.begin(), cp.end());
    double edge = 0;
    int edges = 0;
    for (const auto& tet : q->volume.tets)
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j, ++edges)
          edge += length(q->volume.position(tet[i]) - q->volume.position(tet[j]));
    const double step = 0.01 * edge / edges;
    uint64_t s = streamSeed(41, 1);
    for (int i = 0; i < kQueries; ++i)
      q->random.push_back(Vec3(0.05, 0.05, 0.05) +
                          Vec3(uniform01(s), uniform01(s), uniform01(s)) * 0.9);
    // A closed curve of length ~2.9 (radius 0.4 circle with a vertical wobble) walked at
    // `step` per query; parameter increments are scaled so each step has length ~step.
    double a = 0;
    for (int i = 0; i < kQueries; ++i) {
      q->coherent.push_back(
          {0.5 + 0.4 * std::cos(a), 0.5 + 0.4 * std::sin(a), 0.5 + 0.3 * std::sin(2 * a)});
      const double speed = std::sqrt(0.16 + 0.36 * std::cos(2 * a) * std::cos(2 * a));
      a += step / speed;
    }
    return q;
  }();
  return *f;
}

// A renderer's brute force: the first tet whose float-matrix barycentrics are all >= -slack.
int32_t bruteForceScan(const ProbeVolume& v, Vec3 p) {
  for (int32_t t = 0; t < int32_t(v.tets.size()); ++t) {
    const auto& m = v.matrices[t];
    const Vec3 d = p - v.position(v.tets[t][3]);
    const double w0 = m[0] * d.x + m[1] * d.y + m[2] * d.z;
    const double w1 = m[3] * d.x + m[4] * d.y + m[5] * d.z;
    const double w2 = m[6] * d.x + m[7] * d.y + m[8] * d.z;
    const double s = -1e-5;
    if (w0 >= s && w1 >= s && w2 >= s && 1 - w0 - w1 - w2 >= s) return t;
  }
  return -1;
}

// Manual-time helper: runs `f(i)` for `n` queries and returns ns per query.
template <class F>
double nsPerQuery(int n, F&& f) {
  const auto t0 = Clock::now();
  for (int i = 0; i < n; ++i) f(i);
  return 1e9 * secondsSince(t0) / n;
}

// The moving object: warm walk from the last tet (the reported time) against a cold start from
// the locator and a brute-force scan for the same points.
void BM_LocateCoherentWarmVsColdVsBrute(benchmark::State& state) {
  const QueryFixture& q = queries();
  const int bruteN = 256;
  double warm = 0, cold = 0, brute = 0;
  int32_t sink = 0;
  for (auto _ : state) {
    int32_t hint = -1;
    warm = nsPerQuery(kQueries, [&](int i) {
      hint = locate(q.volume, q.coherent[i], hint).tet;
      sink += hint;
    });
    cold = nsPerQuery(kQueries, [&](int i) { sink += locate(q.volume, q.coherent[i]).tet; });
    brute = nsPerQuery(bruteN, [&](int i) { sink += bruteForceScan(q.volume, q.coherent[i]); });
    state.SetIterationTime(warm * 1e-9 * kQueries);
  }
  benchmark::DoNotOptimize(sink);
  state.counters["warm_ns"] = warm;
  state.counters["cold_ns"] = cold;
  state.counters["brute_ns"] = brute;
  state.counters["cold_over_warm"] = cold / warm;
  state.counters["brute_over_warm"] = brute / warm;
  state.SetItemsProcessed(int64_t(state.iterations()) * kQueries);
}
BENCHMARK(BM_LocateCoherentWarmVsColdVsBrute)->UseManualTime()->Unit(benchmark::kMillisecond);

// The same three ways, one per benchmark, in CPU time per query (robust to a shared machine).
void BM_LocateCoherentWarm(benchmark::State& state) {
  const QueryFixture& q = queries();
  int32_t hint = -1;
  size_t i = 0;
  for (auto _ : state) {
    hint = locate(q.volume, q.coherent[i], hint).tet;
    benchmark::DoNotOptimize(hint);
    i = (i + 1) % q.coherent.size();
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_LocateCoherentWarm);

void BM_LocateCoherentCold(benchmark::State& state) {
  const QueryFixture& q = queries();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(locate(q.volume, q.coherent[i]).tet);
    i = (i + 1) % q.coherent.size();
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_LocateCoherentCold);

void BM_LocateRandomCold(benchmark::State& state) {
  const QueryFixture& q = queries();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(locate(q.volume, q.random[i]).tet);
    i = (i + 1) % q.random.size();
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_LocateRandomCold);

void BM_LocateBruteForceScan(benchmark::State& state) {
  const QueryFixture& q = queries();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(bruteForceScan(q.volume, q.random[i]));
    i = (i + 1) % q.random.size();
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_LocateBruteForceScan);

// Random points: cold start from the locator (the reported time) against a brute-force scan.
void BM_LocateRandomLocatorVsBrute(benchmark::State& state) {
  const QueryFixture& q = queries();
  const int bruteN = 256;
  double cold = 0, brute = 0;
  int32_t sink = 0;
  for (auto _ : state) {
    cold = nsPerQuery(kQueries, [&](int i) { sink += locate(q.volume, q.random[i]).tet; });
    brute = nsPerQuery(bruteN, [&](int i) { sink += bruteForceScan(q.volume, q.random[i]); });
    state.SetIterationTime(cold * 1e-9 * kQueries);
  }
  benchmark::DoNotOptimize(sink);
  state.counters["locator_ns"] = cold;
  state.counters["brute_ns"] = brute;
  state.counters["brute_over_locator"] = brute / cold;
  state.SetItemsProcessed(int64_t(state.iterations()) * kQueries);
}
BENCHMARK(BM_LocateRandomLocatorVsBrute)->UseManualTime()->Unit(benchmark::kMillisecond);

// Our locate against CGAL's Delaunay_triangulation_3::locate on the same 10k points: random
// points (ours cold from the locator, CGAL without hint) and the moving object (both hinted
// with the previous answer). Counters: ns per query and CGAL's / ours.
void BM_LocateVsCgal(benchmark::State& state) {
  const QueryFixture& q = queries();
  double oursRandom = 0, cgalRandom = 0, oursCoherent = 0, cgalCoherent = 0;
  size_t sink = 0;
  for (auto _ : state) {
    oursRandom = nsPerQuery(kQueries, [&](int i) { sink += locate(q.volume, q.random[i]).tet; });
    cgalRandom = nsPerQuery(kQueries, [&](int i) {
      const Vec3 p = q.random[i];
      sink += q.cgal.is_infinite(q.cgal.locate(K::Point_3(p.x, p.y, p.z)));
    });
    int32_t hint = -1;
    oursCoherent = nsPerQuery(kQueries, [&](int i) {
      hint = locate(q.volume, q.coherent[i], hint).tet;
      sink += hint;
    });
    CgalDelaunay::Cell_handle c;
    cgalCoherent = nsPerQuery(kQueries, [&](int i) {
      const Vec3 p = q.coherent[i];
      c = q.cgal.locate(K::Point_3(p.x, p.y, p.z), c);
      sink += q.cgal.is_infinite(c);
    });
    state.SetIterationTime(oursRandom * 1e-9 * kQueries);
  }
  benchmark::DoNotOptimize(sink);
  state.counters["ours_random_ns"] = oursRandom;
  state.counters["cgal_random_ns"] = cgalRandom;
  state.counters["ours_coherent_ns"] = oursCoherent;
  state.counters["cgal_coherent_ns"] = cgalCoherent;
  state.counters["cgal_over_ours_random"] = cgalRandom / oursRandom;
  state.counters["cgal_over_ours_coherent"] = cgalCoherent / oursCoherent;
}
BENCHMARK(BM_LocateVsCgal)->UseManualTime()->Unit(benchmark::kMillisecond);

// The batch API: items per second for the moving object and for random points.
void BM_LocateBatchCoherent(benchmark::State& state) {
  const QueryFixture& q = queries();
  std::vector<VolumeLocation> out(q.coherent.size());
  for (auto _ : state) {
    locateBatch(q.volume, q.coherent, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * kQueries);
}
BENCHMARK(BM_LocateBatchCoherent)->Unit(benchmark::kMillisecond);

void BM_LocateBatchRandom(benchmark::State& state) {
  const QueryFixture& q = queries();
  std::vector<VolumeLocation> out(q.random.size());
  for (auto _ : state) {
    locateBatch(q.volume, q.random, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * kQueries);
}
BENCHMARK(BM_LocateBatchRandom)->Unit(benchmark::kMillisecond);

// --- Editing a 10k-probe mesh -------------------------------------------------------------------

// Moving one probe of 10k (random ids to random positions, each a remove + insert in the live
// triangulation; the reported time) against a full tetrahedralize() of the same 10k points,
// timed in the same run. Counters: ms of a rebuild, rebuild / edit, mean cells touched.
void BM_EditMoveOneProbeVsRebuild10k(benchmark::State& state) {
  const auto pts = randomPoints(10000, 43);
  EditableTetrahedralization e(pts);
  uint64_t s = streamSeed(43, 1);
  double edits = 0, touched = 0;
  int64_t n = 0;
  for (auto _ : state) {
    const int32_t id = int32_t(uniform01(s) * pts.size());
    const TetEditReport r = e.move(id, {uniform01(s), uniform01(s), uniform01(s)});
    state.SetIterationTime(r.seconds);
    edits += r.seconds;
    touched += double(r.tetsRemoved + r.tetsCreated);
    ++n;
  }
  std::vector<Vec3> live;
  for (size_t id = 0; id < e.idCount(); ++id) live.push_back(e.position(int32_t(id)));
  const auto t0 = Clock::now();
  const Tetrahedralization t = tetrahedralize(live);
  const double rebuild = secondsSince(t0);
  benchmark::DoNotOptimize(t.tets.data());
  state.counters["rebuild_ms"] = 1e3 * rebuild;
  state.counters["rebuild_over_edit"] = rebuild / (edits / double(n));
  state.counters["cells_touched"] = touched / double(n);
}
BENCHMARK(BM_EditMoveOneProbeVsRebuild10k)->UseManualTime()->Unit(benchmark::kMicrosecond);

// Moving one probe of 10k and then bringing the runtime volume up to date by a rebuild: the edit
// plus snapshot() and buildProbeVolume() (matrices, hull faces, locator), O(n).
void BM_EditMoveOneProbeAndRuntimeVolume10k(benchmark::State& state) {
  const auto pts = randomPoints(10000, 43);
  EditableTetrahedralization e(pts);
  uint64_t s = streamSeed(43, 2);
  double edit = 0, snap = 0, build = 0;
  for (auto _ : state) {
    const int32_t id = int32_t(uniform01(s) * pts.size());
    const auto t0 = Clock::now();
    edit += e.move(id, {uniform01(s), uniform01(s), uniform01(s)}).seconds;
    const auto t1 = Clock::now();
    const Tetrahedralization t = e.snapshot();
    const auto t2 = Clock::now();
    const ProbeVolume v = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
    benchmark::DoNotOptimize(v.tets.data());
    snap += std::chrono::duration<double>(t2 - t1).count();
    build += secondsSince(t2);
    state.SetIterationTime(secondsSince(t0));
  }
  const double n = double(state.iterations());
  state.counters["edit_us"] = 1e6 * edit / n;
  state.counters["snapshot_ms"] = 1e3 * snap / n;
  state.counters["build_volume_ms"] = 1e3 * build / n;
}
BENCHMARK(BM_EditMoveOneProbeAndRuntimeVolume10k)->UseManualTime()->Unit(benchmark::kMillisecond);

// The same moves (same seed) with EditableProbeVolume: the edit and the local update of the
// runtime arrays. Counters: slots rewritten per move; a full rebuild of the final volume
// (snapshot + buildProbeVolume, timed once at the end) over one incremental move.
void BM_EditMoveOneProbeIncrementalVolume10k(benchmark::State& state) {
  const auto pts = randomPoints(10000, 43);
  EditableProbeVolume e(pts, std::vector<ShRgb>(pts.size()));
  uint64_t s = streamSeed(43, 2);
  double total = 0, changed = 0;
  for (auto _ : state) {
    const int32_t id = int32_t(uniform01(s) * pts.size());
    const TetEditReport r = e.move(id, {uniform01(s), uniform01(s), uniform01(s)});
    state.SetIterationTime(r.seconds);
    total += r.seconds;
    changed += double(r.changedTets.size());
  }
  const double n = double(state.iterations());
  const auto t0 = Clock::now();
  const Tetrahedralization t = e.tetrahedralization().snapshot();
  const ProbeVolume v = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
  benchmark::DoNotOptimize(v.tets.data());
  const double rebuild = secondsSince(t0);
  state.counters["tet_slots_rewritten"] = changed / n;
  state.counters["rebuild_ms"] = 1e3 * rebuild;
  state.counters["rebuild_over_move"] = rebuild / (total / n);
}
BENCHMARK(BM_EditMoveOneProbeIncrementalVolume10k)->UseManualTime()->Unit(benchmark::kMicrosecond);

// A renderer's whole query, locate + weights + SH blend, on the 10k-probe volume: barycentric
// weights against the visibility-aware ones (VisibleInterpolation.h, no normal). The volume gets
// 16 x 16 maps whose texels hold a mean distance of 0.03 to 0.07 (about the mean edge, so that
// the Chebyshev test runs its full path for most probes) and a standard deviation of 0.01.
const ProbeVolume& visibleVolume() {
  static const ProbeVolume* v = [] {
    auto* out = new ProbeVolume(queries().volume);
    const size_t R = 16, P = out->probeCount();
    out->visibilityMapSize = int32_t(R);
    out->probeInside.assign(P, 0);
    out->visibility.resize(P * 2 * R * R);
    uint64_t s = streamSeed(43, 1);
    for (size_t k = 0; k < out->visibility.size(); k += 2) {
      const double mu = 0.03 + 0.04 * uniform01(s);
      out->visibility[k] = float(mu);
      out->visibility[k + 1] = float(mu * mu + 1e-4);
    }
    for (float& c : out->sh) c = float(uniform01(s));
    return out;
  }();
  return *v;
}

template <bool kVisible>
void queryLoop(benchmark::State& state, const std::vector<Vec3>& points, bool warm) {
  const ProbeVolume& v = visibleVolume();
  int32_t hint = -1;
  size_t i = 0;
  for (auto _ : state) {
    const Vec3 p = points[i];
    const VolumeLocation loc = locate(v, p, warm ? hint : -1);
    ShRgb sh;
    if constexpr (kVisible)
      sh = interpolate(v, visibleWeights(v, loc, p, std::nullopt));
    else
      sh = interpolate(v, loc);
    benchmark::DoNotOptimize(sh);
    hint = loc.tet;
    i = (i + 1) % points.size();
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
void BM_QueryCoherentBarycentric(benchmark::State& state) {
  queryLoop<false>(state, queries().coherent, true);
}
void BM_QueryCoherentVisible(benchmark::State& state) {
  queryLoop<true>(state, queries().coherent, true);
}
void BM_QueryRandomBarycentric(benchmark::State& state) {
  queryLoop<false>(state, queries().random, false);
}
void BM_QueryRandomVisible(benchmark::State& state) {
  queryLoop<true>(state, queries().random, false);
}
BENCHMARK(BM_QueryCoherentBarycentric);
BENCHMARK(BM_QueryCoherentVisible);
BENCHMARK(BM_QueryRandomBarycentric);
BENCHMARK(BM_QueryRandomVisible);

}  // namespace

BENCHMARK_MAIN();
