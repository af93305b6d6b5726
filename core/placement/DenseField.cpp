#include "core/placement/DenseField.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>

#include "core/capture/PrefilteredCapture.h"
#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/math/Random.h"

namespace ps {

namespace {

constexpr int kMaxDepthLimit = 8;
constexpr int kCoordBits = 21;  ///< bits per axis of a packed cell coordinate

/// A cell of the octree: integer coordinates at its depth (cell size base / 2^depth).
struct Cell {
  int64_t i = 0, j = 0, k = 0;
  int depth = 0;
};

uint64_t packCell(int64_t i, int64_t j, int64_t k) {
  return (uint64_t(i) << (2 * kCoordBits)) | (uint64_t(j) << kCoordBits) | uint64_t(k);
}

/// The 26 directions to the neighbours of a cube cell (components in {-1, 0, 1}).
std::array<Vec3, 26> cubeDirections() {
  std::array<Vec3, 26> d{};
  int n = 0;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x != 0 || y != 0 || z != 0) d[n++] = Vec3(x, y, z);
  return d;
}

/// Whether two neighbouring samples differ enough to refine between them: the luminance of their
/// SH coefficients (all 9: the mean and the directional bands, so that a shadow edge, which
/// mostly turns the l = 1 band, counts) differs by more than `refineRelativeDifference` of the
/// larger one (plus a floor of 1 % of the base level's mean), and by more than
/// `refineSignificance` standard errors of the difference (noise alone must not refine).
bool samplesDiffer(const FieldSample& a, const FieldSample& b, const DenseFieldSettings& s,
                   double floorLum) {
  double diffSq = 0, aSq = 0, bSq = 0, varSum = 0;
  for (int i = 0; i < kShCoeffCount; ++i) {
    const double la = luminance(a.sh.c[size_t(i)]), lb = luminance(b.sh.c[size_t(i)]);
    const double sa = luminance(a.shStdError.c[size_t(i)]);
    const double sb = luminance(b.shStdError.c[size_t(i)]);
    diffSq += (la - lb) * (la - lb);
    aSq += la * la;
    bSq += lb * lb;
    varSum += sa * sa + sb * sb;
  }
  const double diff = std::sqrt(diffSq);
  const double scale = std::max(std::sqrt(aSq), std::sqrt(bSq)) + floorLum;
  return diff > s.refineRelativeDifference * scale &&
         diffSq > s.refineSignificance * s.refineSignificance * varSum;
}

/// A field sample at `p` from its capture (depth and cell size left to the caller).
FieldSample sampleFromCapture(Vec3 p, const ProbeCapture& cap) {
  FieldSample fs;
  fs.position = p;
  fs.sh = cap.sh;
  fs.shStdError = cap.shStdError;
  fs.f = luminanceDirection(fs.sh);  // Chajdas sec. 2.1, eq. 1
  fs.luminanceHistogram = cap.luminanceHistogram;
  fs.hueHistogram = cap.hueHistogram;
  fs.backfaceFraction = cap.backfaceFraction;
  return fs;
}

/// The settings checks of buildDenseField that need no scene; throws ps::ParameterError.
void checkDenseFieldSettings(const DenseFieldSettings& s) {
  if (!(s.baseSpacingMeters >= 0) || !std::isfinite(s.baseSpacingMeters))
    throw ParameterError("field spacing: expected a non-negative number of metres, got " +
                         std::to_string(s.baseSpacingMeters));
  if (s.maxDepth < 0 || s.maxDepth > kMaxDepthLimit)
    throw ParameterError("field depth: expected 0 to 8 refinement levels, got " +
                         std::to_string(s.maxDepth));
  if (s.maxSurfaceDepth < -1 || s.maxSurfaceDepth > kMaxDepthLimit)
    throw ParameterError(
        "field surface depth: expected 0 to 8 levels (or -1: the field depth), got " +
        std::to_string(s.maxSurfaceDepth));
  if (!(s.boundaryOffset > 0 && s.boundaryOffset < 0.25))
    throw ParameterError(
        "field boundary offset: expected a fraction of the finest cell in (0, 0.25)");
  if (s.samplesPerProbe < 1)
    throw ParameterError("field spp: expected at least 1 sample per probe, got " +
                         std::to_string(s.samplesPerProbe));
  if (s.validityRays < 1)
    throw ParameterError("field validity rays: expected at least 1, got " +
                         std::to_string(s.validityRays));
}

/// The octree's geometry: the domain of interest and the cell-centred base grid of cubes of
/// edge h0 over it, centred on the domain (n[a] cells along axis a, overhanging it by up to a
/// cell). Lengths in metres.
class FieldGrid {
 public:
  /// The domain is the importance volumes' bounding box, or the scene bounds without any; h0
  /// is s.baseSpacingMeters, or the domain's diagonal / 12. Throws ps::ParameterError for an
  /// empty domain, or a base grid above s.maxSamples cells or of 4096 cells or more along an
  /// axis.
  FieldGrid(const Tracer& tracer, const DenseFieldSettings& s) : s_(s) {
    if (s.importanceVolumes.empty()) {
      domain = tracer.scene().bounds;
    } else {
      for (const ImportanceVolume& v : s.importanceVolumes) {
        domain.extend(v.lo);
        domain.extend(v.hi);
      }
    }
    h0 = s.baseSpacingMeters > 0 ? s.baseSpacingMeters : domain.diagonal() / 12.0;
    if (!(h0 > 0)) throw ParameterError("field spacing: the domain of interest is empty");
    const Vec3 e = domain.extent();
    for (int a = 0; a < 3; ++a) n[a] = std::max(1.0, std::ceil(e[a] / h0 - 1e-9));
    const double baseCount = n[0] * n[1] * n[2];
    if (baseCount > double(s.maxSamples) || std::max({n[0], n[1], n[2]}) >= double(1 << 12))
      throw ParameterError("field spacing " + std::to_string(h0) + " m would make " +
                           std::to_string(static_cast<long long>(baseCount)) +
                           " base samples (limit " + std::to_string(s.maxSamples) +
                           "); use a larger spacing");
    for (int a = 0; a < 3; ++a) gridLo[a] = domain.center()[a] - 0.5 * n[a] * h0;
  }

  double cellSize(int depth) const { return h0 / double(int64_t(1) << depth); }
  Vec3 cellCentre(const Cell& c) const {
    const double h = cellSize(c.depth);
    return gridLo + Vec3(c.i + 0.5, c.j + 0.5, c.k + 0.5) * h;
  }
  /// Inside the domain and, with importance volumes, inside one of them. Cells whose centre is
  /// not are not made (outside a closed scene's outer walls a point sees front faces only and
  /// would pass validity).
  bool inDomain(Vec3 p) const {
    if (!domain.contains(p)) return false;
    if (s_.reachable && !s_.reachable->contains(p)) return false;
    if (s_.importanceVolumes.empty()) return true;
    for (const ImportanceVolume& v : s_.importanceVolumes)
      if (p.x >= v.lo.x && p.x <= v.hi.x && p.y >= v.lo.y && p.y <= v.hi.y && p.z >= v.lo.z &&
          p.z <= v.hi.z)
        return true;
    return false;
  }
  /// The base grid's cells in the domain, x fastest.
  std::vector<Cell> baseCells() const {
    std::vector<Cell> level;
    for (int64_t k = 0; k < int64_t(n[2]); ++k)
      for (int64_t j = 0; j < int64_t(n[1]); ++j)
        for (int64_t i = 0; i < int64_t(n[0]); ++i) {
          const Cell c{i, j, k, 0};
          if (inDomain(cellCentre(c))) level.push_back(c);
        }
    return level;
  }

  Bounds3 domain;
  double h0 = 0;            ///< the base grid spacing
  double n[3] = {1, 1, 1};  ///< base cells per axis (whole numbers)
  Vec3 gridLo;              ///< the base grid's low corner

 private:
  const DenseFieldSettings& s_;
};

/// DenseFieldSettings::boundarySamples: from every leaf sample's centre, along each axis, a
/// surface (any face: a back face bounds the valid space as much) or the domain's boundary less
/// than one cell away gets a sample `off` short of it, when that is at least a quarter cell from
/// the centre, inside the domain (grid.inDomain), and valid. Captured at their point (also in a
/// pre-filtered field), at the field's spp; those beyond maxSamples are dropped (the first ones,
/// in sample order, kept) and refinementTruncated set. Throws ps::Cancelled through `progress`.
void addBoundarySamples(const Tracer& tracer, const LightingRig& rig, const DenseFieldSettings& s,
                        const FieldGrid& grid, DenseField& field, const ProgressFn& progress) {
  const Bounds3& dom = field.domain;
  double finest = std::numeric_limits<double>::infinity();
  for (const FieldSample& f : field.samples) finest = std::min(finest, f.cellSize);
  if (!std::isfinite(finest)) return;
  const double off = std::max(s.boundaryOffset * finest, 8 * tracer.rayEpsilon());
  const Vec3 axes[6] = {Vec3(1, 0, 0),  Vec3(-1, 0, 0), Vec3(0, 1, 0),
                        Vec3(0, -1, 0), Vec3(0, 0, 1),  Vec3(0, 0, -1)};
  const size_t leaves = field.samples.size();
  struct Candidate {
    Vec3 p;
    size_t from;
    double slab;
  };
  std::vector<std::array<Candidate, 6>> found(leaves);
  std::vector<std::array<char, 6>> has(leaves);
  tbb::parallel_for(size_t(0), leaves, [&](size_t i) {
    has[i].fill(0);
    const FieldSample& f = field.samples[i];
    if (f.refined) return;
    const double h = f.cellSize;
    for (int a = 0; a < 6; ++a) {
      const Vec3& d = axes[a];
      const int axis = a / 2;
      // Distance to the domain box's face along the axis, then to the first surface.
      double t = d[axis] > 0 ? dom.hi[axis] - f.position[axis] : f.position[axis] - dom.lo[axis];
      t = std::min(t, h);
      Ray r;
      r.origin = f.position;
      r.direction = d;
      r.tMax = t;
      if (const auto hit = tracer.intersect(r)) t = std::min(t, hit->t);
      const double slab = t - off;
      if (t >= h || slab < 0.25 * h) continue;  // nothing near, or the centre is close enough
      const Vec3 p = f.position + d * slab;
      if (!grid.inDomain(p)) continue;
      found[i][size_t(a)] = {p, i, slab};
      has[i][size_t(a)] = 1;
    }
  });
  std::vector<Vec3> points;
  std::vector<Candidate> cands;
  for (size_t i = 0; i < leaves; ++i)
    for (int a = 0; a < 6; ++a)
      if (has[i][size_t(a)]) {
        cands.push_back(found[i][size_t(a)]);
        points.push_back(cands.back().p);
      }
  // maxSamples holds for them too, before any capture: the first ones (in sample order) are kept.
  const size_t room = s.maxSamples > field.samples.size() ? s.maxSamples - field.samples.size() : 0;
  if (points.size() > room) {
    points.resize(room);
    cands.resize(room);
    field.refinementTruncated = true;
  }
  if (points.empty()) return;
  CaptureSettings cs;
  cs.samplesPerProbe = s.samplesPerProbe;
  cs.seed = streamSeed(s.seed, 0xB0DA7ull);
  cs.mode = s.mode;
  const std::vector<ProbeCapture> caps = captureProbes(tracer, rig, points, cs, progress);
  for (size_t q = 0; q < caps.size(); ++q) {
    if (caps[q].backfaceFraction > s.invalidBackfaceFraction) continue;
    const FieldSample& from = field.samples[cands[q].from];
    FieldSample fs = sampleFromCapture(points[q], caps[q]);
    fs.depth = from.depth;
    fs.cellSize = from.cellSize;
    fs.boundary = true;
    fs.slab = cands[q].slab;
    field.samples.push_back(fs);
  }
}

/// A level's cells tested from their centres (testCells).
struct CellTests {
  std::vector<Vec3> centres;
  std::vector<double> validity;  ///< backface fraction of the validity rays
  std::vector<char> valid;       ///< validity <= invalidBackfaceFraction
  std::vector<char> crossed;     ///< a surface crosses the cell
};

/// Validity (Kontkanen & Laine sec. 5: a point whose rays mostly see back faces is inside
/// geometry) of each cell of `level` (at `depth`) and whether a surface crosses it: rays from the
/// centre towards the 26 neighbours, each stopped at the cell's boundary (t = h / 2 for the
/// unnormalized direction). Each cell's rays are seeded by its depth and coordinates, so the
/// result does not depend on the order of the cells. In parallel, O(cells x (validityRays + 26)
/// rays).
CellTests testCells(const Tracer& tracer, const FieldGrid& grid, const std::vector<Cell>& level,
                    int depth, const DenseFieldSettings& s) {
  static const std::array<Vec3, 26> dirs = cubeDirections();
  const double h = grid.cellSize(depth);
  const size_t m = level.size();
  CellTests t;
  t.centres.resize(m);
  t.valid.assign(m, 0);
  t.crossed.assign(m, 0);
  t.validity.assign(m, 0.0);
  tbb::parallel_for(size_t(0), m, [&](size_t c) {
    const Cell& cell = level[c];
    t.centres[c] = grid.cellCentre(cell);
    const uint64_t key = packCell(cell.i, cell.j, cell.k);
    const uint64_t seed = streamSeed(s.seed ^ (uint64_t(depth + 1) * 0x9E3779B97F4A7C15ull), key);
    t.validity[c] = backfaceFraction(tracer, t.centres[c], s.validityRays, seed);
    t.valid[c] = t.validity[c] <= s.invalidBackfaceFraction;
    for (const Vec3& d : dirs) {
      Ray r;
      r.origin = t.centres[c];
      r.direction = d;
      r.tMax = 0.5 * h;
      if (tracer.occluded(r)) {
        t.crossed[c] = 1;
        break;
      }
    }
  });
  return t;
}

/// Captures the valid cells' samples of a level at `depth` (cell size h, metres) and appends
/// them to field.samples; returns each cell's sample index (-1: invalid, or dropped by its
/// capture's own validity). Throws ps::Cancelled through `captureProgress`.
std::vector<int64_t> captureCells(const Tracer& tracer, const LightingRig& rig,
                                  const CellTests& tests, int depth, double h,
                                  const DenseFieldSettings& s, const ProgressFn& captureProgress,
                                  DenseField& field) {
  std::vector<Vec3> points;
  std::vector<size_t> cellOfPoint;
  for (size_t c = 0; c < tests.centres.size(); ++c)
    if (tests.valid[c]) {
      points.push_back(tests.centres[c]);
      cellOfPoint.push_back(c);
    }
  CaptureSettings cs;
  cs.samplesPerProbe = s.samplesPerProbe;
  cs.seed = streamSeed(s.seed, 0xF1E1Dull + uint64_t(depth));
  cs.mode = s.mode;
  std::vector<ProbeCapture> caps;
  if (points.empty()) {
  } else if (s.prefilter) {
    // Kontkanen & Laine sec. 4, eq. 5: the cell's node averages the light over its trilinear
    // support (half-width h, the spacing of this level's nodes), from origins in the domain
    // of interest only (sec. 5-6).
    std::vector<PrefilterNode> nodes;
    nodes.reserve(points.size());
    for (Vec3 p : points) nodes.push_back({p, h});
    caps = capturePrefiltered(tracer, rig, nodes, cs, captureProgress);
  } else {
    caps = captureProbes(tracer, rig, points, cs, captureProgress);
  }
  std::vector<int64_t> sampleOfCell(tests.centres.size(), -1);
  for (size_t q = 0; q < caps.size(); ++q) {
    // The capture's own rays are a second, larger validity test. A pre-filtered capture drops
    // the origins outside the domain instead: its centre's test decides, and a sample keeps
    // at least one ray.
    if (s.prefilter ? caps[q].samples == 0 : caps[q].backfaceFraction > s.invalidBackfaceFraction)
      continue;
    FieldSample fs = sampleFromCapture(points[q], caps[q]);
    if (s.prefilter) fs.backfaceFraction = tests.validity[cellOfPoint[q]];
    fs.depth = depth;
    fs.cellSize = h;
    sampleOfCell[cellOfPoint[q]] = int64_t(field.samples.size());
    field.samples.push_back(fs);
  }
  return sampleOfCell;
}

/// The refinement's luminance floor: 1 % of the mean |DC luminance| of `samples` (the base
/// level's), at least 1e-12.
double luminanceFloorOf(const std::vector<FieldSample>& samples) {
  double sum = 0;
  size_t count = 0;
  for (const FieldSample& fs : samples) {
    sum += std::abs(luminance(fs.sh.c[0]));
    ++count;
  }
  const double floorLum = count > 0 ? 0.01 * sum / double(count) : 0.0;
  return std::max(floorLum, 1e-12);
}

/// Per level: packed cell coordinates -> sample index (or -1 for an invalid cell).
using CellMaps = std::vector<std::unordered_map<uint64_t, int64_t>>;

/// The cells of the next level: the children (in the domain) of each cell of `level` (at
/// `depth`) that splits, because a surface crosses it (below maxSurfaceDepth) or because a face
/// neighbour's sample differs from its own (samplesDiffer; the neighbour at this level, or the
/// coarser cell covering that place when this level was not made there). Marks the split
/// cells' samples refined and counts the splits in `splits`. O(cells x 6 x depth) lookups.
std::vector<Cell> refineLevel(const FieldGrid& grid, const std::vector<Cell>& level,
                              const CellTests& tests, const std::vector<int64_t>& sampleOfCell,
                              int depth, const CellMaps& cellsAt, double luminanceFloor,
                              const DenseFieldSettings& s, DenseField& field, size_t& splits) {
  // The sample covering the place of cell (i, j, k) at `depth`: that cell's, or that of the
  // coarser cell containing it when the finer level was not made there; -1 when none is valid.
  auto coveringSample = [&](int64_t i, int64_t j, int64_t k) -> int64_t {
    for (int d = depth; d >= 0; --d) {
      const auto it = cellsAt[size_t(d)].find(packCell(i, j, k));
      if (it != cellsAt[size_t(d)].end()) return it->second;
      i >>= 1;
      j >>= 1;
      k >>= 1;
    }
    return -1;
  };
  const int64_t limit[3] = {int64_t(grid.n[0]) << depth, int64_t(grid.n[1]) << depth,
                            int64_t(grid.n[2]) << depth};
  std::vector<Cell> next;
  splits = 0;
  for (size_t c = 0; c < level.size(); ++c) {
    const Cell& cell = level[c];
    bool split = tests.crossed[c] != 0 && (s.maxSurfaceDepth < 0 || depth < s.maxSurfaceDepth);
    const int64_t self = sampleOfCell[c];
    if (!split && self >= 0) {
      const FieldSample& mine = field.samples[size_t(self)];
      for (int axis = 0; axis < 3 && !split; ++axis)
        for (int sign = -1; sign <= 1 && !split; sign += 2) {
          int64_t q[3] = {cell.i, cell.j, cell.k};
          q[axis] += sign;
          if (q[axis] < 0 || q[axis] >= limit[axis]) continue;
          const int64_t other = coveringSample(q[0], q[1], q[2]);
          if (other >= 0 && samplesDiffer(mine, field.samples[size_t(other)], s, luminanceFloor))
            split = true;
        }
    }
    if (!split) continue;
    ++splits;
    if (self >= 0) field.samples[size_t(self)].refined = true;
    for (int dz = 0; dz < 2; ++dz)
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const Cell child{2 * cell.i + dx, 2 * cell.j + dy, 2 * cell.k + dz, depth + 1};
          if (grid.inDomain(grid.cellCentre(child))) next.push_back(child);
        }
  }
  return next;
}

}  // namespace

DenseField buildDenseField(const Tracer& tracer, const LightingRig& rig,
                           const DenseFieldSettings& s, const ProgressFn& progress) {
  const auto start = std::chrono::steady_clock::now();
  checkDenseFieldSettings(s);
  DenseField field;
  const FieldGrid grid(tracer, s);
  field.domain = grid.domain;
  field.baseSpacingMeters = grid.h0;

  std::vector<Cell> level = grid.baseCells();
  CellMaps cellsAt(size_t(s.maxDepth) + 1);
  double luminanceFloor = 0;
  // Progress: one share per level, and one for the boundary samples.
  const double levels = s.maxDepth + 1 + (s.boundarySamples ? 1 : 0);
  for (int depth = 0; depth <= s.maxDepth && !level.empty(); ++depth) {
    const size_t m = level.size();
    // maxSamples guard, before any capture of this level: every cell may become a sample.
    if (field.samples.size() + m > s.maxSamples) {
      PS_CHECK_LT(0, depth);  // the base level was checked by FieldGrid
      field.refinementTruncated = true;
      for (FieldSample& fs : field.samples)
        if (fs.depth == depth - 1) fs.refined = false;  // its children were not made
      break;
    }
    const CellTests tests = testCells(tracer, grid, level, depth, s);
    if (progress && !progress((depth + 0.2) / levels)) throw Cancelled();
    ProgressFn captureProgress;
    if (progress)
      captureProgress = [&](double f) { return progress((depth + 0.2 + 0.8 * f) / levels); };
    const std::vector<int64_t> sampleOfCell =
        captureCells(tracer, rig, tests, depth, grid.cellSize(depth), s, captureProgress, field);
    auto& map = cellsAt[size_t(depth)];
    for (size_t c = 0; c < m; ++c)
      map[packCell(level[c].i, level[c].j, level[c].k)] = sampleOfCell[c];
    field.cellsPerLevel.push_back(m);
    if (depth == 0) luminanceFloor = luminanceFloorOf(field.samples);
    if (depth == s.maxDepth) {
      field.splitsPerLevel.push_back(0);
      break;
    }
    size_t splits = 0;
    level = refineLevel(grid, level, tests, sampleOfCell, depth, cellsAt, luminanceFloor, s, field,
                        splits);
    field.splitsPerLevel.push_back(splits);
  }
  if (s.boundarySamples) {
    ProgressFn boundaryProgress;
    if (progress) boundaryProgress = [&](double f) { return progress((levels - 1 + f) / levels); };
    addBoundarySamples(tracer, rig, s, grid, field, boundaryProgress);
  }
  if (progress && !progress(1.0)) throw Cancelled();
  field.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return field;
}

}  // namespace ps
