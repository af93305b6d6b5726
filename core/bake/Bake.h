#pragma once
// Bake: the accepted probes of a set captured at final quality, tetrahedralized and turned into
// the runtime volume (DESIGN.md data flow, last stage). Stages, in order, each a function below
// so that more can be slotted in: gather the accepted probes -> capture (through the capture
// cache) -> tetrahedralize -> least-squares fit (when asked) -> metadata. The volume holds
// exactly the set's accepted probes; light leaks are the visibility maps' business
// (docs/leaks.md).
#include <filesystem>
#include <optional>
#include <span>
#include <string>

#include "core/bake/LeastSquaresFit.h"
#include "core/capture/Capture.h"
#include "core/io/ProbeSet.h"
#include "core/io/VolumeFile.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

/// The visibility of one captured probe (ProbeCapture::distanceMoments, and whether the capture
/// found it inside geometry).
struct ProbeVisibility {
  std::array<float, kVisibilityFloats> distanceMoments{};
  bool inside = false;
};

/// The runtime volume over `positions` with one SH per position (duplicates merged: the first
/// occurrence's SH is kept), and, when `visibility` is not empty (one per position), the
/// visibility maps (the first occurrence's likewise). Throws ps::ParameterError when the
/// positions span less than 3D.
ProbeVolume volumeFromProbes(std::span<const Vec3> positions, std::span<const ShRgb> sh,
                             std::span<const ProbeVisibility> visibility = {});

struct BakeSettings {
  CaptureSettings capture{.samplesPerProbe = 1024};
  /// Folder of the capture cache (see CaptureCache); none = capture every probe.
  std::optional<std::filesystem::path> cacheDir;
  /// sceneContentHash() of the scene the tracer was built from; part of every cache key. The
  /// cache is used only when this is non-zero.
  uint64_t sceneHash = 0;
  /// Least-squares probe values (LeastSquaresFit.h) after the tetrahedralization; off by
  /// default (`bake --fit`). The fit points are drawn in the set's importance volumes (the
  /// scene bounds when it has none) and are not cached.
  std::optional<FitSettings> fit;
  /// The fit points' domain where the set has no importance volume (DomainPoints.h).
  DomainSettings domain;
};

struct BakeResult {
  VolumeFile file;
  size_t probes = 0;
  size_t captured = 0;   ///< probes traced in this bake
  size_t cacheHits = 0;  ///< probes whose SH came from the capture cache
  double captureSeconds = 0;
  double tetraSeconds = 0;
  std::optional<FitResult> fit;  ///< when BakeSettings::fit was set
};

/// The bake's working data between stages.
struct BakeProbes {
  std::vector<uint64_t> ids;  ///< the probes' ids in the set
  std::vector<Vec3> positions;
  std::vector<ShRgb> sh;                    ///< filled by the capture stage
  std::vector<ProbeVisibility> visibility;  ///< filled by the capture stage
};

/// Stage 1: the accepted probes of `set`. Throws ps::ParameterError when fewer than 4.
BakeProbes gatherAcceptedProbes(const ProbeSet& set);

/// Stage 2: fills `probes.sh` and `probes.visibility`, from the cache where it has an entry,
/// tracing the rest (in one captureProbes call) and storing them in the cache. Adds to r.captured /
/// r.cacheHits.
void captureStage(BakeProbes& probes, const LightingRig& rig, const Tracer& tracer,
                  const BakeSettings& settings, const ProgressFn& progress, BakeResult& r);

/// Captures every accepted probe of `set` with the set's rig, builds the volume and, when
/// settings.fit is set, fits its values. The volume's metadata JSON records the scene path
/// (absolute; saveVolume's caller may relativize), the rig and the probe ids. Throws
/// ps::ParameterError when fewer than 4 probes are accepted. `progress` covers the capture and
/// the fit, each a share of [0, 1]; returning false from it during either throws ps::Cancelled.
BakeResult bakeProbeSet(const ProbeSet& set, const Tracer& tracer, const BakeSettings& settings,
                        const ProgressFn& progress = {});

}  // namespace ps
