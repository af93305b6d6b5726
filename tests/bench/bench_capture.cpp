// Capture throughput in rays per second against bare Embree tracing the same rays, in the same
// process. The capture's rays (probe, bounce and shadow rays) are recorded once through
// Tracer::setRayLog from a one-thread capture; BM_BareEmbreeRays then traces exactly those rays
// with rtcIntersect1 / rtcOccluded1 on an Embree scene built here with the same settings, and
// BM_CaptureRaysPerSecond runs the capture itself (args: threads, packets; the default a ray at a
// time on 1 and 2 threads, and 1 thread in packets, CaptureSettings::tracePackets), counting the
// same rays. After the runs the ratios are printed: capture / bare (goal >= 1.0), 2 threads / 1
// (goal >= 1.9) and packets / single rays. With --benchmark_repetitions the ratios are of the
// medians.
//
// BM_LevelTimeToError: the wall time of an adaptive capture to a 5 % relative error per probe
// (CaptureSettings::targetRelativeError) at 64 probes (placeUniformBudget) of the generated
// level (scripts/make_level.py, written to the temporary folder; sky 0.2, 0.25, 0.35), on one
// thread: `level` is the full level (79 point lights and a sun), `lamps` the same building with
// a lamp in every room (--lamps-per-room 1: 690 point lights), `lamps10` that building with 10
// of those point lights (every 69th) and the sun. Goal: lamps at most 2 times lamps10.
#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <string>

#include "core/capture/Capture.h"
#include "core/placement/Uniform.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

constexpr int kProbes = 64;
constexpr int kSpp = 256;

struct Fixture {
  std::string name;
  Scene scene;
  std::unique_ptr<Tracer> tracer;
  LightingRig rig;
  std::vector<Vec3> points;
  std::vector<LoggedRay> rays;  // what one capture of `points` traces
  size_t occlusionRays = 0;
  RTCDevice device = nullptr;
  RTCScene bare = nullptr;
};

CaptureSettings settings(int threads) {
  CaptureSettings cs;
  cs.samplesPerProbe = kSpp;
  cs.threads = threads;
  return cs;
}

/// The same Embree scene the Tracer builds (robust flag, high build quality, one triangle
/// geometry), without any ProbeStudio code on the query path.
void buildBare(Fixture& f) {
  f.device = rtcNewDevice(nullptr);
  f.bare = rtcNewScene(f.device);
  rtcSetSceneFlags(f.bare, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(f.bare, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geom = rtcNewGeometry(f.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                        RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                        f.scene.vertexCount()));
  auto* i = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0,
                                                           RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                                           f.scene.triangleCount()));
  std::copy(f.scene.positions.begin(), f.scene.positions.end(), v);
  std::copy(f.scene.indices.begin(), f.scene.indices.end(), i);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(f.bare, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(f.bare);
}

Fixture* load(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Fixture>> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second.get();
  fs::path path;
  auto f = std::make_unique<Fixture>();
  f->name = name;
  if (name == "dream-apartment") {
    path = fs::path(PS_SHARED_SCENES_DIR) / "dream-apartment/dream-apartment.glb";
    Light sun;
    sun.type = LightType::Directional;
    sun.name = "sun";
    sun.direction = normalize(Vec3(-0.4, -0.8, -0.3));
    sun.intensity = {3, 3, 3};
    f->rig.lights.push_back(sun);
    f->rig.skyRadiance = {0.3, 0.4, 0.6};
  } else {
    path = fs::path(PS_SOURCE_DIR) / "resources/scenes" / (name + ".gltf");
  }
  if (!fs::exists(path)) {
    cache[name] = nullptr;
    return nullptr;
  }
  f->scene = loadScene(path);
  f->tracer = std::make_unique<Tracer>(f->scene);
  f->points = placeUniformBudget(*f->tracer, kProbes, UniformSettings{}).points;
  f->tracer->setRayLog(&f->rays);
  captureProbes(*f->tracer, f->rig, f->points, settings(1));
  f->tracer->setRayLog(nullptr);
  for (const LoggedRay& r : f->rays) f->occlusionRays += r.occlusion ? 1 : 0;
  buildBare(*f);
  Fixture* raw = f.get();
  cache[name] = std::move(f);
  return raw;
}

std::map<std::string, double>& rates() {
  static std::map<std::string, double> r;
  return r;
}

/// Wall seconds per iteration per benchmark name.
std::map<std::string, double>& seconds() {
  static std::map<std::string, double> r;
  return r;
}

void fillRay(const Ray& ray, RTCRay& r) {
  r.org_x = float(ray.origin.x);
  r.org_y = float(ray.origin.y);
  r.org_z = float(ray.origin.z);
  r.dir_x = float(ray.direction.x);
  r.dir_y = float(ray.direction.y);
  r.dir_z = float(ray.direction.z);
  r.tnear = float(ray.tMin);
  r.tfar = ray.tMax >= double(std::numeric_limits<float>::max())
               ? std::numeric_limits<float>::infinity()
               : float(ray.tMax);
  r.time = 0;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
}

void BM_BareEmbreeRays(benchmark::State& state, const std::string& name) {
  Fixture* f = load(name);
  if (!f) {
    state.SkipWithError(("scene not found: " + name).c_str());
    return;
  }
  size_t hits = 0;
  for (auto _ : state) {
    for (const LoggedRay& lr : f->rays) {
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      if (lr.occlusion) {
        RTCRay r;
        fillRay(lr.ray, r);
        rtcOccluded1(f->bare, &context, &r);
        hits += r.tfar < 0 ? 1 : 0;
      } else {
        RTCRayHit rh;
        fillRay(lr.ray, rh.ray);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(f->bare, &context, &rh);
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID ? 1 : 0;
      }
    }
  }
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(f->rays.size()));
  state.counters["rays"] = double(f->rays.size());
  state.counters["shadow_rays"] = double(f->occlusionRays);
}

void BM_CaptureRaysPerSecond(benchmark::State& state, const std::string& name) {
  Fixture* f = load(name);
  if (!f) {
    state.SkipWithError(("scene not found: " + name).c_str());
    return;
  }
  CaptureSettings cs = settings(int(state.range(0)));
  cs.tracePackets = state.range(1) != 0;
  for (auto _ : state) benchmark::DoNotOptimize(captureProbes(*f->tracer, f->rig, f->points, cs));
  // Deterministic sampling: every run traces exactly the recorded rays.
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(f->rays.size()));
  state.counters["probes"] = double(f->points.size());
}

// ---- Time to a given error -----------------------------------------------------------------

constexpr double kTargetError = 0.02;

double worstError(const std::vector<ProbeCapture>& caps) {
  double w = 0;
  for (const ProbeCapture& c : caps) w = std::max(w, c.relativeError);
  return w;
}

struct ErrorSetup {
  CaptureSettings adaptive, fixed;
  double adaptiveWorst = 0, fixedWorst = 0;
};

/// Adaptive at kTargetError, and the smallest fixed spp (a multiple of 64, found by doubling
/// then bisection) whose worst probe error is at most the adaptive run's worst.
const ErrorSetup* errorSetup(Fixture* f) {
  static std::map<Fixture*, std::unique_ptr<ErrorSetup>> cache;
  auto it = cache.find(f);
  if (it != cache.end()) return it->second.get();
  auto e = std::make_unique<ErrorSetup>();
  e->adaptive.targetRelativeError = kTargetError;
  e->adaptiveWorst = worstError(captureProbes(*f->tracer, f->rig, f->points, e->adaptive));
  auto worstAt = [&](int spp) {
    CaptureSettings cs;
    cs.samplesPerProbe = spp;
    return worstError(captureProbes(*f->tracer, f->rig, f->points, cs));
  };
  int hi = 64;
  while (worstAt(hi) > e->adaptiveWorst && hi < (1 << 20)) hi *= 2;
  int lo = hi / 2;  // fails (or is below 64)
  while (hi - lo > 64) {
    const int mid = (lo + hi) / 2 / 64 * 64;
    if (mid <= lo) break;
    (worstAt(mid) <= e->adaptiveWorst ? hi : lo) = mid;
  }
  e->fixed.samplesPerProbe = hi;
  e->fixedWorst = worstAt(hi);
  ErrorSetup* raw = e.get();
  cache[f] = std::move(e);
  return raw;
}

void BM_TimeToError(benchmark::State& state, const std::string& name, bool adaptive) {
  Fixture* f = load(name);
  if (!f) {
    state.SkipWithError(("scene not found: " + name).c_str());
    return;
  }
  const ErrorSetup* e = errorSetup(f);
  const CaptureSettings& cs = adaptive ? e->adaptive : e->fixed;
  int64_t samples = 0;
  for (auto _ : state) {
    const auto caps = captureProbes(*f->tracer, f->rig, f->points, cs);
    samples = 0;
    for (const ProbeCapture& c : caps) samples += c.samples;
    benchmark::DoNotOptimize(samples);
  }
  state.counters["worst_rel_error"] = adaptive ? e->adaptiveWorst : e->fixedWorst;
  state.counters["samples"] = double(samples);
  state.counters["fixed_spp"] = adaptive ? 0.0 : double(e->fixed.samplesPerProbe);
}

// ---- The generated level -------------------------------------------------------------------

constexpr int kLevelProbes = 64;
constexpr double kLevelTargetError = 0.05;

struct LevelFixture {
  Scene scene;
  std::unique_ptr<Tracer> tracer;
  LightingRig rig;
  std::vector<Vec3> points;
};

/// "level", "lamps" or "lamps10" (above); null when the script fails.
LevelFixture* levelFixture(const std::string& which) {
  static std::map<std::string, std::unique_ptr<LevelFixture>> cache;
  auto it = cache.find(which);
  if (it != cache.end()) return it->second.get();
  const bool lamps = which != "level";
  const fs::path path = fs::temp_directory_path() /
                        (std::string("ps-bench-capture-") + (lamps ? "lamps" : "level") + ".glb");
  const std::string command = "python3 '" + std::string(PS_SOURCE_DIR) +
                              "/scripts/make_level.py' " + (lamps ? "--lamps-per-room 1 " : "") +
                              "-o '" + path.string() + "' > /dev/null";
  if (std::system(command.c_str()) != 0) {
    cache[which] = nullptr;
    return nullptr;
  }
  auto f = std::make_unique<LevelFixture>();
  f->scene = loadScene(path);
  if (which == "lamps10") {
    std::vector<Light> kept;
    std::vector<const Light*> points;
    for (const Light& l : f->scene.lights)
      (l.type == LightType::Directional ? kept.push_back(l) : points.push_back(&l));
    const size_t step = std::max<size_t>(1, points.size() / 10);
    for (size_t i = 0; i < points.size() && kept.size() < 11; i += step) kept.push_back(*points[i]);
    f->scene.lights = kept;
  }
  f->tracer = std::make_unique<Tracer>(f->scene);
  f->rig.skyRadiance = {0.2, 0.25, 0.35};
  f->points = placeUniformBudget(*f->tracer, kLevelProbes, UniformSettings{}).points;
  LevelFixture* raw = f.get();
  cache[which] = std::move(f);
  return raw;
}

void BM_LevelTimeToError(benchmark::State& state, const std::string& which) {
  LevelFixture* f = levelFixture(which);
  if (!f) {
    state.SkipWithError("scripts/make_level.py failed");
    return;
  }
  CaptureSettings cs;
  cs.targetRelativeError = kLevelTargetError;
  cs.threads = 1;
  int64_t samples = 0;
  double worst = 0;
  for (auto _ : state) {
    const auto caps = captureProbes(*f->tracer, f->rig, f->points, cs);
    samples = 0;
    worst = 0;
    for (const ProbeCapture& c : caps) {
      samples += c.samples;
      worst = std::max(worst, c.relativeError);
    }
    benchmark::DoNotOptimize(samples);
  }
  size_t pointLights = 0;
  for (const Light& l : f->scene.lights) pointLights += l.type == LightType::Directional ? 0 : 1;
  state.counters["probes"] = double(f->points.size());
  state.counters["point_lights"] = double(pointLights);
  state.counters["samples"] = double(samples);
  state.counters["worst_rel_error"] = worst;
}

/// Rates (rays/s) per benchmark name, for the ratios printed after the runs.
class RateReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      auto it = run.counters.find("items_per_second");
      if (run.error_occurred) continue;
      std::string name = run.benchmark_name();  // without the "/min_time:..." part
      const size_t cut = name.find("/min_time:");
      if (cut != std::string::npos) name.erase(cut, name.find('/', cut + 1) - cut);
      // Repetitions: the median stands for the runs (it is reported after them).
      if (run.run_type == Run::RT_Aggregate) {
        const std::string median = "_median";
        if (!name.ends_with(median)) continue;
        name.erase(name.size() - median.size());
      }
      if (it != run.counters.end()) rates()[name] = it->second.value;
      seconds()[name] = run.GetAdjustedRealTime() / benchmark::GetTimeUnitMultiplier(run.time_unit);
    }
    ConsoleReporter::ReportRuns(runs);
  }
};

}  // namespace

int main(int argc, char** argv) {
  const char* scenes[] = {"cornell", "two-rooms", "dream-apartment"};
  for (const char* s : scenes) {
    const std::string name = s;
    benchmark::RegisterBenchmark(("BM_BareEmbreeRays/" + name).c_str(), BM_BareEmbreeRays, name)
        ->Unit(benchmark::kMillisecond)
        ->MinTime(1.0)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("BM_CaptureRaysPerSecond/" + name).c_str(),
                                 BM_CaptureRaysPerSecond, name)
        ->Args({1, 0})
        ->Args({2, 0})
        ->Args({1, 1})
        ->Unit(benchmark::kMillisecond)
        ->MinTime(1.0)
        ->UseRealTime();
  }
  for (const bool adaptive : {true, false})
    benchmark::RegisterBenchmark(
        (std::string("BM_TimeToError/two-rooms/") + (adaptive ? "adaptive" : "fixed")).c_str(),
        BM_TimeToError, std::string("two-rooms"), adaptive)
        ->Unit(benchmark::kMillisecond)
        ->MinTime(1.0)
        ->UseRealTime();
  for (const char* which : {"level", "lamps", "lamps10"})
    benchmark::RegisterBenchmark((std::string("BM_LevelTimeToError/") + which).c_str(),
                                 BM_LevelTimeToError, std::string(which))
        ->Unit(benchmark::kMillisecond)
        ->Iterations(1)
        ->UseRealTime();
  benchmark::Initialize(&argc, argv);
  RateReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  std::printf("\nratios (same rays, same process):\n");
  for (const char* s : scenes) {
    const std::string name = s;
    const double bare = rates()["BM_BareEmbreeRays/" + name + "/real_time"];
    // The default (a ray at a time) on 1 and 2 threads, and packets on 1.
    const double one = rates()["BM_CaptureRaysPerSecond/" + name + "/1/0/real_time"];
    const double two = rates()["BM_CaptureRaysPerSecond/" + name + "/2/0/real_time"];
    const double packets = rates()["BM_CaptureRaysPerSecond/" + name + "/1/1/real_time"];
    if (bare > 0 && one > 0)
      std::printf("  %-16s capture 1 thread / bare Embree 1 thread: %.3f", s, one / bare);
    if (one > 0 && two > 0) std::printf("   capture 2 threads / 1 thread: %.3f", two / one);
    if (one > 0 && packets > 0) std::printf("   packets / single rays: %.3f", packets / one);
    if (bare > 0 || one > 0) std::printf("\n");
  }
  const double ta = seconds()["BM_TimeToError/two-rooms/adaptive/real_time"];
  const double tf = seconds()["BM_TimeToError/two-rooms/fixed/real_time"];
  if (ta > 0 && tf > 0)
    std::printf("  two-rooms time to %.0f %% worst error: fixed spp / adaptive = %.3f\n",
                100 * kTargetError, tf / ta);
  const double tl = seconds()["BM_LevelTimeToError/lamps/iterations:1/real_time"];
  const double t10 = seconds()["BM_LevelTimeToError/lamps10/iterations:1/real_time"];
  if (tl > 0 && t10 > 0)
    std::printf("  level time to %.0f %% error: a lamp in every room / 10 lamps = %.3f\n",
                100 * kLevelTargetError, tl / t10);
  benchmark::Shutdown();
  return 0;
}
