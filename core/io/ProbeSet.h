#pragma once
// The probe set: what the artist edits and keeps in version control (format: docs/formats.md).
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/math/Sh.h"
#include "core/scene/LightingRig.h"

namespace ps {

enum class ProbeState { Candidate, Accepted, Rejected };

// In memory every length is in metres (the core's unit); the file stores positions, importance
// volumes and rig light positions in the scene's unit (`metresPerUnit`), converted on save and
// load (core/io/ProbeSetFile.h).

struct Probe {
  uint64_t id = 0;  ///< stable across edits and saves; never reused within a set
  Vec3 position;    ///< metres
  ProbeState state = ProbeState::Candidate;
  bool locked = false;      ///< placement keeps locked probes where they are
  std::string method;       ///< provenance: the placement method, or "manual"
  double score = 0;         ///< method-specific (error removed, cluster size, ...)
  std::optional<ShRgb> sh;  ///< captured incident radiance, when captured
  /// sceneContentHash() of the scene the SH was captured in; 0 = unknown (a version-1 file).
  uint64_t captureSceneHash = 0;
};

/// An axis-aligned box where placement should put more probes (weight > 1) or fewer (< 1).
struct ImportanceVolume {
  std::string name;
  Vec3 lo, hi;  ///< metres, lo <= hi on every axis
  double weight = 1.0;
};

/// The volumes' boxes, in order.
inline std::vector<Bounds3> importanceBoxes(std::span<const ImportanceVolume> volumes) {
  std::vector<Bounds3> boxes;
  for (const ImportanceVolume& v : volumes) boxes.push_back({v.lo, v.hi});
  return boxes;
}

struct PlacementSettings {
  std::string method = "uniform";
  double spacingMeters = 1.0;
  int budget = 0;  ///< 0 = no budget
};

struct ProbeSet {
  static constexpr int kFormatVersion = 3;
  std::string scenePath;  ///< relative to the probe-set file when saved
  /// The scene's unit, metres per unit (core/scene/SceneUnits.h): the scene is loaded with it,
  /// and the file's lengths are in it. 1 (metres) for a file older than version 3.
  double metresPerUnit = 1.0;
  /// sceneContentHash() of the scene when the set was last saved from a loaded scene; 0 = unknown.
  uint64_t sceneHash = 0;
  LightingRig rig;
  PlacementSettings placement;
  std::vector<ImportanceVolume> importanceVolumes;
  std::vector<Probe> probes;
  uint64_t nextId = 1;

  /// Appends a probe with a fresh id and returns that id.
  uint64_t add(Probe p) {
    p.id = nextId++;
    probes.push_back(std::move(p));
    return probes.back().id;
  }
};

const char* toString(ProbeState s);

}  // namespace ps
