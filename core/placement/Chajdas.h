#pragma once
// Chajdas, Weis & Westermann, "Assisted environment map probe placement" (SCCG 2011): from a
// dense field of cheap probes, particles traced along the luminance-weighted direction field f
// (sec. 2.1) gather in sinks; the samples that share a sink form candidate clusters, cleaned up
// by probe matching (sec. 2.2: histogram earth-mover's distances plus a low-frequency spectral
// distance), and each cluster gets one representative probe (sec. 2.3). Completely unlit
// samples, which the method leaves without probes (its Fig. 3b), are clustered with k-means
// (Sukys 3.1.3).
#include <cstdint>
#include <span>
#include <vector>

#include "core/io/ProbeSet.h"
#include "core/placement/DenseField.h"

namespace ps {

struct ChajdasSettings {
  /// Merging strength, > 0: the probe-matching threshold is A and clusters reach
  /// 4 * A sample spacings; larger values merge more and give fewer probes.
  double aggressiveness = 1.0;
  /// RK2 step as a fraction of the sample spacing ((domain volume / samples)^(1/3)).
  double stepRelative = 0.5;
  int maxSteps = 400;  ///< per particle
  /// A sample is unlit when its mean radiance luminance is at most this fraction of the 95th
  /// percentile of the field's.
  double unlitFraction = 0.01;
  /// Importance volumes: inside one of weight w, the matching threshold and cluster reach are
  /// divided by w (more, smaller clusters where w > 1). Empty: weight 1 everywhere.
  std::vector<ImportanceVolume> importanceVolumes;
  /// Point and spot light positions, and the clearance a probe keeps from them (0: none). The
  /// field's sinks lie on the lights (f points at the brightest direction), so a cluster of
  /// samples around a bulb would put its representative on it: a capture of the 1/r^2
  /// singularity that the volume then spreads over tetrahedra metres across, so that a single
  /// probe next to a light can dominate eval's error. A representative is chosen among samples
  /// at least this far from every light; a cluster with none gets no probe.
  std::vector<Vec3> punctualLights;
  double lightClearanceMeters = 0;
  uint64_t seed = 1;  ///< k-means initialisation
};

struct ChajdasProbe {
  Vec3 position;           ///< a field sample's position (valid: the field has no invalid ones)
  size_t sampleIndex = 0;  ///< that sample
  double score = 0;        ///< cluster size (samples it represents)
  bool unlit = false;      ///< placed by the k-means over unlit samples
};

struct ChajdasResult {
  std::vector<ChajdasProbe> probes;
  size_t sinks = 0;              ///< distinct sink samples the particles ended in
  size_t candidateClusters = 0;  ///< after merging adjacent matching sinks
  size_t unlitSamples = 0;
  double seconds = 0;
};

/// The distance probe matching uses (sec. 2.2), >= 0, 0 for equal SH: the earth-mover's
/// distance of the luminance histograms plus that of the hue histograms (each in [0, 1]) plus a
/// relative low-frequency SH distance. Histograms are computed from the SH's radiance on a fixed
/// set of 64 directions, our choice since a probe stores SH rather than an image;
/// [log2LumLo, log2LumHi] is the range of the luminance bins. (placeChajdas also subtracts the
/// samples' SH noise, from their standard errors, from the SH term.)
double probeMatchDistance(const ShRgb& a, const ShRgb& b, double log2LumLo, double log2LumHi);

/// Places probes for the field. Deterministic for a seed. Throws ps::ParameterError for an
/// empty field or aggressiveness <= 0 (or not finite).
ChajdasResult placeChajdas(std::span<const FieldSample> samples,
                           const ChajdasSettings& settings = {});

struct ChajdasBudgetResult {
  ChajdasResult result;
  double aggressiveness = 0;  ///< the value that gave it
};

/// placeChajdas at the aggressiveness whose probe count is `budget` within 10 % (bisection on
/// log A in [0.02, 50]; the closest count found when none gets that close), so that methods are
/// compared at equal probe count. Throws ps::ParameterError for a budget below 4.
ChajdasBudgetResult placeChajdasBudget(std::span<const FieldSample> samples, int budget,
                                       ChajdasSettings settings = {});

}  // namespace ps
