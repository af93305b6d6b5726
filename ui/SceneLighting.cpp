#include "ui/SceneLighting.h"

#include <algorithm>
#include <cmath>

#include "core/capture/DirectLight.h"
#include "core/scene/EnvironmentMap.h"

namespace ps::ui {

namespace {

/// `n` unit directions spread evenly over the sphere (spherical Fibonacci points: z uniform in
/// (-1, 1), longitude advancing by the golden angle).
std::vector<Vec3> fibonacciSphere(int n) {
  std::vector<Vec3> dirs;
  dirs.reserve(size_t(std::max(n, 0)));
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * i;
    dirs.emplace_back(r * std::cos(phi), z, r * std::sin(phi));
  }
  return dirs;
}

/// Cells flagged invalid take the mean of their valid face neighbours, in passes outward from
/// the valid ones (at most 4 passes; a cell still unreached keeps what it traced).
void fillInvalidCells(ShGrid& g, std::vector<uint8_t>& invalid) {
  const int nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const auto index = [&](int i, int j, int k) { return size_t(i + nx * (j + ny * k)); };
  for (int pass = 0; pass < 4; ++pass) {
    std::vector<std::pair<size_t, ShRgb>> filled;
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          const size_t c = index(i, j, k);
          if (!invalid[c]) continue;
          ShRgb sum;
          int count = 0;
          const int offsets[6][3] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                     {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
          for (const auto& o : offsets) {
            const int a = i + o[0], b = j + o[1], d = k + o[2];
            if (a < 0 || b < 0 || d < 0 || a >= nx || b >= ny || d >= nz) continue;
            const size_t n = index(a, b, d);
            if (invalid[n]) continue;
            sum += g.sh[n];
            ++count;
          }
          if (count > 0) filled.emplace_back(c, sum * (1.0 / count));
        }
    if (filled.empty()) return;
    for (const auto& [c, sh] : filled) {
      g.sh[c] = sh;
      invalid[c] = 0;
    }
  }
}

}  // namespace

bool hasAnyLight(const Scene& scene, const LightingRig& rig) {
  return !allLights(scene, rig).empty() || !rig.skyRadiance.isBlack() || !rig.envMapPath.empty() ||
         rig.envMap || scene.hasEmissiveSurfaces();
}

ShGrid directLightGrid(const Tracer& tracer, const LightingRig& rig, const Bounds3& box,
                       int maxCellsPerAxis, int skyRays, const std::function<bool()>& cancelled) {
  ShGrid g = shGridLayout(box, maxCellsPerAxis);
  if (g.sh.empty()) return g;
  const Scene& scene = tracer.scene();
  const std::vector<Light> lights = allLights(scene, rig);
  const std::shared_ptr<const EnvironmentMap> env = environmentOf(rig);
  const std::vector<Vec3> dirs = fibonacciSphere(std::max(skyRays, 8));
  const double weight = 4.0 * kPi / double(dirs.size());  // 1 / (pdf N), pdf = 1 / (4 pi)
  const double eps = tracer.rayEpsilon();
  const double minCell = std::min({g.cellMeters.x, g.cellMeters.y, g.cellMeters.z});
  std::vector<uint8_t> invalid(g.sh.size(), 0);
  const size_t rowLength = size_t(g.dims[0]);
  for (size_t row = 0; row * rowLength < g.sh.size(); ++row) {
    if (cancelled && cancelled()) return {};
    for (size_t c = row * rowLength; c < (row + 1) * rowLength; ++c) {
      const Vec3 p = g.centre(c);
      ShRgb sh;
      for (const Light& light : lights)
        if (const auto a = visibleDeltaArrival(tracer, light, p)) {
          // A point or spot light nearer than a cell is taken as a cell away: the grid cannot
          // show its 1 / d^2 peak, and the bounce would spread that peak as bright spots.
          const double near = std::min(1.0, (a->distance * a->distance) / (minCell * minCell));
          sh.addSample(a->directionToLight, a->irradiance * near, 1.0);  // c_i = E Y_i(w)
        }
      int backHits = 0;
      for (const Vec3& d : dirs) {
        const auto hit = tracer.intersect(Ray{p, d, eps});
        Rgb radiance;
        if (!hit) {
          radiance = rig.skyRadiance;
          if (env) radiance += env->radiance(d);
        } else if (hit->frontFace) {
          radiance = scene.emissionAt(hit->triangle, hit->u, hit->v);
        } else {
          ++backHits;
        }
        if (!radiance.isBlack()) sh.addSample(d, radiance, weight);
      }
      g.sh[c] = sh;
      invalid[c] = backHits * 4 > int(dirs.size()) ? 1 : 0;
    }
  }
  fillInvalidCells(g, invalid);
  // One bounce, gathered on a grid of half the resolution with eight times the rays (the same
  // cost): bounced light is smooth, and a small bright patch (the ceiling above a lamp) needs
  // many rays to be seen without spots. Each front face hit reflects the direct light found
  // there (Lambertian: albedo x E(n) / pi, E read from the direct grid); the coarse grid is then
  // added to the direct one trilinearly.
  ShGrid bounce = shGridLayout(box, std::max(1, maxCellsPerAxis / 2));
  const std::vector<Vec3> bounceDirs = fibonacciSphere(8 * int(dirs.size()));
  const double bounceWeight = 4.0 * kPi / double(bounceDirs.size());
  std::vector<uint8_t> bounceInvalid(bounce.sh.size(), 0);
  const size_t bounceRow = size_t(bounce.dims[0]);
  for (size_t row = 0; row * bounceRow < bounce.sh.size(); ++row) {
    if (cancelled && cancelled()) return {};
    for (size_t c = row * bounceRow; c < (row + 1) * bounceRow; ++c) {
      const Vec3 p = bounce.centre(c);
      int backHits = 0;
      for (const Vec3& d : bounceDirs) {
        const auto hit = tracer.intersect(Ray{p, d, eps});
        if (!hit) continue;
        if (!hit->frontFace) {
          ++backHits;
          continue;
        }
        const Vec3 n = hit->geometricNormal;
        const Rgb e = sampleShGridAt(g, p + d * hit->t).irradiance(n);
        const Rgb albedo = scene.albedoAt(hit->triangle, hit->u, hit->v);
        const Rgb reflected =
            Rgb(std::max(e.r, 0.0), std::max(e.g, 0.0), std::max(e.b, 0.0)) * albedo / kPi;
        if (!reflected.isBlack()) bounce.sh[c].addSample(d, reflected, bounceWeight);
      }
      bounceInvalid[c] = backHits * 4 > int(bounceDirs.size()) ? 1 : 0;
    }
  }
  fillInvalidCells(bounce, bounceInvalid);
  for (size_t c = 0; c < g.sh.size(); ++c) g.sh[c] += sampleShGridAt(bounce, g.centre(c));
  return g;
}

ShRgb sampleShGridAt(const ShGrid& g, Vec3 p) {
  if (g.sh.empty()) return {};
  int i0[3], i1[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    const double cell = std::max(g.cellMeters[a], 1e-12);
    const double t = std::clamp((p[a] - g.lo[a]) / cell - 0.5, 0.0, double(g.dims[a] - 1));
    i0[a] = std::min(int(t), g.dims[a] - 1);
    i1[a] = std::min(i0[a] + 1, g.dims[a] - 1);
    f[a] = t - i0[a];
  }
  const auto at = [&](int i, int j, int k) {
    return g.sh[size_t(i) + size_t(g.dims[0]) * (size_t(j) + size_t(g.dims[1]) * size_t(k))];
  };
  ShRgb out;
  for (int corner = 0; corner < 8; ++corner) {
    const int i = corner & 1 ? i1[0] : i0[0], j = corner & 2 ? i1[1] : i0[1],
              k = corner & 4 ? i1[2] : i0[2];
    const double w = (corner & 1 ? f[0] : 1 - f[0]) * (corner & 2 ? f[1] : 1 - f[1]) *
                     (corner & 4 ? f[2] : 1 - f[2]);
    if (w > 0) out += at(i, j, k) * w;
  }
  return out;
}

std::vector<double> litSurfaceLuminances(const Tracer& tracer, const ShGrid& grid,
                                         std::span<const Ray> rays) {
  const Scene& scene = tracer.scene();
  std::vector<double> out;
  out.reserve(rays.size());
  for (const Ray& ray : rays) {
    const auto hit = tracer.intersect(ray);
    if (!hit || !hit->frontFace) continue;
    const Vec3 p = ray.origin + ray.direction * hit->t;
    const Rgb e = sampleShGridAt(grid, p).irradiance(hit->geometricNormal);
    const Rgb albedo = scene.albedoAt(hit->triangle, hit->u, hit->v);
    const Rgb lit = Rgb(std::max(e.r, 0.0), std::max(e.g, 0.0), std::max(e.b, 0.0)) * albedo / kPi +
                    scene.emissionAt(hit->triangle, hit->u, hit->v);
    out.push_back(luminance(lit));
  }
  return out;
}

std::optional<double> meterExposure(std::vector<double> luminances) {
  if (luminances.empty()) return std::nullopt;
  double mean = 0;
  for (double l : luminances) mean += std::max(l, 0.0);
  mean /= double(luminances.size());
  if (!(mean > 0) || !std::isfinite(mean)) return std::nullopt;
  // Reinhard et al. 2002, eq. 1: the log-average, delta keeping black pixels finite.
  const double delta = 1e-3 * mean;
  double sumLog = 0;
  for (double l : luminances) sumLog += std::log(delta + std::max(l, 0.0));
  const double logAverage = std::exp(sumLog / double(luminances.size()));
  double exposure = kExposureKey / logAverage;
  const size_t k = std::min(luminances.size() - 1,
                            size_t(kExposureHighlightPercentile * double(luminances.size())));
  std::nth_element(luminances.begin(), luminances.begin() + long(k), luminances.end());
  if (luminances[k] > 0) exposure = std::min(exposure, kExposureHighlight / luminances[k]);
  return exposure;
}

}  // namespace ps::ui
