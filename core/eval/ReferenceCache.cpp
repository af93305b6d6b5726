#include "core/eval/ReferenceCache.h"

#include <cstring>
#include <nlohmann/json.hpp>

#include "core/bake/CaptureCache.h"
#include "core/io/JsonFields.h"
#include "core/io/SceneHash.h"

// Entries (KeyedFileCache): magic "PSEVREF2", payload u64 query count, then per query f64[10]:
// point xyz, normal xyz, irradiance rgb, the variance of the irradiance's luminance.
namespace ps {

namespace {
constexpr std::array<char, 8> kMagic = {'P', 'S', 'E', 'V', 'R', 'E', 'F', '2'};
constexpr size_t kQueryBytes = 10 * 8;

size_t payloadBytes(size_t queries) {
  return 8 + queries * kQueryBytes;
}
}  // namespace

std::optional<std::filesystem::path> defaultReferenceCacheDir(const std::filesystem::path& folder) {
  const std::filesystem::path dir = folder / "eval-reference-cache";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (!std::filesystem::is_directory(dir, ec)) return std::nullopt;
  return dir;
}

ReferenceCache::ReferenceCache(std::filesystem::path dir)
    : files_(std::move(dir), kMagic, ".psref", "eval reference cache") {}

uint64_t ReferenceCache::key(uint64_t sceneHash, const LightingRig& rig,
                             std::span<const Bounds3> domain, const EvalSettings& s,
                             bool hasPunctualLights, bool hasDoubleSided) {
  const uint32_t versions[2] = {kAlgorithmVersion, CaptureCache::kAlgorithmVersion};
  uint64_t h = fnv1a64(versions, sizeof versions);
  h = fnv1a64(&sceneHash, sizeof sceneHash, h);
  h = foldEnvironmentTexels(h, rig);
  const std::string r = rigToJson(rig).dump();  // shortest round-trip doubles: exact
  h = fnv1a64(r.data(), r.size(), h);
  for (const Bounds3& b : domain) {  // in order, no count: one box hashes as the box alone
    const double box[6] = {b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z};
    h = fnv1a64(box, sizeof box, h);
  }
  // The reachable space's cells (the `reachable` rule); absent under `bounds`, whose keys stay
  // as they were.
  if (s.reachable) {
    const double cell = s.reachable->cellMeters();
    h = fnv1a64(&cell, sizeof cell, h);
    for (const Vec3& c : s.reachable->cellCorners()) {
      const double xyz[3] = {c.x, c.y, c.z};
      h = fnv1a64(xyz, sizeof xyz, h);
    }
  }
  const int32_t counts[2] = {s.queries, s.referenceSpp};
  h = fnv1a64(counts, sizeof counts, h);
  // The clearance from punctual lights moves the queries only where there are such lights, so
  // only those scenes' keys include it.
  if (hasPunctualLights && s.lightClearanceRelative > 0)
    h = fnv1a64(&s.lightClearanceRelative, sizeof s.lightClearanceRelative, h);
  // The double-sided validity rule moves queries only in scenes with double-sided geometry, so
  // only those scenes' keys include its version.
  if (hasDoubleSided)
    h = fnv1a64(&kDoubleSidedValidityVersion, sizeof kDoubleSidedValidityVersion, h);
  return fnv1a64(&s.seed, sizeof s.seed, h);
}

std::optional<EvalReference> ReferenceCache::find(uint64_t key, size_t queries,
                                                  std::string* problem) const {
  const KeyedFileCache::Lookup e = files_.find(key, payloadBytes(queries));
  if (e.status == KeyedFileCache::Status::Damaged && problem)
    *problem = files_.entryPath(key).string() + ": " + e.problem;
  if (e.status != KeyedFileCache::Status::Found) return std::nullopt;
  uint64_t n;
  std::memcpy(&n, e.payload.data(), 8);
  if (n != queries) {  // a checksummed entry of the right size cannot say otherwise; be safe
    if (problem)
      *problem = files_.entryPath(key).string() + ": holds " + std::to_string(n) +
                 " queries, expected " + std::to_string(queries);
    return std::nullopt;
  }
  EvalReference ref;
  ref.points.resize(queries);
  ref.normals.resize(queries);
  ref.irradiance.resize(queries);
  ref.variance.resize(queries);
  const char* p = e.payload.data() + 8;
  for (size_t q = 0; q < queries; ++q, p += kQueryBytes) {
    double v[10];
    std::memcpy(v, p, sizeof v);
    ref.points[q] = {v[0], v[1], v[2]};
    ref.normals[q] = {v[3], v[4], v[5]};
    ref.irradiance[q] = {v[6], v[7], v[8]};
    ref.variance[q] = v[9];
  }
  return ref;
}

void ReferenceCache::store(uint64_t key, const EvalReference& ref) const {
  const size_t n = ref.points.size();
  std::string buf(payloadBytes(n), '\0');
  const uint64_t n64 = n;
  std::memcpy(buf.data(), &n64, 8);
  char* p = buf.data() + 8;
  for (size_t q = 0; q < n; ++q, p += kQueryBytes) {
    const Vec3 a = ref.points[q], b = ref.normals[q];
    const Rgb c = ref.irradiance[q];
    const double v[10] = {a.x, a.y, a.z, b.x, b.y,
                          b.z, c.r, c.g, c.b, q < ref.variance.size() ? ref.variance[q] : 0.0};
    std::memcpy(p, v, sizeof v);
  }
  files_.store(key, buf);
}

}  // namespace ps
