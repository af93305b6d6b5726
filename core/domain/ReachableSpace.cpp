#include "core/domain/ReachableSpace.h"

#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/common/Error.h"
#include "core/domain/FreeSpaceGrid.h"
#include "core/math/Random.h"

namespace ps {

namespace {

/// Smallest automatic cell edge, metres: a quarter of a doorway, a tenth of the band.
constexpr double kMinAutoCellMeters = 0.25;
/// Edge of the blocks the enclosure test is sampled over, in cells (a power of two).
constexpr int kEnclosureBlock = 8;
/// Free cells among a block's eight corners that must agree for the block to take their outcome.
constexpr int kEnclosureSamples = 4;
/// Grids of at most this many cells test the enclosure of every band cell (under a second on 2
/// cores); larger ones sample it over blocks.
constexpr size_t kEnclosureSampledAbove = 1000000;

}  // namespace

void checkReachableSettings(const ReachableSettings& s) {
  if (!(s.bandMeters > 0 && s.bandMeters <= 100))
    throw ParameterError("bandMeters",
                         "expected a height in (0, 100] m above walkable surfaces, "
                         "got " +
                             std::to_string(s.bandMeters));
  if (!(s.maxSlopeDeg >= 0 && s.maxSlopeDeg < 90))
    throw ParameterError("maxSlopeDeg", "expected an angle in [0, 90) degrees, got " +
                                            std::to_string(s.maxSlopeDeg));
  if (!(s.cellMeters >= 0))
    throw ParameterError("cellMeters", "expected 0 (automatic) or an edge above 0 m, got " +
                                           std::to_string(s.cellMeters));
  if (s.maxCells < 1000)
    throw ParameterError("maxCells",
                         "expected at least 1000 cells, got " + std::to_string(s.maxCells));
  if (s.enclosureRays < 1)
    throw ParameterError("enclosureRays",
                         "expected at least 1 ray, got " + std::to_string(s.enclosureRays));
  if (!(s.maxOpenFraction >= 0 && s.maxOpenFraction <= 1))
    throw ParameterError("maxOpenFraction",
                         "expected a fraction in [0, 1], got " + std::to_string(s.maxOpenFraction));
  if (!(s.interiorShare >= 0 && s.interiorShare <= 1))
    throw ParameterError("interiorShare",
                         "expected a fraction in [0, 1], got " + std::to_string(s.interiorShare));
}

ReachableSpace::ReachableSpace(const Tracer& tracer, std::span<const Bounds3> domain,
                               const ReachableSettings& s) {
  checkReachableSettings(s);
  const auto start = std::chrono::steady_clock::now();
  const FreeSpaceGrid::CellChoice choice =
      FreeSpaceGrid::chooseCell(tracer, domain, s.cellMeters, kMinAutoCellMeters, s.maxCells);
  if (!choice.note.empty())
    note_ = "reachable domain: " + choice.note +
            "; the space kept may be off by half a cell at walls, floors and ceilings";
  const FreeSpaceGrid grid(tracer, domain, choice.meters, s.maxCells, s.seed);
  box_ = grid.box();
  cell_ = grid.cellMeters();
  for (int a = 0; a < 3; ++a) n_[a] = grid.size(a);
  const size_t cells = grid.cellCount();
  const double cellVolume = cell_ * cell_ * cell_;
  const double minUp = std::cos(s.maxSlopeDeg * M_PI / 180.0);

  // Band cells: free, with a walkable surface (seen from above, its normal within maxSlopeDeg
  // of +Y) first hit straight down within bandMeters of the centre. Column by column, upwards:
  // a free cell joined to the free cell below it sees the same first hit one cell farther (the
  // ray down passes through the lower centre along a free segment), so only the lowest cell of
  // each run of joined cells traces a ray.
  std::vector<char> band(cells, 0);
  tbb::parallel_for(size_t(0), size_t(n_[0]) * size_t(n_[2]), [&](size_t column) {
    const int x = int(column % size_t(n_[0])), z = int(column / size_t(n_[0]));
    double below = std::numeric_limits<double>::infinity();  // distance to the first hit
    bool walkable = false;
    for (int y = 0; y < n_[1]; ++y) {
      const size_t c = grid.index(x, y, z);
      if (!grid.isFree(c)) continue;
      if (y > 0 && (grid.joins(grid.index(x, y - 1, z)) & 2u)) {
        below += cell_;
      } else {
        Ray down;
        down.origin = grid.centre(c);
        down.direction = Vec3(0, -1, 0);
        down.tMin = 0;
        const std::optional<Hit> floor = tracer.intersect(down);
        below = floor ? floor->t : std::numeric_limits<double>::infinity();
        walkable = floor && std::abs(floor->geometricNormal.y) >= minUp;
      }
      band[c] = walkable && below <= s.bandMeters ? 1 : 0;
    }
  });
  // Enclosed band cells: at most maxOpenFraction of enclosureRays uniform directions escape the
  // scene. The share escaping varies slowly away from openings, so on a grid of more than
  // kEnclosureSampledAbove cells it is sampled: a block whose corners include at least
  // kEnclosureSamples free cells (in the band or not), all clearly on one side (at most half
  // the limit escaping, or more than halfway from it to all of the rays), gives its band cells
  // that outcome; any other block is split in eight, down to blocks of 2^3 cells, whose band
  // cells are each tested. Near the limit the outcome is noise and is not spread; an opening
  // narrower than a block between corners that all lie clearly inside may be missed.
  // Per free cell: 0 untested, 1 clearly open, 2 open, 3 enclosed, 4 clearly enclosed.
  std::vector<char> enclosed(cells, 0);
  const double limit = s.maxOpenFraction * s.enclosureRays;
  auto test = [&](size_t c, bool corner) {
    if (enclosed[c] == 0) {
      uint64_t rng = streamSeed(s.seed ^ 0x5eedc0de5eedc0deull, c);
      // A corner counts every ray; any other cell stops once its outcome is settled (more
      // than `limit` open, or too few rays left to get there).
      int open = 0;
      for (int r = 0;
           r < s.enclosureRays && (corner || (open <= limit && open + s.enclosureRays - r > limit));
           ++r) {
        Ray out;
        out.origin = grid.centre(c);
        out.direction = uniformSphere(uniform01(rng), uniform01(rng));
        out.tMin = 0;
        if (!tracer.occluded(out)) ++open;
      }
      if (open <= limit)
        enclosed[c] = corner && open <= 0.5 * limit ? 4 : 3;
      else
        enclosed[c] = corner && open >= 0.5 * (limit + s.enclosureRays) ? 1 : 2;
    }
    return enclosed[c];
  };
  auto sample = [&](auto&& self, const int lo[3], int size) -> void {
    int hi[3];
    for (int a = 0; a < 3; ++a) hi[a] = std::min(lo[a] + size, n_[a]);
    if (size > 2) {
      char outcome = 0;
      int samples = 0;
      bool agree = true;
      for (int k = 0; k < 8 && agree; ++k) {
        const size_t c = grid.index(k & 1 ? hi[0] - 1 : lo[0], k & 2 ? hi[1] - 1 : lo[1],
                                    k & 4 ? hi[2] - 1 : lo[2]);
        if (!grid.isFree(c)) continue;
        const char got = test(c, true);
        agree = (got == 1 || got == 4) && (outcome == 0 || got == outcome);
        outcome = got;
        ++samples;
      }
      if (agree && samples >= kEnclosureSamples) {
        for (int z = lo[2]; z < hi[2]; ++z)
          for (int y = lo[1]; y < hi[1]; ++y)
            for (int x = lo[0]; x < hi[0]; ++x) {
              const size_t c = grid.index(x, y, z);
              if (band[c] && enclosed[c] == 0) enclosed[c] = outcome;
            }
        return;
      }
      const int half = size / 2;
      for (int k = 0; k < 8; ++k) {
        const int sub[3] = {lo[0] + (k & 1 ? half : 0), lo[1] + (k & 2 ? half : 0),
                            lo[2] + (k & 4 ? half : 0)};
        if (sub[0] < hi[0] && sub[1] < hi[1] && sub[2] < hi[2]) self(self, sub, half);
      }
      return;
    }
    for (int z = lo[2]; z < hi[2]; ++z)
      for (int y = lo[1]; y < hi[1]; ++y)
        for (int x = lo[0]; x < hi[0]; ++x)
          if (band[grid.index(x, y, z)]) test(grid.index(x, y, z), false);
  };
  const int top = cells > kEnclosureSampledAbove ? kEnclosureBlock : 2;
  int blocks[3];
  for (int a = 0; a < 3; ++a) blocks[a] = (n_[a] + top - 1) / top;
  tbb::parallel_for(size_t(0), size_t(blocks[0]) * size_t(blocks[1]) * size_t(blocks[2]),
                    [&](size_t b) {
                      const int lo[3] = {int(b % size_t(blocks[0])) * top,
                                         int((b / size_t(blocks[0])) % size_t(blocks[1])) * top,
                                         int(b / (size_t(blocks[0]) * size_t(blocks[1]))) * top};
                      sample(sample, lo, top);
                    });
  for (size_t c = 0; c < cells; ++c) enclosed[c] = band[c] && enclosed[c] >= 3 ? 1 : 0;
  for (size_t c = 0; c < cells; ++c) {
    freeVolume_ += grid.isFree(c) ? cellVolume : 0;
    bandVolume_ += band[c] ? cellVolume : 0;
    enclosedVolume_ += enclosed[c] ? cellVolume : 0;
  }
  // An interior keeps its enclosed band (Rooms' free space without the air around the
  // building); an exterior keeps the band above its ground.
  interior_ = bandVolume_ > 0 && enclosedVolume_ >= s.interiorShare * bandVolume_;
  // An interior's enclosed cells, opened (eroded, then grown back within them): a cell stays
  // when no free face neighbour of it is outside the enclosed set, or when a face neighbour
  // that stays is beside it. The foot of an outer wall, where the ground and the wall hide
  // three quarters of the sky from a one-cell strip of outside air, goes; rooms keep every cell
  // (a wall or floor face neighbour, being geometry, does not erode them).
  auto forFaces = [&](size_t c, auto&& visit) {
    int xyz[3];
    grid.coords(c, xyz);
    for (int side = 0; side < 6; ++side) {
      int nb[3] = {xyz[0], xyz[1], xyz[2]};
      nb[side / 2] += side % 2 ? 1 : -1;
      if (nb[0] < 0 || nb[1] < 0 || nb[2] < 0 || nb[0] >= n_[0] || nb[1] >= n_[1] || nb[2] >= n_[2])
        continue;
      visit(grid.index(nb[0], nb[1], nb[2]));
    }
  };
  std::vector<char> core(cells, 0), opened(cells, 0);
  tbb::parallel_for(size_t(0), cells, [&](size_t c) {
    if (!enclosed[c]) return;
    bool keep = true;
    forFaces(c, [&](size_t d) { keep = keep && (!grid.isFree(d) || enclosed[d]); });
    core[c] = keep ? 1 : 0;
  });
  tbb::parallel_for(size_t(0), cells, [&](size_t c) {
    if (!enclosed[c]) return;
    bool keep = core[c] != 0;
    forFaces(c, [&](size_t d) { keep = keep || core[d]; });
    opened[c] = keep ? 1 : 0;
  });
  reachable_.assign(cells, 0);
  for (size_t c = 0; c < cells; ++c) {
    reachable_[c] = (interior_ ? opened[c] : band[c]) ? 1 : 0;
    keptVolume_ += reachable_[c] ? cellVolume : 0;
  }
  kept_ = reachable_;
  // A cell whose centre is inside geometry (a wall, the floor slab) beside a reachable cell is
  // kept too: the free part of it against the wall is as reachable as its neighbour, and the
  // points drawn in it are tested for validity one by one (DomainPoints::draw).
  std::vector<char> beside(cells, 0);
  tbb::parallel_for(size_t(0), cells, [&](size_t c) {
    if (grid.isFree(c)) return;
    int xyz[3];
    grid.coords(c, xyz);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int x = xyz[0] + dx, y = xyz[1] + dy, z = xyz[2] + dz;
          if (x < 0 || y < 0 || z < 0 || x >= n_[0] || y >= n_[1] || z >= n_[2]) continue;
          if (reachable_[grid.index(x, y, z)]) beside[c] = 1;
        }
  });
  size_t count = 0;
  for (size_t c = 0; c < cells; ++c) {
    reachable_[c] = reachable_[c] || beside[c];
    count += reachable_[c] ? 1 : 0;
  }
  corners_.reserve(count);
  for (size_t c = 0; c < cells; ++c)
    if (reachable_[c]) corners_.push_back(grid.centre(c) - Vec3(0.5, 0.5, 0.5) * cell_);
  seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool ReachableSpace::contains(Vec3 p) const {
  if (!box_.contains(p)) return false;
  const Vec3 q = (p - box_.lo) * (1 / cell_);
  const int x = std::min(int(q.x), n_[0] - 1), y = std::min(int(q.y), n_[1] - 1),
            z = std::min(int(q.z), n_[2] - 1);
  return reachable_[(size_t(z) * size_t(n_[1]) + size_t(y)) * size_t(n_[0]) + size_t(x)] != 0;
}

std::vector<std::array<Vec3, 4>> ReachableSpace::shellFaces(size_t maxFaces) const {
  // A face per (cell, side) whose neighbour across it is not reachable.
  auto kept = [&](int x, int y, int z) {
    if (x < 0 || y < 0 || z < 0 || x >= n_[0] || y >= n_[1] || z >= n_[2]) return false;
    return kept_[(size_t(z) * size_t(n_[1]) + size_t(y)) * size_t(n_[0]) + size_t(x)] != 0;
  };
  std::vector<std::array<int, 4>> faces;  // x, y, z, side (axis * 2 + positive)
  for (int z = 0; z < n_[2]; ++z)
    for (int y = 0; y < n_[1]; ++y)
      for (int x = 0; x < n_[0]; ++x) {
        if (!kept(x, y, z)) continue;
        for (int side = 0; side < 6; ++side) {
          const int a = side / 2, step = side % 2 ? 1 : -1;
          int nb[3] = {x, y, z};
          nb[a] += step;
          if (!kept(nb[0], nb[1], nb[2])) faces.push_back({x, y, z, side});
        }
      }
  const size_t stride =
      maxFaces == 0 || faces.size() <= maxFaces ? 1 : (faces.size() + maxFaces - 1) / maxFaces;
  std::vector<std::array<Vec3, 4>> out;
  for (size_t i = 0; i < faces.size(); i += std::max<size_t>(stride, 1)) {
    const auto [x, y, z, side] = faces[i];
    const int a = side / 2, b = (a + 1) % 3, c = (a + 2) % 3;
    Vec3 lo = box_.lo + Vec3(x, y, z) * cell_;
    lo[a] += side % 2 ? cell_ : 0.0;
    Vec3 eb, ec;
    eb[b] = cell_;
    ec[c] = cell_;
    out.push_back({lo, lo + eb, lo + eb + ec, lo + ec});
  }
  return out;
}

std::string ReachableSpace::summary() const {
  char line[256];
  std::snprintf(line, sizeof line,
                "reachable domain: %.1f of %.1f m^3 free (%s; band %.1f m^3, enclosed %.1f m^3), "
                "%.2f m cells, %.2f s",
                keptVolume_, freeVolume_, interior_ ? "interior" : "exterior", bandVolume_,
                enclosedVolume_, cell_, seconds_);
  return note_.empty() ? std::string(line) : std::string(line) + "\n" + note_;
}

}  // namespace ps
