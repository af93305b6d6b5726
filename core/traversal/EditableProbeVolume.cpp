// Local updates of the runtime probe volume after one edit (Sukys 2014, sec. 3.2.1: the
// per-tet probe ids, neighbour ids and barycentric matrix of "Interpolation with barycentric
// coordinates" and "Drawbacks"). Sukys and Cupisz rebuild the whole volume after a change; an
// edit here rewrites only the slots the re-triangulation changed (EditableTetrahedralization
// reports them), so moving one probe of 10k costs tens of microseconds rather than a rebuild.
#include "core/traversal/EditableProbeVolume.h"

#include <chrono>
#include <string>

#include "core/common/Check.h"
#include "core/common/Error.h"

namespace ps {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace

EditableProbeVolume::EditableProbeVolume(std::span<const Vec3> positions, std::span<const ShRgb> sh)
    : mesh_(positions), shOfId_(sh.begin(), sh.end()) {
  if (positions.size() != sh.size())
    throw ParameterError("EditableProbeVolume: " + std::to_string(positions.size()) +
                         " positions but " + std::to_string(sh.size()) +
                         " SH; expected one SH per probe");
  const Tetrahedralization& m = mesh_.mesh();
  std::vector<ShRgb> shOfVertex(m.vertices.size());
  for (size_t k = 0; k < m.vertices.size(); ++k)
    shOfVertex[k] = shOfId_[mesh_.idsAt(static_cast<int32_t>(k)).front()];
  volume_ = buildProbeVolume(m, shOfVertex);
  hullIndex_.assign(4 * volume_.tets.size(), -1);
  for (size_t j = 0; j < volume_.hullFaces.size(); ++j) {
    const auto [t, i] = volume_.hullFaces[j];
    hullIndex_[4 * size_t(t) + i] = static_cast<int32_t>(j);
  }
  cellHead_.assign(volume_.tets.size(), -1);
  cellNext_.assign(volume_.locatorGrid.size(), -1);
  for (size_t c = 0; c < volume_.locatorGrid.size(); ++c) {
    const int32_t t = volume_.locatorGrid[c];
    cellNext_[c] = cellHead_[t];
    cellHead_[t] = static_cast<int32_t>(c);
  }
}

TetEditReport EditableProbeVolume::insert(Vec3 p, const ShRgb& sh) {
  const auto t0 = Clock::now();
  TetEditReport r = mesh_.insert(p);
  shOfId_.push_back(sh);
  apply(r);
  r.seconds = secondsSince(t0);
  return r;
}

TetEditReport EditableProbeVolume::remove(int32_t id) {
  const auto t0 = Clock::now();
  TetEditReport r = mesh_.remove(id);
  apply(r);
  r.seconds = secondsSince(t0);
  return r;
}

TetEditReport EditableProbeVolume::move(int32_t id, Vec3 p) {
  const auto t0 = Clock::now();
  TetEditReport r = mesh_.move(id, p);
  apply(r);
  r.seconds = secondsSince(t0);
  return r;
}

void EditableProbeVolume::setSh(int32_t id, const ShRgb& sh) {
  if (!mesh_.isLive(id))
    throw ParameterError("setSh: probe " + std::to_string(id) + " is not live");
  shOfId_[id] = sh;
  writeVertex(mesh_.mesh().vertexOfInput[id]);
}

void EditableProbeVolume::writeVertex(int32_t vertex) {
  const Vec3 p = mesh_.mesh().vertices[vertex];
  for (int a = 0; a < 3; ++a) volume_.positions[3 * size_t(vertex) + a] = static_cast<float>(p[a]);
  const ShRgb& s = shOfId_[mesh_.idsAt(vertex).front()];
  float* out = volume_.sh.data() + 27 * size_t(vertex);
  for (int k = 0; k < kShCoeffCount; ++k)
    for (int ch = 0; ch < 3; ++ch) out[3 * k + ch] = static_cast<float>(s.c[k][ch]);
}

void EditableProbeVolume::removeHullFaces(int32_t tet) {
  for (int i = 0; i < 4; ++i) {
    const int32_t j = hullIndex_[4 * size_t(tet) + i];
    if (j < 0) continue;
    hullIndex_[4 * size_t(tet) + i] = -1;
    const auto last = volume_.hullFaces.back();
    volume_.hullFaces.pop_back();
    if (size_t(j) == volume_.hullFaces.size()) continue;  // it was the last entry
    volume_.hullFaces[j] = last;
    hullIndex_[4 * size_t(last[0]) + last[1]] = j;
  }
}

void EditableProbeVolume::addHullFaces(int32_t tet) {
  for (int i = 0; i < 4; ++i) {
    if (volume_.neighbors[tet][i] >= 0) continue;
    hullIndex_[4 * size_t(tet) + i] = static_cast<int32_t>(volume_.hullFaces.size());
    volume_.hullFaces.push_back({tet, i});
  }
}

void EditableProbeVolume::apply(const TetEditReport& r) {
  const Tetrahedralization& m = mesh_.mesh();
  ProbeVolume& v = volume_;
  PS_CHECK_EQ(v.tets.size(), r.tetCountBefore);
  PS_CHECK_EQ(v.probeCount(), r.vertexCountBefore);

  // Vertices: the arrays follow the mesh's vertex slots.
  v.positions.resize(3 * m.vertices.size());
  v.sh.resize(27 * m.vertices.size());
  for (int32_t k : r.changedVertices) writeVertex(k);

  // The tets leaving their slot (rewritten or dropped) give up their hull faces and their
  // locator cells, which are walked again once the new tets are in.
  const size_t before = r.tetCountBefore, after = m.tets.size();
  std::vector<int32_t> pending;
  const auto release = [&](int32_t t) {
    removeHullFaces(t);
    for (int32_t c = cellHead_[t]; c >= 0; c = cellNext_[c]) pending.push_back(c);
    cellHead_[t] = -1;
  };
  for (int32_t t : r.changedTets)
    if (size_t(t) < before) release(t);
  for (size_t t = after; t < before; ++t) release(static_cast<int32_t>(t));

  v.tets.resize(after);
  v.neighbors.resize(after);
  v.matrices.resize(after);
  v.thinTets.resize(after);
  v.frames.resize(after);
  hullIndex_.resize(4 * after, -1);
  cellHead_.resize(after, -1);
  for (int32_t t : r.changedTets) {
    v.tets[t] = m.tets[t];
    v.neighbors[t] = m.neighbors[t];
    detail::updateTet(v, t);
    addHullFaces(t);
  }

  // A locator cell's old tet was replaced by tets of the same region (or renumbered), so the
  // walk from its slot (when still in range), or from a changed tet, is short.
  if (v.locatorGrid.empty()) return;
  const int32_t fallback = r.changedTets.empty() ? 0 : r.changedTets.front();
  for (int32_t c : pending) {
    const int32_t old = v.locatorGrid[c];
    const int32_t start = size_t(old) < after ? old : fallback;
    const int32_t t = detail::locatorCellTet(v, size_t(c), start);
    v.locatorGrid[c] = t;
    cellNext_[c] = cellHead_[t];
    cellHead_[t] = c;
  }
}

}  // namespace ps
