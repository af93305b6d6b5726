#include "core/placement/GreedyError.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/math/Stops.h"
#include "core/tessellation/Tetrahedralization.h"
#include "core/traversal/ProbeVolume.h"
#include "core/traversal/VisibleInterpolation.h"

namespace ps::greedy {

namespace {

/// The irradiance variance of a point from its capture noise (ErrorPoints::noiseVar), given the
/// standard errors of its SH coefficients.
double noiseVariance(const ShRgb& shStdError) {
  const std::array<Vec3, kNormals>& normals = errorNormals();
  double v = 0;
  for (const Vec3& nrm : normals) {
    const auto y = shBasis(nrm);
    for (int c = 0; c < kShCoeffCount; ++c) {
      const double t = shCosineLobe(c) * y[size_t(c)] * luminance(shStdError.c[size_t(c)]);
      v += t * t;
    }
  }
  return v / kNormals;
}

/// The Delaunay mesh of a probe set, its tetrahedra and hull faces keyed by the probes' slots,
/// which additions and swaps never renumber (the mesh's own vertex numbers can change with the
/// input). Not copyable: hullClamp points into volume.
class TrialMesh {
 public:
  /// Tetrahedralizes `probes` less the one at slot `absent` (kNone: none). Throws FlatProbes
  /// when they span less than 3D.
  TrialMesh(const std::vector<Vec3>& probes, size_t absent)
      : TrialMesh(tetrahedralizeProbes(probes, absent), absent) {}
  TrialMesh(const TrialMesh&) = delete;
  TrialMesh& operator=(const TrialMesh&) = delete;

  /// The probe slot of mesh vertex v.
  int32_t slotOf(int32_t v) const { return probeOfVertex_[size_t(v)]; }
  /// The tetKey of a tetrahedron given by its mesh vertices.
  uint64_t tetKeyOf(const std::array<int32_t, 4>& v) const {
    return tetKey({slotOf(v[0]), slotOf(v[1]), slotOf(v[2]), slotOf(v[3])});
  }
  /// A hull face's key, the face of `tet` opposite its local vertex `opp`: the slots of its
  /// three probes, the lowest repeated (the same key whichever tet holds the face and however
  /// its row is ordered).
  uint64_t faceKey(int32_t tet, int opp) const {
    const auto& tv = volume.tets[size_t(tet)];
    const int32_t a = slotOf(tv[size_t((opp + 1) & 3)]);
    const int32_t b = slotOf(tv[size_t((opp + 2) & 3)]);
    const int32_t c = slotOf(tv[size_t((opp + 3) & 3)]);
    return tetKey({a, b, c, std::min({a, b, c})});
  }

 private:
  TrialMesh(const Tetrahedralization& t, size_t absent)
      : probeOfVertex_(slotsOfVertices(t, absent)),
        volume(buildProbeVolume(t, std::vector<ShRgb>(t.vertices.size(), ShRgb{}))),
        hullClamp(volume) {
    hullKeys.reserve(volume.hullFaces.size());
    for (const auto& [tet, opp] : volume.hullFaces) hullKeys.push_back(faceKey(tet, opp));
  }
  static Tetrahedralization tetrahedralizeProbes(const std::vector<Vec3>& probes, size_t absent) {
    std::vector<Vec3> input;
    if (absent != kNone) {
      input = probes;
      input.erase(input.begin() + std::ptrdiff_t(absent));
    }
    try {
      return tetrahedralize(absent != kNone ? input : probes);
    } catch (const ParameterError&) {
      throw FlatProbes{};
    }
  }
  static std::vector<int32_t> slotsOfVertices(const Tetrahedralization& t, size_t absent) {
    std::vector<int32_t> probeOfVertex(t.vertices.size(), -1);
    for (size_t q = 0; q < t.vertexOfInput.size(); ++q) {
      const size_t p = absent != kNone && q >= absent ? q + 1 : q;
      if (probeOfVertex[size_t(t.vertexOfInput[q])] < 0)
        probeOfVertex[size_t(t.vertexOfInput[q])] = int32_t(p);
    }
    return probeOfVertex;
  }

  std::vector<int32_t> probeOfVertex_;

 public:
  const ProbeVolume volume;  ///< with zero SH: only its geometry and search data are used
  const HullClamp hullClamp;
  std::vector<uint64_t> hullKeys;  ///< faceKey of each of volume.hullFaces, in that order
};

/// The boxes of a trial mesh's tetrahedra and hull faces that the committed mesh does not have,
/// and the box of each kind's boxes.
struct NewParts {
  std::vector<Bounds3> tets, faces;
  Bounds3 tetsBox, facesBox;
};

/// NewParts of `mesh` (whose tetrahedron keys are trial.tets, in the mesh's order) against
/// `committed`. O(tets log tets + faces log faces).
NewParts newParts(const TrialMesh& mesh, const Trial& trial, const CommittedMesh& committed) {
  NewParts parts;
  const ProbeVolume& volume = mesh.volume;
  for (size_t k = 0; k < volume.tets.size(); ++k) {  // trial.tets is in this order
    if (std::binary_search(committed.tets.begin(), committed.tets.end(), trial.tets[k])) continue;
    Bounds3 b;
    for (int32_t v : volume.tets[k]) b.extend(volume.position(v));
    parts.tets.push_back(b);
    parts.tetsBox.extend(b.lo);
    parts.tetsBox.extend(b.hi);
  }
  for (size_t f = 0; f < volume.hullFaces.size(); ++f) {
    if (std::binary_search(committed.hull.begin(), committed.hull.end(), mesh.hullKeys[f]))
      continue;
    const auto& [tet, opp] = volume.hullFaces[f];
    Bounds3 b;
    for (int c = 1; c < 4; ++c)
      b.extend(volume.position(volume.tets[size_t(tet)][size_t((opp + c) & 3)]));
    parts.faces.push_back(b);
    parts.facesBox.extend(b.lo);
    parts.facesBox.extend(b.hi);
  }
  return parts;
}

double boxDist2(const Bounds3& b, Vec3 p) {
  const Vec3 d = max(max(b.lo - p, p - b.hi), Vec3(0, 0, 0));
  return dot(d, d);
}

/// Whether the clamp of a point outside the committed hull, at `p` with state `st`, may change
/// in a mesh with hull `hull` (sorted) and new parts `parts`: its face went, a new tetrahedron's
/// box holds it (it may now be inside), or a new hull face's box is as near as its face (it may
/// clamp to that one); every other face of the mesh was there before, and no nearer. The boxes
/// are widened by `clampMargin` (metres): the walk counts a point within its barycentric slack
/// of a tetrahedron as inside it.
bool clampMayChange(const NewParts& parts, const std::vector<uint64_t>& hull, const SampleState& st,
                    Vec3 p, double clampMargin) {
  if (!std::binary_search(hull.begin(), hull.end(), st.face)) return true;
  const double margin2 = clampMargin * clampMargin;
  if (boxDist2(parts.tetsBox, p) <= margin2)
    for (const Bounds3& b : parts.tets)
      if (boxDist2(b, p) <= margin2) return true;
  const double reach =
      (std::sqrt(st.clampD2) + clampMargin) * (std::sqrt(st.clampD2) + clampMargin);
  if (boxDist2(parts.facesBox, p) <= reach)
    for (const Bounds3& b : parts.faces)
      if (boxDist2(b, p) <= reach) return true;
  return false;
}

/// The barycentric coordinates of p in tet t of `volume`, exactly to double rounding: ratios of
/// the signed volumes of the tetrahedra p makes with each face (the float positions taken as
/// exact). Non-finite for a tetrahedron flat in double.
std::array<double, 4> exactBarycentric(const ProbeVolume& volume, int32_t t, Vec3 p) {
  const auto& tv = volume.tets[size_t(t)];
  std::array<Vec3, 4> v;
  for (int c = 0; c < 4; ++c) v[size_t(c)] = volume.position(tv[size_t(c)]);
  auto signedVolume = [](Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
    return dot(a - d, cross(b - d, c - d));
  };
  const double whole = signedVolume(v[0], v[1], v[2], v[3]);
  std::array<double, 4> w{};
  for (int c = 0; c < 4; ++c) {
    std::array<Vec3, 4> q = v;
    q[size_t(c)] = p;
    w[size_t(c)] = signedVolume(q[0], q[1], q[2], q[3]) / whole;
  }
  return w;
}

/// A point's visibility-aware weights are fragile when the barycentric weight of the probes that
/// see it sums to less than this: float rounding of the barycentric weights (a point on a face
/// shared by two tetrahedra) then moves the result by far more than rounding.
constexpr double kFragileVisibleWeight = 1e-4;

/// The points a trial interpolates again when it is not the first: those of the committed
/// tetrahedra the trial's mesh does not have (every point's tetrahedron is one of the committed
/// mesh's), `extraProbe`, and those outside the hull whose clamp may change. A point outside
/// keeps its clamp unless the hull's faces changed near it (points outside are most of a
/// boundary-sampled field's cost otherwise: clampToHull visits every hull face; and coplanar
/// probes on the hull, boundary samples along a floor, have more than one triangulation, so the
/// faces change at many additions). Ascending, as a scan of every point would give them, so
/// that the error's sum is the same to the last bit. O(points moved + tets log tets).
std::vector<size_t> pointsToRedo(const TrialMesh& mesh, const Trial& trial,
                                 const CommittedMesh& committed, const ErrorPoints& points,
                                 size_t extraProbe) {
  std::vector<uint64_t> sortedTets = trial.tets;
  std::sort(sortedTets.begin(), sortedTets.end());
  std::vector<size_t> redo;
  for (size_t k = 0, m = 0; k < committed.tets.size(); ++k) {
    while (m < sortedTets.size() && sortedTets[m] < committed.tets[k]) ++m;
    if (m < sortedTets.size() && sortedTets[m] == committed.tets[k]) continue;
    redo.insert(redo.end(), committed.tetSamples.begin() + committed.tetStart[k],
                committed.tetSamples.begin() + committed.tetStart[k + 1]);
  }
  if (extraProbe != kNone) redo.push_back(extraProbe);
  if (trial.hull != committed.hull) {
    const NewParts parts = newParts(mesh, trial, committed);
    for (uint32_t i : committed.outsideSamples)
      if (clampMayChange(parts, trial.hull, committed.state[i], points.position[i],
                         points.clampMargin))
        redo.push_back(i);
  }
  std::sort(redo.begin(), redo.end());
  redo.erase(std::unique(redo.begin(), redo.end()), redo.end());
  return redo;
}

/// Interpolates trial.changed's points from `mesh` with the probe irradiance `values` (per
/// slot) into trial.changedState. In parallel, one point per task.
void interpolateChanged(const TrialMesh& mesh, const std::vector<IrrVec>& values,
                        const std::vector<SlotVisibility>& visibility, const ErrorPoints& points,
                        const std::vector<char>& isProbe, size_t extraProbe, Trial& trial) {
  const ProbeVolume& volume = mesh.volume;
  trial.changedState.resize(trial.changed.size());
  tbb::parallel_for(size_t(0), trial.changed.size(), [&](size_t q) {
    const size_t i = trial.changed[q];
    const VolumeLocation loc = locate(volume, points.position[i], -1, &mesh.hullClamp);
    PS_CHECK_LE(0, loc.tet);
    const auto& tv = volume.tets[size_t(loc.tet)];
    // Blend of the probes' irradiance (linear in SH, so equal to the irradiance of the
    // interpolated SH: core/traversal interpolate), with the barycentric weights or the
    // visibility-aware ones.
    std::array<double, 4> weights{};
    for (int c = 0; c < 4; ++c) weights[size_t(c)] = double(loc.weights[size_t(c)]);
    bool fragile = false;
    // How much the weights' rounding can grow through the visibility-aware renormalisation
    // w'_c = b_c f_c / S, S = sum_j b_j f_j: |dw'_c| <= eps (f_c + w'_c sum_j f_j) / S, so the
    // blend moves by at most eps * 5 max(f) / S times the largest value.
    double amplification = 1;
    if (!visibility.empty()) {
      const std::array<double, 4> barycentric = weights;
      std::array<double, 4> factors{};
      for (int c = 0; c < 4; ++c) {
        const int32_t v = tv[size_t(c)];
        const SlotVisibility& sv = visibility[size_t(mesh.slotOf(v))];
        factors[size_t(c)] = visibilityFactor(sv.map, kVisibilityMapSize, sv.inside,
                                              volume.position(v), points.position[i], {});
      }
      double seen = 0;
      for (int c = 0; c < 4; ++c) seen += barycentric[size_t(c)] * factors[size_t(c)];
      const bool fellBack =
          combineVisibleWeights(barycentric, factors, weights) != VisibleFallback::None;
      fragile = fellBack || seen < kFragileVisibleWeight;
      // A fallback's weights do not depend on the barycentric ones; otherwise S = seen > 0, and
      // a tiny S gives a bound as large as the point's result is ill-conditioned.
      const double maxFactor = *std::max_element(factors.begin(), factors.end());
      amplification = fellBack ? 1 : 5 * maxFactor / seen;
    }
    IrrVec interp{};
    for (int c = 0; c < 4; ++c) {
      const size_t p = size_t(mesh.slotOf(tv[size_t(c)]));
      const double w = weights[size_t(c)];
      for (int k = 0; k < kNormals; ++k) interp[k] += w * values[p][k];
    }
    // The rounding bound (SampleState::roundoff), per normal in irradiance: the weights' own
    // (kWeightRoundingBound each), and for a clamped point the clamp's position rounding times
    // the gradient of the tetrahedron's linear interpolant (the rows of its barycentric matrix
    // are the weights' gradients, the fourth's their negated sum).
    IrrVec bound{};
    {
      const auto& m = volume.matrices[size_t(loc.tet)];
      std::array<double, 4> gradient{};
      // Inside, each weight's actual rounding when it exceeds the contract's (a point within the
      // walk's slack outside its tetrahedron has a weight clamped to 0 from a slightly negative
      // one): the exact interpolation of the neighbour holding the point is then that far off.
      std::array<double, 4> rounding;
      rounding.fill(kWeightRoundingBound);
      if (!loc.outside) {
        const std::array<double, 4> exact = exactBarycentric(volume, loc.tet, points.position[i]);
        for (int c = 0; c < 4; ++c) {
          const double off = std::abs(double(loc.weights[size_t(c)]) - exact[size_t(c)]);
          if (std::isfinite(off)) rounding[size_t(c)] = std::max(rounding[size_t(c)], off);
        }
      } else {
        Vec3 sum;
        for (int r = 0; r < 3; ++r) {
          const Vec3 row(m[size_t(3 * r)], m[size_t(3 * r + 1)], m[size_t(3 * r + 2)]);
          gradient[size_t(r)] = length(row);
          sum = sum + row;
        }
        gradient[3] = length(sum);
      }
      for (int c = 0; c < 4; ++c) {
        const size_t p = size_t(mesh.slotOf(tv[size_t(c)]));
        const double perUnitValue =
            amplification * (rounding[size_t(c)] + points.clampMargin * gradient[size_t(c)]);
        for (int k = 0; k < kNormals; ++k) bound[k] += perUnitValue * std::abs(values[p][k]);
      }
    }
    const IrrVec& ref = points.ref[i];
    double e = 0, roundoff = 0;
    if (points.objective == GreedyObjective::kPerceptual)
      for (int k = 0; k < kNormals; ++k) {
        const double stops = errorStops(interp[k], ref[k], points.floorLuminance);
        e += stops * stops;
        // d log2(E) / dE = 1 / (E ln 2), E floored as errorStops floors it, taken at the lowest
        // value two evaluations can give.
        const double low = std::max(interp[k] - 2 * bound[k], points.floorLuminance);
        roundoff = std::max(roundoff, bound[k] / (low * std::log(2.0)));
      }
    else
      for (int k = 0; k < kNormals; ++k) {
        e += (interp[k] - ref[k]) * (interp[k] - ref[k]);
        roundoff = std::max(roundoff, bound[k]);
      }
    SampleState& st = trial.changedState[q];
    st.rmsError = std::sqrt(e / kNormals);
    st.roundoff = roundoff;
    st.errSq = (isProbe[i] || i == extraProbe)
                   ? 0.0
                   : std::clamp(e / kNormals - points.noiseVar[i], 0.0, points.errSqCap);
    st.tet = mesh.tetKeyOf(tv);
    st.outside = loc.outside;
    st.fragile = fragile;
    if (loc.outside) {
      // The clamped point, and the hull face it lies on: the one opposite a vertex of weight
      // 0 (on an edge or a corner of the hull, any of its faces there holds it).
      Vec3 on;
      for (int c = 0; c < 4; ++c)
        on = on + volume.position(tv[size_t(c)]) * double(loc.weights[size_t(c)]);
      st.clampD2 = dot(on - points.position[i], on - points.position[i]);
      st.face = 0;
      for (int c = 0; c < 4 && st.face == 0; ++c)
        if (loc.weights[size_t(c)] == 0.0f) {
          const uint64_t key = mesh.faceKey(loc.tet, c);
          if (std::binary_search(trial.hull.begin(), trial.hull.end(), key)) st.face = key;
        }
    }
  });
}

/// Whether point i's capture resolves its light: its mean luminance over the normals is above
/// kResolvedSigmas standard deviations of its noise (pts.noiseVar in luminance, before the
/// perceptual objective turns it into stops).
bool resolvesLight(const ErrorPoints& pts, size_t i) {
  double mean = 0;
  for (double r : pts.ref[i]) mean += r / kNormals;
  return mean > kResolvedSigmas * std::sqrt(pts.noiseVar[i]);
}

/// kAdaptationFloorFraction times the weighted median of the points' mean luminance over the
/// normals (the weights are volumes: the median luminance of the domain, as eval's floor is
/// its queries'); 1e-12 when that is 0. With `resolvedOnly`, the median of the points whose
/// captures resolve their light (resolvesLight): where most do not, the median of all is their
/// noise (often 0), not the light a viewer adapts to, and the objective would weigh ratios of
/// noise. The floor then says what the captures can measure: light below it counts as black.
double perceptualFloor(const ErrorPoints& pts, bool resolvedOnly) {
  std::vector<std::pair<double, double>> lum;  // (mean luminance, weight)
  double total = 0;
  for (size_t i = 0; i < pts.count; ++i) {
    if (!(pts.weight[i] > 0) || (resolvedOnly && !resolvesLight(pts, i))) continue;
    double m = 0;
    for (double r : pts.ref[i]) m += r;
    lum.emplace_back(m / kNormals, pts.weight[i]);
    total += pts.weight[i];
  }
  std::sort(lum.begin(), lum.end());
  double below = 0, median = 0;
  for (const auto& [l, w] : lum) {
    below += w;
    median = l;
    if (below >= 0.5 * total) break;
  }
  return std::max(kAdaptationFloorFraction * median, 1e-12);
}

}  // namespace

const std::array<Vec3, kNormals>& errorNormals() {
  static const std::array<Vec3, kNormals> normals = [] {
    const double d = 1.0 / std::sqrt(3.0);
    return std::array<Vec3, kNormals>{
        Vec3(1, 0, 0),  Vec3(-1, 0, 0),  Vec3(0, 1, 0),   Vec3(0, -1, 0),  Vec3(0, 0, 1),
        Vec3(0, 0, -1), Vec3(d, d, d),   Vec3(d, d, -d),  Vec3(d, -d, d),  Vec3(d, -d, -d),
        Vec3(-d, d, d), Vec3(-d, d, -d), Vec3(-d, -d, d), Vec3(-d, -d, -d)};
  }();
  return normals;
}

uint64_t tetKey(std::array<int32_t, 4> v) {
  std::sort(v.begin(), v.end());
  return (uint64_t(v[0]) << 48) | (uint64_t(v[1]) << 32) | (uint64_t(v[2]) << 16) | uint64_t(v[3]);
}

ErrorPoints gatherErrorPoints(const DenseField& field, const GreedySettings& s) {
  ErrorPoints pts;
  const size_t S = field.samples.size();
  const size_t N = S + s.heldOut.size();
  pts.fieldCount = S;
  pts.count = N;
  auto shOf = [&](size_t i) -> const ShRgb& {
    return i < S ? field.samples[i].sh : s.heldOut[i - S].sh;
  };
  auto shStdErrorOf = [&](size_t i) -> const ShRgb& {
    return i < S ? field.samples[i].shStdError : s.heldOut[i - S].shStdError;
  };
  pts.position.resize(N);
  for (size_t i = 0; i < N; ++i)
    pts.position[i] = i < S ? field.samples[i].position : s.heldOut[i - S].position;

  pts.ref.resize(N);
  tbb::parallel_for(size_t(0), N,
                    [&](size_t i) { pts.ref[i] = greedyErrorNormalsIrradiance(shOf(i)); });
  pts.noiseVar.assign(N, 0.0);
  tbb::parallel_for(size_t(0), N,
                    [&](size_t i) { pts.noiseVar[i] = noiseVariance(shStdErrorOf(i)); });
  double refSq = 0;
  for (const IrrVec& r : pts.ref)
    for (double x : r) refSq += x * x;
  const double refScale = std::sqrt(refSq / double(N * kNormals));  // RMS point irradiance
  if (!(refScale > 0))
    throw ParameterError("greedy: the dense field is black everywhere (no light reaches it)");

  pts.avoided.assign(N, 0);
  if (s.avoidRadius > 0)
    for (size_t i = 0; i < N; ++i)
      for (const Vec3& a : s.avoid) {
        const Vec3 d = pts.position[i] - a;
        if (dot(d, d) < s.avoidRadius * s.avoidRadius) pts.avoided[i] = 1;
      }

  for (const FieldSample& f : field.samples) pts.fieldBox.extend(f.position);
  // A clamp's distance is rebuilt from float barycentric weights: its rounding grows with the
  // coordinates (a scene far from the origin) as well as with the field's size.
  const Bounds3& box = pts.fieldBox;
  pts.clampMargin = 1e-5 * (box.diagonal() +
                            std::max({std::abs(box.lo.x), std::abs(box.lo.y), std::abs(box.lo.z),
                                      std::abs(box.hi.x), std::abs(box.hi.y), std::abs(box.hi.z)}));
  return pts;
}

void weighErrorPoints(ErrorPoints& pts, const DenseField& field, const GreedySettings& s) {
  const size_t S = pts.fieldCount, N = pts.count;
  // A sample stands for its octree cell's volume (0 for a split cell, whose children cover it),
  // so that the field error is a volume average like eval's. The held-out points take no part
  // in this first weighting (below, they replace the field's samples).
  std::vector<double>& weight = pts.weight;
  weight.assign(N, 1.0);
  std::fill(weight.begin() + std::ptrdiff_t(S), weight.end(), 0.0);
  bool sized = true;
  for (const FieldSample& f : field.samples) sized = sized && f.cellSize > 0;
  if (sized)
    for (size_t i = 0; i < S; ++i) weight[i] = greedySampleWeight(field.samples[i]);
  // Zeroes the weights in the light clearance, then sums weight |ref|^2 / kNormals.
  auto sumWeightedRefSq = [&] {
    for (size_t i = 0; i < N; ++i)
      if (pts.avoided[i]) weight[i] = 0;
    double sum = 0;
    for (size_t i = 0; i < N; ++i)
      for (double x : pts.ref[i]) sum += weight[i] * x * x / kNormals;
    return sum;
  };
  double weightedRefSq = sumWeightedRefSq();
  if (!(weightedRefSq > 0)) {
    std::fill(weight.begin(), weight.begin() + std::ptrdiff_t(S), 1.0);
    weightedRefSq = sumWeightedRefSq();
  }
  if (!(weightedRefSq > 0))
    throw ParameterError(
        "greedy: every lit sample of the dense field is within the light clearance");
  if (N > S) {
    // Held-out points measure the error alone, with their weights: the field's samples stay the
    // candidates.
    std::vector<double> heldOutWeight(N, 0.0);
    for (size_t i = S; i < N; ++i) heldOutWeight[i] = s.heldOut[i - S].weight;
    std::swap(weight, heldOutWeight);
    const double heldOutRefSq = sumWeightedRefSq();
    if (heldOutRefSq > 0)
      weightedRefSq = heldOutRefSq;
    else  // the held-out points are all black (or in the light clearance): the field's samples
      std::swap(weight, heldOutWeight);
  }
  double weightSum = 0;
  for (double w : weight) weightSum += w;
  pts.weightedRefSq = weightedRefSq;
  pts.refRms = std::sqrt(weightedRefSq / weightSum);
  pts.objective = s.objective;
  if (s.objective == GreedyObjective::kPerceptual) {
    pts.errorNorm = weightSum;
    pts.scoreUnit = 1;
    double unresolved = 0;
    for (size_t i = 0; i < N; ++i)
      if (!resolvesLight(pts, i)) unresolved += weight[i];
    pts.unresolvedShare = unresolved / weightSum;
    pts.floorLuminance = perceptualFloor(pts, pts.unresolvedShare > kGreedyUnresolvedShareLimit);
    // The noise in stops, to first order: d log2(E) = dE / (E ln 2), with E floored as
    // errorStops floors it (below the floor, noise moves nothing: bounded by the floor's).
    for (size_t i = 0; i < N; ++i) {
      double gain = 0;
      for (double r : pts.ref[i]) {
        const double g = 1 / (std::max(r, pts.floorLuminance) * std::log(2.0));
        gain += g * g;
      }
      pts.noiseVar[i] *= gain / kNormals;
    }
  } else {
    pts.errorNorm = weightedRefSq;
    pts.scoreUnit = pts.refRms;
    pts.floorLuminance = 0;
  }
  // Next to a light the irradiance (and any interpolation's error) grows without bound, over a
  // volume so small that it would otherwise draw probe after probe while the rest of the domain
  // stays wrong: errorCapRelative bounds a point's share.
  pts.errSqCap = s.errorCapRelative > 0 && s.objective == GreedyObjective::kEnergy
                     ? (s.errorCapRelative * pts.refRms) * (s.errorCapRelative * pts.refRms)
                     : std::numeric_limits<double>::infinity();
}

GreedyErrorState::GreedyErrorState(const ErrorPoints& points) : points_(points) {
  mesh_.state.resize(points.count);
}

Trial GreedyErrorState::evaluate(const std::vector<Vec3>& probes, const std::vector<IrrVec>& values,
                                 const std::vector<SlotVisibility>& visibility,
                                 const std::vector<char>& isProbe, size_t extraProbe, size_t absent,
                                 TrialScope scope) const {
  const TrialMesh mesh(probes, absent);
  Trial trial;
  trial.absent = absent;
  trial.hull = mesh.hullKeys;
  std::sort(trial.hull.begin(), trial.hull.end());
  trial.tets.reserve(mesh.volume.tets.size());
  for (const auto& v : mesh.volume.tets) trial.tets.push_back(mesh.tetKeyOf(v));
  const bool all = scope == TrialScope::kAllPoints;
  if (all) {
    std::sort(trial.tets.begin(), trial.tets.end());
    trial.changed.resize(points_.count);
    for (size_t i = 0; i < points_.count; ++i) trial.changed[i] = i;
  } else {
    const bool weightedOnly = scope == TrialScope::kChangedWeightedPoints;
    for (size_t i : pointsToRedo(mesh, trial, mesh_, points_, extraProbe)) {
      if (weightedOnly && points_.weight[i] == 0 && i != extraProbe)
        trial.partial = true;
      else
        trial.changed.push_back(i);
    }
  }
  if (!visibility.empty()) PS_CHECK_EQ(visibility.size(), probes.size());
  interpolateChanged(mesh, values, visibility, points_, isProbe, extraProbe, trial);
  double sum = all ? 0.0 : mesh_.weightedErrSq;
  for (size_t q = 0; q < trial.changed.size(); ++q) {
    const size_t i = trial.changed[q];
    if (!all) sum -= points_.weight[i] * mesh_.state[i].errSq;
    sum += points_.weight[i] * trial.changedState[q].errSq;
  }
  trial.weightedErrSq = std::max(0.0, sum);
  return trial;
}

void GreedyErrorState::indexSamples() {
  const size_t N = points_.count;
  const std::vector<uint64_t>& tets = mesh_.tets;
  std::vector<uint32_t> tetOf(N);
  mesh_.tetStart.assign(tets.size() + 1, 0);
  mesh_.outsideSamples.clear();
  for (size_t i = 0; i < N; ++i) {
    const auto it = std::lower_bound(tets.begin(), tets.end(), mesh_.state[i].tet);
    PS_CHECK(it != tets.end() && *it == mesh_.state[i].tet);
    tetOf[i] = uint32_t(it - tets.begin());
    ++mesh_.tetStart[tetOf[i] + 1];
    if (mesh_.state[i].outside) mesh_.outsideSamples.push_back(uint32_t(i));
  }
  for (size_t k = 0; k < tets.size(); ++k) mesh_.tetStart[k + 1] += mesh_.tetStart[k];
  mesh_.tetSamples.resize(N);
  std::vector<uint32_t> fill(mesh_.tetStart.begin(), mesh_.tetStart.end() - 1);
  for (size_t i = 0; i < N; ++i) mesh_.tetSamples[fill[tetOf[i]]++] = uint32_t(i);
}

double GreedyErrorState::commit(const Trial& trial) {
  PS_CHECK(!trial.partial);
  for (size_t q = 0; q < trial.changed.size(); ++q)
    mesh_.state[trial.changed[q]] = trial.changedState[q];
  mesh_.hull = trial.hull;
  mesh_.tets = trial.tets;
  std::sort(mesh_.tets.begin(), mesh_.tets.end());
  indexSamples();
  mesh_.absent = trial.absent;
  double sum = 0;
  for (size_t i = 0; i < points_.count; ++i) sum += points_.weight[i] * mesh_.state[i].errSq;
  mesh_.weightedErrSq = sum;
  return sum;
}

size_t GreedyErrorState::countMismatches(const Trial& full) const {
  size_t mismatches = 0;
  const double unit = points_.scoreUnit;
  for (size_t q = 0; q < full.changed.size(); ++q) {
    const SampleState& want = full.changedState[q];
    const SampleState& have = mesh_.state[full.changed[q]];
    // A point on a face shared by two tetrahedra can be found in either, with the same
    // interpolation to float rounding of the barycentric weights: its tetrahedron need only
    // be one of the mesh's. The interpolations differ by at most the sum of the two states'
    // roundoff bounds D, so the squared errors (means over the normals of squares of
    // differences that can be far smaller than the values) by at most 2 r D + D^2 for the
    // larger RMS error r (Cauchy-Schwarz over the normals; subtracting the noise and the cap
    // only bring them closer). A point outside the hull must also keep a face of the hull, at
    // the distance of the nearest (a stale clamp can keep a face and tetrahedron that still
    // exist, with an error close to the right one).
    // A point whose visibility-aware weights are fragile rests on probes it barely lies
    // towards (or, fallen back, on all four), so that on a shared face each tetrahedron gives
    // its own error: any of the mesh's tetrahedra holding it is right.
    const bool sameTet = have.tet == want.tet;
    const double d = kRoundoffMargin * (have.roundoff + want.roundoff);
    const double tolerance = 2 * std::max(have.rmsError, want.rmsError) * d + d * d;
    const bool eitherFragile = have.fragile || want.fragile;
    const bool clampRight =
        !want.outside ||
        (std::binary_search(full.hull.begin(), full.hull.end(), have.face) &&
         std::abs(std::sqrt(have.clampD2) - std::sqrt(want.clampD2)) <= points_.clampMargin);
    const bool same =
        (sameTet || std::binary_search(full.tets.begin(), full.tets.end(), have.tet)) &&
        have.outside == want.outside && clampRight &&
        ((eitherFragile && !sameTet) ||
         std::abs(have.errSq - want.errSq) <= tolerance + 1e-12 * unit * unit);
    mismatches += same ? 0 : 1;
  }
  return mismatches;
}

}  // namespace ps::greedy
