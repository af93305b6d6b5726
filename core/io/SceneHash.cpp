#include "core/io/SceneHash.h"

#include <cstdio>
#include <nlohmann/json.hpp>

#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"
#include "core/scene/SceneUnits.h"

namespace ps {

namespace fs = std::filesystem;

uint64_t fnv1a64(const void* data, size_t size, uint64_t h) {
  const auto* p = static_cast<const uint8_t*>(data);
  for (size_t i = 0; i < size; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ull;
  }
  return h;
}

uint64_t foldEnvironmentTexels(uint64_t h, const LightingRig& rig) {
  if (const auto map = environmentOf(rig))
    h = fnv1a64(map->rgb.data(), map->rgb.size() * sizeof(float), h);
  return h;
}

namespace {

std::string lowerExtension(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

// Decodes %XX escapes in a glTF URI (glTF 2.0 3.3.2: URIs are RFC 3986).
std::string percentDecode(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out.push_back(static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(s[i]);
    }
  }
  return out;
}

}  // namespace

uint64_t sceneContentHash(const fs::path& scene, double metresPerUnit) {
  const std::string bytes = readWholeFile(scene);
  uint64_t h = fnv1a64(bytes.data(), bytes.size());
  if (lowerExtension(scene) == ".gltf") {
    const auto j = nlohmann::json::parse(bytes, nullptr, /*allow_exceptions=*/false);
    if (j.is_object()) {
      for (const char* key : {"buffers", "images"}) {
        auto it = j.find(key);
        if (it == j.end() || !it->is_array()) continue;
        for (const auto& item : *it) {
          if (!item.is_object() || !item.contains("uri") || !item["uri"].is_string()) continue;
          const std::string uri = item["uri"].get<std::string>();
          if (uri.rfind("data:", 0) == 0) continue;
          std::string ext;
          if (std::string(key) == "images") {
            // A missing or unreadable texture is a warning for loadScene (the material keeps its
            // factor), not an error: hash its absence, so that adding the file changes the hash.
            try {
              ext = readWholeFile(scene.parent_path() / percentDecode(uri));
            } catch (const FileError&) {
              ext = "\x01missing image";
            }
          } else {
            ext = readWholeFile(scene.parent_path() / percentDecode(uri));
          }
          h = fnv1a64(uri.data(), uri.size(), h);
          h = fnv1a64(ext.data(), ext.size(), h);
        }
      }
    }
  }
  // The scene the core sees is the file scaled to metres: another unit is another scene. Metres
  // fold nothing in, so hashes of scenes in metres are those of the file alone.
  if (metresPerUnit != 1.0) {
    const std::string unit = "\x01units " + sceneUnitName(metresPerUnit);
    h = fnv1a64(unit.data(), unit.size(), h);
  }
  return h == 0 ? 1 : h;
}

std::string sceneHashText(uint64_t h) {
  if (h == 0) return "unknown";
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

StaleCaptures staleCaptures(const ProbeSet& set, uint64_t currentSceneHash) {
  StaleCaptures s;
  for (const Probe& p : set.probes) {
    if (!p.sh) continue;
    if (p.captureSceneHash == 0)
      s.unknown.push_back(p.id);
    else if (p.captureSceneHash != currentSceneHash)
      s.changed.push_back(p.id);
  }
  return s;
}

std::string describeStaleCaptures(const ProbeSet& set, const StaleCaptures& s, size_t maxIds) {
  if (!s.any()) return "";
  size_t captured = 0;
  for (const Probe& p : set.probes) captured += p.sh.has_value();
  auto list = [&](const std::vector<uint64_t>& ids) {
    std::string out;
    for (size_t i = 0; i < ids.size() && i < maxIds; ++i)
      out += (i ? ", " : "") + std::to_string(ids[i]);
    if (ids.size() > maxIds) out += ", ... (" + std::to_string(ids.size() - maxIds) + " more)";
    return out;
  };
  std::string msg;
  if (!s.changed.empty())
    msg += std::to_string(s.changed.size()) + " of " + std::to_string(captured) +
           " captures are stale (the scene changed since they were captured): probes " +
           list(s.changed);
  if (!s.unknown.empty())
    msg += std::string(msg.empty() ? "" : "; ") + std::to_string(s.unknown.size()) + " of " +
           std::to_string(captured) +
           " captures have no scene hash (saved by an older version) and may be stale: probes " +
           list(s.unknown);
  return msg;
}

}  // namespace ps
