// The runtime probe volume and its traversal (Sukys 2014, sec. 3.2.1 "Interpolation with
// barycentric coordinates", "Traversal" and "Drawbacks", after Cupisz 2012).
#include "core/traversal/ProbeVolume.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "core/common/Check.h"
#include "core/common/Tolerances.h"

namespace ps {
namespace {

std::atomic<uint64_t> gBruteForceCount{0};

double orient(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
  return dot(b - a, cross(c - a, d - a));
}

double longestEdge(const Vec3 (&v)[4]) {
  double l2 = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) l2 = std::max(l2, dot(v[i] - v[j], v[i] - v[j]));
  return std::sqrt(l2);
}

void tetVertices(const ProbeVolume& v, int32_t t, Vec3 (&out)[4]) {
  for (int i = 0; i < 4; ++i) out[i] = v.position(v.tets[t][i]);
}

bool isFlat(const std::array<float, 9>& m) {
  for (float x : m)
    if (x != 0.0f) return false;
  return true;
}

// Sukys 3.2.1 "Drawbacks": the precomputed 3x3 matrix turns (p - v3) into barycentrics.
std::array<double, 4> matrixWeights(const ProbeVolume& v, int32_t t, Vec3 p) {
  const auto& m = v.matrices[t];
  const Vec3 d = p - v.position(v.tets[t][3]);
  std::array<double, 4> w;
  w[0] = double(m[0]) * d.x + double(m[1]) * d.y + double(m[2]) * d.z;
  w[1] = double(m[3]) * d.x + double(m[4]) * d.y + double(m[5]) * d.z;
  w[2] = double(m[6]) * d.x + double(m[7]) * d.y + double(m[8]) * d.z;
  w[3] = 1.0 - w[0] - w[1] - w[2];
  return w;
}

// Barycentrics from double orientations of the (float) vertices: w_i is the signed volume of
// the tet with vertex i replaced by p, over the tet's volume. Accurate for thin tets. For a flat
// tet (zero volume) returns the signed distances of p to the face planes instead, positive on
// the tet's side, and sets `flat`.
std::array<double, 4> orientWeights(const ProbeVolume& v, int32_t t, Vec3 p, bool& flat) {
  Vec3 q[4];
  tetVertices(v, t, q);
  std::array<double, 4> o;
  o[0] = orient(p, q[1], q[2], q[3]);
  o[1] = orient(q[0], p, q[2], q[3]);
  o[2] = orient(q[0], q[1], p, q[3]);
  o[3] = orient(q[0], q[1], q[2], p);
  flat = isFlat(v.matrices[t]);
  if (!flat) {
    const double vol = orient(q[0], q[1], q[2], q[3]);
    for (double& x : o) x /= vol;
    return o;
  }
  // Face i's area vector (length = 2 * area); dividing gives a signed distance.
  for (int i = 0; i < 4; ++i) {
    const Vec3 a = q[(i + 1) & 3], b = q[(i + 2) & 3], c = q[(i + 3) & 3];
    const double n = length(cross(b - a, c - a));
    o[i] = n > 0 ? o[i] / n : 0.0;
  }
  return o;
}

// Fast path of locate(): barycentrics from tet t's double frame (Sukys 3.2.1 "Drawbacks": the
// precomputed matrix applied to p - v3, here in double and stored next to v3), returned only
// when all four are >= tol::kFastPathMargin. Then p is strictly inside t, so t is the only tet
// containing it, and the walk from t would stop at once (its float-matrix weights are off by
// ~6e-8 / relative volume, <= ~6e-6 outside thin tets, less than margin + slack; the tests
// check it). No clamping is needed: the weights are in [margin, 1], w3 = 1 - w0 - w1 - w2 in
// double, and rounding each to float moves it by at most 2^-25 * w (<= 3e-8) and their sum by
// at most 3e-8; the frame's own error is ~1e-14 (double from float positions, relative volume
// >= tol::kThinTetRelativeVolume). Tolerance stated to callers: each weight within 1e-7 of the
// exact barycentric, sum within 1e-7 of 1. Thin and flat tets have NaN frames, which fail the
// test, as does a non-finite p.
inline bool frameWeights(const ProbeVolume& v, int32_t t, Vec3 p, std::array<float, 4>& out) {
  if (v.frames.size() != v.tets.size()) return false;
  const ProbeVolume::Frame& f = v.frames[t];
  const double dx = p.x - f.origin[0], dy = p.y - f.origin[1], dz = p.z - f.origin[2];
  const double w0 = f.m[0] * dx + f.m[1] * dy + f.m[2] * dz;
  const double w1 = f.m[3] * dx + f.m[4] * dy + f.m[5] * dz;
  const double w2 = f.m[6] * dx + f.m[7] * dy + f.m[8] * dz;
  const double w3 = 1.0 - w0 - w1 - w2;
  constexpr double e = tol::kFastPathMargin;
  if (!((w0 >= e) & (w1 >= e) & (w2 >= e) & (w3 >= e))) return false;
  out = {static_cast<float>(w0), static_cast<float>(w1), static_cast<float>(w2),
         static_cast<float>(w3)};
  return true;
}

int argMin(const std::array<double, 4>& w) {
  int k = 0;
  for (int i = 1; i < 4; ++i)
    if (w[i] < w[k]) k = i;
  return k;
}

// Clamps tiny negatives and rounding, renormalises: finite, in [0, 1], sum 1.
std::array<float, 4> cleanWeights(const std::array<double, 4>& w) {
  std::array<double, 4> c;
  double sum = 0;
  for (int i = 0; i < 4; ++i) {
    c[i] = std::isfinite(w[i]) ? std::clamp(w[i], 0.0, 1.0) : 0.0;
    sum += c[i];
  }
  std::array<float, 4> out;
  if (!(sum > 0)) {
    out = {0.25f, 0.25f, 0.25f, 0.25f};
    return out;
  }
  for (int i = 0; i < 4; ++i) out[i] = static_cast<float>(c[i] / sum);
  return out;
}

struct WalkResult {
  enum Kind { kInside, kOutside, kFailed } kind = kFailed;
  int32_t tet = -1;
  std::array<double, 4> w{};
};

// Visibility walk (Sukys 3.2.1 "Traversal"): step to the neighbour opposite the most negative
// barycentric coordinate until none is below -slack. Stepping through a hull face means p is
// beyond a supporting plane of the convex hull, i.e. outside. The step function depends only
// on (tet, p), so a cycle (possible through rounding, Sukys "Drawbacks") is caught by Brent's
// algorithm; the step cap is a second backstop.
WalkResult walk(const ProbeVolume& v, Vec3 p, int32_t start) {
  const bool haveThin = v.thinTets.size() == v.tets.size();
  const size_t cap = 4 * v.tets.size() + 100;
  int32_t t = start;
  int32_t tortoise = t;
  size_t power = 1, lambda = 0;
  for (size_t step = 0; step < cap; ++step) {
    std::array<double, 4> w;
    bool flat = false;
    if (haveThin && v.thinTets[t]) {
      w = orientWeights(v, t, p, flat);
    } else {
      w = matrixWeights(v, t, p);
      // A zero matrix gives w = (0, 0, 0, 1): "inside". Only then check for a flat tet.
      if (w[3] == 1.0 && w[0] == 0.0 && w[1] == 0.0 && w[2] == 0.0 && isFlat(v.matrices[t]))
        w = orientWeights(v, t, p, flat);
    }
    const int k = argMin(w);
    if (!flat && w[k] >= -double(tol::kBarycentricSlack)) return {WalkResult::kInside, t, w};
    const int32_t n = v.neighbors[t][k];
    if (n < 0) return {WalkResult::kOutside, t, w};
    t = n;
    if (t == tortoise) return {WalkResult::kFailed, t, w};
    if (++lambda == power) {
      tortoise = t;
      power *= 2;
      lambda = 0;
    }
  }
  return {WalkResult::kFailed, t, {}};
}

// Closest point to p on triangle abc, with its barycentrics (Ericson, Real-Time Collision
// Detection, 5.1.5).
Vec3 closestOnTriangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c, std::array<double, 3>& bary) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return bary = {1, 0, 0}, a;
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return bary = {0, 1, 0}, b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double s = d1 / (d1 - d3);
    bary = {1 - s, s, 0};
    return a + ab * s;
  }
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return bary = {0, 0, 1}, c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double s = d2 / (d2 - d6);
    bary = {1 - s, 0, s};
    return a + ac * s;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    bary = {0, 1 - s, s};
    return b + (c - b) * s;
  }
  const double denom = va + vb + vc;
  if (!(denom > 0)) {  // degenerate triangle: fall back to its first vertex
    bary = {1, 0, 0};
    return a;
  }
  const double sv = vb / denom, sw = vc / denom;
  bary = {1 - sv - sw, sv, sw};
  return a + ab * sv + ac * sw;
}

// The nearest of a set of hull faces so far: squared distance, hull-face index (ties go to the
// lower index, as in a scan in hull-face order), and the clamp's weights.
struct NearestFace {
  double d2 = std::numeric_limits<double>::infinity();
  size_t face = 0;
  int32_t tet = -1;
  std::array<double, 4> w{};

  void consider(const ProbeVolume& v, Vec3 p, size_t f) {
    const auto& [t, opp] = v.hullFaces[f];
    const int i0 = (opp + 1) & 3, i1 = (opp + 2) & 3, i2 = (opp + 3) & 3;
    std::array<double, 3> bary;
    const Vec3 q = closestOnTriangle(p, v.position(v.tets[t][i0]), v.position(v.tets[t][i1]),
                                     v.position(v.tets[t][i2]), bary);
    const double e = dot(q - p, q - p);
    if (e < d2 || (e == d2 && f < face)) {
      d2 = e;
      face = f;
      tet = t;
      w = {};
      w[i0] = bary[0];
      w[i1] = bary[1];
      w[i2] = bary[2];
    }
  }
  VolumeLocation location() const {
    VolumeLocation loc;
    loc.outside = true;
    loc.tet = tet;
    if (tet >= 0) loc.weights = cleanWeights(w);
    return loc;
  }
};

// Sukys 3.2.1 "Drawbacks": outside the hull, track the point along the hull surface. We clamp p
// to the nearest point of the hull (brute force over hull faces) and return the barycentrics of
// that point in the hull face's tet (0 for the vertex opposite the face): continuous with the
// inside and never black.
VolumeLocation clampToHull(const ProbeVolume& v, Vec3 p) {
  NearestFace n;
  for (size_t f = 0; f < v.hullFaces.size(); ++f) n.consider(v, p, f);
  return n.location();
}

// Correctness backstop: the non-flat tet in which p is deepest (largest smallest barycentric,
// from double orientations); outside the hull, the clamp.
VolumeLocation bruteForce(const ProbeVolume& v, Vec3 p) {
  int32_t bestTet = -1;
  double bestMin = -std::numeric_limits<double>::infinity();
  std::array<double, 4> bestW{};
  for (int32_t t = 0; t < static_cast<int32_t>(v.tets.size()); ++t) {
    bool flat = false;
    const auto w = orientWeights(v, t, p, flat);
    if (flat) continue;
    const double m = *std::min_element(w.begin(), w.end());
    if (m > bestMin) {
      bestMin = m;
      bestTet = t;
      bestW = w;
    }
  }
  if (bestTet < 0 || bestMin < -double(tol::kBarycentricSlack)) return clampToHull(v, p);
  VolumeLocation loc;
  loc.tet = bestTet;
  loc.weights = cleanWeights(bestW);
  return loc;
}

int32_t coldStart(const ProbeVolume& v, Vec3 p) {
  if (v.locatorGrid.empty()) return 0;
  int32_t c[3];
  for (int a = 0; a < 3; ++a) {
    const double x = (p[a] - v.locatorLo[a]) / v.locatorCellSize[a];
    const double clamped = std::clamp(std::isfinite(x) ? x : 0.0, 0.0, v.locatorDims[a] - 1.0);
    c[a] = static_cast<int32_t>(clamped);
  }
  return v.locatorGrid[c[0] + v.locatorDims[0] * (c[1] + v.locatorDims[1] * c[2])];
}

// Sukys 3.2.1 "Drawbacks": per tet, the 3x3 matrix M = [v0 - v3, v1 - v3, v2 - v3]^-1 (in
// double, from the float positions the renderer sees), so (w0, w1, w2) = M (p - v3).
std::array<float, 9> tetMatrix(const ProbeVolume& v, int32_t t) {
  Vec3 q[4];
  tetVertices(v, t, q);
  const Vec3 a = q[0] - q[3], b = q[1] - q[3], c = q[2] - q[3];
  const Vec3 r0 = cross(b, c), r1 = cross(c, a), r2 = cross(a, b);
  const double det = dot(a, r0);
  const double l = longestEdge(q);
  std::array<float, 9> m{};
  if (std::abs(det) > tol::kFlatTetRelativeVolume * l * l * l) {
    const Vec3 rows[3] = {r0 / det, r1 / det, r2 / det};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m[3 * i + j] = static_cast<float>(rows[i][j]);
  }
  return m;
}

// Sets thinTets[t] and frames[t] (the arrays are sized by the caller).
void tetFrame(ProbeVolume& v, int32_t t) {
  Vec3 q[4];
  tetVertices(v, t, q);
  const double l = longestEdge(q);
  const double relVolume = std::abs(orient(q[0], q[1], q[2], q[3])) / (l * l * l);
  const bool thin = !(relVolume >= tol::kThinTetRelativeVolume);
  v.thinTets[t] = thin;
  // The fast path's frame: M = [v0 - v3, v1 - v3, v2 - v3]^-1 in double (the differences of
  // float positions are exact in double), origin v3.
  ProbeVolume::Frame& f = v.frames[t];
  const Vec3 a = q[0] - q[3], b = q[1] - q[3], c = q[2] - q[3];
  const Vec3 rows[3] = {cross(b, c), cross(c, a), cross(a, b)};
  const double det = dot(a, rows[0]);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j)
      f.m[3 * i + j] = thin ? std::numeric_limits<double>::quiet_NaN() : rows[i][j] / det;
    f.origin[i] = q[3][i];
  }
}

}  // namespace

namespace detail {
void updateTet(ProbeVolume& v, int32_t t) {
  v.matrices[t] = tetMatrix(v, t);
  tetFrame(v, t);
}

int32_t locatorCellTet(const ProbeVolume& v, size_t cell, int32_t start) {
  const size_t nx = size_t(v.locatorDims[0]), ny = size_t(v.locatorDims[1]);
  const size_t c[3] = {cell % nx, (cell / nx) % ny, cell / (nx * ny)};
  Vec3 centre;
  for (int a = 0; a < 3; ++a)
    centre[a] = v.locatorLo[a] + (double(c[a]) + 0.5) * double(v.locatorCellSize[a]);
  const WalkResult r = walk(v, centre, start);
  return r.kind != WalkResult::kFailed ? r.tet : start;
}
}  // namespace detail

ShRgb ProbeVolume::probeSh(int32_t i) const {
  ShRgb out;
  const float* s = sh.data() + size_t(27) * i;
  for (int k = 0; k < kShCoeffCount; ++k) out.c[k] = Rgb(s[3 * k], s[3 * k + 1], s[3 * k + 2]);
  return out;
}

ProbeVolume buildProbeVolume(const Tetrahedralization& t, std::span<const ShRgb> shOfVertex) {
  PS_CHECK_EQ(shOfVertex.size(), t.vertices.size());
  PS_CHECK_EQ(t.tets.size(), t.neighbors.size());
  ProbeVolume v;
  v.positions.reserve(3 * t.vertices.size());
  for (Vec3 p : t.vertices)
    for (int a = 0; a < 3; ++a) v.positions.push_back(static_cast<float>(p[a]));
  v.sh.reserve(27 * shOfVertex.size());
  for (const ShRgb& s : shOfVertex)
    for (const Rgb& c : s.c)
      for (int ch = 0; ch < 3; ++ch) v.sh.push_back(static_cast<float>(c[ch]));
  v.tets = t.tets;
  v.neighbors = t.neighbors;

  v.matrices.resize(v.tets.size());
  for (size_t k = 0; k < v.tets.size(); ++k) {
    v.matrices[k] = tetMatrix(v, static_cast<int32_t>(k));
    for (int i = 0; i < 4; ++i)
      if (v.neighbors[k][i] < 0) v.hullFaces.push_back({static_cast<int32_t>(k), i});
  }
  buildLocator(v);
  return v;
}

void scaleVolume(ProbeVolume& v, double factor) {
  PS_CHECK_OP(factor, >, 0.0);
  PS_CHECK(std::isfinite(factor));
  if (factor == 1.0) return;
  for (float& x : v.positions) x = static_cast<float>(double(x) * factor);
  for (size_t k = 0; k < v.tets.size(); ++k) v.matrices[k] = tetMatrix(v, static_cast<int32_t>(k));
  for (size_t k = 0; k + 1 < v.visibility.size(); k += 2) {
    v.visibility[k] = static_cast<float>(double(v.visibility[k]) * factor);
    v.visibility[k + 1] = static_cast<float>(double(v.visibility[k + 1]) * factor * factor);
  }
  buildLocator(v);
}

void buildLocator(ProbeVolume& v) {
  v.thinTets.assign(v.tets.size(), 0);
  v.frames.assign(v.tets.size(), {});
  v.locatorGrid.clear();
  v.locatorDims = {0, 0, 0};
  if (v.tets.empty()) return;
  for (size_t k = 0; k < v.tets.size(); ++k) tetFrame(v, static_cast<int32_t>(k));

  Bounds3 box;
  for (size_t i = 0; i < v.probeCount(); ++i) box.extend(v.position(static_cast<int32_t>(i)));
  // About one cell per probe (a handful of tets per cell), at most 2^20 cells.
  const double target = std::clamp<double>(double(v.probeCount()), 1.0, double(1 << 20));
  const Vec3 e = box.extent();
  const double maxE = std::max({e.x, e.y, e.z});
  double volume = 1;
  for (int a = 0; a < 3; ++a) volume *= std::max(e[a], 1e-3 * maxE);
  const double cell = std::cbrt(volume / target);
  size_t cells = 1;
  for (int a = 0; a < 3; ++a) {
    const int32_t n = static_cast<int32_t>(std::clamp(std::ceil(e[a] / cell), 1.0, 1024.0));
    v.locatorDims[a] = n;
    v.locatorLo[a] = static_cast<float>(box.lo[a]);
    v.locatorCellSize[a] = static_cast<float>(std::max(e[a] / n, 1e-30));
    cells *= n;
  }
  v.locatorGrid.assign(cells, 0);
  // Each cell centre is found by walking from the previous cell's tet (coherent, cheap); the
  // cells are in index order.
  int32_t t = 0;
  for (size_t c = 0; c < cells; ++c) v.locatorGrid[c] = t = detail::locatorCellTet(v, c, t);
}

namespace {
VolumeLocation locateBarycentric(const ProbeVolume& v, Vec3 p, int32_t hintTet,
                                 const HullClamp* clamp) {
  if (v.tets.empty()) return {};
  const int32_t n = static_cast<int32_t>(v.tets.size());
  const bool hinted = hintTet >= 0 && hintTet < n;
  // A query that stays clearly inside its hint tet (most of a moving object's) is answered by
  // the fast path alone. It rejects a non-finite p.
  if (hinted) {
    VolumeLocation loc;
    if (frameWeights(v, hintTet, p, loc.weights)) {
      loc.tet = hintTet;
      return loc;
    }
  }
  if (!isFinite(p)) {
    // No meaningful place: the centre of the locator's first tet, never NaN weights.
    VolumeLocation loc;
    loc.tet = 0;
    loc.weights = {0.25f, 0.25f, 0.25f, 0.25f};
    loc.outside = true;
    return loc;
  }
  const int32_t start = hinted ? hintTet : coldStart(v, p);
  const WalkResult r = walk(v, p, start);
  switch (r.kind) {
    case WalkResult::kInside: {
      // The walk decided with the float matrix, as a renderer would. After a hinted walk (a
      // coherent query that left its tet, whose neighbours' frames are likely cached) the
      // weights are the frame's when p is clearly inside (as above). Otherwise, and after a
      // cold start (where reading the frame is a cache miss: 10 % slower on random points),
      // they are recomputed from double orientations, which are accurate even in flattish tets
      // (float matrix weights are off by ~6e-8 / relative volume), and clamped.
      VolumeLocation loc;
      loc.tet = r.tet;
      if (hinted && frameWeights(v, r.tet, p, loc.weights)) return loc;
      bool flat = false;
      const auto w = orientWeights(v, r.tet, p, flat);
      loc.weights = cleanWeights(flat ? r.w : w);
      return loc;
    }
    case WalkResult::kOutside:
      return clamp ? clamp->clamp(p) : clampToHull(v, p);
    case WalkResult::kFailed:
      break;
  }
  gBruteForceCount.fetch_add(1, std::memory_order_relaxed);
  return bruteForce(v, p);
}
}  // namespace

VolumeLocation locate(const ProbeVolume& v, Vec3 p, int32_t hintTet, const HullClamp* clamp) {
  return locateBarycentric(v, p, hintTet, clamp);
}

VolumeLocation locate(const ProbeVolume& v, Vec3 p, int32_t hintTet) {
  return locate(v, p, hintTet, nullptr);
}

HullClamp::HullClamp(const ProbeVolume& v) : v_(&v) {
  if (v.hullFaces.empty()) return;
  for (const auto& [t, opp] : v.hullFaces)
    for (int k = 1; k < 4; ++k) box_.extend(v.position(v.tets[t][(opp + k) & 3]));
  // About one face per cell: hull faces lie on the box's surface, n^2 of n^3 cells.
  const int n = std::clamp(int(std::ceil(std::sqrt(double(v.hullFaces.size())))), 1, 64);
  const Vec3 e = box_.extent();
  for (int a = 0; a < 3; ++a) {
    dims_[a] = e[a] > 0 ? n : 1;
    cell_[a] = e[a] > 0 ? e[a] / n : 1.0;
  }
  cellStart_.assign(size_t(dims_[0]) * dims_[1] * dims_[2] + 1, 0);
  // Two passes (count, fill): each face in every cell its bounding box touches.
  std::vector<std::array<int, 6>> range(v.hullFaces.size());
  for (size_t f = 0; f < v.hullFaces.size(); ++f) {
    const auto& [t, opp] = v.hullFaces[f];
    Bounds3 fb;
    for (int k = 1; k < 4; ++k) fb.extend(v.position(v.tets[t][(opp + k) & 3]));
    const auto lo = cellOf(fb.lo), hi = cellOf(fb.hi);
    range[f] = {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]};
    forCells(range[f], [&](size_t c) { ++cellStart_[c + 1]; });
  }
  for (size_t c = 1; c < cellStart_.size(); ++c) cellStart_[c] += cellStart_[c - 1];
  faces_.resize(cellStart_.back());
  std::vector<uint32_t> fill(cellStart_.begin(), cellStart_.end() - 1);
  for (size_t f = 0; f < v.hullFaces.size(); ++f)
    forCells(range[f], [&](size_t c) { faces_[fill[c]++] = uint32_t(f); });
}

std::array<int, 3> HullClamp::cellOf(Vec3 p) const {
  std::array<int, 3> c{};
  for (int a = 0; a < 3; ++a) {
    const double x = std::floor((p[a] - box_.lo[a]) / cell_[a]);
    c[size_t(a)] = int(std::clamp(std::isfinite(x) ? x : 0.0, 0.0, double(dims_[a] - 1)));
  }
  return c;
}

template <class F>
void HullClamp::forCells(const std::array<int, 6>& r, const F& f) const {
  for (int z = r[2]; z <= r[5]; ++z)
    for (int y = r[1]; y <= r[4]; ++y)
      for (int x = r[0]; x <= r[3]; ++x)
        f(size_t(x) + size_t(dims_[0]) * (y + size_t(dims_[1]) * z));
}

VolumeLocation HullClamp::clamp(Vec3 p) const {
  if (v_->hullFaces.empty() || !isFinite(p)) return clampToHull(*v_, p);
  // Rings of cells around p's cell (p clamped into the box), nearest first, until the best face
  // is nearer than every cell not yet visited: the same face as the scan over all faces.
  const std::array<int, 3> c = cellOf(p);
  NearestFace n;
  // A face is in every cell its box touches: each is measured once per query.
  thread_local std::vector<uint32_t> seen;
  thread_local uint32_t stamp = 0;
  if (seen.size() < v_->hullFaces.size()) seen.assign(v_->hullFaces.size(), 0);
  if (++stamp == 0) {
    std::fill(seen.begin(), seen.end(), 0);
    stamp = 1;
  }
  for (int r = 0;; ++r) {
    std::array<int, 6> block{};
    for (int a = 0; a < 3; ++a) {
      block[size_t(a)] = std::max(0, c[size_t(a)] - r);
      block[size_t(a) + 3] = std::min(dims_[a] - 1, c[size_t(a)] + r);
    }
    forCells(block, [&](size_t cell) {
      const int x = int(cell % size_t(dims_[0]));
      const int y = int(cell / size_t(dims_[0]) % size_t(dims_[1]));
      const int z = int(cell / (size_t(dims_[0]) * dims_[1]));
      if (std::max({std::abs(x - c[0]), std::abs(y - c[1]), std::abs(z - c[2])}) != r) return;
      for (uint32_t k = cellStart_[cell]; k < cellStart_[cell + 1]; ++k)
        if (seen[faces_[k]] != stamp) {
          seen[faces_[k]] = stamp;
          n.consider(*v_, p, faces_[k]);
        }
    });
    // The squared distance from p to the nearest cell outside the block (sides at the grid's
    // edge have none beyond them): the gap to that side, plus how far p lies outside the box
    // along the other axes (every cell is inside the box).
    double out2[3];
    for (int a = 0; a < 3; ++a) {
      const double o = std::max({0.0, box_.lo[a] - p[a], p[a] - box_.hi[a]});
      out2[a] = o * o;
    }
    double free2 = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      const double others = out2[(a + 1) % 3] + out2[(a + 2) % 3];
      if (block[size_t(a)] > 0) {
        const double gap = std::max(0.0, p[a] - (box_.lo[a] + block[size_t(a)] * cell_[a]));
        free2 = std::min(free2, gap * gap + others);
      }
      if (block[size_t(a) + 3] < dims_[a] - 1) {
        const double gap = std::max(0.0, box_.lo[a] + (block[size_t(a) + 3] + 1) * cell_[a] - p[a]);
        free2 = std::min(free2, gap * gap + others);
      }
    }
    if (!std::isfinite(free2)) break;  // the block is the whole grid
    if (n.tet >= 0 && free2 > 0 && n.d2 < free2 * (1 - 1e-9)) break;
  }
  return n.location();
}

void locateBatch(const ProbeVolume& v, std::span<const Vec3> points,
                 std::span<VolumeLocation> out) {
  PS_CHECK_EQ(points.size(), out.size());
  // Walk from the previous point's tet when the point is within one locator cell of it (a few
  // steps); otherwise start from the locator, so that incoherent batches cost a cold query each
  // rather than a walk across the volume.
  double reach2 = 0;
  for (int a = 0; a < 3; ++a) reach2 += double(v.locatorCellSize[a]) * v.locatorCellSize[a];
  int32_t hint = -1;
  Vec3 prev;
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3 d = points[i] - prev;
    const bool near = hint >= 0 && dot(d, d) <= reach2;
    out[i] = locate(v, points[i], near ? hint : -1);
    hint = out[i].tet;
    prev = points[i];
  }
}

// Sukys 3.2.1 "Interpolation with barycentric coordinates": SH is linear, so the blend of the
// four probes' coefficients with the barycentric weights is the interpolated function.
ShRgb interpolate(const ProbeVolume& v, const VolumeLocation& loc) {
  ShRgb out;
  if (loc.tet < 0) return out;
  // Per stored value (coefficient-major, RGB), the sum over the probes in their order.
  const auto& t = v.tets[size_t(loc.tet)];
  const float* s[4];
  double w[4];
  for (int i = 0; i < 4; ++i) {
    s[i] = v.sh.data() + size_t(27) * size_t(t[i]);
    w[i] = loc.weights[i];
  }
  double acc[27];
  for (int k = 0; k < 27; ++k) {
    double a = 0;
    for (int i = 0; i < 4; ++i) a += w[i] * s[i][k];
    acc[k] = a;
  }
  for (int k = 0; k < kShCoeffCount; ++k)
    out.c[k] = Rgb(acc[3 * k], acc[3 * k + 1], acc[3 * k + 2]);
  return out;
}

namespace detail {
bool fastWeights(const ProbeVolume& v, int32_t t, Vec3 p, std::array<float, 4>& weights) {
  return t >= 0 && t < static_cast<int32_t>(v.tets.size()) && frameWeights(v, t, p, weights);
}

uint64_t locateBruteForceCount() {
  return gBruteForceCount.load(std::memory_order_relaxed);
}
}  // namespace detail

}  // namespace ps
