#include "core/domain/FreeSpaceGrid.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "core/math/Random.h"

namespace ps {

double FreeSpaceGrid::autoCellMeters(const Tracer& tracer, std::span<const Bounds3> domain,
                                     double preferredMeters, double minimumMeters,
                                     size_t maxCells) {
  if (preferredMeters > 0) return preferredMeters;
  const Vec3 e = domainBounds(tracer, domain).extent();
  return std::max(minimumMeters, std::cbrt(e.x * e.y * e.z / double(maxCells)));
}

FreeSpaceGrid::FreeSpaceGrid(const Tracer& tracer, std::span<const Bounds3> domain,
                             double cellMeters, size_t maxCells, uint64_t seed)
    : box_(domainBounds(tracer, domain)), cell_(cellMeters) {
  const Vec3 e = box_.extent();
  if (!(e.x * e.y * e.z > 0)) throw ParameterError("domain: the domain has no volume");
  const double ext[kAxes] = {e.x, e.y, e.z};
  size_t cells = 1;
  for (int a = 0; a < kAxes; ++a) {
    n_[a] = std::max(1, int(std::ceil(ext[a] / cell_)));
    cells *= size_t(n_[a]);
  }
  if (cells > maxCells)
    throw ParameterError("cellMeters", "a " + std::to_string(cell_) + " m cell makes " +
                                           std::to_string(cells) + " cells, above " +
                                           std::to_string(maxCells));
  // Free cells: the centre inside the domain's boxes and outside geometry.
  const LightingRig noLights;
  const DomainPoints points(tracer, noLights, domain, 0);
  free_.assign(cells, 0);
  tbb::parallel_for(size_t(0), cells, [&](size_t c) {
    free_[c] = points.valid(centre(c), streamSeed(seed, c)) ? 1 : 0;
  });
  // Joins: bit a when the cell and its +a neighbour are free and the segment between their
  // centres crosses no surface.
  join_.assign(cells, 0);
  tbb::parallel_for(size_t(0), cells, [&](size_t c) {
    if (!free_[c]) return;
    int xyz[kAxes];
    coords(c, xyz);
    for (int a = 0; a < kAxes; ++a) {
      if (xyz[a] + 1 >= n_[a]) continue;
      int nb[kAxes] = {xyz[0], xyz[1], xyz[2]};
      ++nb[a];
      const size_t d = index(nb[0], nb[1], nb[2]);
      if (!free_[d]) continue;
      Ray ray;
      ray.origin = centre(c);
      ray.direction = centre(d) - ray.origin;
      ray.tMin = 0;
      ray.tMax = 1;
      if (!tracer.occluded(ray)) join_[c] |= uint8_t(1u << a);
    }
  });
}

int64_t FreeSpaceGrid::cellOf(Vec3 p) const {
  if (!box_.contains(p)) return -1;
  const Vec3 q = (p - box_.lo) * (1 / cell_);
  const int x = std::min(int(q.x), n_[0] - 1), y = std::min(int(q.y), n_[1] - 1),
            z = std::min(int(q.z), n_[2] - 1);
  return int64_t(index(x, y, z));
}

}  // namespace ps
