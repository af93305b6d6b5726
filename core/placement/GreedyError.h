#pragma once
// The error greedy placement lowers (placeGreedy, Greedy.h): the points it is measured at, each
// point's interpolation from the Delaunay mesh of a probe set, and the committed mesh that a
// trial of a changed probe set is measured against, so that a trial interpolates only the
// points its change can move. Greedy's own: nothing outside core/placement/Greedy*.cpp uses it.
//
// Units: positions in metres; irradiance as its luminance (the scene's radiometric unit, W/m^2
// for the bundled rigs), over the 14 fixed normals of greedyErrorNormalsIrradiance; a point's
// squared error in that unit squared; weights are volumes in any unit, the same for all points.
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "core/math/Vec3.h"
#include "core/placement/Greedy.h"

namespace ps::greedy {

inline constexpr int kNormals = 14;  ///< the normals of greedyErrorNormalsIrradiance
/// A point's irradiance luminance for each of the kNormals normals.
using IrrVec = std::array<double, kNormals>;
/// The normals the error is measured for: the 6 axes, then the 8 cube diagonals.
const std::array<Vec3, kNormals>& errorNormals();

/// kPerceptual: a point's capture resolves its light when its mean luminance is above this many
/// standard deviations of its noise (about 95 % confidence, one-sided 1.64 sigma rounded up).
inline constexpr double kResolvedSigmas = 2.0;

/// locate()'s weights lie within this of the exact barycentrics of the point in the tetrahedron
/// of the float positions (core/traversal/ProbeVolume.h), each.
inline constexpr double kWeightRoundingBound = 1e-7;
/// countMismatches' factor on the sum of two states' roundoff bounds: the bounds are first-order
/// (the perceptual objective's logarithm, the renormalisation's quotient), and the comparison
/// must not flag a state that rounding alone explains.
inline constexpr double kRoundoffMargin = 4.0;

/// Probe slots are packed in 16 bits (tetKey): at most this many probes, kept ones included.
inline constexpr size_t kMaxProbes = 65535;
/// No point (held-out points follow the field's samples, so the point count is an index too).
inline constexpr size_t kNone = std::numeric_limits<size_t>::max();

/// Thrown when the probes span less than 3D (no tetrahedralization).
struct FlatProbes {};

/// A tetrahedron's probe set as one key: the probes' slots sorted, 16 bits each. A hull face
/// is keyed the same way with its lowest slot repeated. Slots must be below 65536.
uint64_t tetKey(std::array<int32_t, 4> v);

/// The points greedy measures its error at: the dense field's samples [0, fieldCount), which
/// are also the candidates, then the held-out points [fieldCount, count).
struct ErrorPoints {
  size_t fieldCount = 0;
  size_t count = 0;
  std::vector<Vec3> position;
  /// Reference irradiance of each point: its own capture's (greedyErrorNormalsIrradiance).
  std::vector<IrrVec> ref;
  /// The variance of each point's error from its capture noise (the SH coefficients'
  /// standard errors, taken as independent, through E(n) = sum A_l c_lm Y_lm(n)), averaged over
  /// the normals, in the objective's unit squared (irradiance^2; stops^2 once weighErrorPoints
  /// has converted it for kPerceptual): a point's squared error less this estimates its true
  /// squared error, so that
  /// greedy does not chase the cheap capture's noise. (The probes' own noise, carried into the
  /// interpolation, is not subtracted: next to a light it is so large that it would hide the
  /// harm a bright probe does to its whole fan of tetrahedra.)
  std::vector<double> noiseVar;
  /// Inside the light clearance (GreedySettings::avoid): weight 0, and never a candidate.
  std::vector<char> avoided;
  /// The volume each point stands for in the error (weighErrorPoints); 0: no part in it.
  std::vector<double> weight;
  GreedyObjective objective = GreedyObjective::kEnergy;
  double weightedRefSq = 0;  ///< sum of weight |ref|^2 / kNormals
  double refRms = 0;         ///< sqrt(weightedRefSq / sum of weights): the RMS irradiance
  /// fieldError = sqrt(sum weight errSq / errorNorm): weightedRefSq for kEnergy, the sum of the
  /// weights for kPerceptual.
  double errorNorm = 0;
  /// A point's error as a score is sqrt(errSq) / scoreUnit: refRms for kEnergy (relative to the
  /// RMS irradiance), 1 for kPerceptual (stops).
  double scoreUnit = 1;
  /// kPerceptual: the luminance below which values count as the floor (errorStops), the
  /// weighted median of the points' mean luminance over the normals times
  /// kAdaptationFloorFraction; 0 for kEnergy.
  double floorLuminance = 0;
  /// The weighted share of the points whose capture resolves no light: their mean luminance
  /// over the normals is 0 or below kResolvedSigmas standard deviations of its noise. Where
  /// it is large, the cheap captures miss the light (a scene lit through rare hits of a small
  /// emitter) and the perceptual objective, a ratio, measures their noise.
  double unresolvedShare = 0;
  /// A point's squared error counts at most this (GreedySettings::errorCapRelative; infinite
  /// when off).
  double errSqCap = std::numeric_limits<double>::infinity();
  Bounds3 fieldBox;  ///< of the field's samples
  /// How far a clamp's distance rebuilt from float barycentric weights can be off, metres.
  double clampMargin = 0;
};

/// The points of `field` and `settings.heldOut`, with their reference irradiance, noise
/// variance, light clearance, bounding box and clamp margin; the weights are left to
/// weighErrorPoints. Throws ps::ParameterError when every point is black. O(points), the
/// irradiance and noise in parallel.
ErrorPoints gatherErrorPoints(const DenseField& field, const GreedySettings& settings);

/// Sets the objective, weights, weightedRefSq, refRms, errorNorm, scoreUnit, floorLuminance and
/// errSqCap of `points`, and converts noiseVar to the objective's unit: a field sample stands for
/// greedySampleWeight (uniform weights when the field records no cell sizes, or when those leave
/// no lit sample outside the light clearance); with held-out points, they alone carry weight
/// (theirs), unless they are all black or in the clearance. Throws ps::ParameterError when every
/// lit sample of the field is in the light clearance. O(points).
void weighErrorPoints(ErrorPoints& points, const DenseField& field, const GreedySettings& settings);

/// A probe slot's part in the visibility-aware interpolant (GreedySettings::visibility): its
/// map (kVisibilityFloats floats, core/capture/Capture.h; null: visibility 1) and whether its
/// capture found it inside geometry (visibility 0). The map must outlive the trials.
struct SlotVisibility {
  const float* map = nullptr;
  bool inside = false;
};

/// A point's interpolation from a mesh.
struct SampleState {
  /// Mean over the normals of the squared error (the objective's), noise and cap applied.
  double errSq = 0;
  uint64_t tet = 0;     ///< tetKey of the point's tetrahedron
  bool outside = true;  ///< outside the hull (clamped), or never interpolated
  /// The visibility-aware weights are fragile: they fell back (VisibleFallback), or the probes
  /// that see the point hold less than 1e-4 of its barycentric weight, so that a point on a
  /// face shared by two tetrahedra reads differently in each (countMismatches allows it).
  bool fragile = false;
  /// The RMS over the normals of the interpolation's error, before the noise is subtracted and
  /// the cap applied (errSq comes from its square), in the objective's unit.
  double rmsError = 0;
  /// A bound on how far this evaluation's interpolated values lie from the exact interpolation
  /// of the same probes at the same point, in the objective's unit (the largest over the
  /// normals): the float barycentric weights' rounding (locate's contract,
  /// kWeightRoundingBound), amplified by the visibility-aware renormalisation, and for a clamped
  /// point the clamp's position rounding (ErrorPoints::clampMargin) times the interpolant's
  /// gradient. Two evaluations whose exact interpolations agree (the same tetrahedron, or two
  /// sharing the face the point lies on) differ by at most the sum of their bounds.
  double roundoff = 0;
  /// Outside: the hull face it is clamped to (as in Trial::hull; 0 when not known) and its
  /// squared distance to it (m^2).
  uint64_t face = 0;
  double clampD2 = 0;
};

/// The mesh of a probe set and the points whose interpolation it changes.
struct Trial {
  std::vector<size_t> changed;  ///< ascending
  std::vector<SampleState> changedState;
  double weightedErrSq = 0;    ///< sum of weight * errSq over all points after the change
  std::vector<uint64_t> hull;  ///< the mesh's hull faces (tetKey of their probes), sorted
  /// Points of weight 0 (the candidates, with held-out points) were left as they were: the
  /// error is right, the state is not one to commit.
  bool partial = false;
  /// The mesh's tetrahedra (tetKey): sorted when every point was interpolated, else in the
  /// order of the mesh's own.
  std::vector<uint64_t> tets;
  size_t absent = kNone;  ///< the probe slot left out of the mesh
};

/// The committed mesh: every point's state and what a trial reads to find the points it moves.
struct CommittedMesh {
  std::vector<SampleState> state;  ///< per point
  size_t absent = kNone;           ///< the probe slot left out of it (a swap's probe taken out)
  std::vector<uint64_t> hull;      ///< sorted
  std::vector<uint64_t> tets;      ///< sorted
  /// The points of each tetrahedron (CSR over tets: those of tets[k] are
  /// tetSamples[tetStart[k], tetStart[k + 1]), ascending) and the points outside the hull
  /// (ascending): a trial visits the points of the tetrahedra it removed, not every point.
  std::vector<uint32_t> tetStart, tetSamples, outsideSamples;
  double weightedErrSq = 0;  ///< sum of weight * errSq, summed in full at each commit
};

/// Which points a trial interpolates.
enum class TrialScope {
  kAllPoints,      ///< every point, afresh (the first mesh; a check of the committed state)
  kChangedPoints,  ///< those the change from the committed mesh can move
  /// Of those, only the points of weight > 0 and the extra probe: the error is exact, the state
  /// partial (Trial::partial). A candidate's trial, when candidates outnumber the weighted points.
  kChangedWeightedPoints,
};

/// The committed mesh of greedy's probes and the trials measured against it.
class GreedyErrorState {
 public:
  /// `points` must outlive this and keep its weights from the first trial on.
  explicit GreedyErrorState(const ErrorPoints& points);

  /// Tetrahedralizes `probes` (positions in metres, with irradiance `values`; Delaunay, Sukys
  /// 3.2.1) less the slot `absent` (kNone: none; the others keep their slots), and interpolates
  /// the points `scope` names: with kChangedPoints, those whose tetrahedron disappeared, those
  /// outside the hull near a change of its faces, and `extraProbe`. `isProbe` (per point) and
  /// `extraProbe` (a point index or kNone) count as probes: error 0. Reads the committed state
  /// and writes nothing shared, so that several trials can run at once. Throws FlatProbes when
  /// the probes span less than 3D. `visibility` (per slot, or empty): the points interpolate
  /// with the visibility-aware weights (combineVisibleWeights, core/traversal/
  /// VisibleInterpolation.h, without the normal term, as eval's default), else with the
  /// barycentric weights. A point's weights depend on its tetrahedron's probes alone, so the
  /// points a change can move are the same either way. Cost: the tetrahedralization (O(P log P)
  /// expected for P probes) plus a point location (and four map lookups) per point
  /// interpolated, those in parallel.
  Trial evaluate(const std::vector<Vec3>& probes, const std::vector<IrrVec>& values,
                 const std::vector<SlotVisibility>& visibility, const std::vector<char>& isProbe,
                 size_t extraProbe, size_t absent, TrialScope scope) const;

  /// Makes `trial` (not partial) the committed mesh and returns its weighted squared error,
  /// summed in full over every point so that no rounding accumulates. O(points log tets).
  double commit(const Trial& trial);

  /// Points whose committed state differs from `full` (a kAllPoints trial of the same probes)
  /// beyond the rounding that a different but equivalent tetrahedron or clamp can give: their
  /// squared errors may differ by what the two states' roundoff bounds allow
  /// (2 r D + D^2 for an RMS error r and D = kRoundoffMargin times the sum of the bounds).
  size_t countMismatches(const Trial& full) const;

  const CommittedMesh& committed() const { return mesh_; }
  /// For a swap, which saves the committed mesh and swaps it back when its probe stays.
  CommittedMesh& committed() { return mesh_; }

 private:
  /// Rebuilds mesh_'s tetStart, tetSamples and outsideSamples from its state and tets.
  void indexSamples();

  const ErrorPoints& points_;
  CommittedMesh mesh_;
};

}  // namespace ps::greedy
