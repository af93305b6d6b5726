#pragma once
// What the viewport's lighting overlays show, computed on the CPU from core data (no GL here):
// the preview volume of the current probes, its resampling on a grid (the "probe lighting"
// preview and the gradient glyphs), the luminance-weighted direction vector f (Chajdas et al.
// 2011, sec. 3.2, eq. 1; their Fig. 2), the luminance distance between two probes (their
// Fig. 11), the interpolation error against a reference, and the tetrahedral mesh's edges with
// the ones that cross geometry (light leaks, Sukys 2014 sec. 3.3).
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "core/io/ProbeSet.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {
class Tracer;
class EditableProbeVolume;
}  // namespace ps

namespace ps::ui {

/// Mean incident radiance's luminance (Y00 * luminance(c00)), the probe's "brightness".
double meanLuminance(const ShRgb& sh);

/// Luminance distance of two probes in stops: |log2(meanLuminance(a) / meanLuminance(b))|, with
/// both clamped below at 1e-6 (so black against black is 0). Our reading of Chajdas Fig. 11's
/// "luminance distance", in stops because brightness is perceived on a log scale.
double luminanceDistanceStops(const ShRgb& a, const ShRgb& b);

/// Which probes the preview volume is built from.
enum class PreviewSource {
  Accepted,     ///< accepted probes with SH (what a bake would use, at preview quality)
  AllCaptured,  ///< every non-rejected probe with SH (candidates too)
  Baked         ///< the document's baked (or loaded) volume; buildPreviewVolume gives nothing
};

/// The volume over the chosen probes (Bake.h volumeFromProbes), or nothing when fewer than 4
/// of them span 3D.
std::optional<ProbeVolume> buildPreviewVolume(const std::vector<Probe>& probes,
                                              PreviewSource source);

/// The preview volume kept in step with the document by local edits (EditableProbeVolume,
/// Sukys 3.2.1 after Cupisz): sync() compares the probes with what the volume holds and inserts,
/// removes, moves or re-colours only the probes that changed, so one edit costs microseconds
/// instead of a rebuild. It rebuilds when the source changes, when more than an eighth of the
/// probes changed, or when a local edit is refused (the probes would span fewer than 3D). The
/// volume holds the probes buildPreviewVolume() takes; its tets are the same, numbered by the
/// edit history. Exact duplicates take the SH of the one the volume met first.
class PreviewVolumeMirror {
 public:
  PreviewVolumeMirror();
  ~PreviewVolumeMirror();
  PreviewVolumeMirror(const PreviewVolumeMirror&) = delete;
  PreviewVolumeMirror& operator=(const PreviewVolumeMirror&) = delete;

  struct SyncReport {
    size_t inserted = 0, removed = 0, moved = 0, recoloured = 0;
    bool rebuilt = false;      ///< built from scratch instead of edited
    size_t tetsRewritten = 0;  ///< by the local edits
    double seconds = 0;        ///< wall time of the local edits (or of the rebuild)
    bool changed() const { return rebuilt || inserted + removed + moved + recoloured > 0; }
  };
  SyncReport sync(const std::vector<Probe>& probes, PreviewSource source);
  /// The volume, or nullptr when fewer than 4 probes span 3D (or the source is Baked).
  const ProbeVolume* volume() const;

 private:
  struct Entry {
    int32_t probe = -1;  ///< id in the EditableProbeVolume
    Vec3 position;
    ShRgb sh;
    uint64_t stamp = 0;  ///< the sync that last met it
  };
  SyncReport rebuild(const std::vector<const Probe*>& wanted);

  std::unique_ptr<EditableProbeVolume> volume_;
  std::unordered_map<uint64_t, Entry> entries_;  ///< document probe id -> its probe in volume_
  std::optional<PreviewSource> source_;
  uint64_t stamp_ = 0;
};

/// SH sampled from a volume at the centres of a regular grid over a box.
struct ShGrid {
  std::array<int, 3> dims{0, 0, 0};
  Vec3 lo;          ///< corner of the box
  Vec3 cellMeters;  ///< cell size; sample (i, j, k) is at lo + (i + 0.5, j + 0.5, k + 0.5) * cell
  std::vector<ShRgb> sh;  ///< x fastest, then y, then z
  size_t size() const { return sh.size(); }
  Vec3 centre(size_t index) const;
};

/// The grid over `box` whose longest side has `maxCellsPerAxis` cells (cubic cells; every axis
/// gets >= 1), its SH zero; empty for an empty box or maxCellsPerAxis < 1.
ShGrid shGridLayout(const Bounds3& box, int maxCellsPerAxis);

/// Samples `volume` (locate + interpolate, walks starting from the previous cell) on
/// shGridLayout(box, maxCellsPerAxis).
ShGrid sampleGrid(const ProbeVolume& volume, const Bounds3& box, int maxCellsPerAxis);

/// Unique edges of the volume's tetrahedra (vertex pairs, smaller index first), sorted.
std::vector<std::array<int32_t, 2>> tetEdges(const ProbeVolume& volume);

/// For each edge, true when the segment between its probes hits geometry (the interpolation
/// along it blends light from both sides of a wall: a leak).
std::vector<uint8_t> leakingEdges(const Tracer& tracer, const ProbeVolume& volume,
                                  const std::vector<std::array<int32_t, 2>>& edges);

/// For each edge, the luminance distance in stops between its two probes (luminanceDistanceStops):
/// where neighbouring probes differ too much (Chajdas sec. 4, "we can show the locations where
/// the distance becomes too large").
std::vector<float> edgeLuminanceDistances(const ProbeVolume& volume,
                                          const std::vector<std::array<int32_t, 2>>& edges);

/// Relative irradiance error |E_test - E_ref| / max(E_ref, floor) of the luminance of the
/// irradiance for normal n, at p (the error slice). `floor` keeps dark regions from dominating.
double relativeIrradianceError(const ProbeVolume& test, const ProbeVolume& reference, Vec3 p,
                               Vec3 n, double floor);

}  // namespace ps::ui
