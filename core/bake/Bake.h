#pragma once
// Bake: the accepted probes of a set captured at final quality, tetrahedralized and turned into
// the runtime volume (DESIGN.md data flow, last stage). Stages, in order, each a function below
// so that more can be slotted in: gather the accepted probes -> leak refinement (adds probes
// where the mesh's edges cross geometry; geometry only, so before the capture) -> capture
// (through the capture cache, the added probes too) -> tetrahedralize -> leak cuts (with leak
// refinement) -> least-squares fit (when asked) -> metadata.
#include <filesystem>
#include <optional>
#include <span>
#include <string>

#include "core/bake/LeastSquaresFit.h"
#include "core/capture/Capture.h"
#include "core/io/ProbeSet.h"
#include "core/io/VolumeFile.h"
#include "core/placement/LeakRefine.h"
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
  /// Leak handling (Sukys 3.2.2 and the leak cuts) before and after the capture; off by default
  /// (`bake --leak-refine` turns it on): the volume's visibility maps keep the light from
  /// crossing walls, and neither Sukys's probes (at equal probe count) nor the cuts lower the
  /// error on top of them (docs/leaks.md). Off, the volume holds exactly the set's accepted
  /// probes.
  bool leakRefine = false;
  /// With leak refinement: Sukys's probes on both sides of the walls the mesh's edges cross.
  /// Off (`bake --leak-cuts-only`), the edges are traced and counted but nothing is added: with
  /// the cuts, the volume holds exactly the set's accepted probes.
  bool leakRefineProbes = true;
  /// With leak refinement: the leak cuts after the tetrahedralization (computeLeakCuts);
  /// `bake --no-leak-cuts` turns them off, leaving Sukys's refinement alone.
  bool leakCuts = true;
  /// With the cuts: probes where they cannot end a leak (refineForLeakCuts); off by default
  /// (`bake --leak-cut-probes`, which also sets leakCutSettings.overCutWeight to 0 unless
  /// `--over-cut-weight` is given). Off by default: they end leaks the cuts leave by adding
  /// probes beyond the placed set, so the volume's probe count is no longer the set's (their
  /// effect on rel_rmse is not measured under today's defaults).
  bool leakCutProbes = false;
  LeakRefineSettings leakRefineSettings;
  LeakCutSettings leakCutSettings;
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
  size_t captured = 0;            ///< probes traced in this bake
  size_t cacheHits = 0;           ///< probes whose SH came from the capture cache
  size_t leakProbesAdded = 0;     ///< probes added by leak refinement (included in `probes`)
  size_t leakCutProbesAdded = 0;  ///< of those, added for the cuts (refineForLeakCuts)
  size_t leakingEdgesBefore = 0, leakingEdgesAfter = 0;
  double leakingVolumeFractionBefore = 0, leakingVolumeFractionAfter = 0;
  double leakSeconds = 0;                 ///< the leak refinement stage (the cuts apart)
  std::optional<LeakCutResult> leakCuts;  ///< with leak refinement and cuts
  double captureSeconds = 0;
  double tetraSeconds = 0;
  std::optional<FitResult> fit;  ///< when BakeSettings::fit was set
};

/// The bake's working data between stages.
struct BakeProbes {
  std::vector<uint64_t> ids;  ///< 0 for probes added by leak refinement (not in the set)
  std::vector<Vec3> positions;
  std::vector<ShRgb> sh;                    ///< filled by the capture stage
  std::vector<ProbeVisibility> visibility;  ///< filled by the capture stage
};

/// Stage 1: the accepted probes of `set`. Throws ps::ParameterError when fewer than 4.
BakeProbes gatherAcceptedProbes(const ProbeSet& set);

/// Stage 2: leak refinement (when settings.leakRefine): Sukys's edge refinement, then the probes
/// the leak cuts need (refineForLeakCuts, with the set's rig, for queries in
/// `domain`: the importance boxes, empty for the scene bounds); appends the added probes (id 0)
/// and records the counts in r.
void leakRefineStage(BakeProbes& probes, const Tracer& tracer, const BakeSettings& settings,
                     const LightingRig& rig, std::span<const Bounds3> domain, BakeResult& r);

/// Stage 3: fills `probes.sh` and `probes.visibility`, from the cache where it has an entry,
/// tracing the rest (in one captureProbes call) and storing them in the cache. Adds to r.captured /
/// r.cacheHits.
void captureStage(BakeProbes& probes, const LightingRig& rig, const Tracer& tracer,
                  const BakeSettings& settings, const ProgressFn& progress, BakeResult& r);

/// Captures every accepted probe of `set` (plus those leak refinement adds) with the set's rig,
/// builds the volume and, when settings.fit is set, fits its values. The volume's metadata JSON
/// records the scene path (absolute; saveVolume's caller may relativize), the rig, the probe ids
/// and the leak probes added. Throws ps::ParameterError when fewer than 4 probes are accepted.
/// `progress` covers the capture, the leak cuts and the fit, each a share of [0, 1]; returning
/// false from it during any of them throws ps::Cancelled.
BakeResult bakeProbeSet(const ProbeSet& set, const Tracer& tracer, const BakeSettings& settings,
                        const ProgressFn& progress = {});

}  // namespace ps
