#pragma once
// A capture cache on disk: one small file per captured probe, keyed by everything that decides
// the capture (scene content hash, lighting rig, capture settings, probe position), so a re-bake
// after moving one probe recaptures only that probe.
#include <cstdint>
#include <filesystem>
#include <optional>

#include "core/capture/Capture.h"
#include "core/io/KeyedFileCache.h"
#include "core/math/Sh.h"
#include "core/scene/LightingRig.h"

namespace ps {

/// What the cache keeps of one capture: the SH, the visibility map and whether the probe is
/// inside geometry.
struct CaptureCacheEntry {
  ShRgb sh;
  std::array<float, kVisibilityFloats> distanceMoments{};
  bool inside = false;
  bool operator==(const CaptureCacheEntry&) const = default;
};

class CaptureCache {
 public:
  /// Opens (creating when missing) the cache folder `dir`. Throws ps::FileError when it cannot
  /// be created.
  explicit CaptureCache(std::filesystem::path dir);

  /// The key of one capture. Changes with any bit of the scene hash, rig, settings (samples,
  /// seed, mode, adaptive target and bounds; not the thread count, which does not change
  /// results) or position, and with kAlgorithmVersion. The bake folds the environment map's
  /// texels into `sceneHash` (the rig names the map by path only).
  static uint64_t key(uint64_t sceneHash, const LightingRig& rig, const CaptureSettings& settings,
                      Vec3 position);

  /// The cached entry for `key`, or nothing when absent. A damaged entry (truncated, bad CRC,
  /// another key, an entry of the older layout without visibility) counts as absent and is
  /// overwritten by the next store().
  std::optional<CaptureCacheEntry> find(uint64_t key) const;
  /// Stores atomically (a killed bake never leaves a half entry).
  void store(uint64_t key, const CaptureCacheEntry& entry) const;

  const std::filesystem::path& dir() const { return files_.dir(); }

  /// Bump when the capture integrator changes its results, to invalidate every old entry.
  static constexpr uint32_t kAlgorithmVersion = 3;  ///< 2: textures, environment maps, adaptive;
                                                    ///< 3: many lights sampled from a tree

 private:
  KeyedFileCache files_;
};

}  // namespace ps
