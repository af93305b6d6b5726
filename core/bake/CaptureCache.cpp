#include "core/bake/CaptureCache.h"

#include <cstring>
#include <nlohmann/json.hpp>

#include "core/io/JsonFields.h"
#include "core/io/SceneHash.h"

// Entries (KeyedFileCache): magic "PSCACHE1", payload f64[27] SH (coefficient-major RGB).
namespace ps {

namespace {
constexpr std::array<char, 8> kMagic = {'P', 'S', 'C', 'A', 'C', 'H', 'E', '1'};
constexpr size_t kPayloadBytes = 27 * 8;
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

std::optional<ShRgb> CaptureCache::find(uint64_t key) const {
  const KeyedFileCache::Lookup e = files_.find(key, kPayloadBytes);
  if (e.status != KeyedFileCache::Status::Found) return std::nullopt;
  ShRgb sh;
  for (int k = 0; k < kShCoeffCount; ++k)
    for (int c = 0; c < 3; ++c) std::memcpy(&sh.c[k][c], e.payload.data() + 8 * (3 * k + c), 8);
  return sh;
}

void CaptureCache::store(uint64_t key, const ShRgb& sh) const {
  std::string buf(kPayloadBytes, '\0');
  for (int k = 0; k < kShCoeffCount; ++k)
    for (int c = 0; c < 3; ++c) {
      const double v = sh.c[k][c];
      std::memcpy(buf.data() + 8 * (3 * k + c), &v, 8);
    }
  files_.store(key, buf);
}

}  // namespace ps
