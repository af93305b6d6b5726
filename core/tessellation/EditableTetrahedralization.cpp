// Editable Delaunay tetrahedralization (Sukys 2014, sec. 3.2.1 "Delaunay tessellation": Watson's
// incremental algorithm, after Cupisz 2012). Sukys rebuilds the tessellation from scratch; for
// the editor we keep CGAL's triangulation alive so that one edit is local: insertion replaces
// the conflict region (the tets whose circumsphere contains the point, Watson's cavity) and
// removal re-triangulates the star of the vertex. Exact predicates and symbolic perturbation as
// in Tetrahedralization.cpp.
#include "core/tessellation/EditableTetrahedralization.h"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>
#include <CGAL/utility.h>

#include <chrono>
#include <iterator>
#include <sstream>
#include <vector>

#include "core/common/Check.h"
#include "core/common/Error.h"

namespace ps {
namespace {

struct VertexInfo {
  std::vector<int32_t> ids;  ///< live probe ids at this position, ascending (exact duplicates)
  int32_t index = -1;        ///< the vertex's slot in the dense mesh
};

struct CellInfo {
  int32_t slot = -1;  ///< the finite cell's slot in the dense mesh; -1 for a cell not yet slotted
};

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<VertexInfo, K>;
using Cb = CGAL::Triangulation_cell_base_with_info_3<CellInfo, K,
                                                     CGAL::Delaunay_triangulation_cell_base_3<K>>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb, CGAL::Sequential_tag>;
// CGAL's test of whether removing a vertex lowers the dimension is protected; it is cheap (it
// stops at the first finite cell without the vertex), so we ask it before a removal rather
// than repair the mesh after one.
using DelaunayBase = CGAL::Delaunay_triangulation_3<K, Tds>;
struct Delaunay : DelaunayBase {
  using DelaunayBase::test_dim_down;
};
using Point = K::Point_3;
using VertexHandle = Delaunay::Vertex_handle;
using CellHandle = Delaunay::Cell_handle;
using Clock = std::chrono::steady_clock;

/// Sorts `slots`, drops repeats and the slots at or past `count` (dropped by the edit).
void sortedSlotsBelow(std::vector<int32_t>& slots, int32_t count) {
  std::sort(slots.begin(), slots.end());
  slots.erase(std::unique(slots.begin(), slots.end()), slots.end());
  slots.erase(std::lower_bound(slots.begin(), slots.end(), count), slots.end());
}

void requireFinite(Vec3 p, const char* what) {
  if (!isFinite(p)) {
    std::ostringstream s;
    s << what << ": " << p << " is not finite; expected finite coordinates";
    throw ParameterError(s.str());
  }
}

}  // namespace

struct EditableTetrahedralization::Impl {
  Delaunay dt;
  std::vector<VertexHandle> vertexOfId;  ///< null for removed ids
  CellHandle hint;                       ///< a cell near the last edit, to start locate from

  // The dense mesh and its slot maps. Invariants between edits: cellOfSlot[s]->info().slot == s
  // for every tet slot, vertexOfSlot[k]->info().index == k for every vertex slot, and the rows
  // of `mesh` equal what the cells say.
  Tetrahedralization mesh;
  std::vector<CellHandle> cellOfSlot;
  std::vector<VertexHandle> vertexOfSlot;

  // The edit under way: slots freed and not yet reused, rows to rewrite, vertices changed.
  std::vector<int32_t> freeSlots;
  std::vector<int32_t> touchedTets, touchedVertices;
  size_t tetCountBefore = 0, vertexCountBefore = 0;

  struct Change {
    VertexHandle vertex;
    size_t removed = 0, created = 0;
  };

  void beginEdit() {
    freeSlots.clear();
    touchedTets.clear();
    touchedVertices.clear();
    tetCountBefore = mesh.tets.size();
    vertexCountBefore = mesh.vertices.size();
  }

  // Cells about to be destroyed: their slots become free (handles are not used afterwards).
  void releaseCells(const std::vector<CellHandle>& cells) {
    for (CellHandle c : cells) {
      const int32_t s = c->info().slot;
      if (s < 0) continue;  // an infinite cell
      cellOfSlot[s] = CellHandle();
      freeSlots.push_back(s);
      touchedTets.push_back(s);
    }
  }

  // New cells: finite ones take a free slot or a new one at the end; their rows, and those of
  // their finite neighbours (whose neighbour pointers changed), are rewritten at the end.
  void slotCells(const std::vector<CellHandle>& cells) {
    for (CellHandle c : cells) {
      if (dt.is_infinite(c)) continue;
      int32_t s;
      if (!freeSlots.empty()) {
        s = freeSlots.back();
        freeSlots.pop_back();
      } else {
        s = static_cast<int32_t>(cellOfSlot.size());
        cellOfSlot.emplace_back();
      }
      cellOfSlot[s] = c;
      c->info().slot = s;
      touchedTets.push_back(s);
    }
    for (CellHandle c : cells) touchNeighbours(c);
  }

  // The finite neighbours of c point at c: their rows are rewritten at the end.
  void touchNeighbours(CellHandle c) {
    for (int i = 0; i < 4; ++i) {
      const CellHandle n = c->neighbor(i);
      if (dt.is_infinite(n)) continue;
      PS_CHECK(n->info().slot >= 0);
      touchedTets.push_back(n->info().slot);
    }
  }

  void addVertex(VertexHandle v) {
    v->info().index = static_cast<int32_t>(vertexOfSlot.size());
    vertexOfSlot.push_back(v);
    const Point& p = v->point();
    mesh.vertices.push_back({p.x(), p.y(), p.z()});
    touchedVertices.push_back(v->info().index);
  }

  // Vertex slot k lost its vertex: the last vertex moves into it, and the cells around that
  // vertex get their rows rewritten.
  void dropVertexSlot(int32_t k) {
    const int32_t last = static_cast<int32_t>(vertexOfSlot.size()) - 1;
    if (k != last) {
      const VertexHandle v = vertexOfSlot[last];
      vertexOfSlot[k] = v;
      v->info().index = k;
      mesh.vertices[k] = mesh.vertices[last];
      for (int32_t id : v->info().ids) mesh.vertexOfInput[id] = k;
      std::vector<CellHandle> star;
      dt.finite_incident_cells(v, std::back_inserter(star));
      for (CellHandle c : star) touchedTets.push_back(c->info().slot);
      touchedVertices.push_back(k);
    }
    vertexOfSlot.pop_back();
    mesh.vertices.pop_back();
  }

  // Fills the slots left free from the end of the arrays, then rewrites the touched rows.
  void finishEdit(TetEditReport& r) {
    std::sort(freeSlots.begin(), freeSlots.end());
    while (!freeSlots.empty()) {
      const int32_t last = static_cast<int32_t>(cellOfSlot.size()) - 1;
      if (freeSlots.back() == last) {
        freeSlots.pop_back();
      } else {
        const int32_t s = freeSlots.front();
        freeSlots.erase(freeSlots.begin());
        const CellHandle c = cellOfSlot[last];
        cellOfSlot[s] = c;
        c->info().slot = s;
        touchedTets.push_back(s);
        touchNeighbours(c);
      }
      cellOfSlot.pop_back();
    }
    const int32_t tetCount = static_cast<int32_t>(cellOfSlot.size());
    mesh.tets.resize(tetCount);
    mesh.neighbors.resize(tetCount);
    sortedSlotsBelow(touchedTets, tetCount);
    // CGAL keeps every finite cell positively oriented, neighbour i opposite vertex i.
    for (int32_t s : touchedTets) {
      const CellHandle c = cellOfSlot[s];
      for (int i = 0; i < 4; ++i) {
        mesh.tets[s][i] = c->vertex(i)->info().index;
        const CellHandle n = c->neighbor(i);
        mesh.neighbors[s][i] = dt.is_infinite(n) ? -1 : n->info().slot;
      }
    }
    const int32_t vertexCount = static_cast<int32_t>(vertexOfSlot.size());
    sortedSlotsBelow(touchedVertices, vertexCount);
    r.changedTets = touchedTets;
    r.tetCountBefore = tetCountBefore;
    r.changedVertices = touchedVertices;
    r.vertexCountBefore = vertexCountBefore;
  }

  // Watson insertion: the cavity (cells in conflict with p) is replaced by the star of p.
  Change insertPoint(const Point& p) {
    Change ch;
    Delaunay::Locate_type lt;
    int li = 0, lj = 0;
    const CellHandle c = dt.locate(p, lt, li, lj, hint);
    if (lt == Delaunay::VERTEX) {
      ch.vertex = c->vertex(li);
      return ch;
    }
    std::vector<CellHandle> cavity;
    dt.find_conflicts(p, c, CGAL::Emptyset_iterator(), std::back_inserter(cavity));
    ch.removed = cavity.size();
    releaseCells(cavity);
    ch.vertex = dt.insert(p, lt, c, li, lj);
    std::vector<CellHandle> star;
    dt.incident_cells(ch.vertex, std::back_inserter(star));
    ch.created = star.size();
    slotCells(star);
    addVertex(ch.vertex);
    hint = ch.vertex->cell();
    return ch;
  }

  // Removal re-triangulates the star of v; the cells outside it are untouched. The caller has
  // checked that the removal keeps the mesh 3-dimensional.
  Change removeVertex(VertexHandle v) {
    Change ch;
    std::vector<CellHandle> star;
    dt.incident_cells(v, std::back_inserter(star));
    ch.removed = star.size();
    // A neighbour of v outside its star survives the removal: the next locate starts there.
    VertexHandle keep;
    for (CellHandle c : star)
      for (int i = 0; i < 4 && keep == VertexHandle(); ++i)
        if (c->vertex(i) != v && !dt.is_infinite(c->vertex(i))) keep = c->vertex(i);
    const int32_t index = v->info().index;
    releaseCells(star);
    std::vector<CellHandle> created;
    dt.remove_and_give_new_cells(v, std::back_inserter(created));
    ch.created = created.size();
    slotCells(created);
    dropVertexSlot(index);
    hint = keep != VertexHandle() ? keep->cell() : CellHandle();
    return ch;
  }

  // Slots every finite cell and vertex from scratch (after construction).
  void slotAll() {
    beginEdit();
    mesh.vertices.clear();
    vertexOfSlot.clear();
    cellOfSlot.clear();
    for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v)
      v->info().index = -1;
    // Vertices in order of first appearance by id, as tetrahedralize() numbers them.
    for (VertexHandle v : vertexOfId)
      if (v != VertexHandle() && v->info().index < 0) addVertex(v);
    PS_CHECK_EQ(vertexOfSlot.size(), dt.number_of_vertices());
    mesh.vertexOfInput.assign(vertexOfId.size(), -1);
    for (size_t id = 0; id < vertexOfId.size(); ++id)
      if (vertexOfId[id] != VertexHandle()) mesh.vertexOfInput[id] = vertexOfId[id]->info().index;
    std::vector<CellHandle> cells;
    for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) cells.push_back(c);
    slotCells(cells);
    TetEditReport unused;
    finishEdit(unused);
  }
};

EditableTetrahedralization::EditableTetrahedralization(std::span<const Vec3> points)
    : impl_(std::make_unique<Impl>()) {
  for (size_t i = 0; i < points.size(); ++i) {
    if (!isFinite(points[i])) {
      std::ostringstream s;
      s << "tetrahedralize: points[" << i << "] = " << points[i]
        << " is not finite; expected finite coordinates";
      throw ParameterError(s.str());
    }
  }
  // Range insertion (spatially sorted), then map each input to its vertex by locating it.
  std::vector<Point> pts;
  pts.reserve(points.size());
  for (Vec3 p : points) pts.emplace_back(p.x, p.y, p.z);
  impl_->dt.insert(pts.begin(), pts.end());
  if (impl_->dt.dimension() < 3) {
    std::ostringstream s;
    s << "tetrahedralize: need at least 4 points not all in one plane; got "
      << impl_->dt.number_of_vertices() << " distinct points spanning dimension "
      << impl_->dt.dimension();
    throw ParameterError(s.str());
  }
  impl_->vertexOfId.reserve(points.size());
  CellHandle hint;
  for (size_t id = 0; id < pts.size(); ++id) {
    Delaunay::Locate_type lt;
    int li = 0, lj = 0;
    const CellHandle c = impl_->dt.locate(pts[id], lt, li, lj, hint);
    PS_CHECK(lt == Delaunay::VERTEX);
    const VertexHandle v = c->vertex(li);
    v->info().ids.push_back(static_cast<int32_t>(id));
    impl_->vertexOfId.push_back(v);
    hint = c;
  }
  impl_->slotAll();
}

EditableTetrahedralization::~EditableTetrahedralization() = default;
EditableTetrahedralization::EditableTetrahedralization(EditableTetrahedralization&&) noexcept =
    default;
EditableTetrahedralization& EditableTetrahedralization::operator=(
    EditableTetrahedralization&&) noexcept = default;

namespace {

void addId(std::vector<int32_t>& ids, int32_t id) {
  ids.insert(std::lower_bound(ids.begin(), ids.end(), id), id);
}

void removeId(std::vector<int32_t>& ids, int32_t id) {
  ids.erase(std::lower_bound(ids.begin(), ids.end(), id));
}

}  // namespace

TetEditReport EditableTetrahedralization::insert(Vec3 p) {
  requireFinite(p, "insert");
  const auto t0 = Clock::now();
  Impl& m = *impl_;
  m.beginEdit();
  const Impl::Change ch = m.insertPoint(Point(p.x, p.y, p.z));
  const int32_t id = static_cast<int32_t>(m.vertexOfId.size());
  addId(ch.vertex->info().ids, id);
  m.vertexOfId.push_back(ch.vertex);
  m.mesh.vertexOfInput.push_back(ch.vertex->info().index);
  m.touchedVertices.push_back(ch.vertex->info().index);
  TetEditReport r;
  r.probe = id;
  r.tetsRemoved = ch.removed;
  r.tetsCreated = ch.created;
  m.finishEdit(r);
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

TetEditReport EditableTetrahedralization::remove(int32_t id) {
  if (!isLive(id)) throw ParameterError("remove: probe " + std::to_string(id) + " is not live");
  const auto t0 = Clock::now();
  Impl& m = *impl_;
  TetEditReport r;
  r.probe = id;
  const VertexHandle v = m.vertexOfId[id];
  const bool last = v->info().ids.size() == 1;  // else an exact duplicate keeps the vertex
  if (last && m.dt.test_dim_down(v))
    throw ParameterError("remove: probe " + std::to_string(id) +
                         " is needed: the other probes lie in one plane");
  m.beginEdit();
  removeId(v->info().ids, id);
  m.vertexOfId[id] = VertexHandle();
  m.mesh.vertexOfInput[id] = -1;
  if (last) {
    const Impl::Change ch = m.removeVertex(v);
    r.tetsRemoved = ch.removed;
    r.tetsCreated = ch.created;
  } else {
    m.touchedVertices.push_back(v->info().index);
  }
  m.finishEdit(r);
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

TetEditReport EditableTetrahedralization::move(int32_t id, Vec3 p) {
  if (!isLive(id)) throw ParameterError("move: probe " + std::to_string(id) + " is not live");
  requireFinite(p, "move");
  const auto t0 = Clock::now();
  Impl& m = *impl_;
  TetEditReport r;
  r.probe = id;
  const VertexHandle old = m.vertexOfId[id];
  const Point target(p.x, p.y, p.z);
  if (old->point() == target) {
    r.tetCountBefore = m.mesh.tets.size();
    r.vertexCountBefore = m.mesh.vertices.size();
    return r;
  }
  const bool last = old->info().ids.size() == 1;
  // Insert first, then remove: the probes span 3 dimensions throughout unless the old vertex
  // is the only one off the plane of all the others and the target lies in that plane. Every
  // finite cell then contains the old vertex; the face opposite it spans the plane.
  if (last && m.dt.test_dim_down(old)) {
    const CellHandle c = m.dt.finite_cells_begin();
    const int i = c->index(old);
    if (CGAL::coplanar(c->vertex((i + 1) & 3)->point(), c->vertex((i + 2) & 3)->point(),
                       c->vertex((i + 3) & 3)->point(), target))
      throw ParameterError("move: probe " + std::to_string(id) +
                           " cannot move there: all probes would lie in one plane");
  }
  m.beginEdit();
  const Impl::Change in = m.insertPoint(target);
  removeId(old->info().ids, id);
  addId(in.vertex->info().ids, id);
  m.vertexOfId[id] = in.vertex;
  m.touchedVertices.push_back(in.vertex->info().index);
  r.tetsRemoved = in.removed;
  r.tetsCreated = in.created;
  if (last) {
    const Impl::Change out = m.removeVertex(old);
    r.tetsRemoved += out.removed;
    r.tetsCreated += out.created;
  } else {
    m.touchedVertices.push_back(old->info().index);
  }
  m.mesh.vertexOfInput[id] = in.vertex->info().index;
  m.finishEdit(r);
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

size_t EditableTetrahedralization::idCount() const {
  return impl_->vertexOfId.size();
}

bool EditableTetrahedralization::isLive(int32_t id) const {
  return id >= 0 && size_t(id) < impl_->vertexOfId.size() &&
         impl_->vertexOfId[id] != VertexHandle();
}

Vec3 EditableTetrahedralization::position(int32_t id) const {
  PS_CHECK(isLive(id));
  const Point& p = impl_->vertexOfId[id]->point();
  return {p.x(), p.y(), p.z()};
}

size_t EditableTetrahedralization::tetCount() const {
  return impl_->mesh.tets.size();
}

const Tetrahedralization& EditableTetrahedralization::mesh() const {
  return impl_->mesh;
}

std::span<const int32_t> EditableTetrahedralization::idsAt(int32_t vertex) const {
  PS_CHECK(vertex >= 0 && size_t(vertex) < impl_->vertexOfSlot.size());
  return impl_->vertexOfSlot[vertex]->info().ids;
}

Tetrahedralization EditableTetrahedralization::snapshot() const {
  // The dense mesh, renumbered: vertices in order of first appearance by id.
  const Tetrahedralization& mesh = impl_->mesh;
  std::vector<int32_t> renumber(mesh.vertices.size(), -1);
  Tetrahedralization out;
  out.vertexOfInput.assign(mesh.vertexOfInput.size(), -1);
  out.vertices.reserve(mesh.vertices.size());
  for (size_t id = 0; id < mesh.vertexOfInput.size(); ++id) {
    const int32_t v = mesh.vertexOfInput[id];
    if (v < 0) continue;
    if (renumber[v] < 0) {
      renumber[v] = static_cast<int32_t>(out.vertices.size());
      out.vertices.push_back(mesh.vertices[v]);
    }
    out.vertexOfInput[id] = renumber[v];
  }
  PS_CHECK_EQ(out.vertices.size(), mesh.vertices.size());
  out.tets = mesh.tets;
  for (auto& tet : out.tets)
    for (int32_t& v : tet) v = renumber[v];
  out.neighbors = mesh.neighbors;
  return out;
}

}  // namespace ps
