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

  // Merge exact duplicates ourselves (CGAL would merge them too, but silently): vertices are the
  // distinct points in order of first appearance, so the numbering is deterministic.
  Tetrahedralization out;
  out.vertexOfInput.assign(points.size(), -1);
  {
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
  }

  // Insertion of a range of (point, info) pairs spatially sorts it first (Hilbert order).
  std::vector<std::pair<Point, int32_t>> input;
  input.reserve(out.vertices.size());
  for (size_t i = 0; i < out.vertices.size(); ++i) {
    const Vec3 p = out.vertices[i];
    input.emplace_back(Point(p.x, p.y, p.z), static_cast<int32_t>(i));
  }
  Delaunay dt(input.begin(), input.end());

  if (dt.dimension() < 3) {
    std::ostringstream s;
    s << "tetrahedralize: need at least 4 points not all in one plane; got " << out.vertices.size()
      << " distinct points spanning dimension " << dt.dimension();
    throw ParameterError(s.str());
  }
  PS_CHECK_EQ(dt.number_of_vertices(), out.vertices.size());

  int32_t next = 0;
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) c->info() = next++;
  out.tets.reserve(next);
  out.neighbors.reserve(next);
  // CGAL stores every finite cell positively oriented (CGAL::orientation of its vertices 0..3 is
  // POSITIVE) and neighbour i opposite vertex i; we keep both conventions as they are.
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
    std::array<int32_t, 4> tet{}, nb{};
    for (int i = 0; i < 4; ++i) {
      tet[i] = c->vertex(i)->info();
      const auto n = c->neighbor(i);
      nb[i] = dt.is_infinite(n) ? -1 : n->info();
    }
    out.tets.push_back(tet);
    out.neighbors.push_back(nb);
  }
  return out;
}

}  // namespace ps
