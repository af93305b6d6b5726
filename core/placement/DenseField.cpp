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

/// DenseFieldSettings::boundarySamples: from every leaf sample's centre, along each axis, a
/// surface (any face: a back face bounds the valid space as much) or the domain's boundary less
/// than one cell away gets a sample `off` short of it, when that is at least a quarter cell from
/// the centre, inside the domain (`inDomain`), and valid. Captured at their point (also in a
/// pre-filtered field), at the field's spp.
template <class InDomain>
void addBoundarySamples(const Tracer& tracer, const LightingRig& rig, const DenseFieldSettings& s,
                        DenseField& field, const InDomain& inDomain, const ProgressFn& progress) {
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
      if (!inDomain(p)) continue;
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

}  // namespace

DenseField buildDenseField(const Tracer& tracer, const LightingRig& rig,
                           const DenseFieldSettings& s, const ProgressFn& progress) {
  const auto start = std::chrono::steady_clock::now();
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

  DenseField field;
  // The domain of interest: the importance volumes' bounding box, or the scene bounds.
  if (s.importanceVolumes.empty()) {
    field.domain = tracer.scene().bounds;
  } else {
    for (const ImportanceVolume& v : s.importanceVolumes) {
      field.domain.extend(v.lo);
      field.domain.extend(v.hi);
    }
  }
  const Bounds3& dom = field.domain;
  const double h0 = s.baseSpacingMeters > 0 ? s.baseSpacingMeters : dom.diagonal() / 12.0;
  if (!(h0 > 0)) throw ParameterError("field spacing: the domain of interest is empty");
  field.baseSpacingMeters = h0;
  const Vec3 e = dom.extent();
  double n[3];
  for (int a = 0; a < 3; ++a) n[a] = std::max(1.0, std::ceil(e[a] / h0 - 1e-9));
  const double baseCount = n[0] * n[1] * n[2];
  if (baseCount > double(s.maxSamples) || std::max({n[0], n[1], n[2]}) >= double(1 << 12))
    throw ParameterError("field spacing " + std::to_string(h0) + " m would make " +
                         std::to_string(static_cast<long long>(baseCount)) +
                         " base samples (limit " + std::to_string(s.maxSamples) +
                         "); use a larger spacing");
  // Cell-centred grid of cubes of edge h0, centred on the domain.
  Vec3 gridLo;
  for (int a = 0; a < 3; ++a) gridLo[a] = dom.center()[a] - 0.5 * n[a] * h0;

  auto cellSize = [&](int depth) { return h0 / double(int64_t(1) << depth); };
  auto cellCentre = [&](const Cell& c) {
    const double h = cellSize(c.depth);
    return gridLo + Vec3(c.i + 0.5, c.j + 0.5, c.k + 0.5) * h;
  };
  // The grid overhangs the domain by up to a cell: cells whose centre is outside it are not made
  // (outside a closed scene's outer walls a point sees front faces only and would pass validity).
  auto inDomain = [&](Vec3 p) {
    if (!dom.contains(p)) return false;
    if (s.importanceVolumes.empty()) return true;
    for (const ImportanceVolume& v : s.importanceVolumes)
      if (p.x >= v.lo.x && p.x <= v.hi.x && p.y >= v.lo.y && p.y <= v.hi.y && p.z >= v.lo.z &&
          p.z <= v.hi.z)
        return true;
    return false;
  };

  std::vector<Cell> level;
  for (int64_t k = 0; k < int64_t(n[2]); ++k)
    for (int64_t j = 0; j < int64_t(n[1]); ++j)
      for (int64_t i = 0; i < int64_t(n[0]); ++i) {
        const Cell c{i, j, k, 0};
        if (inDomain(cellCentre(c))) level.push_back(c);
      }

  // Per level: packed cell coordinates -> sample index (or -1 for an invalid cell).
  std::vector<std::unordered_map<uint64_t, int64_t>> cellsAt(size_t(s.maxDepth) + 1);
  const std::array<Vec3, 26> dirs = cubeDirections();
  double luminanceFloor = 0;
  // Progress: one share per level, and one for the boundary samples.
  const double levels = s.maxDepth + 1 + (s.boundarySamples ? 1 : 0);

  for (int depth = 0; depth <= s.maxDepth && !level.empty(); ++depth) {
    const double h = cellSize(depth);
    const size_t m = level.size();
    // maxSamples guard, before any capture of this level: every cell may become a sample.
    if (field.samples.size() + m > s.maxSamples) {
      PS_CHECK_LT(0, depth);  // the base level was checked above
      field.refinementTruncated = true;
      for (FieldSample& fs : field.samples)
        if (fs.depth == depth - 1) fs.refined = false;  // its children were not made
      break;
    }
    // Validity (Kontkanen & Laine sec. 5: a point whose rays mostly see back faces is inside
    // geometry) and whether a surface crosses the cell: rays from the centre towards the 26
    // neighbours, each stopped at the cell's boundary (t = h / 2 for the unnormalized direction).
    std::vector<Vec3> centres(m);
    std::vector<char> valid(m, 0), crossed(m, 0);
    std::vector<double> validity(m, 0.0);
    tbb::parallel_for(size_t(0), m, [&](size_t c) {
      const Cell& cell = level[c];
      centres[c] = cellCentre(cell);
      const uint64_t key = packCell(cell.i, cell.j, cell.k);
      const uint64_t seed = streamSeed(s.seed ^ (uint64_t(depth + 1) * 0x9E3779B97F4A7C15ull), key);
      validity[c] = backfaceFraction(tracer, centres[c], s.validityRays, seed);
      valid[c] = validity[c] <= s.invalidBackfaceFraction;
      for (const Vec3& d : dirs) {
        Ray r;
        r.origin = centres[c];
        r.direction = d;
        r.tMax = 0.5 * h;
        if (tracer.occluded(r)) {
          crossed[c] = 1;
          break;
        }
      }
    });
    if (progress && !progress((depth + 0.2) / levels)) throw Cancelled();

    std::vector<Vec3> points;
    std::vector<size_t> cellOfPoint;
    for (size_t c = 0; c < m; ++c)
      if (valid[c]) {
        points.push_back(centres[c]);
        cellOfPoint.push_back(c);
      }
    CaptureSettings cs;
    cs.samplesPerProbe = s.samplesPerProbe;
    cs.seed = streamSeed(s.seed, 0xF1E1Dull + uint64_t(depth));
    cs.mode = s.mode;
    ProgressFn captureProgress;
    if (progress)
      captureProgress = [&](double f) { return progress((depth + 0.2 + 0.8 * f) / levels); };
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

    auto& map = cellsAt[size_t(depth)];
    std::vector<int64_t> sampleOfCell(m, -1);
    for (size_t q = 0; q < caps.size(); ++q) {
      // The capture's own rays are a second, larger validity test. A pre-filtered capture drops
      // the origins outside the domain instead: its centre's test decides, and a sample keeps
      // at least one ray.
      if (s.prefilter ? caps[q].samples == 0 : caps[q].backfaceFraction > s.invalidBackfaceFraction)
        continue;
      FieldSample fs = sampleFromCapture(points[q], caps[q]);
      if (s.prefilter) fs.backfaceFraction = validity[cellOfPoint[q]];
      fs.depth = depth;
      fs.cellSize = h;
      sampleOfCell[cellOfPoint[q]] = int64_t(field.samples.size());
      field.samples.push_back(fs);
    }
    for (size_t c = 0; c < m; ++c)
      map[packCell(level[c].i, level[c].j, level[c].k)] = sampleOfCell[c];
    field.cellsPerLevel.push_back(m);
    if (depth == 0) {
      double sum = 0;
      size_t count = 0;
      for (const FieldSample& fs : field.samples) {
        sum += std::abs(luminance(fs.sh.c[0]));
        ++count;
      }
      luminanceFloor = count > 0 ? 0.01 * sum / double(count) : 0.0;
      luminanceFloor = std::max(luminanceFloor, 1e-12);
    }
    if (depth == s.maxDepth) {
      field.splitsPerLevel.push_back(0);
      break;
    }

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
    const int64_t limit[3] = {int64_t(n[0]) << depth, int64_t(n[1]) << depth,
                              int64_t(n[2]) << depth};
    std::vector<Cell> next;
    size_t splits = 0;
    for (size_t c = 0; c < m; ++c) {
      const Cell& cell = level[c];
      bool split = crossed[c] != 0 && (s.maxSurfaceDepth < 0 || depth < s.maxSurfaceDepth);
      // Neighbouring samples differ (the "where neighbouring probes differ"): compare
      // mean luminance in stops with the six face neighbours.
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
            if (inDomain(cellCentre(child))) next.push_back(child);
          }
    }
    field.splitsPerLevel.push_back(splits);
    level = std::move(next);
  }
  if (s.boundarySamples) {
    ProgressFn boundaryProgress;
    if (progress) boundaryProgress = [&](double f) { return progress((levels - 1 + f) / levels); };
    addBoundarySamples(tracer, rig, s, field, inDomain, boundaryProgress);
  }
  if (progress && !progress(1.0)) throw Cancelled();
  field.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return field;
}

}  // namespace ps
