#include "core/bake/CaptureCache.h"

#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <system_error>

#include "core/common/Error.h"
#include "core/io/JsonFields.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/io/VolumeFile.h"

// Entry layout, little-endian: char[8] "PSCACHE1", u64 key, f64[27] SH (coefficient-major RGB),
// u32 CRC-32 of the bytes before it.
namespace ps {

namespace {
constexpr char kMagic[8] = {'P', 'S', 'C', 'A', 'C', 'H', 'E', '1'};
constexpr size_t kEntryBytes = 8 + 8 + 27 * 8 + 4;
}  // namespace

CaptureCache::CaptureCache(std::filesystem::path dir) : dir_(std::move(dir)) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec || !std::filesystem::is_directory(dir_))
    throw FileError(dir_.string(), "", "cannot create the capture cache folder");
}

uint64_t CaptureCache::key(uint64_t sceneHash, const LightingRig& rig,
                           const CaptureSettings& settings, Vec3 position) {
  uint64_t h = fnv1a64(&kAlgorithmVersion, sizeof kAlgorithmVersion);
  h = fnv1a64(&sceneHash, sizeof sceneHash, h);
  const std::string r = rigToJson(rig).dump();  // shortest round-trip doubles: exact
  h = fnv1a64(r.data(), r.size(), h);
  const int32_t spp = settings.samplesPerProbe;
  const int32_t mode = static_cast<int32_t>(settings.mode);
  h = fnv1a64(&spp, sizeof spp, h);
  h = fnv1a64(&settings.seed, sizeof settings.seed, h);
  h = fnv1a64(&mode, sizeof mode, h);
  // Adaptive sampling decides how many rays each probe gets.
  const double target = settings.targetRelativeError;
  const int32_t minMax[2] = {settings.minSamplesPerProbe, settings.maxSamplesPerProbe};
  h = fnv1a64(&target, sizeof target, h);
  h = fnv1a64(minMax, sizeof minMax, h);
  const double xyz[3] = {position.x, position.y, position.z};
  return fnv1a64(xyz, sizeof xyz, h);
}

std::filesystem::path CaptureCache::entryPath(uint64_t key) const {
  return dir_ / (sceneHashText(key) + ".pscc");
}

std::optional<ShRgb> CaptureCache::find(uint64_t key) const {
  std::FILE* f = std::fopen(entryPath(key).c_str(), "rb");
  if (!f) return std::nullopt;
  char buf[kEntryBytes + 1];
  const size_t n = std::fread(buf, 1, sizeof buf, f);
  std::fclose(f);
  if (n != kEntryBytes || std::memcmp(buf, kMagic, 8) != 0) return std::nullopt;
  uint64_t stored;
  std::memcpy(&stored, buf + 8, 8);
  uint32_t crc;
  std::memcpy(&crc, buf + kEntryBytes - 4, 4);
  if (stored != key || crc32(buf, kEntryBytes - 4) != crc) return std::nullopt;
  ShRgb sh;
  for (int k = 0; k < kShCoeffCount; ++k)
    for (int c = 0; c < 3; ++c) std::memcpy(&sh.c[k][c], buf + 16 + 8 * (3 * k + c), 8);
  return sh;
}

void CaptureCache::store(uint64_t key, const ShRgb& sh) const {
  std::string buf(kEntryBytes, '\0');
  std::memcpy(buf.data(), kMagic, 8);
  std::memcpy(buf.data() + 8, &key, 8);
  for (int k = 0; k < kShCoeffCount; ++k)
    for (int c = 0; c < 3; ++c) {
      const double v = sh.c[k][c];
      std::memcpy(buf.data() + 16 + 8 * (3 * k + c), &v, 8);
    }
  const uint32_t crc = crc32(buf.data(), kEntryBytes - 4);
  std::memcpy(buf.data() + kEntryBytes - 4, &crc, 4);
  writeFileAtomic(entryPath(key), buf, /*durable=*/false);
}

}  // namespace ps
