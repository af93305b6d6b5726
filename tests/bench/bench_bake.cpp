// Bake with the capture cache on dream-apartment (sun + sky): a full bake (every probe traced)
// against a re-bake after moving one probe (one probe traced, the rest from the cache), and
// against a full bake with least-squares values (bake --fit, its default settings), in the same
// process.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "core/bake/Bake.h"
#include "core/io/SceneHash.h"
#include "core/placement/Uniform.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

constexpr int kBudget = 200;
constexpr int kSpp = 1024;  // BakeSettings' final quality

struct Fixture {
  Scene scene;
  std::unique_ptr<Tracer> tracer;
  uint64_t sceneHash = 0;
  ProbeSet set;
  fs::path cacheDir;
};

Fixture* fixture() {
  static Fixture* f = [] {
    const fs::path path = fs::path(PS_SHARED_SCENES_DIR) / "dream-apartment/dream-apartment.glb";
    if (!fs::exists(path)) return static_cast<Fixture*>(nullptr);
    auto* fx = new Fixture;
    fx->scene = loadScene(path);
    fx->tracer = std::make_unique<Tracer>(fx->scene);
    fx->sceneHash = sceneContentHash(path);
    fx->set.scenePath = path.string();
    Light sun;
    sun.type = LightType::Directional;
    sun.name = "sun";
    sun.direction = normalize(Vec3(-0.4, -0.8, -0.3));
    sun.intensity = {3, 3, 3};
    fx->set.rig.lights.push_back(sun);
    fx->set.rig.skyRadiance = {0.3, 0.4, 0.6};
    for (Vec3 p : placeUniformBudget(*fx->tracer, kBudget, UniformSettings{}).points) {
      Probe probe;
      probe.position = p;
      probe.state = ProbeState::Accepted;
      fx->set.add(probe);
    }
    fx->cacheDir = fs::temp_directory_path() / ("ps_bench_bake_" + std::to_string(::getpid()));
    fs::remove_all(fx->cacheDir);
    return fx;
  }();
  return f;
}

BakeSettings settings(const Fixture& f, bool cache) {
  BakeSettings bs;
  bs.capture.samplesPerProbe = kSpp;
  bs.sceneHash = f.sceneHash;
  if (cache) bs.cacheDir = f.cacheDir;
  return bs;
}

void BM_FullBake(benchmark::State& state) {
  Fixture* f = fixture();
  if (!f) return state.SkipWithError("dream-apartment not found in PS_SHARED_SCENES_DIR");
  size_t captured = 0;
  for (auto _ : state) captured = bakeProbeSet(f->set, *f->tracer, settings(*f, false)).captured;
  state.counters["probes"] = double(f->set.probes.size());
  state.counters["captured"] = double(captured);
}

void BM_FullBakeWithFit(benchmark::State& state) {
  Fixture* f = fixture();
  if (!f) return state.SkipWithError("dream-apartment not found in PS_SHARED_SCENES_DIR");
  BakeSettings bs = settings(*f, false);
  bs.fit = FitSettings{};
  double fitSeconds = 0, points = 0, iterations = 0;
  for (auto _ : state) {
    const BakeResult r = bakeProbeSet(f->set, *f->tracer, bs);
    fitSeconds = r.fit->seconds;
    points = double(r.fit->points);
    iterations = r.fit->iterations;
  }
  state.counters["probes"] = double(f->set.probes.size());
  state.counters["fit_points"] = points;
  state.counters["fit_seconds"] = fitSeconds;
  state.counters["cg_iterations"] = iterations;
}

void BM_ReBakeAfterOneMove(benchmark::State& state) {
  Fixture* f = fixture();
  if (!f) return state.SkipWithError("dream-apartment not found in PS_SHARED_SCENES_DIR");
  ProbeSet set = f->set;
  bakeProbeSet(set, *f->tracer, settings(*f, true));  // fills the cache
  Probe& moved = set.probes[set.probes.size() / 2];
  const Vec3 home = moved.position;
  size_t captured = 0, hits = 0;
  static int step = 0;  // across repetitions too: every position is new
  for (auto _ : state) {
    // A new position every iteration, so each re-bake really recaptures the moved probe.
    moved.position = home + Vec3(0.01 * (++step), 0, 0);
    const BakeResult r = bakeProbeSet(set, *f->tracer, settings(*f, true));
    captured = r.captured;
    hits = r.cacheHits;
  }
  state.counters["probes"] = double(set.probes.size());
  state.counters["captured"] = double(captured);
  state.counters["cache_hits"] = double(hits);
}

}  // namespace

BENCHMARK(BM_FullBake)->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK(BM_FullBakeWithFit)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_ReBakeAfterOneMove)->Unit(benchmark::kMillisecond)->Iterations(20);

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (Fixture* f = fixture()) fs::remove_all(f->cacheDir);
  return 0;
}
