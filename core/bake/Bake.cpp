#include "core/bake/Bake.h"

#include <chrono>
#include <nlohmann/json.hpp>

#include "core/common/Error.h"
#include "core/io/JsonFields.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps {

ProbeVolume volumeFromProbes(std::span<const Vec3> positions, std::span<const ShRgb> sh) {
  const Tetrahedralization t = tetrahedralize(positions);
  std::vector<ShRgb> shOfVertex(t.vertices.size());
  std::vector<char> seen(t.vertices.size(), 0);
  for (size_t i = 0; i < positions.size(); ++i) {
    const int32_t v = t.vertexOfInput[i];
    if (!seen[v]) shOfVertex[v] = sh[i];
    seen[v] = 1;
  }
  return buildProbeVolume(t, shOfVertex);
}

BakeResult bakeProbeSet(const ProbeSet& set, const Tracer& tracer, const BakeSettings& settings,
                        const ProgressFn& progress) {
  std::vector<Vec3> positions;
  std::vector<uint64_t> ids;
  for (const Probe& p : set.probes)
    if (p.state == ProbeState::Accepted) {
      positions.push_back(p.position);
      ids.push_back(p.id);
    }
  if (positions.size() < 4)
    throw ParameterError("bake: the probe set has " + std::to_string(positions.size()) +
                         " accepted probes; a volume needs at least 4 (accept candidates first)");
  BakeResult r;
  r.probes = positions.size();
  auto t0 = std::chrono::steady_clock::now();
  ProgressFn captureProgress;
  if (progress) captureProgress = [&](double f) { return progress(0.95 * f); };
  const auto captures =
      captureProbes(tracer, set.rig, positions, settings.capture, captureProgress);
  auto t1 = std::chrono::steady_clock::now();
  std::vector<ShRgb> sh(captures.size());
  for (size_t i = 0; i < captures.size(); ++i) sh[i] = captures[i].sh;
  r.file.volume = volumeFromProbes(positions, sh);
  auto t2 = std::chrono::steady_clock::now();
  r.captureSeconds = std::chrono::duration<double>(t1 - t0).count();
  r.tetraSeconds = std::chrono::duration<double>(t2 - t1).count();

  nlohmann::ordered_json meta;
  meta["generator"] = "probestudio";
  meta["scene"] = set.scenePath;
  meta["rig"] = rigToJson(set.rig);
  meta["capture_spp"] = settings.capture.samplesPerProbe;
  meta["probe_ids"] = ids;
  r.file.metadataJson = meta.dump();
  if (progress && !progress(1.0)) throw Cancelled();
  return r;
}

}  // namespace ps
