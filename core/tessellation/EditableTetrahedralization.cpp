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
  int32_t refs = 0;    ///< live probe ids at this position (exact duplicates share a vertex)
  int32_t index = -1;  ///< scratch: vertex index during snapshot()
};

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<VertexInfo, K>;
using Cb = CGAL::Triangulation_cell_base_with_info_3<int32_t, K,
                                                     CGAL::Delaunay_triangulation_cell_base_3<K>>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb, CGAL::Sequential_tag>;
using Delaunay = CGAL::Delaunay_triangulation_3<K, Tds>;
using Point = K::Point_3;
using VertexHandle = Delaunay::Vertex_handle;
using CellHandle = Delaunay::Cell_handle;
using Clock = std::chrono::steady_clock;

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

  struct Change {
    VertexHandle vertex;
    size_t removed = 0, created = 0;
  };

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
    ch.vertex = dt.insert(p, lt, c, li, lj);
    std::vector<CellHandle> star;
    dt.incident_cells(ch.vertex, std::back_inserter(star));
    ch.created = star.size();
    hint = ch.vertex->cell();
    return ch;
  }

  // Removal re-triangulates the star of v; the cells outside it are untouched.
  Change removeVertex(VertexHandle v) {
    Change ch;
    std::vector<CellHandle> star;
    dt.incident_cells(v, std::back_inserter(star));
    ch.removed = star.size();
    const size_t before = dt.number_of_cells();
    // A neighbour of v outside its star survives the removal: the next locate starts there.
    VertexHandle keep;
    for (CellHandle c : star)
      for (int i = 0; i < 4 && keep == VertexHandle(); ++i)
        if (c->vertex(i) != v && !dt.is_infinite(c->vertex(i))) keep = c->vertex(i);
    dt.remove(v);
    ch.created = dt.number_of_cells() + ch.removed - before;
    hint = keep != VertexHandle() ? keep->cell() : CellHandle();
    return ch;
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
  for (const Point& p : pts) {
    Delaunay::Locate_type lt;
    int li = 0, lj = 0;
    const CellHandle c = impl_->dt.locate(p, lt, li, lj, hint);
    PS_CHECK(lt == Delaunay::VERTEX);
    const VertexHandle v = c->vertex(li);
    ++v->info().refs;
    impl_->vertexOfId.push_back(v);
    hint = c;
  }
}

EditableTetrahedralization::~EditableTetrahedralization() = default;
EditableTetrahedralization::EditableTetrahedralization(EditableTetrahedralization&&) noexcept =
    default;
EditableTetrahedralization& EditableTetrahedralization::operator=(
    EditableTetrahedralization&&) noexcept = default;

TetEditReport EditableTetrahedralization::insert(Vec3 p) {
  requireFinite(p, "insert");
  const auto t0 = Clock::now();
  const Impl::Change ch = impl_->insertPoint(Point(p.x, p.y, p.z));
  ++ch.vertex->info().refs;
  impl_->vertexOfId.push_back(ch.vertex);
  TetEditReport r;
  r.probe = static_cast<int32_t>(impl_->vertexOfId.size() - 1);
  r.tetsRemoved = ch.removed;
  r.tetsCreated = ch.created;
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

TetEditReport EditableTetrahedralization::remove(int32_t id) {
  if (!isLive(id)) throw ParameterError("remove: probe " + std::to_string(id) + " is not live");
  const auto t0 = Clock::now();
  TetEditReport r;
  r.probe = id;
  const VertexHandle v = impl_->vertexOfId[id];
  if (v->info().refs > 1) {  // an exact duplicate keeps the vertex
    --v->info().refs;
    impl_->vertexOfId[id] = VertexHandle();
  } else {
    const Point p = v->point();
    const Impl::Change ch = impl_->removeVertex(v);
    if (impl_->dt.dimension() < 3) {
      const Impl::Change back = impl_->insertPoint(p);
      back.vertex->info().refs = 1;
      impl_->vertexOfId[id] = back.vertex;
      throw ParameterError("remove: probe " + std::to_string(id) +
                           " is needed: the other probes lie in one plane");
    }
    impl_->vertexOfId[id] = VertexHandle();
    r.tetsRemoved = ch.removed;
    r.tetsCreated = ch.created;
  }
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

TetEditReport EditableTetrahedralization::move(int32_t id, Vec3 p) {
  if (!isLive(id)) throw ParameterError("move: probe " + std::to_string(id) + " is not live");
  requireFinite(p, "move");
  const auto t0 = Clock::now();
  TetEditReport r;
  r.probe = id;
  const VertexHandle old = impl_->vertexOfId[id];
  const Point target(p.x, p.y, p.z);
  if (old->point() == target) return r;
  // Insert first, then remove: the probes span 3 dimensions throughout unless the old vertex
  // was the only one off a plane that the new position lies in.
  const Impl::Change in = impl_->insertPoint(target);
  ++in.vertex->info().refs;
  impl_->vertexOfId[id] = in.vertex;
  r.tetsRemoved = in.removed;
  r.tetsCreated = in.created;
  if (--old->info().refs == 0) {
    const Point from = old->point();
    const Impl::Change out = impl_->removeVertex(old);
    if (impl_->dt.dimension() < 3) {
      // Undo: put the old vertex back and take the new one out again.
      const Impl::Change back = impl_->insertPoint(from);
      back.vertex->info().refs = 1;
      impl_->vertexOfId[id] = back.vertex;
      if (--in.vertex->info().refs == 0) impl_->removeVertex(in.vertex);
      throw ParameterError("move: probe " + std::to_string(id) +
                           " cannot move there: all probes would lie in one plane");
    }
    r.tetsRemoved += out.removed;
    r.tetsCreated += out.created;
  }
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
  return impl_->dt.number_of_finite_cells();
}

Tetrahedralization EditableTetrahedralization::snapshot() const {
  Delaunay& dt = impl_->dt;
  Tetrahedralization out;
  for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v)
    v->info().index = -1;
  out.vertexOfInput.assign(impl_->vertexOfId.size(), -1);
  out.vertices.reserve(dt.number_of_vertices());
  for (size_t id = 0; id < impl_->vertexOfId.size(); ++id) {
    const VertexHandle v = impl_->vertexOfId[id];
    if (v == VertexHandle()) continue;
    if (v->info().index < 0) {
      v->info().index = static_cast<int32_t>(out.vertices.size());
      const Point& p = v->point();
      out.vertices.push_back({p.x(), p.y(), p.z()});
    }
    out.vertexOfInput[id] = v->info().index;
  }
  PS_CHECK_EQ(out.vertices.size(), dt.number_of_vertices());
  int32_t next = 0;
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) c->info() = next++;
  out.tets.reserve(next);
  out.neighbors.reserve(next);
  // CGAL keeps every finite cell positively oriented, neighbour i opposite vertex i.
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
    std::array<int32_t, 4> tet{}, nb{};
    for (int i = 0; i < 4; ++i) {
      tet[i] = c->vertex(i)->info().index;
      const auto n = c->neighbor(i);
      nb[i] = dt.is_infinite(n) ? -1 : n->info();
    }
    out.tets.push_back(tet);
    out.neighbors.push_back(nb);
  }
  return out;
}

}  // namespace ps
