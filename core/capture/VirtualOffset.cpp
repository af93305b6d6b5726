// Virtual offset (Kontkanen & Laine sec. 5, "domain of interest"; the relocation itself is what
// engines call a virtual offset): from an invalid probe, the back faces its rays hit are where
// the solid it sits in ends; the nearest of those exits, pushed out along the face's front
// normal, that classifies as valid is where the probe is captured.
#include "core/capture/VirtualOffset.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/math/Random.h"

namespace ps {

std::optional<Vec3> virtualOffset(const Tracer& tracer, Vec3 p,
                                  const VirtualOffsetSettings& settings) {
  if (settings.rays < 1)
    throw ParameterError("virtualOffset: rays is " + std::to_string(settings.rays) +
                         ", expected at least 1");
  if (!(settings.pushOutMeters >= 0))
    throw ParameterError("virtualOffset: pushOutMeters must be >= 0");
  if (backfaceFraction(tracer, p, settings.rays, settings.seed) <= settings.invalidBackfaceFraction)
    return p;
  const Scene& scene = tracer.scene();
  const double push =
      settings.pushOutMeters > 0 ? settings.pushOutMeters : 0.005 * scene.bounds.diagonal();

  // Exits: back faces seen from p (double-sided ones too: backfaceFraction counts them), with
  // their distance.
  struct Exit {
    double t;
    Vec3 candidate;
  };
  std::vector<Exit> exits;
  uint64_t rng = streamSeed(settings.seed, 0x5EED0FF5E7ull);
  for (int j = 0; j < settings.rays; ++j) {
    const Vec3 dir = uniformSphere(uniform01(rng), uniform01(rng));
    const auto hit = tracer.intersect(Ray{p, dir});
    if (!hit || hit->frontFace) continue;
    // The front normal points out of the solid: step through the face and push out.
    exits.push_back({hit->t, p + dir * hit->t + hit->geometricNormal * push});
  }
  std::sort(exits.begin(), exits.end(), [](const Exit& a, const Exit& b) { return a.t < b.t; });
  for (const Exit& e : exits)
    if (backfaceFraction(tracer, e.candidate, settings.rays, settings.seed) <=
        settings.invalidBackfaceFraction)
      return e.candidate;
  return std::nullopt;
}

}  // namespace ps
