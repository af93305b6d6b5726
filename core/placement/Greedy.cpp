#include "core/placement/Greedy.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <tuple>
#include <unordered_map>

#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/tessellation/Tetrahedralization.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

namespace {

constexpr int kNormals = 14;
using IrrVec = std::array<double, kNormals>;

std::array<Vec3, kNormals> errorNormals() {
  const double d = 1.0 / std::sqrt(3.0);
  return {Vec3(1, 0, 0),  Vec3(-1, 0, 0),  Vec3(0, 1, 0),   Vec3(0, -1, 0),  Vec3(0, 0, 1),
          Vec3(0, 0, -1), Vec3(d, d, d),   Vec3(d, d, -d),  Vec3(d, -d, d),  Vec3(d, -d, -d),
          Vec3(-d, d, d), Vec3(-d, d, -d), Vec3(-d, -d, d), Vec3(-d, -d, -d)};
}

/// A tetrahedron's probe set as one key (the probes' slots sorted, 16 bits each).
uint64_t tetKey(std::array<int32_t, 4> v) {
  std::sort(v.begin(), v.end());
  return (uint64_t(v[0]) << 48) | (uint64_t(v[1]) << 32) | (uint64_t(v[2]) << 16) | uint64_t(v[3]);
}

constexpr size_t kMaxProbes = 65535;  ///< tetKey packs probe slots in 16 bits
/// No sample (held-out points follow the field's samples, so the count S is an index too).
constexpr size_t kNone = std::numeric_limits<size_t>::max();
/// Thrown when the probes span less than 3D (no tetrahedralization).
struct FlatProbes {};

}  // namespace

std::array<double, 14> greedyErrorNormalsIrradiance(const ShRgb& sh) {
  static const std::array<Vec3, kNormals> normals = errorNormals();
  IrrVec r{};
  for (int k = 0; k < kNormals; ++k) r[k] = luminance(sh.irradiance(normals[k]));
  return r;
}

double greedySampleWeight(const FieldSample& f) {
  const double h = f.cellSize;
  return f.refined ? 0.0 : f.boundary ? 0.5 * h * h * f.slab : h * h * h;
}

void checkGreedySettings(const GreedySettings& s, size_t keptCount) {
  if (s.budget == 0 && !(s.maxError > 0))
    throw ParameterError("greedy: give --budget N or --max-error E (or both)");
  if (s.budget != 0 && s.budget < 4)
    throw ParameterError("budget: expected at least 4 probes, got " + std::to_string(s.budget));
  if (s.budget != 0 && size_t(s.budget) < keptCount + 4)
    throw ParameterError("budget: " + std::to_string(s.budget) + " probes leave room for fewer " +
                         "than 4 new ones beside the " + std::to_string(keptCount) +
                         " kept probes; expected at least " + std::to_string(keptCount + 4));
  if (!(s.maxError >= 0) || !std::isfinite(s.maxError))
    throw ParameterError("max-error: expected a non-negative relative error");
  if (s.swapPasses < 0)
    throw ParameterError("swap-passes: expected 0 or more passes, got " +
                         std::to_string(s.swapPasses));
  if (s.swapNeighbours < 0)
    throw ParameterError("swap-neighbours: expected 0 or more samples, got " +
                         std::to_string(s.swapNeighbours));
  if (!(s.swapMinGain >= 0 && s.swapMinGain < 1))
    throw ParameterError("greedy: swapMinGain must be in [0, 1)");
  if (s.budget > int(kMaxProbes))
    throw ParameterError("budget: at most 65535 probes for greedy, got " +
                         std::to_string(s.budget));
}

GreedyResult placeGreedy(const DenseField& field, std::span<const KeptProbe> kept,
                         const GreedySettings& s, const ProgressFn& progress) {
  checkGreedySettings(s, kept.size());
  const size_t S = field.samples.size();
  if (S < 4)
    throw ParameterError("greedy: the dense field has " + std::to_string(S) +
                         " valid samples; at least 4 are needed (use a smaller field spacing)");
  const size_t budget = s.budget != 0 ? size_t(s.budget) : std::min(kMaxProbes, kept.size() + S);
  // The points the error is measured at: the field's samples [0, S), the candidates, then the
  // held-out points [S, N).
  const size_t N = S + s.heldOut.size();
  std::vector<Vec3> point(N);
  auto shOf = [&](size_t i) -> const ShRgb& {
    return i < S ? field.samples[i].sh : s.heldOut[i - S].sh;
  };
  auto shStdErrorOf = [&](size_t i) -> const ShRgb& {
    return i < S ? field.samples[i].shStdError : s.heldOut[i - S].shStdError;
  };
  for (size_t i = 0; i < N; ++i)
    point[i] = i < S ? field.samples[i].position : s.heldOut[i - S].position;
  if (budget > kMaxProbes)
    throw ParameterError("budget: at most 65535 probes, got " + std::to_string(budget));

  // Reference irradiance of every sample for the fixed normals, and the field's RMS scale.
  std::vector<IrrVec> ref(N);
  tbb::parallel_for(size_t(0), N,
                    [&](size_t i) { ref[i] = greedyErrorNormalsIrradiance(shOf(i)); });
  // The variance of each sample's irradiance from its capture noise (the coefficients' standard
  // errors, taken as independent, through E(n) = sum A_l c_lm Y_lm(n)), averaged over the
  // normals: a sample's squared error less this estimates its true squared error, so that
  // greedy does not chase the cheap capture's noise. (The probes' own noise, carried into the
  // interpolation, is not subtracted: next to a light it is so large that it would hide the
  // harm a bright probe does to its whole fan of tetrahedra.)
  static const std::array<Vec3, kNormals> normals = errorNormals();
  std::vector<double> noiseVar(N, 0.0);
  tbb::parallel_for(size_t(0), N, [&](size_t i) {
    double v = 0;
    for (const Vec3& nrm : normals) {
      const auto y = shBasis(nrm);
      for (int c = 0; c < kShCoeffCount; ++c) {
        const double t = shCosineLobe(c) * y[size_t(c)] * luminance(shStdErrorOf(i).c[size_t(c)]);
        v += t * t;
      }
    }
    noiseVar[i] = v / kNormals;
  });
  double refSq = 0;
  for (const IrrVec& r : ref)
    for (double x : r) refSq += x * x;
  const double refScale = std::sqrt(refSq / double(N * kNormals));  // RMS sample irradiance
  if (!(refScale > 0))
    throw ParameterError("greedy: the dense field is black everywhere (no light reaches it)");

  // The probes: kept ones first, then field samples. vals[p] = irradiance vector of probe p.
  std::vector<Vec3> pos;
  std::vector<IrrVec> vals;
  for (const KeptProbe& k : kept) {
    pos.push_back(k.position);
    vals.push_back(greedyErrorNormalsIrradiance(k.sh));
  }
  GreedyResult result;
  std::vector<char> isProbe(N, 0);
  {
    // A sample at a kept probe's position is that probe: never a candidate, error 0.
    auto less = [](const Vec3& a, const Vec3& b) {
      return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
    };
    std::vector<Vec3> keptAt;
    for (const KeptProbe& k : kept) keptAt.push_back(k.position);
    std::sort(keptAt.begin(), keptAt.end(), less);
    if (!keptAt.empty())
      for (size_t i = 0; i < S; ++i)
        isProbe[i] = std::binary_search(keptAt.begin(), keptAt.end(), point[i], less) ? 1 : 0;
  }
  // Samples inside the light clearance: weight 0 below, and never a candidate (as if already a
  // probe, but not one).
  std::vector<char> avoided(N, 0);
  if (s.avoidRadius > 0)
    for (size_t i = 0; i < N; ++i)
      for (const Vec3& a : s.avoid) {
        const Vec3 d = point[i] - a;
        if (dot(d, d) < s.avoidRadius * s.avoidRadius) avoided[i] = 1;
      }
  // A sample's value as a probe: its field capture, or its own capture (captureProbeValues),
  // made for a batch of samples before they are first tried.
  std::vector<IrrVec> probeVal;
  std::vector<char> haveProbeVal;
  if (s.captureProbeValues) {
    probeVal.resize(S);
    haveProbeVal.assign(S, 0);
  }
  auto captureValues = [&](std::span<const size_t> samples) {
    if (!s.captureProbeValues) return;
    std::vector<size_t> missing;
    for (size_t i : samples)
      if (!haveProbeVal[i] && std::find(missing.begin(), missing.end(), i) == missing.end())
        missing.push_back(i);
    if (missing.empty()) return;
    std::vector<Vec3> at;
    for (size_t i : missing) at.push_back(point[i]);
    const std::vector<ShRgb> sh = s.captureProbeValues(at);
    PS_CHECK_EQ(sh.size(), missing.size());
    for (size_t k = 0; k < missing.size(); ++k) {
      probeVal[missing[k]] = greedyErrorNormalsIrradiance(sh[k]);
      haveProbeVal[missing[k]] = 1;
    }
  };
  auto valueAsProbe = [&](size_t i) -> const IrrVec& {
    return s.captureProbeValues ? probeVal[i] : ref[i];
  };
  auto addSample = [&](size_t i, double score) {
    captureValues(std::span<const size_t>(&i, 1));
    isProbe[i] = 1;
    pos.push_back(field.samples[i].position);
    vals.push_back(valueAsProbe(i));
    result.positions.push_back(field.samples[i].position);
    result.sampleIndex.push_back(i);
    result.scores.push_back(score);
  };

  // Initial samples spanning the domain: the nearest sample to each corner of the samples'
  // bounding box (ties to the lower index); the 4 alternate corners (000, 110, 101, 011) are
  // affinely independent and come first.
  Bounds3 box;
  for (const FieldSample& f : field.samples) box.extend(f.position);
  const int cornerOrder[8] = {0, 3, 5, 6, 1, 2, 4, 7};
  const int corners = budget >= kept.size() + 8 ? 8 : 4;
  for (int c = 0; c < corners; ++c) {
    const int bits = cornerOrder[c];
    const Vec3 corner((bits & 1) ? box.hi.x : box.lo.x, (bits & 2) ? box.hi.y : box.lo.y,
                      (bits & 4) ? box.hi.z : box.lo.z);
    size_t best = kNone;
    double bestD = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < S; ++i) {
      if (isProbe[i] || avoided[i]) continue;
      const Vec3 dv = field.samples[i].position - corner;
      const double d = dot(dv, dv);
      if (d < bestD) {
        bestD = d;
        best = i;
      }
    }
    if (best == kNone) break;
    addSample(best, 0.0);
  }
  result.initialCount = result.positions.size();

  // Interpolation state of every sample. Weights: a sample stands for its octree cell's volume
  // (0 for a split cell, whose children cover it), so that the field error is a volume average
  // like eval's; uniform weights when the field does not record cell sizes.
  // The held-out points take no part in this first weighting (below, they replace the field's
  // samples).
  std::vector<double> weight(N, 1.0);
  std::fill(weight.begin() + std::ptrdiff_t(S), weight.end(), 0.0);
  bool sized = true;
  for (const FieldSample& f : field.samples) sized = sized && f.cellSize > 0;
  if (sized)
    for (size_t i = 0; i < S; ++i) weight[i] = greedySampleWeight(field.samples[i]);
  auto sumWeightedRefSq = [&] {
    for (size_t i = 0; i < N; ++i)
      if (avoided[i]) weight[i] = 0;
    double sum = 0;
    for (size_t i = 0; i < N; ++i)
      for (double x : ref[i]) sum += weight[i] * x * x / kNormals;
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
  const double refRms = std::sqrt(weightedRefSq / weightSum);  // of the samples' irradiance
  // A sample's error counts at most errorCapRelative times refRms: next to a light the
  // irradiance (and any interpolation's error) grows without bound, over a volume so small that
  // it would otherwise draw probe after probe while the rest of the domain stays wrong.
  const double errSqCap = s.errorCapRelative > 0
                              ? (s.errorCapRelative * refRms) * (s.errorCapRelative * refRms)
                              : std::numeric_limits<double>::infinity();

  struct SampleState {
    double errSq = 0;     // mean over the normals of the squared difference
    uint64_t tet = 0;     // tetKey of the sample's tet
    bool outside = true;  // outside the hull (clamped), or never evaluated
    // Outside: the hull face it is clamped to (as in Trial::hull; 0 when not known) and its
    // squared distance to it.
    uint64_t face = 0;
    double clampD2 = 0;
  };
  std::vector<SampleState> state(N);

  /// The mesh of a probe set and the samples whose interpolation it changes.
  struct Trial {
    std::vector<size_t> changed;
    std::vector<SampleState> changedState;
    double weightedErrSq = 0;    // sum of weight * errSq over all samples after the change
    std::vector<uint64_t> hull;  // the mesh's hull faces (tetKey of their probes), sorted
    /// Points of weight 0 (the candidates, with held-out points) were left as they were: the
    /// error is right, the state is not one to commit.
    bool partial = false;
    // The mesh's tetrahedra (tetKey): in the order of the volume's, sorted on the first call.
    std::vector<uint64_t> tets;
    size_t absent = kNone;  // the slot of pos left out of the mesh (evaluate)
  };
  size_t committedAbsent = kNone;
  std::vector<uint64_t> committedHull;
  std::vector<uint64_t> committedTets;  // sorted
  // The samples of each committed tetrahedron (CSR over committedTets: those of committedTets[k]
  // are tetSamples[tetStart[k], tetStart[k + 1]), ascending) and the samples outside the hull
  // (ascending): a trial visits the samples of the tetrahedra it removed, not every sample.
  std::vector<uint32_t> tetStart, tetSamples, outsideSamples;
  double currentWeightedErrSq = 0;
  bool first = true;
  // A clamp's distance is rebuilt from float barycentric weights: its rounding grows with the
  // coordinates (a scene far from the origin) as well as with the field's size.
  const double clampMargin =
      1e-5 *
      (box.diagonal() + std::max({std::abs(box.lo.x), std::abs(box.lo.y), std::abs(box.lo.z),
                                  std::abs(box.hi.x), std::abs(box.hi.y), std::abs(box.hi.z)}));

  // Rebuilds tetStart, tetSamples and outsideSamples from state and committedTets.
  auto indexSamples = [&] {
    std::vector<uint32_t> tetOf(N);
    tetStart.assign(committedTets.size() + 1, 0);
    outsideSamples.clear();
    for (size_t i = 0; i < N; ++i) {
      const auto it = std::lower_bound(committedTets.begin(), committedTets.end(), state[i].tet);
      PS_CHECK(it != committedTets.end() && *it == state[i].tet);
      tetOf[i] = uint32_t(it - committedTets.begin());
      ++tetStart[tetOf[i] + 1];
      if (state[i].outside) outsideSamples.push_back(uint32_t(i));
    }
    for (size_t k = 0; k < committedTets.size(); ++k) tetStart[k + 1] += tetStart[k];
    tetSamples.resize(N);
    std::vector<uint32_t> fill(tetStart.begin(), tetStart.end() - 1);
    for (size_t i = 0; i < N; ++i) tetSamples[fill[tetOf[i]]++] = uint32_t(i);
  };
  // Tetrahedralizes the probes `probes` (positions, with values `values`; Delaunay, Sukys 3.2.1)
  // and interpolates the samples whose tetrahedron disappeared, and those outside the hull near a
  // change of its faces (below); every sample on the first call. `extraProbe` (a sample index or
  // kNone) is counted as a probe (error 0). `weightedOnly`: points of weight 0, which do not
  // change the error, are left as they were (Trial::partial), a trial's cost when candidates
  // outnumber the held-out points. It reads the committed state and writes nothing shared, so
  // that the trials of several candidates can run at once (tryCandidates).
  auto evaluateWith = [&](const std::vector<Vec3>& probes, const std::vector<IrrVec>& values,
                          size_t extraProbe, bool weightedOnly, size_t absent) {
    // The probes' input to the tetrahedralization: probes, less the one at `absent` (a swap's
    // probe taken out; pos keeps its slot so that every other probe keeps its index).
    std::vector<Vec3> input;
    if (absent != kNone) {
      input = probes;
      input.erase(input.begin() + std::ptrdiff_t(absent));
    }
    Tetrahedralization t;
    try {
      t = tetrahedralize(absent != kNone ? input : probes);
    } catch (const ParameterError&) {
      throw FlatProbes{};
    }
    // Tetrahedra are keyed by the slots in pos of their probes, which additions and swaps never
    // renumber (the mesh's own vertex numbers can change with the input).
    std::vector<int32_t> probeOfVertex(t.vertices.size(), -1);
    for (size_t q = 0; q < t.vertexOfInput.size(); ++q) {
      const size_t p = absent != kNone && q >= absent ? q + 1 : q;
      if (probeOfVertex[size_t(t.vertexOfInput[q])] < 0)
        probeOfVertex[size_t(t.vertexOfInput[q])] = int32_t(p);
    }
    auto keyOf = [&](const std::array<int32_t, 4>& v) {
      return tetKey({probeOfVertex[size_t(v[0])], probeOfVertex[size_t(v[1])],
                     probeOfVertex[size_t(v[2])], probeOfVertex[size_t(v[3])]});
    };
    const std::vector<ShRgb> zeroSh(t.vertices.size(), ShRgb{});
    const ProbeVolume volume = buildProbeVolume(t, zeroSh);
    const HullClamp hullClamp(volume);
    Trial trial;
    trial.absent = absent;
    // A hull face's key: the slots of its three probes, the lowest repeated (the same key
    // whichever tet holds the face and however its row is ordered).
    auto faceKey = [&](int32_t tet, int opp) {
      const auto& tv = volume.tets[size_t(tet)];
      const int32_t a = probeOfVertex[size_t(tv[size_t((opp + 1) & 3)])];
      const int32_t b = probeOfVertex[size_t(tv[size_t((opp + 2) & 3)])];
      const int32_t c = probeOfVertex[size_t(tv[size_t((opp + 3) & 3)])];
      return tetKey({a, b, c, std::min({a, b, c})});
    };
    std::vector<uint64_t> hullKeys;  // in the order of volume.hullFaces
    hullKeys.reserve(volume.hullFaces.size());
    for (const auto& [tet, opp] : volume.hullFaces) hullKeys.push_back(faceKey(tet, opp));
    trial.hull = hullKeys;
    std::sort(trial.hull.begin(), trial.hull.end());
    trial.tets.reserve(volume.tets.size());
    for (const auto& v : volume.tets) trial.tets.push_back(keyOf(v));
    if (first) {
      std::sort(trial.tets.begin(), trial.tets.end());
      trial.changed.resize(N);
      for (size_t i = 0; i < N; ++i) trial.changed[i] = i;
    } else {
      std::vector<uint64_t> sortedTets = trial.tets;
      std::sort(sortedTets.begin(), sortedTets.end());
      // A sample inside the hull changes only when its tetrahedron went. One outside keeps its
      // clamp unless the hull's faces changed near it (samples outside are most of a
      // boundary-sampled field's cost otherwise: clampToHull visits every hull face; and
      // coplanar probes on the hull, boundary samples along a floor, have more than one
      // triangulation, so the faces change at many additions). It is interpolated again when
      // its face or tetrahedron went, when a new tetrahedron's box holds it (it may now be
      // inside), or when a new hull face's box is as near as its face (it may clamp to that
      // one): every other face of the mesh was there before, and no nearer.
      std::vector<Bounds3> newTets, newFaces;
      Bounds3 newTetsBox, newFacesBox;
      const bool hullChanged = trial.hull != committedHull;
      if (hullChanged) {
        for (size_t k = 0; k < volume.tets.size(); ++k) {  // trial.tets is in this order
          if (std::binary_search(committedTets.begin(), committedTets.end(), trial.tets[k]))
            continue;
          Bounds3 b;
          for (int32_t v : volume.tets[k]) b.extend(volume.position(v));
          newTets.push_back(b);
          newTetsBox.extend(b.lo);
          newTetsBox.extend(b.hi);
        }
        for (size_t f = 0; f < volume.hullFaces.size(); ++f) {
          if (std::binary_search(committedHull.begin(), committedHull.end(), hullKeys[f])) continue;
          const auto& [tet, opp] = volume.hullFaces[f];
          Bounds3 b;
          for (int c = 1; c < 4; ++c)
            b.extend(volume.position(volume.tets[size_t(tet)][size_t((opp + c) & 3)]));
          newFaces.push_back(b);
          newFacesBox.extend(b.lo);
          newFacesBox.extend(b.hi);
        }
      }
      auto boxDist2 = [](const Bounds3& b, Vec3 p) {
        const Vec3 d = max(max(b.lo - p, p - b.hi), Vec3(0, 0, 0));
        return dot(d, d);
      };
      // The boxes are widened by the clamp margin: the walk counts a point within its
      // barycentric slack of a tetrahedron as inside it.
      const double margin2 = clampMargin * clampMargin;
      auto clampMayChange = [&](const SampleState& st, Vec3 p) {
        if (!std::binary_search(trial.hull.begin(), trial.hull.end(), st.face)) return true;
        if (boxDist2(newTetsBox, p) <= margin2)
          for (const Bounds3& b : newTets)
            if (boxDist2(b, p) <= margin2) return true;
        const double reach =
            (std::sqrt(st.clampD2) + clampMargin) * (std::sqrt(st.clampD2) + clampMargin);
        if (boxDist2(newFacesBox, p) <= reach)
          for (const Bounds3& b : newFaces)
            if (boxDist2(b, p) <= reach) return true;
        return false;
      };
      // The samples to interpolate again: those of the committed tetrahedra this mesh does not
      // have (every sample's tetrahedron is one of the committed mesh's), the extra probe, and
      // those outside the hull whose clamp may change; in ascending order, as a scan of every
      // sample would give them (the error's sum is then the same to the last bit).
      std::vector<size_t> redo;
      for (size_t k = 0, m = 0; k < committedTets.size(); ++k) {
        while (m < sortedTets.size() && sortedTets[m] < committedTets[k]) ++m;
        if (m < sortedTets.size() && sortedTets[m] == committedTets[k]) continue;
        redo.insert(redo.end(), tetSamples.begin() + tetStart[k],
                    tetSamples.begin() + tetStart[k + 1]);
      }
      if (extraProbe != kNone) redo.push_back(extraProbe);
      if (hullChanged)
        for (uint32_t i : outsideSamples)
          if (clampMayChange(state[i], point[i])) redo.push_back(i);
      std::sort(redo.begin(), redo.end());
      redo.erase(std::unique(redo.begin(), redo.end()), redo.end());
      for (size_t i : redo) {
        if (weightedOnly && weight[i] == 0 && i != extraProbe)
          trial.partial = true;
        else
          trial.changed.push_back(i);
      }
    }
    trial.changedState.resize(trial.changed.size());
    tbb::parallel_for(size_t(0), trial.changed.size(), [&](size_t q) {
      const size_t i = trial.changed[q];
      const VolumeLocation loc = locate(volume, point[i], -1, &hullClamp);
      PS_CHECK_LE(0, loc.tet);
      const auto& tv = volume.tets[size_t(loc.tet)];
      // Barycentric blend of the probes' irradiance (linear in SH, so equal to the irradiance of
      // the interpolated SH: core/traversal interpolate).
      IrrVec interp{};
      for (int c = 0; c < 4; ++c) {
        const size_t p = size_t(probeOfVertex[size_t(tv[size_t(c)])]);
        const double w = double(loc.weights[size_t(c)]);
        for (int k = 0; k < kNormals; ++k) interp[k] += w * values[p][k];
      }
      double e = 0;
      for (int k = 0; k < kNormals; ++k) e += (interp[k] - ref[i][k]) * (interp[k] - ref[i][k]);
      SampleState& st = trial.changedState[q];
      st.errSq = (isProbe[i] || i == extraProbe)
                     ? 0.0
                     : std::clamp(e / kNormals - noiseVar[i], 0.0, errSqCap);
      st.tet = keyOf(tv);
      st.outside = loc.outside;
      if (loc.outside) {
        // The clamped point, and the hull face it lies on: the one opposite a vertex of weight
        // 0 (on an edge or a corner of the hull, any of its faces there holds it).
        Vec3 on;
        for (int c = 0; c < 4; ++c)
          on = on + volume.position(tv[size_t(c)]) * double(loc.weights[size_t(c)]);
        st.clampD2 = dot(on - point[i], on - point[i]);
        st.face = 0;
        for (int c = 0; c < 4 && st.face == 0; ++c)
          if (loc.weights[size_t(c)] == 0.0f) {
            const uint64_t key = faceKey(loc.tet, c);
            if (std::binary_search(trial.hull.begin(), trial.hull.end(), key)) st.face = key;
          }
      }
    });
    double sum = first ? 0.0 : currentWeightedErrSq;
    for (size_t q = 0; q < trial.changed.size(); ++q) {
      const size_t i = trial.changed[q];
      if (!first) sum -= weight[i] * state[i].errSq;
      sum += weight[i] * trial.changedState[q].errSq;
    }
    trial.weightedErrSq = std::max(0.0, sum);
    return trial;
  };
  // The current probes (pos, vals).
  auto evaluate = [&](size_t extraProbe, bool weightedOnly = false, size_t absent = kNone) {
    return evaluateWith(pos, vals, extraProbe, weightedOnly, absent);
  };
  // GreedySettings::verifyState: the committed state against every point interpolated afresh.
  auto verify = [&] {
    first = true;
    const Trial full = evaluate(kNone, false, committedAbsent);
    first = false;
    for (size_t q = 0; q < full.changed.size(); ++q) {
      const SampleState& want = full.changedState[q];
      const SampleState& have = state[full.changed[q]];
      // A point on a face shared by two tetrahedra can be found in either, with the same
      // interpolation to float rounding of the barycentric weights: its tetrahedron need only
      // be one of the mesh's. The error is the square of a difference that can be far smaller
      // than the values, so that rounding moves it by more, relatively (up to 1.3e-4 on the
      // bundled scenes). A point outside the hull must also keep a face of the hull, at the
      // distance of the nearest (a stale clamp can keep a face and tetrahedron that still
      // exist, with an error close to the right one).
      const bool sameTet = have.tet == want.tet;
      const double tolerance = sameTet ? 1e-5 : 1e-3;
      const bool clampRight =
          !want.outside ||
          (std::binary_search(full.hull.begin(), full.hull.end(), have.face) &&
           std::abs(std::sqrt(have.clampD2) - std::sqrt(want.clampD2)) <= clampMargin);
      const bool same =
          (sameTet || std::binary_search(full.tets.begin(), full.tets.end(), have.tet)) &&
          have.outside == want.outside && clampRight &&
          std::abs(have.errSq - want.errSq) <= tolerance * want.errSq + 1e-12 * refRms * refRms;
      result.stateMismatches += same ? 0 : 1;
    }
  };
  // A trial to commit, the current probes' (pos): a partial one interpolated again in full.
  auto complete = [&](Trial trial) {
    if (!trial.partial) return trial;
    Trial full = evaluate(kNone);
    result.reevaluations += full.changed.size();
    return full;
  };
  // Makes `trial` the current mesh; `record`: an addition, whose error goes into errorHistory.
  auto commit = [&](const Trial& trial, bool record = true) {
    PS_CHECK(!trial.partial);
    for (size_t q = 0; q < trial.changed.size(); ++q)
      state[trial.changed[q]] = trial.changedState[q];
    committedHull = trial.hull;
    committedTets = trial.tets;
    std::sort(committedTets.begin(), committedTets.end());
    indexSamples();
    committedAbsent = trial.absent;
    double sum = 0;  // recomputed in full so that no rounding accumulates
    for (size_t i = 0; i < N; ++i) sum += weight[i] * state[i].errSq;
    currentWeightedErrSq = sum;
    first = false;
    result.fieldError = std::sqrt(sum / weightedRefSq);
    if (record) result.errorHistory.push_back(result.fieldError);
    if (s.verifyState) verify();
  };

  try {
    commit(evaluate(kNone));
  } catch (const FlatProbes&) {
    throw ParameterError(
        "greedy: the initial probes span less than 3D (the domain of interest "
        "or the dense field is flat); use a smaller field spacing");
  }
  // Candidates, from the tetrahedra holding the most weighted error: in each, the sample worst
  // interpolated, and the sample nearest to the centroid of its samples (a bright or dark spot
  // is the worst sample but spreads its value over the whole fan of tetrahedra around it; the
  // central sample splits the tetrahedron's region instead). Ties go to the lower index.
  struct TetGroup {
    uint64_t key = 0;
    double weightedErrSq = 0;
    Vec3 positionSum;
    size_t count = 0, worst = 0;
    size_t first = 0;
  };
  // The tetrahedra with a candidate, the most weighted error first.
  auto rankTets = [&] {
    std::unordered_map<uint64_t, TetGroup> groups;
    for (size_t i = 0; i < N; ++i) {
      if (isProbe[i] || avoided[i]) continue;
      TetGroup& g = groups[state[i].tet];
      g.key = state[i].tet;
      g.weightedErrSq += weight[i] * state[i].errSq;
      if (i >= S) continue;  // a held-out point: its error counts, it is no candidate
      if (g.count == 0) {
        g.worst = i;
        g.first = i;
      }
      g.positionSum = g.positionSum + field.samples[i].position;
      ++g.count;
      if (state[i].errSq > state[g.worst].errSq) g.worst = i;
    }
    std::vector<TetGroup> ranked;
    for (const auto& [key, g] : groups)
      if (g.weightedErrSq > 0 && g.count > 0) ranked.push_back(g);
    // No error left where a candidate is: with a budget, every tetrahedron with a candidate
    // (the least harmful one goes in, as past the noise floor); without one, none.
    if (ranked.empty() && s.budget != 0)
      for (const auto& [key, g] : groups)
        if (g.count > 0) ranked.push_back(g);
    std::sort(ranked.begin(), ranked.end(), [](const TetGroup& x, const TetGroup& y) {
      return x.weightedErrSq > y.weightedErrSq ||
             (x.weightedErrSq == y.weightedErrSq && x.first < y.first);
    });
    return ranked;
  };
  // The candidates of ranked[from, to), those in `tried` left out (and added to it).
  auto candidatesOf = [&](const std::vector<TetGroup>& ranked, size_t from, size_t to,
                          std::vector<size_t>& tried) {
    std::vector<size_t> candidates;
    auto addCandidate = [&](size_t c) {
      if (std::find(tried.begin(), tried.end(), c) != tried.end()) return;
      tried.push_back(c);
      candidates.push_back(c);
    };
    for (size_t r = from; r < std::min(ranked.size(), to); ++r) {
      const TetGroup& g = ranked[r];
      addCandidate(g.worst);
      const Vec3 centroid = g.positionSum * (1.0 / double(g.count));
      size_t central = g.first;
      double bestD = std::numeric_limits<double>::infinity();
      for (size_t i = g.first; i < S; ++i) {
        if (isProbe[i] || avoided[i] || state[i].tet != g.key) continue;
        const Vec3 d = field.samples[i].position - centroid;
        if (dot(d, d) < bestD) {
          bestD = dot(d, d);
          central = i;
        }
      }
      addCandidate(central);
    }
    captureValues(candidates);
    return candidates;
  };
  // Tries each candidate as the probe at `slot` of pos (the Delaunay mesh rebuilt with it) and
  // returns the one leaving the lowest error (kNone for none), its trial in `bestTrial`. The
  // candidates' trials run at once, each on its own copy of the probes. Whichever finishes
  // first, the best is the one trying them in order would keep: the lowest error, on a tie the
  // earliest candidate, and a best from an earlier call (`best` given) wins ties. Only the best
  // so far is kept, so at most a trial per thread and the best are alive at once.
  auto tryCandidates = [&](std::span<const size_t> candidates, size_t slot, size_t& best,
                           Trial& bestTrial) {
    const bool append = slot == pos.size();
    std::vector<size_t> changedCount(candidates.size(), kNone);  // kNone: not meshed
    std::mutex bestMutex;
    size_t bestK = kNone;  // the best's index in `candidates`, when it is one of them
    tbb::parallel_for(size_t(0), candidates.size(), [&](size_t k) {
      std::vector<Vec3> probes = pos;
      std::vector<IrrVec> values = vals;
      if (append) {
        probes.emplace_back();
        values.emplace_back();
      }
      probes[slot] = field.samples[candidates[k]].position;
      values[slot] = valueAsProbe(candidates[k]);
      Trial trial;
      try {
        trial = evaluateWith(probes, values, candidates[k], true, kNone);
      } catch (const FlatProbes&) {  // a swap's candidate in the plane of the other probes
        return;
      }
      changedCount[k] = trial.changed.size();
      const std::lock_guard<std::mutex> lock(bestMutex);
      const bool none = best == kNone && bestK == kNone;
      if (none || trial.weightedErrSq < bestTrial.weightedErrSq ||
          (trial.weightedErrSq == bestTrial.weightedErrSq && bestK != kNone && k < bestK)) {
        bestTrial = std::move(trial);
        bestK = k;
      }
    });
    for (size_t count : changedCount)
      if (count != kNone) {
        result.reevaluations += count;
        ++result.trials;
      }
    if (bestK != kNone) best = candidates[bestK];
  };

  constexpr size_t kCandidateTets = 8;  // tetrahedra whose candidates are tried per addition
  constexpr size_t kMaxCandidateTets = 32;
  // Progress: an addition and a probe taken out in a swap pass count as one step each (with a
  // budget; else 0). Before the passes, each is counted as taking out every probe; once they
  // run, a pass counts the probes it takes out (the don't-look bits below skip the others, at
  // no cost), and each pass still allowed is counted as taking out as many again. Passes
  // that stop early still end in a jump, but a smaller one. The fraction never goes back.
  double steps = double(budget) + double(s.swapPasses) * double(budget - kept.size());
  double reported = 0;
  auto reportProgress = [&](double step) {
    reported = std::max(reported, s.budget != 0 ? std::min(1.0, step / steps) : 0.0);
    if (progress && !progress(reported)) throw Cancelled();
  };
  while (pos.size() < budget && !(s.maxError > 0 && result.fieldError <= s.maxError)) {
    reportProgress(double(pos.size()));
    // Each candidate is tried (the Delaunay mesh rebuilt with it); the one leaving the smallest
    // field error is added, provided that error is not larger than before: an addition never
    // makes the field worse (a new vertex can raise the error of its neighbours). When no
    // candidate of the worst kCandidateTets tetrahedra helps, the next ones are tried, up to
    // kMaxCandidateTets (once only: afterwards the first kCandidateTets).
    const std::vector<TetGroup> ranked = rankTets();
    if (ranked.empty()) break;  // no candidate left, or no error and no budget
    size_t best = kNone;
    Trial bestTrial;
    std::vector<size_t> tried;
    // Past the noise floor the wider search is not repeated at every addition.
    const size_t searchTets = result.noImprovement ? kCandidateTets : kMaxCandidateTets;
    for (size_t from = 0; from < std::min(ranked.size(), searchTets); from += kCandidateTets) {
      const std::vector<size_t> candidates =
          candidatesOf(ranked, from, from + kCandidateTets, tried);
      tryCandidates(candidates, pos.size(), best, bestTrial);
      if (best != kNone && bestTrial.weightedErrSq <= currentWeightedErrSq) break;
    }
    if (best == kNone) break;
    if (bestTrial.weightedErrSq > currentWeightedErrSq) {
      // The field's noise floor: no candidate lowers the error any more. Without a budget there
      // is nothing more to gain; with one, the least harmful candidate is added so that methods
      // stay comparable at equal probe count.
      if (!result.noImprovement) result.probesAtNoImprovement = pos.size();
      result.noImprovement = true;
      if (s.budget == 0) break;
    }
    addSample(best, std::sqrt(state[best].errSq) / refRms);
    commit(complete(std::move(bestTrial)));
  }

  // Swaps, a local search after the additions: each added probe in turn is taken out, and the
  // best of itself and the candidates of the tetrahedra then holding the most error goes back in
  // its place. An addition chose the best probe for the probes before it, not for those that
  // came after; past the noise floor, additions were the least harmful candidate. A swap never
  // raises the error (the probe staying where it was is one of the outcomes).
  // After the first pass, a probe is taken out again only when a move touched it: it moved, or
  // shared a tetrahedron with a moved probe at the old place or the new one ("don't look bits"
  // of local search). A heuristic: a probe's removal cost depends on its neighbours alone, but
  // its candidates come from the whole field, and a move elsewhere also raises the error where
  // the moved probe left, so a probe not taken out again may have missed a gain there. It
  // makes the passes after the first cost where something changed.
  const size_t keptCount = kept.size();
  const size_t swappable = result.positions.size();
  // The other swappable probes (indices into result.positions) sharing a tetrahedron of the
  // committed mesh with the probe at `slot`.
  auto neighboursOf = [&](size_t slot, std::vector<size_t>& out) {
    for (uint64_t key : committedTets)
      for (int k = 0; k < 4; ++k)
        if (((key >> (16 * k)) & 0xffff) == slot)
          for (int m = 0; m < 4; ++m) {
            const size_t other = (key >> (16 * m)) & 0xffff;
            if (other != slot && other >= keptCount) out.push_back(other - keptCount);
          }
  };
  // A swap's local candidates: the swapNeighbours field samples nearest to `at` that are not
  // probes, avoided or already in `tried` (ties to the lower index). The other candidates come
  // from wherever the error is largest once the probe is out, not from around it. The octree's
  // samples are denser where the field is refined, so the moves are smaller there. Most moves
  // are these (two-rooms at 32 probes, field seed 1: 56 of 70).
  std::vector<std::pair<double, size_t>> nearBuffer;
  auto nearestFree = [&](Vec3 at, const std::vector<size_t>& tried) {
    std::vector<size_t> out;
    if (s.swapNeighbours <= 0) return out;
    nearBuffer.clear();
    for (size_t i = 0; i < S; ++i) {
      if (isProbe[i] || avoided[i] || std::find(tried.begin(), tried.end(), i) != tried.end())
        continue;
      const Vec3 d = field.samples[i].position - at;
      nearBuffer.push_back({dot(d, d), i});
    }
    const size_t k = std::min(nearBuffer.size(), size_t(s.swapNeighbours));
    std::partial_sort(nearBuffer.begin(), nearBuffer.begin() + std::ptrdiff_t(k), nearBuffer.end());
    for (size_t m = 0; m < k; ++m) out.push_back(nearBuffer[m].second);
    return out;
  };
  std::vector<uint8_t> look(swappable, 1), lookNext(swappable, 0);
  const size_t additionTrials = result.trials;
  std::vector<SampleState> savedState;
  std::vector<uint32_t> savedTetStart, savedTetSamples, savedOutside;  // the index of savedState
  double stepsDone = double(budget);  // the additions, then each probe taken out
  for (int pass = 0; pass < s.swapPasses; ++pass) {
    const double before = result.fieldError;
    size_t swapped = 0;
    std::fill(lookNext.begin(), lookNext.end(), uint8_t(0));
    const double looked = double(std::count(look.begin(), look.end(), uint8_t(1)));
    steps = stepsDone + double(s.swapPasses - pass) * looked;
    for (size_t j = 0; j < swappable; ++j) {
      if (!look[j]) continue;
      reportProgress(stepsDone);
      stepsDone += 1;
      const size_t slot = keptCount + j;
      const size_t old = result.sampleIndex[j];
      std::vector<size_t> touched;  // neighbours at the old place (and later the new one)
      neighboursOf(slot, touched);
      // The committed state with the probe in place, restored when it stays: the same set
      // tetrahedralized again would give the same error (to rounding), at a full
      // re-interpolation's cost.
      savedState = state;
      savedTetStart = tetStart;
      savedTetSamples = tetSamples;
      savedOutside = outsideSamples;
      const std::vector<uint64_t> savedHull = committedHull, savedTets = committedTets;
      const double savedErrSq = currentWeightedErrSq, savedError = result.fieldError;
      const size_t savedAbsent = committedAbsent;
      isProbe[old] = 0;
      try {
        const Trial out = evaluate(kNone, false, slot);
        result.reevaluations += out.changed.size();
        commit(out, false);
      } catch (const FlatProbes&) {  // the others span less than 3D: this probe stays
        isProbe[old] = 1;
        continue;
      }
      ++result.swapTries;
      std::vector<size_t> tried{old};
      size_t best = kNone;
      Trial bestTrial;
      std::vector<size_t> candidates = candidatesOf(rankTets(), 0, kCandidateTets, tried);
      const std::vector<size_t> local = nearestFree(field.samples[old].position, tried);
      captureValues(local);
      candidates.insert(candidates.end(), local.begin(), local.end());
      tryCandidates(candidates, slot, best, bestTrial);
      // Only a clear gain moves a probe (the same probe set can mesh differently, its error
      // differing by rounding).
      if (best == kNone || !(bestTrial.weightedErrSq < savedErrSq * (1 - 1e-9))) {
        isProbe[old] = 1;
        std::swap(state, savedState);
        committedHull = savedHull;
        committedTets = savedTets;
        std::swap(tetStart, savedTetStart);
        std::swap(tetSamples, savedTetSamples);
        std::swap(outsideSamples, savedOutside);
        committedAbsent = savedAbsent;
        currentWeightedErrSq = savedErrSq;
        result.fieldError = savedError;
        if (s.verifyState) verify();
        continue;
      }
      pos[slot] = field.samples[best].position;
      vals[slot] = valueAsProbe(best);
      isProbe[best] = 1;
      ++swapped;
      if (std::find(local.begin(), local.end(), best) != local.end()) ++result.localSwaps;
      result.positions[j] = field.samples[best].position;
      result.sampleIndex[j] = best;
      result.scores[j] = std::sqrt(state[best].errSq) / refRms;
      commit(complete(std::move(bestTrial)), false);
      neighboursOf(slot, touched);
      touched.push_back(j);
      for (size_t k : touched) {
        lookNext[k] = 1;
        if (k > j && !look[k]) {  // still ahead in this pass: one more step
          look[k] = 1;
          steps += 1;
        }
      }
    }
    result.swaps += swapped;
    result.swapTrials = result.trials - additionTrials;
    ++result.swapPasses;
    result.swapErrorHistory.push_back(result.fieldError);
    if (swapped == 0 || !(result.fieldError < before * (1 - s.swapMinGain))) break;
    look.swap(lookNext);
  }
  return result;
}

}  // namespace ps
