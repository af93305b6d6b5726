#include "core/placement/Ascent.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <string>

#include "core/common/Error.h"
#include "core/math/Random.h"
#include "core/placement/DenseField.h"

namespace ps {

namespace {

double meanLuminance(const ShRgb& sh) {
  return luminance(sh.c[0]) * 0.282094791773878143;
}

}  // namespace

AscentResult placeAscent(const Tracer& tracer, const LightingRig& rig, std::span<const Vec3> start,
                         const AscentSettings& s, const ProgressFn& progress) {
  if (s.iterations < 1)
    throw ParameterError("ascent iterations: expected at least 1, got " +
                         std::to_string(s.iterations));
  if (!(s.stepMeters > 0) || !(s.minStepMeters > 0))
    throw ParameterError("ascent step: expected positive step lengths in metres");
  const size_t n = start.size();
  AscentResult r;
  r.positions.assign(start.begin(), start.end());
  r.travelMeters.assign(n, 0.0);
  if (n == 0) return r;
  const Bounds3& bounds = tracer.scene().bounds;

  CaptureSettings cs;
  cs.samplesPerProbe = s.samplesPerProbe;
  cs.mode = s.mode;
  cs.seed = streamSeed(s.seed, 0xA5CE27ull);
  std::vector<ProbeCapture> caps = captureProbes(tracer, rig, r.positions, cs);
  double meanLum = 0;
  for (const ProbeCapture& c : caps) meanLum += std::max(0.0, meanLuminance(c.sh));
  meanLum /= double(n);
  const double dark = s.darkRelative * meanLum;

  std::vector<double> step(n, s.stepMeters);
  std::vector<char> active(n, 1);
  for (size_t i = 0; i < n; ++i)
    if (!(meanLuminance(caps[i].sh) > dark)) {
      active[i] = 0;  // dark from the start: no gradient to follow (Sukys 3.1.3)
      ++r.darkProbes;
    }

  for (int it = 0; it < s.iterations; ++it) {
    // Proposed step of every active probe along f / |f| (Chajdas eq. 1 on its capture).
    std::vector<size_t> moving;
    std::vector<Vec3> proposed;
    for (size_t i = 0; i < n; ++i) {
      if (!active[i]) continue;
      const Vec3 f = luminanceDirection(caps[i].sh);
      const double len = length(f);
      if (!(len > 0) || step[i] < s.minStepMeters) {
        active[i] = 0;
        continue;
      }
      moving.push_back(i);
      proposed.push_back(r.positions[i] + f * (step[i] / len));
    }
    if (moving.empty()) break;
    // Second-order rejection (Sukys 3.1.2): capture at the new position; a step that lands in
    // the dark, inside geometry, outside the scene bounds or across a surface is reverted and
    // the step halved.
    CaptureSettings stepCs = cs;
    stepCs.seed = streamSeed(s.seed, uint64_t(it) + 1);
    const std::vector<ProbeCapture> trial = captureProbes(tracer, rig, proposed, stepCs);
    std::vector<char> crosses(moving.size(), 0);
    tbb::parallel_for(size_t(0), moving.size(), [&](size_t q) {
      Ray ray;
      ray.origin = r.positions[moving[q]];
      ray.direction = proposed[q] - ray.origin;
      ray.tMax = 1.0;
      crosses[q] = tracer.occluded(ray) ? 1 : 0;
    });
    for (size_t q = 0; q < moving.size(); ++q) {
      const size_t i = moving[q];
      const bool reject = crosses[q] || !bounds.contains(proposed[q]) ||
                          trial[q].backfaceFraction > s.invalidBackfaceFraction ||
                          !(meanLuminance(trial[q].sh) > dark);
      if (reject) {
        step[i] *= 0.5;
        ++r.reverted;
        continue;
      }
      r.travelMeters[i] += length(proposed[q] - r.positions[i]);
      r.positions[i] = proposed[q];
      caps[i] = trial[q];
      ++r.steps;
    }
    if (progress && !progress(double(it + 1) / s.iterations)) throw Cancelled();
  }
  return r;
}

}  // namespace ps
