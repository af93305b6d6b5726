#pragma once
// eval's reference cache on disk: one file per reference, keyed by everything that decides it
// (scene content hash, the whole lighting rig with its environment map's texels, the domain of
// interest, query count, seed, reference samples, and the algorithm versions), so evaluating
// another volume of the same scene and rig reads the reference instead of tracing it again.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>

#include "core/eval/Evaluate.h"
#include "core/io/KeyedFileCache.h"
#include "core/math/Vec3.h"
#include "core/scene/LightingRig.h"

namespace ps {

/// The default reference cache folder for inputs in `folder` (`folder/eval-reference-cache`,
/// shared by every set and volume there, and by the editor), created when missing; nothing when
/// it cannot be made (a read-only folder): the cache is a convenience, not a requirement.
std::optional<std::filesystem::path> defaultReferenceCacheDir(const std::filesystem::path& folder);

class ReferenceCache {
 public:
  /// Opens (creating when missing) the cache folder `dir`. Throws ps::FileError when it cannot
  /// be created.
  explicit ReferenceCache(std::filesystem::path dir);

  /// The key of one reference. Changes with any bit of the scene hash, the rig (its JSON and its
  /// environment map's texels), the domain the queries are drawn from (its boxes in order: the
  /// scene bounds, or the importance volumes), queries, referenceSpp or seed, the light
  /// clearance when `hasPunctualLights` (the scene or rig has a point or spot light), and with
  /// kAlgorithmVersion or the capture integrator's CaptureCache::kAlgorithmVersion; when
  /// `hasDoubleSided` (Scene::hasDoubleSidedSurfaces), with kDoubleSidedValidityVersion too (the
  /// only scenes whose queries' validity it decides).
  /// Throws ps::FileError when the rig's map cannot be read.
  static uint64_t key(uint64_t sceneHash, const LightingRig& rig, std::span<const Bounds3> domain,
                      const EvalSettings& settings, bool hasPunctualLights,
                      bool hasDoubleSided = false);
  static uint64_t key(uint64_t sceneHash, const LightingRig& rig, const Bounds3& domain,
                      const EvalSettings& settings, bool hasPunctualLights,
                      bool hasDoubleSided = false) {
    return key(sceneHash, rig, std::span<const Bounds3>(&domain, 1), settings, hasPunctualLights,
               hasDoubleSided);
  }

  /// The reference stored for `key` with `queries` queries, or nothing. A damaged entry
  /// (truncated, bad CRC, another key, another query count) counts as absent and says what is
  /// wrong in `*problem` (left empty when the entry is merely missing).
  std::optional<EvalReference> find(uint64_t key, size_t queries, std::string* problem) const;
  /// Stores atomically. Throws ps::FileError when the entry cannot be written.
  void store(uint64_t key, const EvalReference& reference) const;

  std::filesystem::path entryPath(uint64_t key) const { return files_.entryPath(key); }
  const std::filesystem::path& dir() const { return files_.dir(); }

  /// Bump when the query sampling or the reference estimator changes its results.
  static constexpr uint32_t kAlgorithmVersion = 3;  ///< 2: entries hold the variance; 3: paths
                                                    ///< draw from their own streams, lights sampled
  /// Keys only scenes with double-sided surfaces. 2: the back faces of double-sided geometry
  /// count half towards "inside" (backfaceFraction).
  static constexpr uint32_t kDoubleSidedValidityVersion = 2;

 private:
  KeyedFileCache files_;
};

}  // namespace ps
