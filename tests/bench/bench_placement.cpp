// Placement run time: the dense field, greedy at several budgets over a prebuilt field, and the
// uniform baseline at the same budgets (the peer, in the same process), on the bundled two-rooms
// scene and on the shared japanese-bridge-garden with a sun and sky.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "core/placement/DenseField.h"
#include "core/placement/Greedy.h"
#include "core/placement/GreedyMethod.h"
#include "core/placement/Place.h"
#include "core/placement/Uniform.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

struct Fixture {
  Scene scene;
  std::unique_ptr<Tracer> tracer;
  LightingRig rig;
  std::unique_ptr<DenseField> field;  // greedy's default field, built on first use
};

/// 0: resources/scenes/two-rooms.gltf (its own lights); 1: japanese-bridge-garden (sun + sky).
Fixture* fixture(int which) {
  static std::map<int, std::unique_ptr<Fixture>> cache;
  auto it = cache.find(which);
  if (it != cache.end()) return it->second.get();
  const fs::path path = which == 0 ? fs::path(PS_SOURCE_DIR) / "resources/scenes/two-rooms.gltf"
                                   : fs::path(PS_SHARED_SCENES_DIR) /
                                         "japanese-bridge-garden/japanese-bridge-garden.glb";
  if (!fs::exists(path)) return nullptr;
  auto fx = std::make_unique<Fixture>();
  fx->scene = loadScene(path);
  fx->tracer = std::make_unique<Tracer>(fx->scene);
  if (which == 1) {
    Light sun;
    sun.type = LightType::Directional;
    sun.name = "sun";
    sun.direction = normalize(Vec3(-0.3, -1, -0.2));
    sun.intensity = {5, 5, 5};
    fx->rig.lights.push_back(sun);
    fx->rig.skyRadiance = {0.4, 0.5, 0.7};
  }
  return cache.emplace(which, std::move(fx)).first->second.get();
}

const DenseField& field(Fixture& f) {
  if (!f.field)
    f.field =
        std::make_unique<DenseField>(buildDenseField(*f.tracer, f.rig, greedyFieldSettings({})));
  return *f.field;
}

void BM_DenseField(benchmark::State& state) {
  Fixture* f = fixture(int(state.range(0)));
  if (!f) return state.SkipWithError("scene not found in PS_SHARED_SCENES_DIR");
  size_t samples = 0;
  for (auto _ : state)
    samples = buildDenseField(*f->tracer, f->rig, greedyFieldSettings({})).samples.size();
  state.counters["samples"] = double(samples);
  state.counters["samples/s"] =
      benchmark::Counter(double(samples), benchmark::Counter::kIsIterationInvariantRate);
}

void BM_Greedy(benchmark::State& state) {
  Fixture* f = fixture(int(state.range(0)));
  if (!f) return state.SkipWithError("scene not found in PS_SHARED_SCENES_DIR");
  const DenseField& fld = field(*f);
  GreedySettings gs;
  gs.budget = int(state.range(1));
  GreedyResult r;
  for (auto _ : state) r = placeGreedy(fld, {}, gs);
  state.counters["probes"] = double(r.positions.size());
  state.counters["field_error"] = r.fieldError;
  state.counters["trials"] = double(r.trials);
  state.counters["field_samples"] = double(fld.samples.size());
}

void BM_UniformBudget(benchmark::State& state) {
  Fixture* f = fixture(int(state.range(0)));
  if (!f) return state.SkipWithError("scene not found in PS_SHARED_SCENES_DIR");
  size_t probes = 0;
  for (auto _ : state)
    probes = placeUniformBudget(*f->tracer, int(state.range(1)), UniformSettings{}).points.size();
  state.counters["probes"] = double(probes);
}

}  // namespace

BENCHMARK(BM_DenseField)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Greedy)
    ->ArgsProduct({{0, 1}, {32, 128}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_UniformBudget)
    ->ArgsProduct({{0, 1}, {32, 128}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_MAIN();
