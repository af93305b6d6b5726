// The domain on a generated level (scripts/make_level.py): the reachable space and the rooms as
// place and eval build them by default (ReachableSettings{}, RoomSettings{}), on the full level
// (200 x 60 m, 4 storeys) and on a 120 x 60 m level of 3 storeys (seed 7). The level is written
// once into the temporary folder; its scene load and BVH are outside the timing. The second
// argument is maxCells of both (16 million by default; 400,000 makes the full level's cells
// coarser than the rules need, for comparison). Figures:
// BENCHMARKS.md, "The domain on the full level".
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "core/domain/ReachableSpace.h"
#include "core/domain/Rooms.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

struct Level {
  Scene scene;
  std::unique_ptr<Tracer> tracer;
};

/// 0: the full level; 1: --seed 7 --width 120 --floors 3. Null when the script fails.
Level* level(int which) {
  static std::unique_ptr<Level> cache[2];
  if (!cache[which]) {
    const char* options = which == 0 ? "" : "--seed 7 --width 120 --floors 3";
    const fs::path path =
        fs::temp_directory_path() / ("ps-bench-level-" + std::to_string(which) + ".glb");
    const std::string command = "python3 '" + std::string(PS_SOURCE_DIR) +
                                "/scripts/make_level.py' " + options + " -o '" + path.string() +
                                "' > /dev/null";
    if (std::system(command.c_str()) != 0) return nullptr;
    auto l = std::make_unique<Level>();
    l->scene = loadScene(path);
    l->tracer = std::make_unique<Tracer>(l->scene);
    cache[which] = std::move(l);
  }
  return cache[which].get();
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void BM_DomainLevel(benchmark::State& state) {
  Level* l = level(int(state.range(0)));
  if (!l) {
    state.SkipWithError("scripts/make_level.py failed");
    return;
  }
  ReachableSettings reachSettings;
  RoomSettings roomSettings;
  reachSettings.maxCells = roomSettings.maxCells = size_t(state.range(1));
  double reachSeconds = 0, roomSeconds = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const ReachableSpace reach(*l->tracer, {}, reachSettings);
    reachSeconds = secondsSince(start);
    const auto roomStart = std::chrono::steady_clock::now();
    const RoomMap rooms(*l->tracer, {}, roomSettings);
    roomSeconds = secondsSince(roomStart);
    benchmark::DoNotOptimize(rooms.roomCount());
    state.counters["reach_s"] = reachSeconds;
    state.counters["rooms_s"] = roomSeconds;
    state.counters["reach_cell_m"] = reach.cellMeters();
    state.counters["rooms_cell_m"] = rooms.cellMeters();
    state.counters["reachable_m3"] = reach.keptFreeCubicMeters();
    state.counters["free_m3"] = reach.freeCubicMeters();
    state.counters["interior"] = reach.interior() ? 1 : 0;
    state.counters["rooms"] = rooms.roomCount();
    state.counters["notes"] = double(!reach.note().empty()) + double(!rooms.note().empty());
  }
}
BENCHMARK(BM_DomainLevel)
    ->ArgNames({"level", "maxCells"})
    ->Args({0, 16000000})
    ->Args({1, 16000000})
    ->Args({0, 400000})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
