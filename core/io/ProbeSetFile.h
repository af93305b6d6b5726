#pragma once
// Probe-set JSON files: versioned, stable key order, atomic save.
#include <filesystem>
#include <string>

#include "core/io/ProbeSet.h"

namespace ps {

/// Reads a probe set. `scenePath` in the result is resolved against the file's folder. The
/// file's lengths (probe positions, importance volumes, rig light positions) are in its scene
/// unit ("units", metres before version 3); the result holds them in metres and the unit in
/// `metresPerUnit`. Throws ps::FileError naming the file and the JSON path of the bad field
/// (`probes[12].position: expected 3 numbers, got 2`, `units: expected "m", ...`), or a version
/// newer than this build.
ProbeSet loadProbeSet(const std::filesystem::path& path);

/// loadProbeSet() on the file's text: `path` names the file in errors and resolves `scene`.
ProbeSet parseProbeSet(const std::string& text, const std::filesystem::path& path);

/// Writes atomically (temp file, fsync, rename); `scenePath` is stored relative to the file's
/// folder, and lengths in the set's scene unit (`metresPerUnit`), always as version 3. Throws
/// ps::FileError when the file cannot be written; the old file is then intact.
void saveProbeSet(const ProbeSet& set, const std::filesystem::path& path);

/// The whole content of a file. Throws ps::FileError when it is missing or unreadable.
std::string readWholeFile(const std::filesystem::path& path);

/// Writes `bytes` to `path` atomically: a temp file beside it, fsync, rename. With
/// `durable = false` the fsyncs are skipped (still atomic for a killed process, not for a power
/// loss; for caches whose entries are checksummed).
void writeFileAtomic(const std::filesystem::path& path, const std::string& bytes,
                     bool durable = true);

}  // namespace ps
