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

}  // namespace

double probeMatchDistance(const ShRgb& a, const ShRgb& b, double lo, double hi) {
  return matchDistance(a, histogramsOf(a, lo, hi), b, histogramsOf(b, lo, hi));
}

ChajdasResult placeChajdas(std::span<const FieldSample> samples, const ChajdasSettings& s) {
  if (samples.empty()) throw ParameterError("chajdas: the dense field has no samples");
  if (!(s.aggressiveness > 0) || !std::isfinite(s.aggressiveness))
    throw ParameterError("aggressiveness: expected a positive number, got " +
                         std::to_string(s.aggressiveness));
  if (!(s.stepRelative > 0) || s.maxSteps < 1)
    throw ParameterError("chajdas: step and step count must be positive");
  const auto start = std::chrono::steady_clock::now();
  const size_t n = samples.size();
  ChajdasResult r;

  // Scale of the field.
  Bounds3 box;
  for (const FieldSample& f : samples) box.extend(f.position);
  const Vec3 e = box.extent();
  const double vol = std::max(e.x, 1e-9) * std::max(e.y, 1e-9) * std::max(e.z, 1e-9);
  double spacing = std::cbrt(vol / double(n));
  if (!(spacing > 0)) spacing = 1;

  // Lit and unlit samples (Sukys 3.1.3: unlit probes have no gradient; handled apart).
  std::vector<double> lum(n);
  for (size_t i = 0; i < n; ++i) lum[i] = meanRadianceLum(samples[i].sh);
  std::vector<double> sortedLum = lum;
  std::sort(sortedLum.begin(), sortedLum.end());
  const double p95 = sortedLum[std::min(n - 1, size_t(0.95 * double(n)))];
  std::vector<size_t> lit, unlit;
  for (size_t i = 0; i < n; ++i)
    (lum[i] > s.unlitFraction * p95 && p95 > 0 ? lit : unlit).push_back(i);
  r.unlitSamples = unlit.size();

  // Histogram range: 12 stops below the brightest sample's mean radiance up to 2 above it.
  const double top = std::log2(std::max(sortedLum.back(), 1e-30));
  const double lo = top - 12, hi = top + 2;
  std::vector<Histograms> hist(n);
  tbb::parallel_for(size_t(0), n, [&](size_t i) { hist[i] = histogramsOf(samples[i].sh, lo, hi); });
  auto dist = [&](size_t a, size_t b) {
    return matchDistance(samples[a].sh, hist[a], samples[b].sh, hist[b], &samples[a].shStdError,
                         &samples[b].shStdError);
  };

  // Sec. 2.1: a particle from every lit sample, RK2 through f interpolated over the Delaunay
  // mesh of the lit samples (f is linear in the SH, so interpolating the SH and taking
  // luminanceDirection is interpolating f). It ends in a sink when its path closes a loop (the
  // nearest sample repeats); the sink is the brightest sample of that loop.
  std::vector<size_t> sinkOf(n, 0);
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
        Vec3 p = samples[lit[k]].position;
        int32_t hint = -1;
        std::vector<size_t> path;  // nearest samples, consecutive repeats collapsed
        // f's direction at q (zero where f vanishes); sets the nearest sample (the vertex with
        // the largest weight) and whether q lies outside the hull of the lit samples.
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
        size_t sink = lit[k];
        size_t nearest = n;
        bool outside = false;
        Vec3 d1 = direction(p, nearest, outside);
        for (int step = 0; step < s.maxSteps; ++step) {
          if (path.empty() || path.back() != nearest) {
            const auto seen = std::find(path.begin(), path.end(), nearest);
            if (seen != path.end()) {  // a closed loop: the sink
              sink = *std::max_element(seen, path.end(),
                                       [&](size_t a, size_t b) { return lum[a] < lum[b]; });
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
                                   path.end(), [&](size_t a, size_t b) { return lum[a] < lum[b]; });
        sinkOf[lit[k]] = sink;
      });
      // The loop's brightest sample climbs to the local luminance maximum over the mesh's
      // neighbours, so that particles circling one sink from different sides agree on it.
      std::vector<std::vector<int32_t>> adjacent(t.vertices.size());
      for (const auto& tet : t.tets)
        for (int a = 0; a < 4; ++a)
          for (int b = 0; b < 4; ++b)
            if (a != b) adjacent[size_t(tet[a])].push_back(tet[b]);
      std::vector<int32_t> vertexOfSample(n, -1);
      for (size_t k = 0; k < lit.size(); ++k) vertexOfSample[lit[k]] = t.vertexOfInput[k];
      for (size_t i : lit) {
        int32_t v = vertexOfSample[sinkOf[i]];
        for (;;) {
          int32_t best = v;
          for (int32_t w : adjacent[size_t(v)])
            if (lum[sampleOfVertex[size_t(w)]] > lum[sampleOfVertex[size_t(best)]]) best = w;
          if (best == v) break;
          v = best;
        }
        sinkOf[i] = sampleOfVertex[size_t(v)];
      }
      traced = true;
    } catch (const ParameterError&) {
      // Lit samples spanning less than 3D: no field to trace; each is its own sink.
    }
  }
  if (!traced)
    for (size_t i : lit) sinkOf[i] = i;

  // Candidate clusters: samples sharing a sink; adjacent sinks (1D / 2D sink manifolds, Fig. 4)
  // merged when their probes match (sec. 2.3).
  std::vector<size_t> sinks;
  for (size_t i : lit) sinks.push_back(sinkOf[i]);
  std::sort(sinks.begin(), sinks.end());
  sinks.erase(std::unique(sinks.begin(), sinks.end()), sinks.end());
  r.sinks = sinks.size();
  const double thr = s.aggressiveness;
  const double reach = 4.0 * s.aggressiveness * spacing;
  UnionFind uf(sinks.size());
  for (size_t a = 0; a < sinks.size(); ++a)
    for (size_t b = a + 1; b < sinks.size(); ++b) {
      const Vec3 pa = samples[sinks[a]].position, pb = samples[sinks[b]].position;
      const double w = std::max(importanceWeight(s.importanceVolumes, pa),
                                importanceWeight(s.importanceVolumes, pb));
      if (length(pa - pb) <= 0.5 * reach / w && dist(sinks[a], sinks[b]) <= thr / w) uf.unite(a, b);
    }
  std::vector<std::vector<size_t>> clusters;
  {
    std::vector<int64_t> clusterOfRoot(sinks.size(), -1);
    for (size_t i : lit) {
      const size_t root =
          uf.find(size_t(std::lower_bound(sinks.begin(), sinks.end(), sinkOf[i]) - sinks.begin()));
      if (clusterOfRoot[root] < 0) {
        clusterOfRoot[root] = int64_t(clusters.size());
        clusters.emplace_back();
      }
      clusters[size_t(clusterOfRoot[root])].push_back(i);
    }
  }
  r.candidateClusters = clusters.size();

  // Probe matching (sec. 2.2) cleans each candidate cluster: members, brightest first, join the
  // first sub-cluster whose seed they match and lie within reach of; otherwise they seed one.
  std::vector<std::vector<size_t>> finalClusters;
  for (std::vector<size_t>& c : clusters) {
    std::stable_sort(c.begin(), c.end(), [&](size_t a, size_t b) { return lum[a] > lum[b]; });
    std::vector<size_t> seeds;
    std::vector<std::vector<size_t>> sub;
    for (size_t i : c) {
      const double w = importanceWeight(s.importanceVolumes, samples[i].position);
      size_t k = 0;
      for (; k < seeds.size(); ++k)
        if (length(samples[i].position - samples[seeds[k]].position) <= reach / w &&
            dist(i, seeds[k]) <= thr / w)
          break;
      if (k == seeds.size()) {
        seeds.push_back(i);
        sub.emplace_back();
      }
      sub[k].push_back(i);
    }
    for (auto& m : sub) finalClusters.push_back(std::move(m));
  }

  // One representative per cluster (sec. 2.3): the mean position, snapped to the nearest
  // sample; kept when that sample matches the cluster's seed, else the member nearest the mean.
  auto nearLight = [&](size_t i) {
    for (const Vec3& l : s.punctualLights)
      if (length(samples[i].position - l) < s.lightClearanceMeters) return true;
    return false;
  };
  auto nearestSample = [&](Vec3 p, const std::vector<size_t>* among) {
    size_t best = n;
    double bestD = std::numeric_limits<double>::infinity();
    auto consider = [&](size_t i) {
      if (nearLight(i)) return;
      const double d = length(samples[i].position - p);
      if (d < bestD) {
        bestD = d;
        best = i;
      }
    };
    if (among)
      for (size_t i : *among) consider(i);
    else
      for (size_t i = 0; i < n; ++i) consider(i);
    return best;
  };
  std::vector<int64_t> probeOfSample(n, -1);  // two clusters snapping to one sample: one probe
  auto addProbe = [&](size_t rep, double score, bool isUnlit) {
    if (probeOfSample[rep] >= 0) {
      r.probes[size_t(probeOfSample[rep])].score += score;
      return;
    }
    probeOfSample[rep] = int64_t(r.probes.size());
    r.probes.push_back({samples[rep].position, rep, score, isUnlit});
  };
  for (const std::vector<size_t>& m : finalClusters) {
    Vec3 mean;
    for (size_t i : m) mean += samples[i].position;
    mean = mean / double(m.size());
    size_t rep = nearestSample(mean, nullptr);
    if (rep == n || dist(rep, m.front()) > thr / importanceWeight(s.importanceVolumes, mean))
      rep = nearestSample(mean, &m);
    if (rep == n) continue;  // every sample of the cluster is next to a light
    addProbe(rep, double(m.size()), false);
  }

  // Unlit samples (Sukys 3.1.3): k-means over their positions, at the lit part's density of
  // probes per sample (one per 64 samples when nothing is lit).
  if (!unlit.empty()) {
    const double perProbe =
        lit.empty() ? 64.0 : double(lit.size()) / std::max<size_t>(1, finalClusters.size());
    const size_t k =
        std::clamp<size_t>(size_t(std::lround(double(unlit.size()) / perProbe)), 1, unlit.size());
    // k-means++ initialisation, seeded.
    uint64_t rng = streamSeed(s.seed, 0x6b6d65616e73ull);
    std::vector<Vec3> centres{
        samples[unlit[size_t(uniform01(rng) * unlit.size()) % unlit.size()]].position};
    std::vector<double> d2(unlit.size(), std::numeric_limits<double>::infinity());
    while (centres.size() < k) {
      double total = 0;
      for (size_t j = 0; j < unlit.size(); ++j) {
        const Vec3 q = samples[unlit[j]].position - centres.back();
        d2[j] = std::min(d2[j], dot(q, q));
        total += d2[j];
      }
      double pick = uniform01(rng) * total;
      size_t j = 0;
      for (; j + 1 < unlit.size() && pick > d2[j]; ++j) pick -= d2[j];
      centres.push_back(samples[unlit[j]].position);
    }
    std::vector<size_t> assign(unlit.size(), 0);
    for (int iter = 0; iter < 30; ++iter) {
      bool changed = false;
      for (size_t j = 0; j < unlit.size(); ++j) {
        size_t best = 0;
        double bestD = std::numeric_limits<double>::infinity();
        for (size_t c = 0; c < k; ++c) {
          const Vec3 q = samples[unlit[j]].position - centres[c];
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
      for (size_t j = 0; j < unlit.size(); ++j) {
        sum[assign[j]] += samples[unlit[j]].position;
        ++count[assign[j]];
      }
      for (size_t c = 0; c < k; ++c)
        if (count[c] > 0) centres[c] = sum[c] / double(count[c]);
      if (!changed && iter > 0) break;
    }
    for (size_t c = 0; c < k; ++c) {
      std::vector<size_t> members;
      for (size_t j = 0; j < unlit.size(); ++j)
        if (assign[j] == c) members.push_back(unlit[j]);
      if (members.empty()) continue;
      const size_t rep = nearestSample(centres[c], &members);
      if (rep != n) addProbe(rep, double(members.size()), true);
    }
  }
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
