#pragma once
// An editable Delaunay tetrahedralization for the editor: the triangulation is kept alive between
// edits, so inserting, removing or moving one probe re-triangulates only the region the edit
// affects (Bowyer-Watson: the tets whose circumsphere contains the new point; removal: the star
// of the vertex), with the same exact predicates and symbolic perturbation as tetrahedralize().
// The mesh is also kept as dense arrays (mesh()) updated in place by each edit, and every edit
// reports which slots of those arrays changed, so that a runtime volume built from them can be
// updated locally too (EditableProbeVolume).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/math/Vec3.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps {

/// What one edit changed and how long it took.
struct TetEditReport {
  int32_t probe = -1;      ///< the probe inserted, removed or moved
  size_t tetsRemoved = 0;  ///< cells destroyed, counting the triangulation's infinite cells
  size_t tetsCreated = 0;  ///< cells created, counting the triangulation's infinite cells
  double seconds = 0;      ///< wall time of the edit (excluding any snapshot())

  // Which slots of mesh() the edit changed (a consumer updates only these):
  /// Tet slots whose row in mesh().tets or mesh().neighbors changed (new tets, tets renumbered
  /// into a freed slot, tets whose neighbour changed), ascending, all < mesh().tets.size().
  std::vector<int32_t> changedTets;
  /// mesh().tets.size() before the edit: slots from the current size up to this were dropped.
  size_t tetCountBefore = 0;
  /// Vertex slots that are new, whose position changed (a vertex renumbered into a freed slot)
  /// or whose set of probe ids changed, ascending, all < mesh().vertices.size().
  std::vector<int32_t> changedVertices;
  /// mesh().vertices.size() before the edit.
  size_t vertexCountBefore = 0;
};

class EditableTetrahedralization {
 public:
  /// Builds the Delaunay tetrahedralization of `points`; probe i is points[i]. Exact duplicates
  /// share one vertex (as in tetrahedralize()). Throws ps::ParameterError as tetrahedralize()
  /// does (non-finite coordinates, fewer than 4 affinely independent points).
  explicit EditableTetrahedralization(std::span<const Vec3> points);
  ~EditableTetrahedralization();
  EditableTetrahedralization(EditableTetrahedralization&&) noexcept;
  EditableTetrahedralization& operator=(EditableTetrahedralization&&) noexcept;

  /// Adds a probe at p; its id (report.probe) is the number of ids handed out so far. A point
  /// equal to an existing probe shares its vertex (no tet changes). Throws ps::ParameterError for
  /// non-finite p.
  TetEditReport insert(Vec3 p);
  /// Removes probe `id`. Throws ps::ParameterError when id is not a live probe, or when the
  /// remaining probes would span fewer than 3 dimensions (the mesh, including its slot
  /// numbering, is then left unchanged).
  TetEditReport remove(int32_t id);
  /// Moves probe `id` to p (insert + remove, each local). Throws ps::ParameterError for an id
  /// that is not live, non-finite p, or a move that would leave the probes spanning fewer than 3
  /// dimensions (the mesh, including its slot numbering, is then left unchanged).
  TetEditReport move(int32_t id, Vec3 p);

  /// Ids handed out so far (live or removed).
  size_t idCount() const;
  /// True when `id` was handed out and not removed.
  bool isLive(int32_t id) const;
  /// Position of live probe `id`.
  Vec3 position(int32_t id) const;
  /// Number of finite tets.
  size_t tetCount() const;

  /// The current mesh as dense arrays, kept up to date by every edit (O(1)). Same conventions as
  /// tetrahedralize() (tets positively oriented, neighbour i opposite vertex i, -1 on the hull,
  /// vertexOfInput[id] = -1 for removed ids), but vertex and tet slots are numbered by the edit
  /// history: an edit reuses the slots it frees and fills the rest from the end.
  const Tetrahedralization& mesh() const;
  /// The probe ids at vertex slot `vertex` (exact duplicates share a vertex), ascending.
  std::span<const int32_t> idsAt(int32_t vertex) const;

  /// The current mesh in tetrahedralize()'s layout (O(n)): vertices are the distinct live
  /// positions in order of first appearance by id, vertexOfInput[id] is -1 for removed ids;
  /// tets positively oriented, neighbour i opposite vertex i, -1 on the hull.
  Tetrahedralization snapshot() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ps
