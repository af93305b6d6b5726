#pragma once
// Baked probe volume files (.psv): documented little-endian binary with magic, version,
// counts, float arrays and a CRC-32 (format: docs/formats.md).
#include <filesystem>
#include <string>

#include "core/traversal/ProbeVolume.h"

namespace ps {

struct VolumeFile {
  ProbeVolume volume;
  /// UTF-8 JSON with where the volume came from: scene path (relative to the volume file when
  /// saved, absolute after load), lighting rig; used by `eval` on a volume.
  std::string metadataJson;
};

/// Writes atomically. Throws ps::FileError.
void saveVolume(const VolumeFile& v, const std::filesystem::path& path);
/// Throws ps::FileError naming the file and the problem (bad magic, version, truncated data,
/// counts beyond the file's size, bad CRC, indices out of range).
VolumeFile loadVolume(const std::filesystem::path& path);
/// loadVolume() on the file's bytes; `name` names the file in errors.
VolumeFile parseVolume(const std::string& data, const std::string& name);

uint32_t crc32(const void* data, size_t size, uint32_t crc = 0);

}  // namespace ps
