// probestudio eval: parses its options, calls the core stages and prints what it did; bad
// input surfaces as ps::Error, caught in main.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "app/cli/Common.h"
#include "core/bake/Bake.h"
#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/domain/Rooms.h"
#include "core/eval/Evaluate.h"
#include "core/eval/PerceptualError.h"
#include "core/eval/ReferenceCache.h"
#include "core/io/JsonFields.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/io/VolumeFile.h"
#include "core/placement/Uniform.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps::cli {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

/// What eval reports beside EvalResult: the perceptual error (core/eval/PerceptualError.h).
struct EvalReport {
  double floor = 0;           ///< the adaptation floor the stops are measured against
  double referenceNoise = 0;  ///< referenceNoiseStops: the reference's noise in stops
  std::vector<double> stops;  ///< per query, in EvalResult::perQuery's order
  EvalStops all;
  std::vector<RegionError> regions;  ///< per importance volume
  /// Per room found in the domain (core/domain/Rooms.h), with its volume in cubic metres.
  std::vector<RegionError> rooms;
  std::vector<double> roomVolumes;
};

/// --per-query: one CSV line per query (header in the option's help), written atomically.
/// Positions in the scene's unit (`metresPerUnit`).
void writePerQueryCsv(const std::string& path, const EvalResult& r, std::span<const double> stops,
                      double metresPerUnit) {
  std::string csv =
      "x,y,z,nx,ny,nz,reference,reference_std,interpolated,rel_error,leaking,outside,stops\n";
  char line[512];
  for (size_t i = 0; i < r.perQuery.size(); ++i) {
    const EvalQuery& q = r.perQuery[i];
    const Vec3 p = q.point * (1.0 / metresPerUnit);
    std::snprintf(line, sizeof line,
                  "%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.9g,%.6g,%.9g,%.6g,%d,%d,%.6g\n", p.x, p.y, p.z,
                  q.normal.x, q.normal.y, q.normal.z, q.reference, q.referenceStd, q.interpolated,
                  q.relError, q.leaking ? 1 : 0, q.outside ? 1 : 0, stops[i]);
    csv += line;
  }
  writeFileAtomic(path, csv);
}

ojson stopsJson(const EvalStops& s) {
  ojson js;
  js["queries"] = s.queries;
  js["rms"] = s.rms;
  js["median"] = s.median;
  js["p90"] = s.p90;
  js["beyond_third_stop"] = s.beyondThirdStop;
  return js;
}

/// --json: every figure of the result and the report (docs/evaluation.md names them).
ojson regionJson(const RegionError& region) {
  ojson jr;
  jr["name"] = region.name;
  jr["stops"] = stopsJson(region.stops);
  jr["rel_rmse"] = region.relRmse;
  jr["mean_reference"] = region.meanReference;
  return jr;
}

ojson evalJson(const EvalResult& r, const EvalReport& report, int floorSpp) {
  ojson j;
  j["probes"] = r.probes;
  j["queries"] = r.queries;
  j["visibility"] = r.visibility;
  j["rel_rmse"] = r.relRmse;
  j["rel_rmse_std_error"] = r.relRmseStdError;
  j["reference_rel_noise"] = r.referenceRelNoise;
  j["p95_rel_error"] = r.p95RelError;
  j["max_rel_error"] = r.maxRelError;
  j["leaking_fraction"] = r.leakingFraction;
  j["leaking_outside_hull_fraction"] = r.leakingOutsideHullFraction;
  j["outside_hull_fraction"] = r.outsideHullFraction;
  j["seconds"] = r.seconds;
  j["reference_cached"] = r.referenceCached;
  j["light_clearance_m"] = r.lightClearanceMeters;
  if (r.shFloorRelRmse) {
    j["sh_floor_rel_rmse"] = *r.shFloorRelRmse;
    j["floor_spp"] = floorSpp;
  }
  j["stops"] = stopsJson(report.all);
  j["stops"]["floor"] = report.floor;
  j["stops"]["reference_noise"] = report.referenceNoise;
  j["regions"] = ojson::array();
  for (const RegionError& region : report.regions) j["regions"].push_back(regionJson(region));
  j["rooms"] = ojson::array();
  for (size_t k = 0; k < report.rooms.size(); ++k) {
    ojson jr = regionJson(report.rooms[k]);
    jr["volume_m3"] = report.roomVolumes[k];
    j["rooms"].push_back(jr);
  }
  return j;
}

/// The text report: the same figures as evalJson, in sentences.
void printEval(const EvalResult& r, const EvalReport& report, int floorSpp) {
  std::printf(
      "probes %zu, queries %zu: relative RMS irradiance error %.4f, p95 %.4f, max %.4f, "
      "leaking %.4f (%.2f s%s%s)\n"
      "rel_rmse's standard error from the queries drawn %.4f; reference noise %.4f (the "
      "relative RMS error of a perfect volume against this reference)\n"
      "outside the probes' hull (clamped to it) %.4f of the queries; leaking there %.4f, "
      "inside %.4f\n",
      r.probes, r.queries, r.relRmse, r.p95RelError, r.maxRelError, r.leakingFraction, r.seconds,
      r.referenceCached ? ", reference from the cache" : "",
      r.visibility ? ", visibility-aware interpolation" : "", r.relRmseStdError,
      r.referenceRelNoise, r.outsideHullFraction, r.leakingOutsideHullFraction,
      r.leakingFraction - r.leakingOutsideHullFraction);
  if (r.shFloorRelRmse)
    std::printf(
        "SH floor %.4f (the relative RMS error of a probe at every query, captured at %d "
        "spp: its SH part no placement removes, on average over the normals; it holds that "
        "capture's noise, which a blend of probes lowers, and the reference's)\n",
        *r.shFloorRelRmse, floorSpp);
  std::printf(
      "perceptual error (stops, floor %.4g = %.0f %% of the median reference): RMS %.3f, "
      "median %.3f, p90 %.3f; %.4f of the queries off by a third of a stop or more; the "
      "reference's own noise %.3f stops RMS\n",
      report.floor, 100 * kAdaptationFloorFraction, report.all.rms, report.all.median,
      report.all.p90, report.all.beyondThirdStop, report.referenceNoise);
  auto printRegion = [](const RegionError& region) {
    std::printf(
        "  %s: %zu queries, mean reference %.4g: stops RMS %.3f, median %.3f, p90 "
        "%.3f, beyond a third %.4f; rel_rmse %.4f\n",
        region.name.c_str(), region.stops.queries, region.meanReference, region.stops.rms,
        region.stops.median, region.stops.p90, region.stops.beyondThirdStop, region.relRmse);
  };
  for (const RegionError& region : report.regions) printRegion(region);
  if (!report.rooms.empty())
    std::printf("rooms found in the domain (openings under %.1f m close them off):\n",
                RoomSettings{}.doorwayMeters);
  for (const RegionError& room : report.rooms) printRegion(room);
}

}  // namespace

void registerEval(CLI::App& app) {
  struct Opts {
    DomainOptions domainOptions;
    std::string input;
    int queries = 256, referenceSpp = 1024, spp = 512;
    uint64_t seed = 7;
    std::string cacheDir;
    bool noCache = false;
    bool noVisibility = false;
    bool visibilityNormalTerm = false;
    bool json = false;
    std::string perQuery;
    double lightClearance = kDefaultLightClearanceRelative;
    int floorSpp = 0;
    UnitOptions units;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd =
      app.add_subcommand("eval", "Measure a volume's irradiance error against a reference capture");
  cmd->add_option("input", o->input, "Probe set (.json) or baked volume (.psv)")->required();
  cmd->add_option("--queries", o->queries, "Random query points")->check(CLI::PositiveNumber);
  cmd->add_option("--reference-spp", o->referenceSpp, "Samples per reference query")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--spp", o->spp, "Samples per probe when a probe set must be captured")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->add_option("--cache", o->cacheDir,
                  "Reference cache folder (default: eval-reference-cache beside the input, shared "
                  "by every set and volume there)");
  cmd->add_flag("--no-cache", o->noCache,
                "Trace the reference, neither reading nor writing the reference cache");
  cmd->add_flag("--no-visibility", o->noVisibility,
                "Interpolate with the barycentric weights alone, even when the volume carries "
                "visibility maps (for comparison)");
  cmd->add_flag("--visibility-normal-term", o->visibilityNormalTerm,
                "With visibility: weigh the probes behind each query's normal down (DDGI's "
                "smooth backface term), as a renderer shading a surface would");
  cmd->add_flag("--json", o->json, "Print JSON");
  cmd->add_option("--light-clearance", o->lightClearance,
                  "Queries keep this fraction of the domain's diagonal from point and spot lights "
                  "(default 0.02; 0: none)");
  cmd->add_option("--floor-spp", o->floorSpp,
                  "Also capture a probe at every query at this many samples and report "
                  "sh_floor_rel_rmse, the rel_rmse of a probe at every query: its SH part is, on "
                  "average over the normals, what no placement removes; it also holds the capture "
                  "noise at this spp (which a blend of probes or more spp lowers) and the "
                  "reference's noise (default 0: off)")
      ->check(CLI::Range(0, 1 << 24));
  cmd->add_option("--per-query", o->perQuery,
                  "Write every query to this CSV: x,y,z,nx,ny,nz,reference,reference_std,"
                  "interpolated,rel_error,leaking,outside,stops (x,y,z in the scene's unit; "
                  "luminance of the irradiance; "
                  "rel_error as for p95; outside: clamped to the probes' hull; stops: the "
                  "perceptual error, |log2| of interpolated over reference above the floor)");
  o->domainOptions.add(*cmd);
  o->units.add(*cmd);
  cmd->callback([o] {
    const DomainSettings domainSettings = o->domainOptions.build();
    // Absurd requests get a message before anything is allocated or traced.
    if (o->queries > 10'000'000)
      throw ParameterError("--queries: " + std::to_string(o->queries) +
                           " is above the limit of 10 million query points");
    if (o->referenceSpp > (1 << 24) || o->spp > (1 << 24))
      throw ParameterError("--spp, --reference-spp: above the limit of 16777216 samples");
    std::string scenePath;
    LightingRig rig;
    ProbeVolume volume;
    std::optional<ProbeSet> set;
    std::vector<Bounds3> domain;           // the set's importance volumes: where the queries go
    std::vector<std::string> regionNames;  // their names (a volume keeps their boxes only)
    double unit = 1;                       // the scene's, as the input was saved
    if (isVolumePath(o->input)) {
      VolumeFile vf = loadVolume(o->input);
      unit = vf.metresPerUnit;
      const VolumeSource src = volumeSource(vf, o->input);
      scenePath = src.scenePath;
      rig = src.rig;
      domain = src.domain;
      for (size_t i = 0; i < domain.size(); ++i)
        regionNames.push_back("importance volume " + std::to_string(i + 1));
      volume = std::move(vf.volume);
    } else {
      set = loadProbeSet(o->input);
      unit = set->metresPerUnit;
      scenePath = set->scenePath;
      rig = set->rig;
      domain = importanceBoxes(set->importanceVolumes);
      for (const ImportanceVolume& v : set->importanceVolumes) regionNames.push_back(v.name);
    }
    o->units.agreeWith(unit, o->input);
    const Scene scene = loadSceneReporting(scenePath, unit, o->units.given().has_value());
    const Tracer tracer(scene);
    if (set) {
      BakeSettings bs;
      bs.capture.samplesPerProbe = o->spp;
      volume = bakeProbeSet(*set, tracer, bs, terminalProgress("capture")).file.volume;
    }
    EvalSettings es;
    es.queries = o->queries;
    es.referenceSpp = o->referenceSpp;
    es.seed = o->seed;
    es.domain = domain;
    es.reachable = makeDomain(tracer, domain, domainSettings).reachable;
    if (es.reachable && !o->json) std::printf("%s\n", es.reachable->summary().c_str());
    es.lightClearanceRelative = o->lightClearance;
    es.floorSpp = o->floorSpp;
    es.useVisibility = !o->noVisibility;
    es.visibilityNormalTerm = o->visibilityNormalTerm;
    if (!o->noCache) {
      es.sceneHash = sceneContentHash(scenePath, unit);
      if (!o->cacheDir.empty()) {
        es.cacheDir = fs::path(o->cacheDir);  // a folder asked for must work (else an error)
      } else {
        // The default folder is a convenience: where it cannot be made (a read-only folder),
        // eval runs without one.
        const fs::path folder = fs::absolute(o->input).parent_path();
        es.cacheDir = defaultReferenceCacheDir(folder);
        if (!es.cacheDir)
          std::cerr << "note: cannot create the reference cache folder "
                    << (folder / "eval-reference-cache").string()
                    << "; tracing the reference without the cache (--cache DIR picks another)\n";
      }
    }
    const EvalResult r = evaluateVolume(tracer, rig, volume, es, terminalProgress("eval"));
    // The perceptual error (core/eval/PerceptualError.h), over all queries and per importance
    // volume, all against the floor of the whole domain.
    EvalReport report;
    report.floor = adaptationFloor(r.perQuery);
    report.stops = queryStops(r.perQuery, report.floor);
    report.all = summarizeStops(report.stops);
    report.referenceNoise = referenceNoiseStops(r.perQuery, report.floor);
    report.regions = regionErrors(r.perQuery, report.stops, domain, regionNames);
    // Rooms, told apart without volumes drawn by hand; one room is no split, and says nothing
    // the whole does not.
    const RoomMap rooms(tracer, domain);
    if (!rooms.note().empty()) std::fprintf(stderr, "note: %s\n", rooms.note().c_str());
    if (rooms.roomCount() > 1) {
      std::vector<int> labels;
      for (const EvalQuery& q : r.perQuery) labels.push_back(rooms.roomOf(q.point));
      report.rooms = labelledRegionErrors(r.perQuery, report.stops, labels, rooms.roomNames());
      report.roomVolumes = rooms.roomVolumes();
    }
    if (!o->perQuery.empty()) writePerQueryCsv(o->perQuery, r, report.stops, unit);
    // Notes go to stderr: with --json, stdout holds the JSON only.
    for (const std::string& n : r.notes) std::cerr << "note: " << n << "\n";
    if (o->json)
      std::cout << evalJson(r, report, o->floorSpp).dump(2) << "\n";
    else
      printEval(r, report, o->floorSpp);
  });
}

}  // namespace ps::cli
