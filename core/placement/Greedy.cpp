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
#include "core/placement/GreedyError.h"

namespace ps {

using greedy::ErrorPoints;
using greedy::FlatProbes;
using greedy::GreedyErrorState;
using greedy::IrrVec;
using greedy::kMaxProbes;
using greedy::kNone;
using greedy::kNormals;
using greedy::Trial;
using greedy::TrialScope;

namespace {

constexpr size_t kCandidateTets = 8;      ///< tetrahedra whose candidates an addition tries first
constexpr size_t kMaxCandidateTets = 32;  ///< ... and at most, when none of those helps

/// The probe count placeGreedy stops at: the budget, or with none every field sample (at most
/// kMaxProbes). Throws ps::ParameterError for a field of fewer than 4 samples or a budget above
/// kMaxProbes.
size_t greedyBudget(const DenseField& field, size_t keptCount, const GreedySettings& s) {
  const size_t S = field.samples.size();
  if (S < 4)
    throw ParameterError("greedy: the dense field has " + std::to_string(S) +
                         " valid samples; at least 4 are needed (use a smaller field spacing)");
  const size_t budget = s.budget != 0 ? size_t(s.budget) : std::min(kMaxProbes, keptCount + S);
  if (budget > kMaxProbes)
    throw ParameterError("budget: at most 65535 probes, got " + std::to_string(budget));

  return budget;
}

/// A tetrahedron of the committed mesh with its candidates: the weighted squared error of its
/// points, and of its free field samples (not probes, not avoided) their count, position sum,
/// the worst interpolated and the first (lowest index).
struct TetGroup {
  uint64_t key = 0;
  double weightedErrSq = 0;
  Vec3 positionSum;
  size_t count = 0, worst = 0;
  size_t first = 0;
};

/// Greedy placement's search (placeGreedy, Greedy.h): the probes, their candidates and the
/// steps that add and move probes, over the error state of GreedyErrorState. placeGreedy runs
/// the steps once each, in the order they are declared. Probe slots: the kept probes first,
/// then the new ones in result order (a new probe j has slot kept + j).
class GreedySearch {
 public:
  /// The measurement points, the kept probes and the probe-value cache. Throws
  /// ps::ParameterError for a field of fewer than 4 samples, a budget above kMaxProbes, or a
  /// black field.
  GreedySearch(const DenseField& field, std::span<const KeptProbe> kept,
               const GreedySettings& settings, const ProgressFn& progress);

  /// Adds the free field samples nearest to the corners of the field's bounding box: 8
  /// corners, or the 4 alternate ones when the budget leaves fewer than 8 new probes (stopping
  /// at a corner with no free sample). Captures their values. O(8 x samples).
  void addInitialSamples();
  /// The points' weights (weighErrorPoints); throws as it does.
  void weighPoints() {
    weighErrorPoints(points_, field_, s_);
    result_.unresolvedShare = points_.unresolvedShare;
    result_.errorNorm = points_.errorNorm;
  }
  /// Interpolates every point from the initial probes and commits that mesh. Throws
  /// ps::ParameterError when they span less than 3D.
  void commitInitialMesh();
  /// Adds probes, one addition at a time, until the budget or the error target is reached or
  /// no candidate is left (or, without a budget, none lowers the error). Throws ps::Cancelled.
  void addUntilDone();
  /// Swap passes (GreedySettings::swapPasses) over the new probes. Throws ps::Cancelled.
  void swapUntilDone();

  GreedyResult takeResult() { return std::move(result_); }

 private:
  // Probe values.
  void captureValues(std::span<const size_t> samples);
  const IrrVec& valueAsProbe(size_t i) const;
  greedy::SlotVisibility visibilityAsProbe(size_t i) const;
  void addSample(size_t i, double score);

  // The error state.
  Trial evaluate(size_t extraProbe, size_t absent, TrialScope scope) const {
    return error_.evaluate(pos_, vals_, vis_, isProbe_, extraProbe, absent, scope);
  }
  double currentWeightedErrSq() const { return error_.committed().weightedErrSq; }
  /// The current error of field sample i as a probe's score (ErrorPoints::scoreUnit).
  double scoreOf(size_t i) const {
    return std::sqrt(error_.committed().state[i].errSq) / points_.scoreUnit;
  }
  Trial complete(Trial trial);
  void commit(const Trial& trial, bool record = true);
  void verify();

  // Candidates.
  std::vector<TetGroup> rankTets() const;
  std::vector<size_t> candidatesOf(const std::vector<TetGroup>& ranked, size_t from, size_t to,
                                   std::vector<size_t>& tried);
  void tryCandidates(std::span<const size_t> candidates, size_t slot, size_t& best,
                     Trial& bestTrial);

  // Additions and swaps.
  bool addOne();
  bool swapOne(size_t j, std::vector<uint8_t>& look, std::vector<uint8_t>& lookNext);
  bool takeOut(size_t slot, size_t old);
  void putBack(size_t old, double savedError);
  void neighboursOf(size_t slot, std::vector<size_t>& out) const;
  std::vector<size_t> nearestFree(Vec3 at, const std::vector<size_t>& tried);
  void reportProgress(double step);

  const DenseField& field_;
  std::span<const KeptProbe> kept_;
  const GreedySettings& s_;
  const ProgressFn& progress_;
  const size_t budget_;
  ErrorPoints points_;
  GreedyErrorState error_;  ///< reads points_: declared after it
  /// The probes, kept ones first: positions (metres) and irradiance (IrrVec).
  std::vector<Vec3> pos_;
  std::vector<IrrVec> vals_;
  /// With GreedySettings::visibility: per slot, the probe's map and validity; else empty.
  std::vector<greedy::SlotVisibility> vis_;
  /// Per point: a probe (a kept probe's position, or a sample added): error 0, no candidate.
  std::vector<char> isProbe_;
  /// With captureProbeValues: each field sample's own capture, once made (haveProbeVal_).
  std::vector<IrrVec> probeVal_;
  std::vector<char> haveProbeVal_;
  /// With visibility: each captured sample's map (kVisibilityFloats floats, or empty) and
  /// validity. Sized once, so that the maps' storage never moves under vis_.
  std::vector<std::vector<float>> probeMap_;
  std::vector<char> probeInside_;
  GreedyResult result_;
  // Progress: the steps counted in all, and the fraction reported so far (never lowered).
  double steps_ = 0;
  double reported_ = 0;
  greedy::CommittedMesh saved_;  ///< a swap's committed mesh with its probe in place
  std::vector<std::pair<double, size_t>> nearBuffer_;  ///< nearestFree's, kept for its capacity
};

GreedySearch::GreedySearch(const DenseField& field, std::span<const KeptProbe> kept,
                           const GreedySettings& s, const ProgressFn& progress)
    : field_(field),
      kept_(kept),
      s_(s),
      progress_(progress),
      budget_(greedyBudget(field, kept.size(), s)),
      points_(greedy::gatherErrorPoints(field, s)),
      error_(points_) {
  for (const KeptProbe& k : kept) {
    pos_.push_back(k.position);
    vals_.push_back(greedyErrorNormalsIrradiance(k.sh));
    if (s.visibility) {
      PS_CHECK(k.distanceMoments.empty() || k.distanceMoments.size() == size_t(kVisibilityFloats));
      vis_.push_back({k.distanceMoments.empty() ? nullptr : k.distanceMoments.data(), k.inside});
    }
  }
  // A sample at a kept probe's position is that probe: never a candidate, error 0.
  isProbe_.assign(points_.count, 0);
  auto less = [](const Vec3& a, const Vec3& b) {
    return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
  };
  std::vector<Vec3> keptAt;
  for (const KeptProbe& k : kept) keptAt.push_back(k.position);
  std::sort(keptAt.begin(), keptAt.end(), less);
  if (!keptAt.empty())
    for (size_t i = 0; i < points_.fieldCount; ++i)
      isProbe_[i] =
          std::binary_search(keptAt.begin(), keptAt.end(), points_.position[i], less) ? 1 : 0;
  // New probes are free field samples (not a kept probe's, not in the light clearance): a
  // budget past them cannot be met, and is refused before any trial.
  if (s.budget != 0) {
    size_t free = 0;
    for (size_t i = 0; i < points_.fieldCount; ++i)
      free += !isProbe_[i] && !points_.avoided[i] ? 1 : 0;
    if (budget_ > kept.size() + free)
      throw ParameterError("budget", "expected at most " + std::to_string(kept.size() + free) +
                                         " probes: the dense field has " + std::to_string(free) +
                                         " samples to place new probes on (a finer field has "
                                         "more), got " +
                                         std::to_string(budget_));
  }
  if (s.captureProbeValues) {
    probeVal_.resize(points_.fieldCount);
    haveProbeVal_.assign(points_.fieldCount, 0);
    if (s.visibility) {
      probeMap_.resize(points_.fieldCount);
      probeInside_.assign(points_.fieldCount, 0);
    }
  }
  // Progress: an addition and a probe taken out in a swap pass count as one step each (with a
  // budget; else 0). Before the passes, each is counted as taking out every probe; once they
  // run, a pass counts the probes it takes out (the don't-look bits of swapUntilDone skip the
  // others, at no cost), and each pass still allowed is counted as taking out as many again.
  // Passes that stop early still end in a jump, but a smaller one.
  steps_ = double(budget_) + double(s.swapPasses) * double(budget_ - kept.size());
}

/// Reports the fraction step / steps_ (0 without a budget), never less than before. Throws
/// ps::Cancelled when the progress callback returns false.
void GreedySearch::reportProgress(double step) {
  reported_ = std::max(reported_, s_.budget != 0 ? std::min(1.0, step / steps_) : 0.0);
  if (progress_ && !progress_(reported_)) throw Cancelled();
}

/// With captureProbeValues, captures the samples (field sample indices) not captured yet, in
/// one batch in order of first appearance; otherwise nothing.
void GreedySearch::captureValues(std::span<const size_t> samples) {
  if (!s_.captureProbeValues) return;
  std::vector<size_t> missing;
  for (size_t i : samples)
    if (!haveProbeVal_[i] && std::find(missing.begin(), missing.end(), i) == missing.end())
      missing.push_back(i);
  if (missing.empty()) return;
  std::vector<Vec3> at;
  for (size_t i : missing) at.push_back(points_.position[i]);
  std::vector<GreedyProbeValue> got = s_.captureProbeValues(at);
  PS_CHECK_EQ(got.size(), missing.size());
  for (size_t k = 0; k < missing.size(); ++k) {
    probeVal_[missing[k]] = greedyErrorNormalsIrradiance(got[k].sh);
    haveProbeVal_[missing[k]] = 1;
    if (s_.visibility) {
      PS_CHECK(got[k].distanceMoments.empty() ||
               got[k].distanceMoments.size() == size_t(kVisibilityFloats));
      probeMap_[missing[k]] = std::move(got[k].distanceMoments);
      probeInside_[missing[k]] = got[k].inside ? 1 : 0;
    }
  }
}

/// Field sample i's value as a probe: its own capture (captureValues must have made it), or
/// its field capture.
const IrrVec& GreedySearch::valueAsProbe(size_t i) const {
  return s_.captureProbeValues ? probeVal_[i] : points_.ref[i];
}

/// Field sample i's part in the visibility-aware interpolant (captureValues must have made it).
greedy::SlotVisibility GreedySearch::visibilityAsProbe(size_t i) const {
  return {probeMap_[i].empty() ? nullptr : probeMap_[i].data(), probeInside_[i] != 0};
}

/// Makes field sample i a new probe (the next slot) with provenance `score`.
void GreedySearch::addSample(size_t i, double score) {
  captureValues(std::span<const size_t>(&i, 1));
  isProbe_[i] = 1;
  pos_.push_back(field_.samples[i].position);
  vals_.push_back(valueAsProbe(i));
  if (s_.visibility) vis_.push_back(visibilityAsProbe(i));
  result_.positions.push_back(field_.samples[i].position);
  result_.sampleIndex.push_back(i);
  result_.scores.push_back(score);
}

void GreedySearch::addInitialSamples() {
  // The nearest sample to each corner of the samples' bounding box (ties to the lower index);
  // the 4 alternate corners (000, 110, 101, 011) are affinely independent and come first.
  const Bounds3& box = points_.fieldBox;
  const int cornerOrder[8] = {0, 3, 5, 6, 1, 2, 4, 7};
  const int corners = budget_ >= kept_.size() + 8 ? 8 : 4;
  for (int c = 0; c < corners; ++c) {
    const int bits = cornerOrder[c];
    const Vec3 corner((bits & 1) ? box.hi.x : box.lo.x, (bits & 2) ? box.hi.y : box.lo.y,
                      (bits & 4) ? box.hi.z : box.lo.z);
    size_t best = kNone;
    double bestD = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < points_.fieldCount; ++i) {
      if (isProbe_[i] || points_.avoided[i]) continue;
      const Vec3 dv = field_.samples[i].position - corner;
      const double d = dot(dv, dv);
      if (d < bestD) {
        bestD = d;
        best = i;
      }
    }
    if (best == kNone) break;
    addSample(best, 0.0);
  }
  result_.initialCount = result_.positions.size();
}

/// A trial to commit, of the current probes: a partial one is interpolated again in full.
Trial GreedySearch::complete(Trial trial) {
  if (!trial.partial) return trial;
  Trial full = evaluate(kNone, kNone, TrialScope::kChangedPoints);
  result_.reevaluations += full.changed.size();
  return full;
}

/// Makes `trial` the committed mesh and sets the field error; `record`: an addition, whose
/// error goes into errorHistory.
void GreedySearch::commit(const Trial& trial, bool record) {
  const double sum = error_.commit(trial);
  result_.fieldError = std::sqrt(sum / points_.errorNorm);
  if (record) result_.errorHistory.push_back(result_.fieldError);
  if (s_.verifyState) verify();
}

/// GreedySettings::verifyState: the committed state against every point interpolated afresh.
void GreedySearch::verify() {
  const Trial full = evaluate(kNone, error_.committed().absent, TrialScope::kAllPoints);
  result_.stateMismatches += error_.countMismatches(full);
}

void GreedySearch::commitInitialMesh() {
  try {
    commit(evaluate(kNone, kNone, TrialScope::kAllPoints));
  } catch (const FlatProbes&) {
    throw ParameterError(
        "greedy: the initial probes span less than 3D (the domain of interest "
        "or the dense field is flat); use a smaller field spacing");
  }
}

/// The tetrahedra of the committed mesh with a candidate, the most weighted error first (ties
/// to the lower first sample). With no error left where a candidate is: with a budget, every
/// tetrahedron with a candidate (the least harmful one goes in, as past the noise floor);
/// without one, none. O(points + tets log tets).
std::vector<TetGroup> GreedySearch::rankTets() const {
  const std::vector<greedy::SampleState>& state = error_.committed().state;
  std::unordered_map<uint64_t, TetGroup> groups;
  for (size_t i = 0; i < points_.count; ++i) {
    if (isProbe_[i] || points_.avoided[i]) continue;
    TetGroup& g = groups[state[i].tet];
    g.key = state[i].tet;
    g.weightedErrSq += points_.weight[i] * state[i].errSq;
    if (i >= points_.fieldCount) continue;  // a held-out point: its error counts, no candidate
    if (g.count == 0) {
      g.worst = i;
      g.first = i;
    }
    g.positionSum = g.positionSum + field_.samples[i].position;
    ++g.count;
    if (state[i].errSq > state[g.worst].errSq) g.worst = i;
  }
  std::vector<TetGroup> ranked;
  for (const auto& [key, g] : groups)
    if (g.weightedErrSq > 0 && g.count > 0) ranked.push_back(g);
  if (ranked.empty() && s_.budget != 0)
    for (const auto& [key, g] : groups)
      if (g.count > 0) ranked.push_back(g);
  std::sort(ranked.begin(), ranked.end(), [](const TetGroup& x, const TetGroup& y) {
    return x.weightedErrSq > y.weightedErrSq ||
           (x.weightedErrSq == y.weightedErrSq && x.first < y.first);
  });
  return ranked;
}

/// The candidates of ranked[from, to), captured (captureValues), those in `tried` left out
/// (and the new ones added to it). In each tetrahedron: the sample worst interpolated, and the
/// sample nearest to the centroid of its samples (ties to the lower index). A bright or dark
/// spot is the worst sample but spreads its value over the whole fan of tetrahedra around it;
/// the central sample splits the tetrahedron's region instead. O((to - from) samples).
std::vector<size_t> GreedySearch::candidatesOf(const std::vector<TetGroup>& ranked, size_t from,
                                               size_t to, std::vector<size_t>& tried) {
  const std::vector<greedy::SampleState>& state = error_.committed().state;
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
    for (size_t i = g.first; i < points_.fieldCount; ++i) {
      if (isProbe_[i] || points_.avoided[i] || state[i].tet != g.key) continue;
      const Vec3 d = field_.samples[i].position - centroid;
      if (dot(d, d) < bestD) {
        bestD = dot(d, d);
        central = i;
      }
    }
    addCandidate(central);
  }
  captureValues(candidates);
  return candidates;
}

/// Tries each candidate as the probe at `slot` of pos_ (pos_.size(): a new slot; the Delaunay
/// mesh rebuilt with it) and sets `best` to the one leaving the lowest error, its trial in
/// `bestTrial`; leaves both when none can be meshed. The candidates' trials run at once, each
/// on its own copy of the probes. Whichever finishes first, the best is the one trying them in
/// order would keep: the lowest error, on a tie the earliest candidate, and a best from an
/// earlier call (`best` given) wins ties. Only the best so far is kept, so at most a trial per
/// thread and the best are alive at once. Counts the trials and their re-interpolated points.
void GreedySearch::tryCandidates(std::span<const size_t> candidates, size_t slot, size_t& best,
                                 Trial& bestTrial) {
  const bool append = slot == pos_.size();
  std::vector<size_t> changedCount(candidates.size(), kNone);  // kNone: not meshed
  std::mutex bestMutex;
  size_t bestK = kNone;  // the best's index in `candidates`, when it is one of them
  tbb::parallel_for(size_t(0), candidates.size(), [&](size_t k) {
    std::vector<Vec3> probes = pos_;
    std::vector<IrrVec> values = vals_;
    std::vector<greedy::SlotVisibility> vis = vis_;
    if (append) {
      probes.emplace_back();
      values.emplace_back();
      if (s_.visibility) vis.emplace_back();
    }
    probes[slot] = field_.samples[candidates[k]].position;
    values[slot] = valueAsProbe(candidates[k]);
    if (s_.visibility) vis[slot] = visibilityAsProbe(candidates[k]);
    Trial trial;
    try {
      trial = error_.evaluate(probes, values, vis, isProbe_, candidates[k], kNone,
                              TrialScope::kChangedWeightedPoints);
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
      result_.reevaluations += count;
      ++result_.trials;
    }
  if (bestK != kNone) best = candidates[bestK];
}

/// One addition: each candidate is tried (the Delaunay mesh rebuilt with it); the one leaving
/// the smallest field error is added, provided that error is not larger than before: an
/// addition never makes the field worse (a new vertex can raise the error of its neighbours).
/// When no candidate of the worst kCandidateTets tetrahedra helps, the next ones are tried, up
/// to kMaxCandidateTets (once only: past the noise floor, the first kCandidateTets). Returns
/// false, adding nothing, when there is no candidate or, without a budget, none helps.
bool GreedySearch::addOne() {
  const std::vector<TetGroup> ranked = rankTets();
  if (ranked.empty()) return false;  // no candidate left, or no error and no budget
  size_t best = kNone;
  Trial bestTrial;
  std::vector<size_t> tried;
  const size_t searchTets = result_.noImprovement ? kCandidateTets : kMaxCandidateTets;
  for (size_t from = 0; from < std::min(ranked.size(), searchTets); from += kCandidateTets) {
    const std::vector<size_t> candidates = candidatesOf(ranked, from, from + kCandidateTets, tried);
    tryCandidates(candidates, pos_.size(), best, bestTrial);
    if (best != kNone && bestTrial.weightedErrSq <= currentWeightedErrSq()) break;
  }
  if (best == kNone) return false;
  if (bestTrial.weightedErrSq > currentWeightedErrSq()) {
    // The field's noise floor: no candidate lowers the error any more. Without a budget there
    // is nothing more to gain; with one, the least harmful candidate is added so that methods
    // stay comparable at equal probe count.
    if (!result_.noImprovement) result_.probesAtNoImprovement = pos_.size();
    result_.noImprovement = true;
    if (s_.budget == 0) return false;
  }
  addSample(best, scoreOf(best));
  commit(complete(std::move(bestTrial)));
  return true;
}

void GreedySearch::addUntilDone() {
  while (pos_.size() < budget_ && !(s_.maxError > 0 && result_.fieldError <= s_.maxError)) {
    reportProgress(double(pos_.size()));
    if (!addOne()) break;
  }
}

/// Appends to `out` the other new probes (indices into result_.positions) sharing a tetrahedron
/// of the committed mesh with the probe at `slot` (repeats included). O(tets).
void GreedySearch::neighboursOf(size_t slot, std::vector<size_t>& out) const {
  const size_t keptCount = kept_.size();
  for (uint64_t key : error_.committed().tets)
    for (int k = 0; k < 4; ++k)
      if (((key >> (16 * k)) & 0xffff) == slot)
        for (int m = 0; m < 4; ++m) {
          const size_t other = (key >> (16 * m)) & 0xffff;
          if (other != slot && other >= keptCount) out.push_back(other - keptCount);
        }
}

/// A swap's local candidates: the swapNeighbours field samples nearest to `at` that are not
/// probes, avoided or already in `tried` (ties to the lower index), not captured yet. The other
/// candidates come from wherever the error is largest once the probe is out, not from around
/// it. The octree's samples are denser where the field is refined, so the moves are smaller
/// there; GreedyResult::localSwaps counts the moves to these, and `place` prints it. O(samples).
std::vector<size_t> GreedySearch::nearestFree(Vec3 at, const std::vector<size_t>& tried) {
  std::vector<size_t> out;
  if (s_.swapNeighbours <= 0) return out;
  nearBuffer_.clear();
  for (size_t i = 0; i < points_.fieldCount; ++i) {
    if (isProbe_[i] || points_.avoided[i] ||
        std::find(tried.begin(), tried.end(), i) != tried.end())
      continue;
    const Vec3 d = field_.samples[i].position - at;
    nearBuffer_.push_back({dot(d, d), i});
  }
  const size_t k = std::min(nearBuffer_.size(), size_t(s_.swapNeighbours));
  std::partial_sort(nearBuffer_.begin(), nearBuffer_.begin() + std::ptrdiff_t(k),
                    nearBuffer_.end());
  for (size_t m = 0; m < k; ++m) out.push_back(nearBuffer_[m].second);
  return out;
}

/// Takes the probe at `slot` (field sample `old`) out of the mesh and commits that, having
/// saved the committed mesh with it in saved_: the same set tetrahedralized again would give
/// the same error (to rounding), at a full re-interpolation's cost. Returns false, the probe
/// staying, when the other probes span less than 3D.
bool GreedySearch::takeOut(size_t slot, size_t old) {
  saved_ = error_.committed();
  isProbe_[old] = 0;
  try {
    const Trial out = evaluate(kNone, slot, TrialScope::kChangedPoints);
    result_.reevaluations += out.changed.size();
    commit(out, false);
  } catch (const FlatProbes&) {
    isProbe_[old] = 1;
    return false;
  }
  return true;
}

/// Undoes takeOut: field sample `old` is a probe again, with the saved mesh and field error.
void GreedySearch::putBack(size_t old, double savedError) {
  isProbe_[old] = 1;
  std::swap(error_.committed(), saved_);
  result_.fieldError = savedError;
  if (s_.verifyState) verify();
}

/// One swap: new probe j is taken out, and the best of it, the candidates of the kCandidateTets
/// tetrahedra then holding the most error and its nearestFree samples goes in its place. Only a
/// clear gain moves it (the same probe set can mesh differently, its error differing by
/// rounding). After a move, the probes it touched (j, and those sharing a tetrahedron with it
/// at the old place or the new one) are marked in lookNext, and in `look` when still ahead in
/// this pass (one more progress step each). Returns whether the probe moved.
bool GreedySearch::swapOne(size_t j, std::vector<uint8_t>& look, std::vector<uint8_t>& lookNext) {
  const size_t slot = kept_.size() + j;
  const size_t old = result_.sampleIndex[j];
  std::vector<size_t> touched;  // neighbours at the old place (and later the new one)
  neighboursOf(slot, touched);
  const double savedError = result_.fieldError;
  if (!takeOut(slot, old)) return false;
  ++result_.swapTries;
  std::vector<size_t> tried{old};
  size_t best = kNone;
  Trial bestTrial;
  std::vector<size_t> candidates = candidatesOf(rankTets(), 0, kCandidateTets, tried);
  const std::vector<size_t> local = nearestFree(field_.samples[old].position, tried);
  captureValues(local);
  candidates.insert(candidates.end(), local.begin(), local.end());
  tryCandidates(candidates, slot, best, bestTrial);
  if (best == kNone || !(bestTrial.weightedErrSq < saved_.weightedErrSq * (1 - 1e-9))) {
    putBack(old, savedError);
    return false;
  }
  pos_[slot] = field_.samples[best].position;
  vals_[slot] = valueAsProbe(best);
  if (s_.visibility) vis_[slot] = visibilityAsProbe(best);
  isProbe_[best] = 1;
  if (std::find(local.begin(), local.end(), best) != local.end()) ++result_.localSwaps;
  result_.positions[j] = field_.samples[best].position;
  result_.sampleIndex[j] = best;
  result_.scores[j] = scoreOf(best);
  commit(complete(std::move(bestTrial)), false);
  neighboursOf(slot, touched);
  touched.push_back(j);
  for (size_t k : touched) {
    lookNext[k] = 1;
    if (k > j && !look[k]) {  // still ahead in this pass: one more step
      look[k] = 1;
      steps_ += 1;
    }
  }
  return true;
}

void GreedySearch::swapUntilDone() {
  // A local search after the additions: an addition chose the best probe for the probes
  // before it, not for those that came after; past the noise floor, additions were the least
  // harmful candidate. A swap never raises the error (the probe staying where it was is one of
  // the outcomes). After the first pass, a probe is taken out again only when a move touched
  // it ("don't look bits" of local search). A heuristic: a probe's removal cost depends on its
  // neighbours alone, but its candidates come from the whole field, and a move elsewhere also
  // raises the error where the moved probe left, so a probe not taken out again may have
  // missed a gain there. It makes the passes after the first cost where something changed.
  if (greedySwapsSkipped(s_.swapPasses, points_.unresolvedShare)) {
    result_.swapsSkipped = true;
    return;
  }
  const size_t swappable = result_.positions.size();
  std::vector<uint8_t> look(swappable, 1), lookNext(swappable, 0);
  const size_t additionTrials = result_.trials;
  double stepsDone = double(budget_);  // the additions, then each probe taken out
  for (int pass = 0; pass < s_.swapPasses; ++pass) {
    const double before = result_.fieldError;
    size_t swapped = 0;
    std::fill(lookNext.begin(), lookNext.end(), uint8_t(0));
    const double looked = double(std::count(look.begin(), look.end(), uint8_t(1)));
    steps_ = stepsDone + double(s_.swapPasses - pass) * looked;
    for (size_t j = 0; j < swappable; ++j) {
      if (!look[j]) continue;
      reportProgress(stepsDone);
      stepsDone += 1;
      if (swapOne(j, look, lookNext)) ++swapped;
    }
    result_.swaps += swapped;
    result_.swapTrials = result_.trials - additionTrials;
    ++result_.swapPasses;
    result_.swapErrorHistory.push_back(result_.fieldError);
    if (swapped == 0 || !(result_.fieldError < before * (1 - s_.swapMinGain))) break;
    look.swap(lookNext);
  }
}

}  // namespace

const char* greedyObjectiveName(GreedyObjective objective) {
  return objective == GreedyObjective::kPerceptual ? "perceptual" : "energy";
}

std::array<double, 14> greedyErrorNormalsIrradiance(const ShRgb& sh) {
  const std::array<Vec3, kNormals>& normals = greedy::errorNormals();
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
    throw ParameterError("budget",
                         "expected a probe count: greedy needs a budget, an error target or both");
  if (s.budget != 0 && s.budget < 4)
    throw ParameterError("budget", "expected at least 4 probes, got " + std::to_string(s.budget));
  if (s.budget != 0 && size_t(s.budget) < keptCount + 4)
    throw ParameterError("budget", std::to_string(s.budget) +
                                       " probes leave room for fewer than 4 new ones beside the " +
                                       std::to_string(keptCount) +
                                       " kept probes; expected at least " +
                                       std::to_string(keptCount + 4));
  if (s.budget > int(kMaxProbes))
    throw ParameterError("budget",
                         "at most 65535 probes for greedy, got " + std::to_string(s.budget));
  if (!(s.maxError >= 0) || !std::isfinite(s.maxError))
    throw ParameterError(
        "maxError", "expected a non-negative relative error, got " + std::to_string(s.maxError));
  if (s.swapPasses < 0)
    throw ParameterError("swapPasses",
                         "expected 0 or more passes, got " + std::to_string(s.swapPasses));
  if (s.swapNeighbours < 0)
    throw ParameterError("swapNeighbours",
                         "expected 0 or more samples, got " + std::to_string(s.swapNeighbours));
  if (!(s.swapMinGain >= 0 && s.swapMinGain < 1))
    throw ParameterError("swapMinGain", "expected a share in [0, 1)");
}

GreedyResult placeGreedy(const DenseField& field, std::span<const KeptProbe> kept,
                         const GreedySettings& settings, const ProgressFn& progress) {
  checkGreedySettings(settings, kept.size());
  if (settings.visibility && !settings.captureProbeValues)
    throw ParameterError("interpolant",
                         "the visibility-aware interpolant needs the probes' own captures "
                         "(their visibility maps); expected candidate samples per probe above "
                         "the field's, or the barycentric interpolant");
  GreedySearch search(field, kept, settings, progress);
  search.addInitialSamples();
  search.weighPoints();
  search.commitInitialMesh();
  search.addUntilDone();
  search.swapUntilDone();
  return search.takeResult();
}

}  // namespace ps
