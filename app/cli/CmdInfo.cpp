// probestudio info: parses its options, calls the core stages and prints what it did; bad
// input surfaces as ps::Error, caught in main.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/cli/Common.h"
#include "core/bake/Bake.h"
#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/eval/Evaluate.h"
#include "core/io/JsonFields.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/io/VolumeFile.h"
#include "core/placement/Uniform.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps::cli {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

void registerInfo(CLI::App& app) {
  auto file = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("info", "Print what a probe set or a volume holds");
  cmd->add_option("file", *file, "Probe set (.json) or volume (.psv)")->required();
  cmd->callback([file] {
    if (isVolumePath(*file)) {
      const VolumeFile vf = loadVolume(*file);
      const VolumeSource src = volumeSource(vf, *file);
      // The version saveVolume writes for this content (the loader accepts 1 to 4).
      std::printf("%s: probe volume, format version %d, SH order 2\n", file->c_str(),
                  vf.volume.hasVisibility() ? 4 : 1);
      std::printf("  probes %zu, tetrahedra %zu, hull faces %zu\n", vf.volume.probeCount(),
                  vf.volume.tets.size(), vf.volume.hullFaces.size());
      if (vf.volume.hasVisibility()) {
        size_t inside = 0;
        for (uint8_t f : vf.volume.probeInside) inside += f;
        std::printf("  visibility maps: %dx%d texels per probe, %zu probes inside geometry\n",
                    vf.volume.visibilityMapSize, vf.volume.visibilityMapSize, inside);
      }
      std::printf("  scene %s in units %s, %zu rig lights\n", src.scenePath.c_str(),
                  sceneUnitName(vf.metresPerUnit).c_str(), src.rig.lights.size());
      // How the probes' values were made (volumeSource has checked the metadata is JSON).
      const ojson meta = ojson::parse(vf.metadataJson, nullptr, false);
      const ojson* fit = meta.is_object() && meta.contains("fit") ? &meta["fit"] : nullptr;
      if (fit && fit->is_object() && fit->value("points", ojson()).is_number_unsigned() &&
          fit->value("samples_per_point", ojson()).is_number_integer())
        std::printf("  values fitted by least squares to %llu points at %lld spp (bake --fit)\n",
                    static_cast<unsigned long long>((*fit)["points"].get<uint64_t>()),
                    static_cast<long long>((*fit)["samples_per_point"].get<int64_t>()));
      else
        std::printf("  values captured at each probe\n");
      return;
    }
    const ProbeSet set = loadProbeSet(*file);
    size_t counts[3] = {0, 0, 0}, captured = 0, locked = 0;
    for (const Probe& p : set.probes) {
      ++counts[static_cast<int>(p.state)];
      captured += p.sh.has_value();
      locked += p.locked;
    }
    std::printf("%s: probe set, format version %d\n", file->c_str(), ProbeSet::kFormatVersion);
    std::printf("  scene %s in units %s (positions are in them)\n", set.scenePath.c_str(),
                sceneUnitName(set.metresPerUnit).c_str());
    std::printf(
        "  probes %zu: %zu candidate, %zu accepted, %zu rejected; %zu locked, %zu captured\n",
        set.probes.size(), counts[0], counts[1], counts[2], locked, captured);
    std::printf("  placement %s, spacing %.3f m, budget %d; rig: %zu lights, sky [%g, %g, %g]\n",
                set.placement.method.c_str(), set.placement.spacingMeters, set.placement.budget,
                set.rig.lights.size(), set.rig.skyRadiance.r, set.rig.skyRadiance.g,
                set.rig.skyRadiance.b);
    std::printf("  %zu importance volumes\n", set.importanceVolumes.size());
    std::error_code ec;
    if (set.scenePath.empty() || !fs::exists(set.scenePath, ec)) {
      std::printf("  scene hash %s (the scene file is not there to compare)\n",
                  sceneHashText(set.sceneHash).c_str());
      return;
    }
    const uint64_t now = sceneContentHash(set.scenePath, set.metresPerUnit);
    std::printf(
        "  scene hash %s, %s\n", sceneHashText(set.sceneHash).c_str(),
        set.sceneHash == now ? "matches the scene" : ("scene now " + sceneHashText(now)).c_str());
    const std::string stale = describeStaleCaptures(set, staleCaptures(set, now));
    if (!stale.empty()) std::printf("  %s\n", stale.c_str());
  });
}

}  // namespace ps::cli
