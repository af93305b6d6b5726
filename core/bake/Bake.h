#pragma once
// Bake: the accepted probes of a set captured at final quality, tetrahedralized and turned into
// the runtime volume (DESIGN.md data flow, last stage).
#include <span>
#include <string>

#include "core/capture/Capture.h"
#include "core/io/ProbeSet.h"
#include "core/io/VolumeFile.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

/// The runtime volume over `positions` with one SH per position (duplicates merged: the first
/// occurrence's SH is kept). Throws ps::ParameterError when the positions span less than 3D.
ProbeVolume volumeFromProbes(std::span<const Vec3> positions, std::span<const ShRgb> sh);

struct BakeSettings {
  CaptureSettings capture{.samplesPerProbe = 1024};
};

struct BakeResult {
  VolumeFile file;
  size_t probes = 0;
  double captureSeconds = 0;
  double tetraSeconds = 0;
};

/// Captures every accepted probe of `set` with the set's rig and builds the volume. The volume's
/// metadata JSON records the scene path (absolute; saveVolume's caller may relativize), the rig
/// and the probe ids. Throws ps::ParameterError when fewer than 4 probes are accepted.
BakeResult bakeProbeSet(const ProbeSet& set, const Tracer& tracer, const BakeSettings& settings,
                        const ProgressFn& progress = {});

}  // namespace ps
