// Delaunay tetrahedralization of the probe positions (Sukys 2014, sec. 3.2.1 "Delaunay
// tessellation", after Cupisz 2012). Sukys builds it with Watson's incremental algorithm and
// notes (sec. 3.2.1, "Limitations and adjustments") that floating-point in-sphere tests give
// invalid meshes on unevenly distributed input; we therefore use CGAL's Delaunay_triangulation_3
// with exact predicates and symbolic perturbation, which is correct for every input.
#include "core/tessellation/Tetrahedralization.h"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include <algorithm>
#include <numeric>
#include <sstream>
#include <utility>

#include "core/common/Check.h"
#include "core/common/Error.h"

namespace ps {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<int32_t, K>;
using Cb = CGAL::Triangulation_cell_base_with_info_3<int32_t, K,
                                                     CGAL::Delaunay_triangulation_cell_base_3<K>>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb, CGAL::Sequential_tag>;
using Delaunay = CGAL::Delaunay_triangulation_3<K, Tds>;
using Point = K::Point_3;

bool lexLess(Vec3 a, Vec3 b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z < b.z;
}

}  // namespace

Tetrahedralization tetrahedralize(std::span<const Vec3> points) {
  for (size_t i = 0; i < points.size(); ++i) {
    if (!isFinite(points[i])) {
      std::ostringstream s;
      s << "tetrahedralize: points[" << i << "] = " << points[i]
        << " is not finite; expected finite coordinates";
      throw ParameterError(s.str());
    }
  }

  // Insertion of a range of (point, info) pairs spatially sorts it first (Hilbert order).
  // Common case first: no exact duplicates, so vertex i is input i and no sort is needed. CGAL
  // merges duplicates silently (keeping one of the infos), so when the vertex count shows some,
  // we merge them ourselves and insert again: vertices are then the distinct points in order of
  // first appearance, a deterministic numbering.
  Tetrahedralization out;
  auto insertAll = [](Delaunay& dt, std::span<const Vec3> pts) {
    std::vector<std::pair<Point, int32_t>> input;
    input.reserve(pts.size());
    for (size_t i = 0; i < pts.size(); ++i)
      input.emplace_back(Point(pts[i].x, pts[i].y, pts[i].z), static_cast<int32_t>(i));
    dt.insert(input.begin(), input.end());
  };
  Delaunay dt;
  insertAll(dt, points);
  if (dt.number_of_vertices() == points.size()) {
    out.vertices.assign(points.begin(), points.end());
    out.vertexOfInput.resize(points.size());
    std::iota(out.vertexOfInput.begin(), out.vertexOfInput.end(), 0);
  } else {
    out.vertexOfInput.assign(points.size(), -1);
    std::vector<int32_t> order(points.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](int32_t a, int32_t b) { return lexLess(points[a], points[b]); });
    // Each run of equal points maps to its first (lowest) input index.
    std::vector<int32_t> firstOf(points.size(), -1);
    for (size_t k = 0; k < order.size();) {
      size_t e = k;
      while (e < order.size() && points[order[e]] == points[order[k]]) ++e;
      for (size_t j = k; j < e; ++j) firstOf[order[j]] = order[k];
      k = e;
    }
    for (size_t i = 0; i < points.size(); ++i) {
      if (firstOf[i] == static_cast<int32_t>(i)) {
        out.vertexOfInput[i] = static_cast<int32_t>(out.vertices.size());
        out.vertices.push_back(points[i]);
      } else {
        out.vertexOfInput[i] = out.vertexOfInput[firstOf[i]];
      }
    }
    dt.clear();
    insertAll(dt, out.vertices);
  }

  if (dt.dimension() < 3) {
    std::ostringstream s;
    s << "tetrahedralize: need at least 4 points not all in one plane; got " << out.vertices.size()
      << " distinct points spanning dimension " << dt.dimension();
    throw ParameterError(s.str());
  }
  PS_CHECK_EQ(dt.number_of_vertices(), out.vertices.size());

  // Number the finite cells in iteration order and mark the infinite ones -1, so that the
  // second pass reads a neighbour's index (or -1 on the hull) without an infinity test.
  int32_t next = 0;
  for (auto c = dt.all_cells_begin(); c != dt.all_cells_end(); ++c)
    c->info() = dt.is_infinite(c) ? -1 : next++;
  out.tets.resize(next);
  out.neighbors.resize(next);
  // CGAL stores every finite cell positively oriented (CGAL::orientation of its vertices 0..3 is
  // POSITIVE) and neighbour i opposite vertex i; we keep both conventions as they are.
  for (auto c = dt.all_cells_begin(); c != dt.all_cells_end(); ++c) {
    const int32_t k = c->info();
    if (k < 0) continue;
    for (int i = 0; i < 4; ++i) {
      out.tets[k][i] = c->vertex(i)->info();
      out.neighbors[k][i] = c->neighbor(i)->info();
    }
  }
  return out;
}

}  // namespace ps
