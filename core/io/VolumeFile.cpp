#include "core/io/VolumeFile.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstring>

#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/io/JsonFields.h"
#include "core/io/ProbeSetFile.h"

// Layout (docs/formats.md, "Probe volume"), all little-endian, as written (versions 1 and 4):
//   char[8]  magic "PSVOLUM1"
//   u32      version (1 without visibility maps; 4 with them)
//   u32      sh order (2 = 9 coefficients)
//   u32      probe count P, tet count T, hull face count H, metadata byte count M
//   u32      visibility map size R, texels per side (version 4 only)
//   f32[3P]  positions        f32[27P] SH (probe-major, coefficient-major, RGB)
//   i32[4T]  tets             i32[4T]  neighbours (-1 on the hull)
//   f32[9T]  barycentric matrices (row-major)
//   i32[2H]  hull faces (tet, local vertex opposite the face)
//   u8[P]    probe flags: bit 0 set when the probe is inside geometry (version 4 only)
//   f32[2 R^2 P] visibility maps: per probe, per texel, mean and mean square of the first-hit
//            distance (version 4 only)
//   u8[M]    metadata (UTF-8 JSON)
//   u32      CRC-32 (IEEE) of every byte before it
// Versions 2 and 3 (read, never written) also hold a leak-cut section: a u32 cut plane count C
// after M, and u32[T+1] cut starts then C x 20 bytes of planes after the hull faces (version 3
// then has R and the maps as version 4). A file with C > 0 is refused: its lighting was made to
// be read through the cuts, which this build does not apply.
namespace ps {

namespace {

constexpr char kMagic[8] = {'P', 'S', 'V', 'O', 'L', 'U', 'M', '1'};
// A volume without maps is written as version 1, so that every reader of version 1 reads it.
constexpr uint32_t kVersionPlain = 1;
constexpr uint32_t kVersionCuts = 2;         // read only
constexpr uint32_t kVersionCutsAndMaps = 3;  // read only
constexpr uint32_t kVersionVisibility = 4;
constexpr uint32_t kMaxVisibilityMapSize = 64;
constexpr uint32_t kShOrder = 2;
constexpr size_t kHeaderBytes = 8 + 6 * 4;  // version 1; the others add their counts
constexpr size_t kCutPlaneBytes = 20;       // versions 2 and 3: f32 nx, ny, nz, d, u32 hide
static_assert(std::endian::native == std::endian::little,
              "the volume writer assumes a little-endian host");

class Writer {
 public:
  void bytes(const void* p, size_t n) { buf_.append(static_cast<const char*>(p), n); }
  void u32(uint32_t v) { bytes(&v, 4); }
  template <typename T>
  void array(const std::vector<T>& v) {
    if (!v.empty()) bytes(v.data(), v.size() * sizeof(T));
  }
  std::string& str() { return buf_; }

 private:
  std::string buf_;
};

class Reader {
 public:
  Reader(const std::string& file, const std::string& data) : file_(file), data_(data) {}
  [[noreturn]] void fail(const std::string& field, const std::string& problem) const {
    throw FileError(file_, field, problem);
  }
  void need(size_t n, const char* field) const {
    if (n > data_.size() - pos_)
      fail(field, "truncated: needs " + std::to_string(n) + " bytes at offset " +
                      std::to_string(pos_) + ", file has " + std::to_string(data_.size()));
  }
  uint32_t u32(const char* field) {
    need(4, field);
    uint32_t v;
    std::memcpy(&v, data_.data() + pos_, 4);
    pos_ += 4;
    return v;
  }
  template <typename T>
  void array(std::vector<T>& out, size_t count, const char* field) {
    need(count * sizeof(T), field);
    out.resize(count);
    if (count) std::memcpy(out.data(), data_.data() + pos_, count * sizeof(T));
    pos_ += count * sizeof(T);
  }
  size_t pos() const { return pos_; }
  void skip(size_t n) { pos_ += n; }

 private:
  const std::string& file_;
  const std::string& data_;
  size_t pos_ = 0;
};

}  // namespace

uint32_t crc32(const void* data, size_t size, uint32_t crc) {
  static const auto table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  const auto* p = static_cast<const uint8_t*>(data);
  crc = ~crc;
  for (size_t i = 0; i < size; ++i) crc = table[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

void saveVolume(const VolumeFile& vf, const std::filesystem::path& path) {
  std::string metadata = vf.metadataJson;
  ProbeVolume scaled;
  const bool metres = vf.metresPerUnit == 1.0;
  if (!metres) {
    scaled = vf.volume;
    scaleVolume(scaled, 1.0 / vf.metresPerUnit);
  }
  auto meta = nlohmann::ordered_json::parse(metadata, nullptr, /*allow_exceptions=*/false);
  PS_CHECK(metres || meta.is_object());
  if (meta.is_object() && (!metres || meta.contains("units"))) {
    meta["units"] = sceneUnitName(vf.metresPerUnit);
    metadata = meta.dump();
  }
  const ProbeVolume& v = metres ? vf.volume : scaled;
  const bool maps = v.hasVisibility();
  const size_t R = size_t(v.visibilityMapSize);
  PS_CHECK(!maps || (v.visibility.size() == 2 * R * R * v.probeCount() &&
                     v.probeInside.size() == v.probeCount()));
  Writer w;
  w.bytes(kMagic, 8);
  w.u32(maps ? kVersionVisibility : kVersionPlain);
  w.u32(kShOrder);
  w.u32(static_cast<uint32_t>(v.probeCount()));
  w.u32(static_cast<uint32_t>(v.tets.size()));
  w.u32(static_cast<uint32_t>(v.hullFaces.size()));
  w.u32(static_cast<uint32_t>(metadata.size()));
  if (maps) w.u32(static_cast<uint32_t>(R));
  w.array(v.positions);
  w.array(v.sh);
  w.array(v.tets);
  w.array(v.neighbors);
  w.array(v.matrices);
  w.array(v.hullFaces);
  if (maps) {
    w.array(v.probeInside);
    w.array(v.visibility);
  }
  w.bytes(metadata.data(), metadata.size());
  w.u32(crc32(w.str().data(), w.str().size()));
  writeFileAtomic(path, w.str());
}

VolumeFile loadVolume(const std::filesystem::path& path) {
  return parseVolume(readWholeFile(path), path.string());
}

VolumeFile parseVolume(const std::string& data, const std::string& file) {
  Reader r(file, data);
  r.need(8, "magic");
  if (std::memcmp(data.data(), kMagic, 8) != 0)
    r.fail("magic", "not a ProbeStudio volume (expected magic \"PSVOLUM1\")");
  r.skip(8);
  const uint32_t version = r.u32("version");
  if (version < kVersionPlain || version > kVersionVisibility)
    r.fail("version", "unsupported version " + std::to_string(version) + " (this build reads " +
                          std::to_string(kVersionPlain) + " to " +
                          std::to_string(kVersionVisibility) + ")");
  const bool cuts = version == kVersionCuts || version == kVersionCutsAndMaps;
  const bool maps = version == kVersionCutsAndMaps || version == kVersionVisibility;
  const uint32_t order = r.u32("sh_order");
  if (order != kShOrder) r.fail("sh_order", "expected SH order 2, got " + std::to_string(order));
  const uint64_t P = r.u32("probe_count"), T = r.u32("tet_count"), H = r.u32("hull_face_count"),
                 M = r.u32("metadata_bytes");
  const uint64_t C = cuts ? r.u32("cut_plane_count") : 0;
  const uint64_t R = maps ? r.u32("visibility_map_size") : 0;
  if (maps && (R < 1 || R > kMaxVisibilityMapSize))
    r.fail("visibility_map_size", "is " + std::to_string(R) + ", expected 1 to " +
                                      std::to_string(kMaxVisibilityMapSize) + " texels per side");
  // Refuse counts the file cannot hold before allocating anything.
  const uint64_t header = kHeaderBytes + (cuts ? 4 : 0) + (maps ? 4 : 0);
  const uint64_t body = P * (3 + 27) * 4 + T * (4 + 4 + 9) * 4 + H * 2 * 4 +
                        (cuts ? (T + 1) * 4 + C * kCutPlaneBytes : 0) +
                        (maps ? P * (1 + 2 * R * R * 4) : 0) + M + 4;
  if (header + body != data.size())
    r.fail("header", "counts (" + std::to_string(P) + " probes, " + std::to_string(T) + " tets, " +
                         std::to_string(H) + " hull faces, " +
                         (cuts ? std::to_string(C) + " cut planes, " : std::string()) +
                         (maps ? std::to_string(R) + "x" + std::to_string(R) + " visibility maps, "
                               : std::string()) +
                         std::to_string(M) + " metadata bytes) need " +
                         std::to_string(header + body) + " bytes, file has " +
                         std::to_string(data.size()));
  uint32_t stored;
  std::memcpy(&stored, data.data() + data.size() - 4, 4);
  if (crc32(data.data(), data.size() - 4) != stored)
    r.fail("crc32", "checksum mismatch: the file is corrupted");
  if (P < 4 || T < 1) r.fail("header", "a volume needs at least 4 probes and 1 tetrahedron");
  // Leak cuts changed the weights the volume's lighting was checked with; reading it without
  // them would change that lighting unannounced, so the file is refused with what to do.
  if (C > 0)
    r.fail("cut_plane_count",
           "the volume holds " + std::to_string(C) + " leak cut planes (format version " +
               std::to_string(version) +
               "), which this build no longer applies: the visibility maps and their neighbour "
               "search replace them (docs/leaks.md). Re-bake the volume from its probe set with "
               "`probestudio bake`");

  VolumeFile vf;
  ProbeVolume& v = vf.volume;
  r.array(v.positions, P * 3, "positions");
  r.array(v.sh, P * 27, "sh");
  r.array(v.tets, T, "tets");
  r.array(v.neighbors, T, "neighbors");
  r.array(v.matrices, T, "matrices");
  r.array(v.hullFaces, H, "hull_faces");
  if (cuts) {  // C = 0: every entry must be 0
    std::vector<uint32_t> cutStart;
    r.array(cutStart, T + 1, "cut_start");
    for (size_t t = 0; t <= T; ++t)
      if (cutStart[t] != 0)
        r.fail("cut_start[" + std::to_string(t) + "]",
               "is " + std::to_string(cutStart[t]) + ", expected 0 (the cut plane count is 0)");
  }
  if (maps) {
    r.array(v.probeInside, P, "probe_flags");
    r.array(v.visibility, P * 2 * R * R, "visibility");
    v.visibilityMapSize = static_cast<int32_t>(R);
  }
  vf.metadataJson.assign(data.data() + r.pos(), M);

  for (size_t i = 0; i < v.positions.size(); ++i)
    if (!std::isfinite(v.positions[i])) r.fail("positions", "NaN or infinite coordinate");
  for (size_t i = 0; i < v.sh.size(); ++i)
    if (!std::isfinite(v.sh[i])) r.fail("sh", "NaN or infinite coefficient");
  for (size_t t = 0; t < T; ++t)
    for (int k = 0; k < 4; ++k) {
      if (v.tets[t][k] < 0 || static_cast<uint64_t>(v.tets[t][k]) >= P)
        r.fail("tets[" + std::to_string(t) + "]", "probe index out of range");
      if (v.neighbors[t][k] < -1 || v.neighbors[t][k] >= static_cast<int64_t>(T))
        r.fail("neighbors[" + std::to_string(t) + "]", "tetrahedron index out of range");
    }
  for (size_t t = 0; t < T; ++t)
    for (float m : v.matrices[t])
      if (!std::isfinite(m)) r.fail("matrices[" + std::to_string(t) + "]", "NaN or infinite");
  for (size_t h = 0; h < H; ++h)
    if (v.hullFaces[h][0] < 0 || static_cast<uint64_t>(v.hullFaces[h][0]) >= T ||
        v.hullFaces[h][1] < 0 || v.hullFaces[h][1] > 3)
      r.fail("hull_faces[" + std::to_string(h) + "]", "index out of range");
  if (maps) {
    for (size_t i = 0; i < P; ++i)
      if (v.probeInside[i] > 1)
        r.fail("probe_flags[" + std::to_string(i) + "]",
               "is " + std::to_string(v.probeInside[i]) + ", expected 0 or 1 (bit 0: inside)");
    for (size_t k = 0; k < v.visibility.size(); k += 2) {
      const float mu = v.visibility[k], mu2 = v.visibility[k + 1];
      const std::string field = "visibility[probe " + std::to_string(k / (2 * R * R)) + ", texel " +
                                std::to_string((k / 2) % (R * R)) + "]";
      if (!std::isfinite(mu) || !std::isfinite(mu2) || mu < 0 || mu2 < 0)
        r.fail(field, "expected finite, non-negative distance moments");
      // mean^2 <= mean square (a variance is not negative), to the floats' rounding.
      if (double(mu) * mu > double(mu2) * (1 + 1e-5))
        r.fail(field, "negative variance: mean " + std::to_string(mu) +
                          " squared exceeds mean "
                          "square " +
                          std::to_string(mu2));
    }
  }
  // The file's unit (metadata "units"; metres without it): the volume in memory is in metres.
  const auto meta = nlohmann::ordered_json::parse(vf.metadataJson, nullptr, false);
  if (meta.is_object() && meta.contains("units"))
    vf.metresPerUnit = sceneUnitFromJson(JsonField(file, "metadata", &meta).at("units"));
  if (vf.metresPerUnit != 1.0)
    scaleVolume(v, vf.metresPerUnit);  // rebuilds the locator
  else
    buildLocator(v);  // derived search data is not stored
  return vf;
}

}  // namespace ps
