#include "core/io/ProbeSetFile.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <unordered_set>

#include "core/common/Error.h"
#include "core/io/JsonFields.h"

namespace ps {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

const char* toString(ProbeState s) {
  switch (s) {
    case ProbeState::Candidate:
      return "candidate";
    case ProbeState::Accepted:
      return "accepted";
    case ProbeState::Rejected:
      return "rejected";
  }
  return "candidate";
}

namespace {

ProbeState parseState(const JsonField& f) {
  const std::string s = f.string();
  if (s == "candidate") return ProbeState::Candidate;
  if (s == "accepted") return ProbeState::Accepted;
  if (s == "rejected") return ProbeState::Rejected;
  f.fail("expected one of \"candidate\", \"accepted\", \"rejected\", got \"" + s + "\"");
}

std::string hashToHex(uint64_t h) {
  if (h == 0) return "";
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

uint64_t hashFromHex(const JsonField& f) {
  const std::string s = f.string();
  if (s.empty()) return 0;
  if (s.size() != 16 || s.find_first_not_of("0123456789abcdef") != std::string::npos)
    f.fail("expected 16 lowercase hex digits or \"\", got \"" + s + "\"");
  return std::stoull(s, nullptr, 16);
}

// Version 2 -> 3: version 3 has the scene unit; a version-2 file is in metres.
void migrateV2ToV3(ojson& j) {
  j["version"] = 3;
  if (!j.contains("units")) j["units"] = "m";
}

// Version 1 -> 2: version 2 has the scene hash, importance volumes and the per-capture scene
// hash. A version-1 file has none of them: its captures are of an unknown scene state.
void migrateV1ToV2(ojson& j) {
  j["version"] = 2;
  if (!j.contains("scene_hash")) j["scene_hash"] = "";
  if (!j.contains("importance_volumes")) j["importance_volumes"] = ojson::array();
}

}  // namespace

void saveProbeSet(const ProbeSet& set, const fs::path& path) {
  ojson j;
  j["format"] = "probestudio.probeset";
  j["version"] = ProbeSet::kFormatVersion;
  std::string scene = set.scenePath;
  if (!scene.empty()) {
    const fs::path base = fs::absolute(path).parent_path();
    std::error_code ec;
    const fs::path rel = fs::relative(fs::absolute(set.scenePath), base, ec);
    if (!ec && !rel.empty()) scene = rel.generic_string();
  }
  j["scene"] = scene;
  j["units"] = sceneUnitName(set.metresPerUnit);
  j["scene_hash"] = hashToHex(set.sceneHash);
  // Lengths go to the file in the scene's unit.
  const double unitsPerMetre = 1.0 / set.metresPerUnit;
  // The environment map's path, like the scene's, is stored relative to the set's folder.
  LightingRig rig = scaledRig(set.rig, unitsPerMetre);
  if (!rig.envMapPath.empty()) {
    const fs::path base = fs::absolute(path).parent_path();
    std::error_code ec;
    const fs::path rel = fs::relative(fs::absolute(rig.envMapPath), base, ec);
    if (!ec && !rel.empty()) rig.envMapPath = rel.generic_string();
  }
  j["rig"] = rigToJson(rig);
  j["placement"] = {{"method", set.placement.method},
                    {"spacing_m", set.placement.spacingMeters},
                    {"budget", set.placement.budget}};
  ojson volumes = ojson::array();
  for (const ImportanceVolume& v : set.importanceVolumes) {
    ojson o;
    o["name"] = v.name;
    o["min"] = vecToJson(v.lo * unitsPerMetre);
    o["max"] = vecToJson(v.hi * unitsPerMetre);
    o["weight"] = v.weight;
    volumes.push_back(std::move(o));
  }
  j["importance_volumes"] = std::move(volumes);
  j["next_id"] = set.nextId;
  ojson probes = ojson::array();
  for (const Probe& p : set.probes) {
    ojson o;
    o["id"] = p.id;
    o["position"] = vecToJson(p.position * unitsPerMetre);
    o["state"] = toString(p.state);
    o["locked"] = p.locked;
    o["method"] = p.method;
    o["score"] = p.score;
    if (p.sh) {
      ojson sh = ojson::array();
      for (const Rgb& c : p.sh->c) sh.push_back(rgbToJson(c));
      o["sh"] = std::move(sh);
      o["sh_scene_hash"] = hashToHex(p.captureSceneHash);
    }
    probes.push_back(std::move(o));
  }
  j["probes"] = std::move(probes);
  writeFileAtomic(path, j.dump(1, '\t') + "\n");
}

ProbeSet loadProbeSet(const fs::path& path) {
  // A probe set of a million probes with SH is ~1 GB of JSON; refuse larger before reading it.
  constexpr uintmax_t kMaxBytes = uintmax_t(1) << 30;
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  if (!ec && size > kMaxBytes)
    throw FileError(path.string(), "",
                    "file of " + std::to_string(size) + " bytes is above the probe-set limit of " +
                        std::to_string(kMaxBytes) + " bytes");
  return parseProbeSet(readWholeFile(path), path);
}

ProbeSet parseProbeSet(const std::string& text, const fs::path& path) {
  const std::string file = path.string();
  ojson j;
  try {
    j = ojson::parse(text);
  } catch (const nlohmann::json::exception& e) {  // parse_error, out_of_range (1e999), ...
    throw FileError(file, "", std::string("not valid JSON: ") + e.what());
  }
  const JsonField root(file, "", &j);
  if (!j.is_object()) root.fail("expected a JSON object (a ProbeStudio probe set)");
  if (root.at("format").string() != "probestudio.probeset")
    root.at("format").fail("expected \"probestudio.probeset\"");
  const int version = root.at("version").integer();
  if (version > ProbeSet::kFormatVersion)
    root.at("version").fail("version " + std::to_string(version) +
                            " is newer than this build reads (" +
                            std::to_string(ProbeSet::kFormatVersion) + "); update ProbeStudio");
  if (version < 1)
    root.at("version").fail("expected a version >= 1, got " + std::to_string(version));
  if (version == 1) migrateV1ToV2(j);
  if (version <= 2) migrateV2ToV3(j);

  ProbeSet set;
  const std::string scene = root.at("scene").string();
  if (!scene.empty()) {
    fs::path sp(scene);
    if (sp.is_relative()) sp = fs::absolute(path).parent_path() / sp;
    set.scenePath = sp.lexically_normal().string();
  }
  set.metresPerUnit = sceneUnitFromJson(root.at("units"));
  const double m = set.metresPerUnit;  // file lengths -> metres
  set.sceneHash = hashFromHex(root.at("scene_hash"));
  if (root.has("rig")) set.rig = scaledRig(rigFromJson(root.at("rig")), m);
  if (!set.rig.envMapPath.empty()) {
    fs::path ep(set.rig.envMapPath);
    if (ep.is_relative()) ep = fs::absolute(path).parent_path() / ep;
    set.rig.envMapPath = ep.lexically_normal().string();
  }
  if (root.has("placement")) {
    const JsonField pl = root.at("placement");
    set.placement.method = pl.at("method").string();
    set.placement.spacingMeters = pl.at("spacing_m").number();
    set.placement.budget = pl.at("budget").integer();
  }
  const JsonField volumes = root.at("importance_volumes");
  for (size_t i = 0; i < volumes.arraySize(); ++i) {
    const JsonField vf = volumes.index(i);
    ImportanceVolume v;
    if (vf.has("name")) v.name = vf.at("name").string();
    v.lo = vf.at("min").vec3();
    v.hi = vf.at("max").vec3();
    for (int a = 0; a < 3; ++a)
      if (v.lo[a] > v.hi[a]) vf.at("max").fail("expected max >= min on every axis");
    v.lo = v.lo * m;
    v.hi = v.hi * m;
    v.weight = vf.at("weight").number();
    if (!(v.weight >= 0)) vf.at("weight").fail("expected a weight >= 0");
    set.importanceVolumes.push_back(std::move(v));
  }
  const JsonField probes = root.at("probes");
  const size_t n = probes.arraySize();
  set.probes.reserve(n);
  uint64_t maxId = 0;
  std::unordered_set<uint64_t> seenIds;
  for (size_t i = 0; i < n; ++i) {
    const JsonField pf = probes.index(i);
    Probe p;
    const int64_t id = pf.at("id").integer64();
    if (id <= 0) pf.at("id").fail("expected a positive integer, got " + std::to_string(id));
    p.id = static_cast<uint64_t>(id);
    if (!seenIds.insert(p.id).second) pf.at("id").fail("duplicate id " + std::to_string(id));
    p.position = pf.at("position").vec3() * m;
    p.state = parseState(pf.at("state"));
    if (pf.has("locked")) p.locked = pf.at("locked").boolean();
    if (pf.has("method")) p.method = pf.at("method").string();
    if (pf.has("score")) p.score = pf.at("score").number();
    if (pf.has("sh")) {
      const JsonField shf = pf.at("sh");
      if (shf.arraySize() != kShCoeffCount)
        shf.fail("expected 9 coefficients, got " + std::to_string(shf.arraySize()));
      ShRgb sh;
      for (int c = 0; c < kShCoeffCount; ++c) sh.c[c] = shf.index(c).rgb();
      p.sh = sh;
      if (pf.has("sh_scene_hash")) p.captureSceneHash = hashFromHex(pf.at("sh_scene_hash"));
    }
    maxId = std::max(maxId, p.id);
    set.probes.push_back(std::move(p));
  }
  set.nextId = std::max<uint64_t>(
      maxId + 1, root.has("next_id")
                     ? static_cast<uint64_t>(std::max<int64_t>(root.at("next_id").integer64(), 1))
                     : 1);
  return set;
}

std::string readWholeFile(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw FileError(path.string(), "", "no such file");
  if (fs::is_directory(path, ec)) throw FileError(path.string(), "", "is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path.string(), "", "cannot be opened for reading");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw FileError(path.string(), "", "read error");
  return s.str();
}

void writeFileAtomic(const fs::path& path, const std::string& bytes, bool durable) {
  const fs::path target = fs::absolute(path);
  const fs::path dir = target.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw FileError(path.string(), "", "cannot save: folder " + dir.string() + " does not exist");
  // Hidden temp file in the same folder, so the rename is atomic.
  std::string tmpName = target.filename().string();
  tmpName.insert(tmpName.begin(), '.');
  tmpName.append(".tmp-XXXXXX");
  std::string tmpl = (dir / tmpName).string();
  const int fd = ::mkstemp(tmpl.data());
  if (fd < 0) throw FileError(path.string(), "", "cannot save: cannot create a temporary file");
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t w = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (w <= 0) {
      ::close(fd);
      ::unlink(tmpl.c_str());
      throw FileError(path.string(), "", "cannot save: write failed (disk full?)");
    }
    written += static_cast<size_t>(w);
  }
  ::fchmod(fd, 0644);
  if ((durable && ::fsync(fd) != 0) || ::close(fd) != 0) {
    ::unlink(tmpl.c_str());
    throw FileError(path.string(), "", "cannot save: fsync failed");
  }
  if (::rename(tmpl.c_str(), target.c_str()) != 0) {
    ::unlink(tmpl.c_str());
    throw FileError(path.string(), "", "cannot save: rename failed");
  }
  if (!durable) return;
  // Make the rename itself durable.
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

}  // namespace ps
