#pragma once
// Baked probe volume files (.psv): documented little-endian binary with magic, version,
// counts, float arrays and a CRC-32 (format: docs/formats.md).
#include <filesystem>
#include <string>

#include "core/traversal/ProbeVolume.h"

namespace ps {

struct VolumeFile {
  /// In metres, as the core works. The file holds it in the scene's unit (`metresPerUnit`), so
  /// that an engine queries it in its own coordinates.
  ProbeVolume volume;
  /// UTF-8 JSON with where the volume came from: scene path (relative to the volume file when
  /// saved, absolute after load), lighting rig and importance boxes (positions in the scene's
  /// unit), "units" (absent: metres); used by `eval` on a volume.
  std::string metadataJson;
  /// The scene's unit, metres per unit (core/scene/SceneUnits.h): the unit of the file's
  /// lengths, and metadata "units".
  double metresPerUnit = 1.0;
};

/// Writes atomically, every length in the scene's unit (scaleVolume() by 1 / metresPerUnit),
/// with metadata "units" set to it (left out in metres when the metadata has none, so a volume
/// in metres is written as before). The metadata must be a JSON object unless metresPerUnit
/// is 1 (PS_CHECK). Throws ps::FileError.
void saveVolume(const VolumeFile& v, const std::filesystem::path& path);
/// Throws ps::FileError naming the file and the problem (bad magic, version, truncated data,
/// counts beyond the file's size, bad CRC, indices out of range, a malformed metadata "units").
/// The volume is scaled to metres by the metadata's "units" (metres when absent, or when the
/// metadata is not a JSON object).
VolumeFile loadVolume(const std::filesystem::path& path);
/// loadVolume() on the file's bytes; `name` names the file in errors.
VolumeFile parseVolume(const std::string& data, const std::string& name);

uint32_t crc32(const void* data, size_t size, uint32_t crc = 0);

}  // namespace ps
