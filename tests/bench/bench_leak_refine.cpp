// Leak refinement (Sukys 3.2.2) run time: a uniform set (budget 64 and 256) refined on the
// bundled two-rooms scene and on the shared japanese-bridge-garden; the items are the input
// probes. Geometry only: no lighting is captured. Figures: BENCHMARKS.md, "Placement".
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>

#include "core/placement/LeakRefine.h"
#include "core/placement/Uniform.h"
#include "core/scene/Scene.h"
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

}  // namespace

BENCHMARK_MAIN();
