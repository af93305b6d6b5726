#include "core/bake/Bake.h"

#include <chrono>
#include <nlohmann/json.hpp>

#include "core/bake/CaptureCache.h"
#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/common/Tolerances.h"
#include "core/io/JsonFields.h"
#include "core/io/SceneHash.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps {

ProbeVolume volumeFromProbes(std::span<const Vec3> positions, std::span<const ShRgb> sh,
                             std::span<const ProbeVisibility> visibility) {
  PS_CHECK(visibility.empty() || visibility.size() == positions.size());
  const Tetrahedralization t = tetrahedralize(positions);
  std::vector<ShRgb> shOfVertex(t.vertices.size());
  std::vector<size_t> firstInput(t.vertices.size(), positions.size());
  for (size_t i = 0; i < positions.size(); ++i) {
    const int32_t v = t.vertexOfInput[i];
    if (firstInput[v] == positions.size()) {
      shOfVertex[v] = sh[i];
      firstInput[v] = i;
    }
  }
  ProbeVolume volume = buildProbeVolume(t, shOfVertex);
  if (!visibility.empty()) {
    volume.visibilityMapSize = kVisibilityMapSize;
    volume.visibility.resize(t.vertices.size() * size_t(kVisibilityFloats));
    volume.probeInside.resize(t.vertices.size());
    for (size_t v = 0; v < t.vertices.size(); ++v) {
      PS_CHECK_LT(firstInput[v], positions.size());
      const ProbeVisibility& pv = visibility[firstInput[v]];
      std::copy(pv.distanceMoments.begin(), pv.distanceMoments.end(),
                volume.visibility.begin() + std::ptrdiff_t(v * size_t(kVisibilityFloats)));
      volume.probeInside[v] = pv.inside ? 1 : 0;
    }
  }
  return volume;
}

BakeProbes gatherAcceptedProbes(const ProbeSet& set) {
  BakeProbes b;
  for (const Probe& p : set.probes)
    if (p.state == ProbeState::Accepted) {
      b.positions.push_back(p.position);
      b.ids.push_back(p.id);
    }
  if (b.positions.size() < 4)
    throw ParameterError("bake: the probe set has " + std::to_string(b.positions.size()) +
                         " accepted probes; a volume needs at least 4 (accept candidates first)");
  return b;
}

void captureStage(BakeProbes& probes, const LightingRig& rig, const Tracer& tracer,
                  const BakeSettings& settings, const ProgressFn& progress, BakeResult& r) {
  const size_t n = probes.positions.size();
  probes.sh.assign(n, ShRgb{});
  probes.visibility.assign(n, ProbeVisibility{});
  std::optional<CaptureCache> cache;
  if (settings.cacheDir && settings.sceneHash != 0) cache.emplace(*settings.cacheDir);
  std::vector<uint64_t> keys(n, 0);
  std::vector<size_t> missing;
  // The rig's JSON in the key names the environment map by path only: its texels decide the
  // capture too, so a map edited in place must miss the cache.
  const uint64_t keyBase = cache ? foldEnvironmentTexels(settings.sceneHash, rig) : 0;
  for (size_t i = 0; i < n; ++i) {
    if (cache) {
      keys[i] = CaptureCache::key(keyBase, rig, settings.capture, probes.positions[i]);
      if (auto entry = cache->find(keys[i])) {
        probes.sh[i] = entry->sh;
        probes.visibility[i] = {entry->distanceMoments, entry->inside};
        ++r.cacheHits;
        continue;
      }
    }
    missing.push_back(i);
  }
  if (missing.empty()) return;
  std::vector<Vec3> points;
  points.reserve(missing.size());
  for (size_t i : missing) points.push_back(probes.positions[i]);
  // The volume's probes always carry their visibility maps.
  CaptureSettings cs = settings.capture;
  cs.visibilityMaps = true;
  const auto captures = captureProbes(tracer, rig, points, cs, progress);
  for (size_t k = 0; k < missing.size(); ++k) {
    probes.sh[missing[k]] = captures[k].sh;
    ProbeVisibility& vis = probes.visibility[missing[k]];
    PS_CHECK_EQ(captures[k].distanceMoments.size(), vis.distanceMoments.size());
    std::copy(captures[k].distanceMoments.begin(), captures[k].distanceMoments.end(),
              vis.distanceMoments.begin());
    // Inside geometry by the capture's own rays (Kontkanen & Laine sec. 5), the test placement
    // and eval use.
    vis.inside = captures[k].backfaceFraction > tol::kDefaultInvalidBackfaceFraction;
    if (cache)
      cache->store(keys[missing[k]],
                   {probes.sh[missing[k]], probes.visibility[missing[k]].distanceMoments,
                    probes.visibility[missing[k]].inside});
  }
  r.captured += missing.size();
}

BakeResult bakeProbeSet(const ProbeSet& set, const Tracer& tracer, const BakeSettings& settings,
                        const ProgressFn& progress) {
  BakeResult r;
  BakeProbes probes = gatherAcceptedProbes(set);
  // The fit's settings and domain before anything is traced.
  std::optional<FitSettings> fit = settings.fit;
  Domain fitDomain;
  if (fit) {
    fit->mode = settings.capture.mode;
    fit->threads = settings.capture.threads;
    checkFitSettings(*fit, probes.positions.size());
    fitDomain = makeDomain(tracer, importanceBoxes(set.importanceVolumes), settings.domain);
    checkFitDomain(tracer, set.rig, fitDomain, *fit);
  }
  r.probes = probes.positions.size();
  auto t0 = std::chrono::steady_clock::now();
  // Progress: the capture and the fit (when asked), each a share of it, so that each also
  // cancels.
  const double fitShare = fit ? 0.5 : 0.0;
  const double captureShare = 0.95 - fitShare;
  auto share = [&](double from, double width) -> ProgressFn {
    if (!progress) return {};
    return [&progress, from, width](double f) { return progress(from + width * f); };
  };
  const ProgressFn captureProgress = share(0, captureShare);
  captureStage(probes, set.rig, tracer, settings, captureProgress, r);
  auto t1 = std::chrono::steady_clock::now();
  r.file.volume = volumeFromProbes(probes.positions, probes.sh, probes.visibility);
  auto t2 = std::chrono::steady_clock::now();
  r.captureSeconds = std::chrono::duration<double>(t1 - t0).count();
  r.tetraSeconds = std::chrono::duration<double>(t2 - t1).count();
  if (fit) {
    r.fit = fitProbeValues(tracer, set.rig, r.file.volume, fitDomain, *fit,
                           share(captureShare, fitShare));
  }

  nlohmann::ordered_json meta;
  meta["generator"] = "probestudio";
  meta["scene"] = set.scenePath;
  // Lengths in the metadata are in the scene's unit, like the volume's (saveVolume).
  const double unitsPerMetre = 1.0 / set.metresPerUnit;
  r.file.metresPerUnit = set.metresPerUnit;
  meta["units"] = sceneUnitName(set.metresPerUnit);
  meta["rig"] = rigToJson(scaledRig(set.rig, unitsPerMetre));
  meta["capture_spp"] = settings.capture.samplesPerProbe;
  meta["probe_ids"] = probes.ids;
  if (fit)
    meta["fit"] = {{"method", "least-squares"},
                   {"points_per_probe", fit->pointsPerProbe},
                   {"samples_per_point", fit->samplesPerPoint},
                   {"regularization", fit->regularization},
                   {"light_clearance_relative", fit->lightClearanceRelative},
                   {"seed", fit->seed},
                   {"points", r.fit->points}};
  // The set's domain of interest, so that eval of the volume draws its queries where eval of
  // the set does.
  if (!set.importanceVolumes.empty()) {
    nlohmann::ordered_json domain = nlohmann::ordered_json::array();
    for (const ImportanceVolume& v : set.importanceVolumes)
      domain.push_back(
          {{"min", vecToJson(v.lo * unitsPerMetre)}, {"max", vecToJson(v.hi * unitsPerMetre)}});
    meta["domain"] = std::move(domain);
  }
  r.file.metadataJson = meta.dump();
  if (progress && !progress(1.0)) throw Cancelled();
  return r;
}

}  // namespace ps
