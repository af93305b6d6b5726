#pragma once
// The content hash of a scene, and which captures of a probe set it makes stale.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/io/ProbeSet.h"

namespace ps {

/// 64-bit FNV-1a of `size` bytes, continuing from `h` (the FNV offset basis by default).
uint64_t fnv1a64(const void* data, size_t size, uint64_t h = 0xcbf29ce484222325ull);

/// The hash of a scene's content: FNV-1a 64 of the file's bytes and, for a .gltf, of each
/// external buffer and image it references (in document order; data: URIs are inside the file
/// already). Never 0 (0 means "unknown" in a probe set). Throws ps::FileError when the scene or
/// a referenced buffer cannot be read; a missing or unreadable image is hashed as missing (the
/// loader falls back to the material's factor with a warning). A unit other than metres
/// (`metresPerUnit` != 1, core/scene/SceneUnits.h) is folded in: the same file read in another
/// unit is another scene to every cache.
uint64_t sceneContentHash(const std::filesystem::path& scene, double metresPerUnit = 1.0);

/// `h` with the texels of the rig's environment map folded in (`h` itself when it has none).
/// A rig names its map by path only, so cache keys fold this in: a map edited in place must
/// miss. Throws ps::FileError when the map cannot be read.
uint64_t foldEnvironmentTexels(uint64_t h, const LightingRig& rig);

/// 16 lowercase hex digits, or "unknown" for 0.
std::string sceneHashText(uint64_t h);

struct StaleCaptures {
  std::vector<uint64_t> changed;  ///< ids of probes captured in a different scene state
  std::vector<uint64_t> unknown;  ///< ids of probes whose capture recorded no scene hash
  bool any() const { return !changed.empty() || !unknown.empty(); }
};

/// The captured probes of `set` whose SH does not come from the scene as it is now
/// (`currentSceneHash`, from sceneContentHash()).
StaleCaptures staleCaptures(const ProbeSet& set, uint64_t currentSceneHash);

/// One line for the user, e.g. "3 of 40 captures are stale (the scene changed since they were
/// captured): probes 4, 7, 12"; empty when nothing is stale. Lists at most `maxIds` ids.
std::string describeStaleCaptures(const ProbeSet& set, const StaleCaptures& s, size_t maxIds = 12);

}  // namespace ps
