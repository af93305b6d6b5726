#include "core/bake/CaptureCache.h"

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "core/io/JsonFields.h"
#include "core/io/SceneHash.h"

// Entries (KeyedFileCache): magic "PSCACHE2", payload f64[27] SH (coefficient-major RGB), u32
// inside (0 or 1), f32[kVisibilityFloats] visibility map (Capture.h). Entries of the older magic
// "PSCACHE1" (SH only) count as damaged: recaptured.
namespace ps {

namespace {
constexpr std::array<char, 8> kMagic = {'P', 'S', 'C', 'A', 'C', 'H', 'E', '2'};
constexpr size_t kShBytes = 27 * 8;
constexpr size_t kPayloadBytes = kShBytes + 4 + 4 * size_t(kVisibilityFloats);
}  // namespace

CaptureCache::CaptureCache(std::filesystem::path dir)
    : files_(std::move(dir), kMagic, ".pscc", "capture cache") {}

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

std::optional<CaptureCacheEntry> CaptureCache::find(uint64_t key) const {
  const KeyedFileCache::Lookup e = files_.find(key, kPayloadBytes);
  if (e.status != KeyedFileCache::Status::Found) return std::nullopt;
  CaptureCacheEntry entry;
  for (int k = 0; k < kShCoeffCount; ++k)
    for (int c = 0; c < 3; ++c)
      std::memcpy(&entry.sh.c[k][c], e.payload.data() + 8 * (3 * k + c), 8);
  uint32_t inside = 0;
  std::memcpy(&inside, e.payload.data() + kShBytes, 4);
  if (inside > 1) return std::nullopt;
  entry.inside = inside == 1;
  std::memcpy(entry.distanceMoments.data(), e.payload.data() + kShBytes + 4,
              4 * size_t(kVisibilityFloats));
  for (float m : entry.distanceMoments)
    if (!std::isfinite(m) || m < 0) return std::nullopt;
  return entry;
}

void CaptureCache::store(uint64_t key, const CaptureCacheEntry& entry) const {
  std::string buf(kPayloadBytes, '\0');
  for (int k = 0; k < kShCoeffCount; ++k)
    for (int c = 0; c < 3; ++c) {
      const double v = entry.sh.c[k][c];
      std::memcpy(buf.data() + 8 * (3 * k + c), &v, 8);
    }
  const uint32_t inside = entry.inside ? 1 : 0;
  std::memcpy(buf.data() + kShBytes, &inside, 4);
  std::memcpy(buf.data() + kShBytes + 4, entry.distanceMoments.data(),
              4 * size_t(kVisibilityFloats));
  files_.store(key, buf);
}

}  // namespace ps
