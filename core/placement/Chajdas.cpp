#include "core/placement/Chajdas.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numeric>

#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/math/Random.h"
#include "core/tessellation/Tetrahedralization.h"
#include "core/traversal/ProbeVolume.h"

namespace ps {

namespace {

constexpr int kDirections = 64;
constexpr int kLumBins = 16;
constexpr int kHueBins = 12;

/// Fibonacci-sphere directions: the fixed set the histograms are computed on.
const std::array<Vec3, kDirections>& histogramDirections() {
  static const std::array<Vec3, kDirections> dirs = [] {
    std::array<Vec3, kDirections> d;
    const double golden = kPi * (3.0 - std::sqrt(5.0));
    for (int i = 0; i < kDirections; ++i) {
      const double z = 1.0 - (2.0 * i + 1.0) / kDirections;
      const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
      d[i] = {r * std::cos(golden * i), r * std::sin(golden * i), z};
    }
    return d;
  }();
  return dirs;
}

struct Histograms {
  std::array<double, kLumBins> lum{};  ///< cumulative, normalized
  std::array<double, kHueBins> hue{};  ///< cumulative, normalized (chroma-weighted)
  bool chromatic = false;
};

double hueOf(Rgb c) {
  const double mx = c.maxComponent(), mn = std::min(c.r, std::min(c.g, c.b));
  const double d = mx - mn;
  if (d <= 0) return 0;
  double h;
  if (mx == c.r)
    h = std::fmod((c.g - c.b) / d + 6.0, 6.0);
  else if (mx == c.g)
    h = (c.b - c.r) / d + 2.0;
  else
    h = (c.r - c.g) / d + 4.0;
  return h / 6.0;  // [0, 1)
}

Histograms histogramsOf(const ShRgb& sh, double lo, double hi) {
  Histograms h;
  std::array<double, kLumBins> lum{};
  std::array<double, kHueBins> hue{};
  double chromaSum = 0, brightest = 0;
  for (const Vec3& d : histogramDirections()) {
    Rgb L = sh.radiance(d);
    L = {std::max(0.0, L.r), std::max(0.0, L.g), std::max(0.0, L.b)};
    const double y = luminance(L);
    const double t = y > 0 ? (std::log2(y) - lo) / (hi - lo) : 0.0;
    lum[std::clamp(int(t * kLumBins), 0, kLumBins - 1)] += 1.0 / kDirections;
    const double chroma = L.maxComponent() - std::min(L.r, std::min(L.g, L.b));
    hue[std::min(kHueBins - 1, int(hueOf(L) * kHueBins))] += chroma;
    chromaSum += chroma;
    brightest = std::max(brightest, L.maxComponent());
  }
  h.chromatic = chromaSum > 1e-3 * brightest * kDirections && chromaSum > 0;
  double c = 0;
  for (int i = 0; i < kLumBins; ++i) h.lum[i] = (c += lum[i]);
  c = 0;
  for (int i = 0; i < kHueBins; ++i) h.hue[i] = (c += h.chromatic ? hue[i] / chromaSum : 0);
  return h;
}

/// Earth-mover's distance of two 1D histograms from their cumulative sums (Rubner et al.): the
/// L1 distance of the CDFs, over the bin count so that it lies in [0, 1].
double emdLinear(const std::array<double, kLumBins>& a, const std::array<double, kLumBins>& b) {
  double s = 0;
  for (int i = 0; i < kLumBins - 1; ++i) s += std::abs(a[i] - b[i]);
  return s / (kLumBins - 1);
}

/// The same on the hue circle: min over the shift c of sum |D_i - c|, c the median of D.
double emdCircular(const Histograms& a, const Histograms& b) {
  if (!a.chromatic || !b.chromatic) return a.chromatic == b.chromatic ? 0.0 : 0.5;
  std::array<double, kHueBins> d;
  for (int i = 0; i < kHueBins; ++i) d[i] = a.hue[i] - b.hue[i];
  std::array<double, kHueBins> sorted = d;
  std::nth_element(sorted.begin(), sorted.begin() + kHueBins / 2, sorted.end());
  const double median = sorted[kHueBins / 2];
  double s = 0;
  for (double x : d) s += std::abs(x - median);
  return s / kHueBins;
}

/// Low-frequency spectral distance (the paper's FFT distance, sec. 2.2, with SH bands in place
/// of FFT frequencies and c = 0.5 per band): luminance of the coefficient differences, weighted
/// 0.5^l, relative to the mean of the two DC terms.
/// With the standard errors of the coefficients, the expected squared difference due to noise
/// is subtracted from each term (an unbiased estimate of the noise-free distance).
double shDistance(const ShRgb& a, const ShRgb& b, const ShRgb* aErr = nullptr,
                  const ShRgb* bErr = nullptr) {
  static constexpr int kBand[kShCoeffCount] = {0, 1, 1, 1, 2, 2, 2, 2, 2};
  double s = 0;
  for (int i = 0; i < kShCoeffCount; ++i) {
    const double d = luminance(a.c[i]) - luminance(b.c[i]);
    double noise = 0;
    if (aErr && bErr) {
      const double ea = luminance(aErr->c[i]), eb = luminance(bErr->c[i]);
      noise = ea * ea + eb * eb;
    }
    s += std::pow(0.5, kBand[i]) * std::max(0.0, d * d - noise);
  }
  const double scale = 0.5 * (std::abs(luminance(a.c[0])) + std::abs(luminance(b.c[0])));
  return scale > 0 ? std::sqrt(s) / scale : (s > 0 ? 1.0 : 0.0);
}

double matchDistance(const ShRgb& a, const Histograms& ha, const ShRgb& b, const Histograms& hb,
                     const ShRgb* aErr = nullptr, const ShRgb* bErr = nullptr) {
  return emdLinear(ha.lum, hb.lum) + emdCircular(ha, hb) + shDistance(a, b, aErr, bErr);
}

double importanceWeight(const std::vector<ImportanceVolume>& vols, Vec3 p) {
  double w = 1;
  bool inside = false;
  for (const ImportanceVolume& v : vols)
    if (p.x >= v.lo.x && p.x <= v.hi.x && p.y >= v.lo.y && p.y <= v.hi.y && p.z >= v.lo.z &&
        p.z <= v.hi.z && v.weight > 0) {
      w = inside ? std::max(w, v.weight) : v.weight;
      inside = true;
    }
  return w;
}

struct UnionFind {
  std::vector<size_t> parent;
  explicit UnionFind(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  size_t find(size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void unite(size_t a, size_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

double meanRadianceLum(const ShRgb& sh) {
  return luminance(sh.c[0]);
}

/// The settings checks of placeChajdas; throws ps::ParameterError.
void checkChajdasSettings(std::span<const FieldSample> samples, const ChajdasSettings& s) {
  if (samples.empty()) throw ParameterError("chajdas: the dense field has no samples");
  if (!(s.aggressiveness > 0) || !std::isfinite(s.aggressiveness))
    throw ParameterError("aggressiveness: expected a positive number, got " +
                         std::to_string(s.aggressiveness));
  if (!(s.stepRelative > 0) || s.maxSteps < 1)
    throw ParameterError("chajdas: step and step count must be positive");
}

/// The field's sample spacing in metres: (volume of the samples' bounding box / sample
/// count)^(1/3), each extent taken as at least 1e-9 m; 1 when that is not positive. `samples` not
/// empty.
double sampleSpacing(std::span<const FieldSample> samples) {
  Bounds3 box;
  for (const FieldSample& f : samples) box.extend(f.position);
  const Vec3 e = box.extent();
  const double vol = std::max(e.x, 1e-9) * std::max(e.y, 1e-9) * std::max(e.z, 1e-9);
  double spacing = std::cbrt(vol / double(samples.size()));
  if (!(spacing > 0)) spacing = 1;
  return spacing;
}

/// The samples' brightness and which are lit (Sukys 3.1.3: unlit probes have no gradient, and
/// are handled apart).
struct Lighting {
  std::vector<double> lum;  ///< mean radiance luminance per sample (meanRadianceLum)
  double brightest = 0;     ///< the largest lum
  /// Lit: lum above unlitFraction of the 95th percentile of lum (which must be > 0); ascending.
  std::vector<size_t> lit, unlit;
};

/// Lighting of `samples` (not empty). O(n log n).
Lighting splitLit(std::span<const FieldSample> samples, double unlitFraction) {
  const size_t n = samples.size();
  Lighting l;
  l.lum.resize(n);
  for (size_t i = 0; i < n; ++i) l.lum[i] = meanRadianceLum(samples[i].sh);
  std::vector<double> sortedLum = l.lum;
  std::sort(sortedLum.begin(), sortedLum.end());
  const double p95 = sortedLum[std::min(n - 1, size_t(0.95 * double(n)))];
  for (size_t i = 0; i < n; ++i)
    (l.lum[i] > unlitFraction * p95 && p95 > 0 ? l.lit : l.unlit).push_back(i);
  l.brightest = sortedLum.back();
  return l;
}

/// Probe matching's distance (sec. 2.2) between two samples, their SH noise subtracted: the
/// samples' histograms made once. The luminance histograms span 12 stops below the brightest
/// sample's mean radiance up to 2 above it.
class SampleMatcher {
 public:
  /// Histograms of every sample, in parallel. O(n).
  SampleMatcher(std::span<const FieldSample> samples, double brightestLum)
      : samples_(samples), hist_(samples.size()) {
    const double top = std::log2(std::max(brightestLum, 1e-30));
    const double lo = top - 12, hi = top + 2;
    tbb::parallel_for(size_t(0), samples.size(),
                      [&](size_t i) { hist_[i] = histogramsOf(samples[i].sh, lo, hi); });
  }
  double operator()(size_t a, size_t b) const {
    return matchDistance(samples_[a].sh, hist_[a], samples_[b].sh, hist_[b],
                         &samples_[a].shStdError, &samples_[b].shStdError);
  }

 private:
  std::span<const FieldSample> samples_;
  std::vector<Histograms> hist_;
};

/// The limits probe matching merges within, scaled down by the importance weight w where
/// given: matching distance at most threshold / w, distance at most reach / w (metres).
struct MatchLimits {
  double threshold = 0;  ///< the aggressiveness A
  double reach = 0;      ///< 4 A sample spacings, metres
};

/// A particle's path (sec. 2.1) from `start` (a point of the lit samples' hull, metres), RK2
/// with step h (metres) through f interpolated over `field` (the lit samples' mesh, with
/// their SH), at most maxSteps steps. Its sink: the brightest sample (by lum) of the loop its
/// path closes (the nearest sample repeats); the nearest sample where f vanishes or where the
/// path would leave the hull; after maxSteps, the brightest of the last 8 samples visited.
/// `sampleOfVertex` maps the mesh's vertices to samples.
size_t traceParticle(const ProbeVolume& field, const std::vector<size_t>& sampleOfVertex,
                     const std::vector<double>& lum, Vec3 start, size_t startSample, double h,
                     int maxSteps, size_t n) {
  Vec3 p = start;
  int32_t hint = -1;
  std::vector<size_t> path;  // nearest samples, consecutive repeats collapsed
  // f's direction at q (zero where f vanishes); sets the nearest sample (the vertex with the
  // largest weight) and whether q lies outside the hull of the lit samples.
  auto direction = [&](Vec3 q, size_t& nearest, bool& outside) {
    const VolumeLocation loc = locate(field, q, hint);
    hint = loc.tet;
    const auto& tet = field.tets[size_t(loc.tet)];
    const int w =
        int(std::max_element(loc.weights.begin(), loc.weights.end()) - loc.weights.begin());
    nearest = sampleOfVertex[size_t(tet[w])];
    outside = loc.outside;
    const Vec3 f = luminanceDirection(interpolate(field, loc));
    const double len = length(f);
    return len > 0 ? f / len : Vec3{};
  };
  auto dimmer = [&](size_t a, size_t b) { return lum[a] < lum[b]; };
  size_t sink = startSample;
  size_t nearest = n;
  bool outside = false;
  Vec3 d1 = direction(p, nearest, outside);
  for (int step = 0; step < maxSteps; ++step) {
    if (path.empty() || path.back() != nearest) {
      const auto seen = std::find(path.begin(), path.end(), nearest);
      if (seen != path.end()) {  // a closed loop: the sink
        sink = *std::max_element(seen, path.end(), dimmer);
        path.clear();
        break;
      }
      path.push_back(nearest);
    }
    if (d1 == Vec3{}) {
      sink = nearest;
      path.clear();
      break;
    }
    size_t midNearest = n;
    bool midOutside = false;
    Vec3 d2 = direction(p + d1 * (0.5 * h), midNearest, midOutside);  // RK2 (midpoint)
    if (midOutside || d2 == Vec3{}) d2 = d1;
    const Vec3 next = p + d2 * h;
    size_t nextNearest = n;
    bool nextOutside = false;
    const Vec3 nextD1 = direction(next, nextNearest, nextOutside);
    if (nextOutside) {
      // f leads out of the sampled space: the particle stops at a sink on its boundary.
      sink = nearest;
      path.clear();
      break;
    }
    p = next;
    d1 = nextD1;
    nearest = nextNearest;
  }
  if (!path.empty())  // step cap: the brightest of the last samples visited
    sink = *std::max_element(path.end() - std::min<ptrdiff_t>(8, ptrdiff_t(path.size())),
                             path.end(), dimmer);
  return sink;
}

/// Moves each lit sample's sink (sinkOf, by sample) to the local luminance maximum over the
/// mesh's neighbours, climbing from it, so that particles circling one sink from different
/// sides agree on it. `t` is the lit samples' mesh (input k: sample lit[k]).
/// O(lit samples x climb length x vertex degree).
void climbToMaxima(const Tetrahedralization& t, const std::vector<size_t>& sampleOfVertex,
                   const Lighting& l, std::vector<size_t>& sinkOf) {
  std::vector<std::vector<int32_t>> adjacent(t.vertices.size());
  for (const auto& tet : t.tets)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        if (a != b) adjacent[size_t(tet[a])].push_back(tet[b]);
  std::vector<int32_t> vertexOfSample(sinkOf.size(), -1);
  for (size_t k = 0; k < l.lit.size(); ++k) vertexOfSample[l.lit[k]] = t.vertexOfInput[k];
  for (size_t i : l.lit) {
    int32_t v = vertexOfSample[sinkOf[i]];
    for (;;) {
      int32_t best = v;
      for (int32_t w : adjacent[size_t(v)])
        if (l.lum[sampleOfVertex[size_t(w)]] > l.lum[sampleOfVertex[size_t(best)]]) best = w;
      if (best == v) break;
      v = best;
    }
    sinkOf[i] = sampleOfVertex[size_t(v)];
  }
}

/// Sec. 2.1: each lit sample's sink (by sample; 0 for the unlit ones). A particle from every
/// lit sample, RK2 through f interpolated over the Delaunay mesh of the lit samples (f is
/// linear in the SH, so interpolating the SH and taking luminanceDirection is interpolating f);
/// its sink (traceParticle) then climbs to a maximum (climbToMaxima). Fewer than 4 lit samples,
/// or lit samples spanning less than 3D: no field to trace, and each is its own sink. The
/// particles in parallel, each O(maxSteps) point locations.
std::vector<size_t> traceSinks(std::span<const FieldSample> samples, const Lighting& l,
                               double spacing, const ChajdasSettings& s) {
  const size_t n = samples.size();
  std::vector<size_t> sinkOf(n, 0);
  const std::vector<size_t>& lit = l.lit;
  std::vector<Vec3> litPos;
  std::vector<ShRgb> litSh;
  for (size_t i : lit) {
    litPos.push_back(samples[i].position);
    litSh.push_back(samples[i].sh);
  }
  bool traced = false;
  if (lit.size() >= 4) {
    try {
      const Tetrahedralization t = tetrahedralize(litPos);
      std::vector<ShRgb> shOfVertex(t.vertices.size());
      std::vector<size_t> sampleOfVertex(t.vertices.size(), n);
      for (size_t k = 0; k < lit.size(); ++k) {
        const int32_t v = t.vertexOfInput[k];
        if (sampleOfVertex[v] == n) {
          sampleOfVertex[v] = lit[k];
          shOfVertex[v] = litSh[k];
        }
      }
      const ProbeVolume field = buildProbeVolume(t, shOfVertex);
      const double h = s.stepRelative * spacing;
      tbb::parallel_for(size_t(0), lit.size(), [&](size_t k) {
        sinkOf[lit[k]] = traceParticle(field, sampleOfVertex, l.lum, samples[lit[k]].position,
                                       lit[k], h, s.maxSteps, n);
      });
      climbToMaxima(t, sampleOfVertex, l, sinkOf);
      traced = true;
    } catch (const ParameterError&) {
      // Lit samples spanning less than 3D: no field to trace; each is its own sink.
    }
  }
  if (!traced)
    for (size_t i : lit) sinkOf[i] = i;
  return sinkOf;
}

/// Candidate clusters (sec. 2.3): the lit samples sharing a sink, adjacent sinks (1D / 2D
/// sink manifolds, Fig. 4) merged when their probes match and they lie within half the reach.
struct CandidateClusters {
  size_t sinks = 0;  ///< distinct sinks
  /// Each cluster's samples, ascending; clusters in order of their first sample.
  std::vector<std::vector<size_t>> clusters;
};

/// CandidateClusters of the lit samples. O(sinks^2) matching distances.
CandidateClusters mergeSinks(std::span<const FieldSample> samples, const Lighting& l,
                             const std::vector<size_t>& sinkOf, const SampleMatcher& dist,
                             const MatchLimits& limits, const ChajdasSettings& s) {
  std::vector<size_t> sinks;
  for (size_t i : l.lit) sinks.push_back(sinkOf[i]);
  std::sort(sinks.begin(), sinks.end());
  sinks.erase(std::unique(sinks.begin(), sinks.end()), sinks.end());
  UnionFind uf(sinks.size());
  for (size_t a = 0; a < sinks.size(); ++a)
    for (size_t b = a + 1; b < sinks.size(); ++b) {
      const Vec3 pa = samples[sinks[a]].position, pb = samples[sinks[b]].position;
      const double w = std::max(importanceWeight(s.importanceVolumes, pa),
                                importanceWeight(s.importanceVolumes, pb));
      if (length(pa - pb) <= 0.5 * limits.reach / w &&
          dist(sinks[a], sinks[b]) <= limits.threshold / w)
        uf.unite(a, b);
    }
  CandidateClusters out;
  out.sinks = sinks.size();
  std::vector<int64_t> clusterOfRoot(sinks.size(), -1);
  for (size_t i : l.lit) {
    const size_t root =
        uf.find(size_t(std::lower_bound(sinks.begin(), sinks.end(), sinkOf[i]) - sinks.begin()));
    if (clusterOfRoot[root] < 0) {
      clusterOfRoot[root] = int64_t(out.clusters.size());
      out.clusters.emplace_back();
    }
    out.clusters[size_t(clusterOfRoot[root])].push_back(i);
  }
  return out;
}

/// Probe matching (sec. 2.2) cleans each candidate cluster: its members, brightest first (ties
/// in their order), join the first sub-cluster whose seed they match and lie within reach of;
/// otherwise they seed one. Returns the sub-clusters, each led by its seed, in cluster order.
/// O(members x sub-clusters) matching distances per cluster.
std::vector<std::vector<size_t>> matchWithinClusters(std::vector<std::vector<size_t>> clusters,
                                                     std::span<const FieldSample> samples,
                                                     const Lighting& l, const SampleMatcher& dist,
                                                     const MatchLimits& limits,
                                                     const ChajdasSettings& s) {
  std::vector<std::vector<size_t>> finalClusters;
  for (std::vector<size_t>& c : clusters) {
    std::stable_sort(c.begin(), c.end(), [&](size_t a, size_t b) { return l.lum[a] > l.lum[b]; });
    std::vector<size_t> seeds;
    std::vector<std::vector<size_t>> sub;
    for (size_t i : c) {
      const double w = importanceWeight(s.importanceVolumes, samples[i].position);
      size_t k = 0;
      for (; k < seeds.size(); ++k)
        if (length(samples[i].position - samples[seeds[k]].position) <= limits.reach / w &&
            dist(i, seeds[k]) <= limits.threshold / w)
          break;
      if (k == seeds.size()) {
        seeds.push_back(i);
        sub.emplace_back();
      }
      sub[k].push_back(i);
    }
    for (auto& m : sub) finalClusters.push_back(std::move(m));
  }
  return finalClusters;
}

/// Collects the result's probes at field samples, away from the punctual lights.
class ProbeCollector {
 public:
  ProbeCollector(std::span<const FieldSample> samples, const ChajdasSettings& s,
                 std::vector<ChajdasProbe>& probes)
      : samples_(samples), s_(s), probes_(probes), probeOfSample_(samples.size(), -1) {}

  /// The sample nearest to p (metres) among `among` (nullptr: every sample), those within the
  /// light clearance left out (ties to the first); samples.size() when there is none. O(n).
  size_t nearestSample(Vec3 p, const std::vector<size_t>* among) const {
    size_t best = samples_.size();
    double bestD = std::numeric_limits<double>::infinity();
    auto consider = [&](size_t i) {
      if (nearLight(i)) return;
      const double d = length(samples_[i].position - p);
      if (d < bestD) {
        bestD = d;
        best = i;
      }
    };
    if (among)
      for (size_t i : *among) consider(i);
    else
      for (size_t i = 0; i < samples_.size(); ++i) consider(i);
    return best;
  }

  /// A probe at sample `rep` with `score`; two clusters snapping to one sample make one probe,
  /// their scores summed (and the first one's unlit flag kept).
  void add(size_t rep, double score, bool isUnlit) {
    if (probeOfSample_[rep] >= 0) {
      probes_[size_t(probeOfSample_[rep])].score += score;
      return;
    }
    probeOfSample_[rep] = int64_t(probes_.size());
    probes_.push_back({samples_[rep].position, rep, score, isUnlit});
  }

 private:
  bool nearLight(size_t i) const {
    for (const Vec3& l : s_.punctualLights)
      if (length(samples_[i].position - l) < s_.lightClearanceMeters) return true;
    return false;
  }

  std::span<const FieldSample> samples_;
  const ChajdasSettings& s_;
  std::vector<ChajdasProbe>& probes_;
  std::vector<int64_t> probeOfSample_;
};

/// One representative per cluster (sec. 2.3), scored by the cluster's size: the mean position,
/// snapped to the nearest sample; kept when that sample matches the cluster's seed (its first
/// member), else the member nearest the mean. A cluster whose every sample is within the light
/// clearance gets none. O(clusters x n).
void addRepresentatives(const std::vector<std::vector<size_t>>& clusters,
                        std::span<const FieldSample> samples, const SampleMatcher& dist,
                        const MatchLimits& limits, const ChajdasSettings& s,
                        ProbeCollector& collector) {
  const size_t n = samples.size();
  for (const std::vector<size_t>& m : clusters) {
    Vec3 mean;
    for (size_t i : m) mean += samples[i].position;
    mean = mean / double(m.size());
    size_t rep = collector.nearestSample(mean, nullptr);
    if (rep == n ||
        dist(rep, m.front()) > limits.threshold / importanceWeight(s.importanceVolumes, mean))
      rep = collector.nearestSample(mean, &m);
    if (rep == n) continue;  // every sample of the cluster is next to a light
    collector.add(rep, double(m.size()), false);
  }
}

/// k-means++ initialisation over the positions of samples `members`: k centres (metres), the
/// first drawn uniformly, each next with probability proportional to its squared distance to
/// the nearest centre so far. Draws k uniform01 values from rng. O(k x members).
std::vector<Vec3> kMeansPlusPlus(std::span<const FieldSample> samples,
                                 const std::vector<size_t>& members, size_t k, uint64_t& rng) {
  std::vector<Vec3> centres{
      samples[members[size_t(uniform01(rng) * members.size()) % members.size()]].position};
  std::vector<double> d2(members.size(), std::numeric_limits<double>::infinity());
  while (centres.size() < k) {
    double total = 0;
    for (size_t j = 0; j < members.size(); ++j) {
      const Vec3 q = samples[members[j]].position - centres.back();
      d2[j] = std::min(d2[j], dot(q, q));
      total += d2[j];
    }
    double pick = uniform01(rng) * total;
    size_t j = 0;
    for (; j + 1 < members.size() && pick > d2[j]; ++j) pick -= d2[j];
    centres.push_back(samples[members[j]].position);
  }
  return centres;
}

/// Lloyd iterations of k-means over the positions of samples `members` from `centres` (moved
/// to their clusters' means), at most 30, until no assignment changes. Returns each member's
/// centre (ties to the lower index). O(30 x k x members).
std::vector<size_t> kMeansAssign(std::span<const FieldSample> samples,
                                 const std::vector<size_t>& members, std::vector<Vec3>& centres) {
  const size_t k = centres.size();
  std::vector<size_t> assign(members.size(), 0);
  for (int iter = 0; iter < 30; ++iter) {
    bool changed = false;
    for (size_t j = 0; j < members.size(); ++j) {
      size_t best = 0;
      double bestD = std::numeric_limits<double>::infinity();
      for (size_t c = 0; c < k; ++c) {
        const Vec3 q = samples[members[j]].position - centres[c];
        if (dot(q, q) < bestD) {
          bestD = dot(q, q);
          best = c;
        }
      }
      changed |= assign[j] != best;
      assign[j] = best;
    }
    std::vector<Vec3> sum(k);
    std::vector<size_t> count(k, 0);
    for (size_t j = 0; j < members.size(); ++j) {
      sum[assign[j]] += samples[members[j]].position;
      ++count[assign[j]];
    }
    for (size_t c = 0; c < k; ++c)
      if (count[c] > 0) centres[c] = sum[c] / double(count[c]);
    if (!changed && iter > 0) break;
  }
  return assign;
}

/// Unlit samples (Sukys 3.1.3): k-means over their positions (seeded by `seed`), at the lit
/// part's density of probes per sample (one per 64 samples when nothing is lit); each cluster's
/// probe is its member nearest its centre, scored by the cluster's size.
void addUnlitProbes(std::span<const FieldSample> samples, const Lighting& l, size_t litClusterCount,
                    uint64_t seed, ProbeCollector& collector) {
  const std::vector<size_t>& unlit = l.unlit;
  if (unlit.empty()) return;
  const double perProbe =
      l.lit.empty() ? 64.0 : double(l.lit.size()) / std::max<size_t>(1, litClusterCount);
  const size_t k =
      std::clamp<size_t>(size_t(std::lround(double(unlit.size()) / perProbe)), 1, unlit.size());
  uint64_t rng = streamSeed(seed, 0x6b6d65616e73ull);
  std::vector<Vec3> centres = kMeansPlusPlus(samples, unlit, k, rng);
  const std::vector<size_t> assign = kMeansAssign(samples, unlit, centres);
  for (size_t c = 0; c < k; ++c) {
    std::vector<size_t> members;
    for (size_t j = 0; j < unlit.size(); ++j)
      if (assign[j] == c) members.push_back(unlit[j]);
    if (members.empty()) continue;
    const size_t rep = collector.nearestSample(centres[c], &members);
    if (rep != samples.size()) collector.add(rep, double(members.size()), true);
  }
}

}  // namespace

double probeMatchDistance(const ShRgb& a, const ShRgb& b, double lo, double hi) {
  return matchDistance(a, histogramsOf(a, lo, hi), b, histogramsOf(b, lo, hi));
}

ChajdasResult placeChajdas(std::span<const FieldSample> samples, const ChajdasSettings& s) {
  checkChajdasSettings(samples, s);
  const auto start = std::chrono::steady_clock::now();
  ChajdasResult r;
  const double spacing = sampleSpacing(samples);
  const Lighting lighting = splitLit(samples, s.unlitFraction);
  r.unlitSamples = lighting.unlit.size();
  const SampleMatcher dist(samples, lighting.brightest);
  const std::vector<size_t> sinkOf = traceSinks(samples, lighting, spacing, s);
  const MatchLimits limits{s.aggressiveness, 4.0 * s.aggressiveness * spacing};
  CandidateClusters candidates = mergeSinks(samples, lighting, sinkOf, dist, limits, s);
  r.sinks = candidates.sinks;
  r.candidateClusters = candidates.clusters.size();
  const std::vector<std::vector<size_t>> clusters =
      matchWithinClusters(std::move(candidates.clusters), samples, lighting, dist, limits, s);
  ProbeCollector collector(samples, s, r.probes);
  addRepresentatives(clusters, samples, dist, limits, s, collector);
  addUnlitProbes(samples, lighting, clusters.size(), s.seed, collector);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

ChajdasBudgetResult placeChajdasBudget(std::span<const FieldSample> samples, int budget,
                                       ChajdasSettings s) {
  if (budget < 4)
    throw ParameterError("budget: expected at least 4 probes, got " + std::to_string(budget));
  // More aggressiveness, fewer probes (not strictly: the clusters change discretely).
  double lo = std::log(0.02), hi = std::log(50.0);
  ChajdasBudgetResult best;
  double bestMiss = std::numeric_limits<double>::infinity();
  for (int iter = 0; iter < 24; ++iter) {
    s.aggressiveness = std::exp(0.5 * (lo + hi));
    ChajdasResult r = placeChajdas(samples, s);
    const double count = double(r.probes.size());
    const double miss = std::abs(count - budget) / budget;
    if (miss < bestMiss) {
      bestMiss = miss;
      best.result = std::move(r);
      best.aggressiveness = s.aggressiveness;
    }
    if (bestMiss <= 0.1 || hi - lo < 1e-3) break;
    if (count > budget)
      lo = std::log(s.aggressiveness);
    else
      hi = std::log(s.aggressiveness);
  }
  return best;
}

}  // namespace ps
