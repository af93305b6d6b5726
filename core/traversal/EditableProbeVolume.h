#pragma once
// A runtime probe volume that follows the editor's edits locally. Inserting, removing or moving
// one probe re-triangulates only the region the edit affects (EditableTetrahedralization), and
// the runtime arrays (tets, neighbours, matrices, hull faces, frames, locator) are then updated
// only in the slots that edit changed, instead of rebuilding the volume from all the probes.
// After every edit, volume() equals buildProbeVolume() of tetrahedralization().mesh() in its
// tets, neighbours, matrices, thin flags, frames, positions and SH, and in its hull faces as a
// set; its locator grid keeps the cells of the volume it started from and points every cell at
// a live tet (a start for the walk; the walk decides).
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/math/Sh.h"
#include "core/math/Vec3.h"
#include "core/tessellation/EditableTetrahedralization.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

class EditableProbeVolume {
 public:
  /// Probe i is at positions[i] with SH sh[i]. Exact duplicates share a vertex, which takes the
  /// SH of its lowest live id. Throws ps::ParameterError as tetrahedralize() does, and when the
  /// two spans differ in size.
  EditableProbeVolume(std::span<const Vec3> positions, std::span<const ShRgb> sh);

  /// Adds a probe; its id is report.probe. report.seconds covers the mesh edit and the volume
  /// update. Throws as EditableTetrahedralization::insert (nothing changes then).
  TetEditReport insert(Vec3 p, const ShRgb& sh);
  /// Removes probe `id`. Throws as EditableTetrahedralization::remove (nothing changes then).
  TetEditReport remove(int32_t id);
  /// Moves probe `id` to p, keeping its SH. Throws as EditableTetrahedralization::move
  /// (nothing changes then).
  TetEditReport move(int32_t id, Vec3 p);
  /// Replaces the SH of live probe `id` (e.g. after a recapture); O(1).
  void setSh(int32_t id, const ShRgb& sh);

  const ProbeVolume& volume() const { return volume_; }
  const EditableTetrahedralization& tetrahedralization() const { return mesh_; }

 private:
  void apply(const TetEditReport& r);
  void writeVertex(int32_t vertex);
  void addHullFaces(int32_t tet);
  void removeHullFaces(int32_t tet);

  EditableTetrahedralization mesh_;
  std::vector<ShRgb> shOfId_;
  ProbeVolume volume_;
  /// volume_.hullFaces[hullIndex_[4 * tet + i]] is the hull face opposite vertex i of `tet`,
  /// or -1 when that face is interior.
  std::vector<int32_t> hullIndex_;
  /// The locator cells pointing at each tet, as singly linked lists: the first cell of tet t is
  /// cellHead_[t], the next after cell c is cellNext_[c], -1 ends a list. An edit re-walks only
  /// the cells of the tets it changed.
  std::vector<int32_t> cellHead_, cellNext_;
};

}  // namespace ps
