#include "ui/LightingField.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/bake/Bake.h"
#include "core/common/Error.h"
#include "core/trace/Tracer.h"
#include "core/traversal/EditableProbeVolume.h"

namespace ps::ui {

namespace {
constexpr double kY00 = 0.282095;
}  // namespace

double meanLuminance(const ShRgb& sh) {
  return luminance(sh.c[0]) * kY00;
}

double luminanceDistanceStops(const ShRgb& a, const ShRgb& b) {
  const double la = std::max(meanLuminance(a), 1e-6), lb = std::max(meanLuminance(b), 1e-6);
  return std::abs(std::log2(la / lb));
}

namespace {
bool inPreview(const Probe& p, PreviewSource source) {
  if (!p.sh) return false;
  return source == PreviewSource::Accepted ? p.state == ProbeState::Accepted
                                           : p.state != ProbeState::Rejected;
}
}  // namespace

std::optional<ProbeVolume> buildPreviewVolume(const std::vector<Probe>& probes,
                                              PreviewSource source) {
  if (source == PreviewSource::Baked) return std::nullopt;
  std::vector<Vec3> positions;
  std::vector<ShRgb> sh;
  for (const Probe& p : probes) {
    if (!inPreview(p, source)) continue;
    positions.push_back(p.position);
    sh.push_back(*p.sh);
  }
  if (positions.size() < 4) return std::nullopt;
  try {
    return volumeFromProbes(positions, sh);
  } catch (const ParameterError&) {
    return std::nullopt;  // flat or collinear: no volume
  }
}

PreviewVolumeMirror::PreviewVolumeMirror() = default;
PreviewVolumeMirror::~PreviewVolumeMirror() = default;

const ProbeVolume* PreviewVolumeMirror::volume() const {
  return volume_ ? &volume_->volume() : nullptr;
}

PreviewVolumeMirror::SyncReport PreviewVolumeMirror::rebuild(
    const std::vector<const Probe*>& wanted) {
  const auto t0 = std::chrono::steady_clock::now();
  SyncReport r;
  r.rebuilt = true;
  volume_.reset();
  entries_.clear();
  std::vector<Vec3> positions;
  std::vector<ShRgb> sh;
  for (const Probe* p : wanted) {
    entries_[p->id] = {static_cast<int32_t>(positions.size()), p->position, *p->sh};
    positions.push_back(p->position);
    sh.push_back(*p->sh);
  }
  if (positions.size() >= 4) {
    try {
      volume_ = std::make_unique<EditableProbeVolume>(positions, sh);
    } catch (const ParameterError&) {
      // flat or collinear: no volume; the entries stay so that the next sync edits from here
    }
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

PreviewVolumeMirror::SyncReport PreviewVolumeMirror::sync(const std::vector<Probe>& probes,
                                                          PreviewSource source) {
  std::vector<const Probe*> wanted;
  if (source != PreviewSource::Baked)
    for (const Probe& p : probes)
      if (inPreview(p, source)) wanted.push_back(&p);
  if (source_ != source) {
    source_ = source;
    return rebuild(wanted);
  }
  // What changed, by document id: one lookup per wanted probe; the entries it did not meet are
  // the probes that left.
  ++stamp_;
  std::vector<const Probe*> added, moved, recoloured;
  size_t met = 0;
  for (const Probe* p : wanted) {
    const auto it = entries_.find(p->id);
    if (it == entries_.end()) {
      added.push_back(p);
      continue;
    }
    it->second.stamp = stamp_;
    ++met;
    if (!(it->second.position == p->position)) moved.push_back(p);
    if (!(it->second.sh == *p->sh)) recoloured.push_back(p);
  }
  std::vector<uint64_t> gone;
  if (met != entries_.size())
    for (const auto& [id, e] : entries_)
      if (e.stamp != stamp_) gone.push_back(id);
  const size_t changes = gone.size() + added.size() + moved.size() + recoloured.size();
  if (changes == 0) return {};
  if (!volume_ || changes > std::max<size_t>(16, wanted.size() / 8)) return rebuild(wanted);
  SyncReport r;
  try {
    // Inserts first, so that removals never leave fewer than 4 probes on the way.
    for (const Probe* p : added) {
      const TetEditReport e = volume_->insert(p->position, *p->sh);
      entries_[p->id] = {e.probe, p->position, *p->sh};
      r.seconds += e.seconds;
      r.tetsRewritten += e.changedTets.size();
      ++r.inserted;
    }
    for (const Probe* p : moved) {
      Entry& entry = entries_.at(p->id);
      const TetEditReport e = volume_->move(entry.probe, p->position);
      entry.position = p->position;
      r.seconds += e.seconds;
      r.tetsRewritten += e.changedTets.size();
      ++r.moved;
    }
    for (const Probe* p : recoloured) {
      Entry& entry = entries_.at(p->id);
      volume_->setSh(entry.probe, *p->sh);
      entry.sh = *p->sh;
      ++r.recoloured;
    }
    for (uint64_t id : gone) {
      const TetEditReport e = volume_->remove(entries_.at(id).probe);
      entries_.erase(id);
      r.seconds += e.seconds;
      r.tetsRewritten += e.changedTets.size();
      ++r.removed;
    }
  } catch (const ParameterError&) {
    return rebuild(wanted);  // an edit would flatten the volume: start over from the probes
  }
  return r;
}

Vec3 ShGrid::centre(size_t index) const {
  const size_t nx = size_t(dims[0]), ny = size_t(dims[1]);
  const size_t i = index % nx, j = (index / nx) % ny, k = index / (nx * ny);
  return lo + Vec3((double(i) + 0.5) * cellMeters.x, (double(j) + 0.5) * cellMeters.y,
                   (double(k) + 0.5) * cellMeters.z);
}

ShGrid shGridLayout(const Bounds3& box, int maxCellsPerAxis) {
  ShGrid g;
  if (box.empty() || maxCellsPerAxis < 1) return g;
  const Vec3 e = box.extent();
  const double longest = std::max({e.x, e.y, e.z, 1e-9});
  const double cell = longest / maxCellsPerAxis;
  for (int a = 0; a < 3; ++a) g.dims[a] = std::max(1, int(std::ceil(e[a] / cell - 1e-9)));
  g.cellMeters = Vec3(e.x / g.dims[0], e.y / g.dims[1], e.z / g.dims[2]);
  g.lo = box.lo;
  g.sh.resize(size_t(g.dims[0]) * size_t(g.dims[1]) * size_t(g.dims[2]));
  return g;
}

ShGrid sampleGrid(const ProbeVolume& volume, const Bounds3& box, int maxCellsPerAxis) {
  ShGrid g = shGridLayout(box, maxCellsPerAxis);
  const size_t n = g.size();
  if (n == 0) return g;
  std::vector<Vec3> points(n);
  for (size_t i = 0; i < n; ++i) points[i] = g.centre(i);
  std::vector<VolumeLocation> locs(n);
  locateBatch(volume, points, locs);
  for (size_t i = 0; i < n; ++i) g.sh[i] = interpolate(volume, locs[i]);
  return g;
}

std::vector<std::array<int32_t, 2>> tetEdges(const ProbeVolume& volume) {
  std::vector<std::array<int32_t, 2>> edges;
  edges.reserve(volume.tets.size() * 6);
  for (const auto& t : volume.tets)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) edges.push_back({std::min(t[a], t[b]), std::max(t[a], t[b])});
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

std::vector<uint8_t> leakingEdges(const Tracer& tracer, const ProbeVolume& volume,
                                  const std::vector<std::array<int32_t, 2>>& edges) {
  std::vector<uint8_t> out(edges.size(), 0);
  const double eps = tracer.rayEpsilon();
  for (size_t i = 0; i < edges.size(); ++i) {
    const Vec3 a = volume.position(edges[i][0]), b = volume.position(edges[i][1]);
    const double len = length(b - a);
    if (len <= 2 * eps) continue;
    // Direction of unit length: t in metres, the ends kept clear of surfaces touching a probe.
    out[i] = tracer.occluded(Ray{a, (b - a) / len, eps, len - eps}) ? 1 : 0;
  }
  return out;
}

std::vector<float> edgeLuminanceDistances(const ProbeVolume& volume,
                                          const std::vector<std::array<int32_t, 2>>& edges) {
  std::vector<float> out(edges.size());
  for (size_t i = 0; i < edges.size(); ++i)
    out[i] =
        float(luminanceDistanceStops(volume.probeSh(edges[i][0]), volume.probeSh(edges[i][1])));
  return out;
}

double relativeIrradianceError(const ProbeVolume& test, const ProbeVolume& reference, Vec3 p,
                               Vec3 n, double floor) {
  const double et = luminance(interpolate(test, locate(test, p)).irradiance(n));
  const double er = luminance(interpolate(reference, locate(reference, p)).irradiance(n));
  return std::abs(et - er) / std::max(er, floor);
}

}  // namespace ps::ui
