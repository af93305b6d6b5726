// Chajdas placement run time over a prebuilt dense field (default settings) of the bundled
// pillar-room and two-rooms scenes, at aggressiveness 1 and 2; the items are the field samples.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>

#include "core/placement/Chajdas.h"
#include "core/placement/DenseField.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

struct Fixture {
  Scene scene;
  std::unique_ptr<Tracer> tracer;
  DenseField field;
};

/// 0: pillar-room, 1: two-rooms (their own lights).
const Fixture& fixture(int which) {
  static std::map<int, std::unique_ptr<Fixture>> cache;
  auto it = cache.find(which);
  if (it != cache.end()) return *it->second;
  auto fx = std::make_unique<Fixture>();
  fx->scene = loadScene(fs::path(PS_SOURCE_DIR) / "resources/scenes" /
                        (which == 0 ? "pillar-room.gltf" : "two-rooms.gltf"));
  fx->tracer = std::make_unique<Tracer>(fx->scene);
  fx->field = buildDenseField(*fx->tracer, LightingRig{}, DenseFieldSettings{});
  return *cache.emplace(which, std::move(fx)).first->second;
}

void BM_Chajdas(benchmark::State& state) {
  const Fixture& f = fixture(int(state.range(0)));
  ChajdasSettings s;
  s.aggressiveness = double(state.range(1));
  ChajdasResult r;
  for (auto _ : state) {
    r = placeChajdas(f.field.samples, s);
    benchmark::DoNotOptimize(r.probes.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(f.field.samples.size()));
  state.counters["samples"] = double(f.field.samples.size());
  state.counters["probes"] = double(r.probes.size());
  state.counters["sinks"] = double(r.sinks);
}
BENCHMARK(BM_Chajdas)
    ->ArgNames({"scene", "aggressiveness"})
    ->Args({0, 1})
    ->Args({0, 2})
    ->Args({1, 1})
    ->Args({1, 2})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
