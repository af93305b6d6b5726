// Leak refinement (Sukys 3.2.2) run time: a uniform set (budget 64 and 256) refined on the
// bundled two-rooms scene and on the shared japanese-bridge-garden; the items are the input
// probes. Geometry only: no lighting is captured. Then the leak cuts on the refined set's mesh
// (their bake cost), and a query's run-time cost with and without them, in the same process
// on the same volume.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>

#include "core/math/Random.h"
#include "core/placement/LeakRefine.h"
#include "core/placement/Uniform.h"
#include "core/scene/Scene.h"
#include "core/tessellation/Tetrahedralization.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

struct Fixture {
  Scene scene;
  std::unique_ptr<Tracer> tracer;
  std::map<int, std::vector<Vec3>> sets;  // by budget
};

/// 0: resources/scenes/two-rooms.gltf; 1: the shared japanese-bridge-garden.
Fixture* fixture(int which, int budget) {
  static std::map<int, std::unique_ptr<Fixture>> cache;
  auto it = cache.find(which);
  if (it == cache.end()) {
    const fs::path path = which == 0 ? fs::path(PS_SOURCE_DIR) / "resources/scenes/two-rooms.gltf"
                                     : fs::path(PS_SHARED_SCENES_DIR) /
                                           "japanese-bridge-garden/japanese-bridge-garden.glb";
    if (!fs::exists(path)) return nullptr;
    auto fx = std::make_unique<Fixture>();
    fx->scene = loadScene(path);
    fx->tracer = std::make_unique<Tracer>(fx->scene);
    it = cache.emplace(which, std::move(fx)).first;
  }
  Fixture& f = *it->second;
  if (!f.sets.count(budget))
    f.sets[budget] = placeUniformBudget(*f.tracer, budget, UniformSettings{}).points;
  return &f;
}

void BM_LeakRefine(benchmark::State& state) {
  const int scene = int(state.range(0)), budget = int(state.range(1));
  Fixture* f = fixture(scene, budget);
  if (!f) {
    state.SkipWithError("shared scene not found");
    return;
  }
  const std::vector<Vec3>& probes = f->sets[budget];
  LeakRefineResult r;
  for (auto _ : state) {
    r = refineLeaks(*f->tracer, probes);
    benchmark::DoNotOptimize(r.added.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(probes.size()));
  state.counters["probes"] = double(probes.size());
  state.counters["added"] = double(r.added.size());
  state.counters["leaking_edges_before"] = double(r.leakingEdgesBefore);
  state.counters["leaking_edges_after"] = double(r.leakingEdgesAfter);
}
BENCHMARK(BM_LeakRefine)
    ->ArgNames({"scene", "budget"})
    ->Args({0, 64})
    ->Args({0, 256})
    ->Args({1, 64})
    ->Args({1, 256})
    ->Unit(benchmark::kMillisecond);

/// The refined set's volume (zero SH: geometry only), with its cuts, per scene and budget.
struct CutVolume {
  ProbeVolume plain, cut;
  LeakCutResult cuts;
};
CutVolume* cutVolume(int scene, int budget) {
  static std::map<std::pair<int, int>, std::unique_ptr<CutVolume>> cache;
  auto& slot = cache[{scene, budget}];
  if (!slot) {
    Fixture* f = fixture(scene, budget);
    if (!f) return nullptr;
    std::vector<Vec3> probes = f->sets[budget];
    const LeakRefineResult r = refineLeaks(*f->tracer, probes);
    probes.insert(probes.end(), r.added.begin(), r.added.end());
    const Tetrahedralization t = tetrahedralize(probes);
    slot = std::make_unique<CutVolume>();
    slot->plain = buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size()));
    slot->cut = slot->plain;
    slot->cuts = computeLeakCuts(*f->tracer, slot->cut, {});
  }
  return slot.get();
}

void BM_LeakCuts(benchmark::State& state) {
  const int scene = int(state.range(0)), budget = int(state.range(1));
  CutVolume* cv = cutVolume(scene, budget);
  if (!cv) {
    state.SkipWithError("shared scene not found");
    return;
  }
  Fixture* f = fixture(scene, budget);
  LeakCutResult r;
  for (auto _ : state) {
    ProbeVolume v = cv->plain;
    r = computeLeakCuts(*f->tracer, v, {});
    benchmark::DoNotOptimize(v.cutPlanes.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(cv->plain.tets.size()));
  state.counters["tets"] = double(cv->plain.tets.size());
  state.counters["planes"] = double(r.planes);
  state.counters["points"] = double(r.samples);
  state.counters["leaking_points_before"] = double(r.hiddenSamplesBefore);
  state.counters["leaking_points_after"] = double(r.hiddenSamplesAfter);
}
BENCHMARK(BM_LeakCuts)
    ->ArgNames({"scene", "budget"})
    ->Args({0, 64})
    ->Args({0, 256})
    ->Args({1, 256})
    ->Unit(benchmark::kMillisecond);

/// A renderer's query, locate + interpolate, at random points of the volume's bounding box in a
/// coherent walk (each from the previous one's tet), on the volume without (cuts: 0) and with
/// (cuts: 1) its leak cuts. The ratio of the two is the cuts' run-time cost.
void BM_QueryWithCuts(benchmark::State& state) {
  CutVolume* cv = cutVolume(int(state.range(0)), int(state.range(1)));
  if (!cv) {
    state.SkipWithError("shared scene not found");
    return;
  }
  const ProbeVolume& v = state.range(2) ? cv->cut : cv->plain;
  Bounds3 box;
  for (size_t i = 0; i < v.probeCount(); ++i) box.extend(v.position(int32_t(i)));
  std::vector<Vec3> points(4096);
  uint64_t rng = 7;
  for (Vec3& p : points) {
    const Vec3 e = box.extent();
    p = box.lo + Vec3(e.x * uniform01(rng), e.y * uniform01(rng), e.z * uniform01(rng));
  }
  size_t i = 0;
  int32_t hint = -1;
  for (auto _ : state) {
    const VolumeLocation loc = locate(v, points[i], hint);
    const ShRgb sh = interpolate(v, loc);
    benchmark::DoNotOptimize(sh);
    hint = loc.tet;
    i = (i + 1) % points.size();
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
  state.counters["cut_tets_fraction"] =
      double(cv->cuts.tetsCut) / double(std::max<size_t>(1, cv->cut.tets.size()));
}
BENCHMARK(BM_QueryWithCuts)
    ->ArgNames({"scene", "budget", "cuts"})
    ->Args({0, 256, 0})
    ->Args({0, 256, 1})
    ->Args({1, 256, 0})
    ->Args({1, 256, 1});

}  // namespace

BENCHMARK_MAIN();
