#include "core/scene/EnvironmentMap.h"

#include <algorithm>
#include <cmath>

#include "core/common/Error.h"
#include "core/scene/Texture.h"

namespace ps {

void EnvironmentMap::texelOf(Vec3 dir, int& column, int& row) const {
  const double len = length(dir);
  const Vec3 d = len > 0 && std::isfinite(len) ? dir / len : Vec3{0, 1, 0};
  const double u = 0.5 + std::atan2(d.x, -d.z) / (2 * kPi);
  const double v = std::acos(std::clamp(d.y, -1.0, 1.0)) / kPi;
  column = std::clamp(static_cast<int>(u * width), 0, width - 1);
  row = std::clamp(static_cast<int>(v * height), 0, height - 1);
}

Rgb EnvironmentMap::radiance(Vec3 dir) const {
  int column, row;
  texelOf(dir, column, row);
  const float* t =
      &rgb[(static_cast<size_t>(row) * static_cast<size_t>(width) + static_cast<size_t>(column)) *
           3];
  return {t[0], t[1], t[2]};
}

Vec3 EnvironmentMap::directionOf(double column, double row) const {
  const double phi = 2 * kPi * ((column + 0.5) / width - 0.5);
  const double theta = kPi * (row + 0.5) / height;
  return {std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
}

double EnvironmentMap::texelSolidAngle(int row) const {
  const double theta0 = kPi * row / height, theta1 = kPi * (row + 1) / height;
  return (2 * kPi / width) * (std::cos(theta0) - std::cos(theta1));
}

void EnvironmentMap::buildSampling() {
  marginalCdf.clear();
  conditionalCdf.clear();
  texelProbability.clear();
  const auto w = static_cast<size_t>(width), h = static_cast<size_t>(height);
  std::vector<double> weight(w * h);
  double total = 0;
  for (size_t r = 0; r < h; ++r) {
    const double omega = texelSolidAngle(static_cast<int>(r));
    for (size_t c = 0; c < w; ++c) {
      const float* t = &rgb[(r * w + c) * 3];
      weight[r * w + c] = luminance(Rgb(t[0], t[1], t[2])) * omega;
      total += weight[r * w + c];
    }
  }
  if (!(total > 0) || !std::isfinite(total)) return;  // black: nothing to sample
  texelProbability.resize(w * h);
  conditionalCdf.assign(h * (w + 1), 0.0);
  marginalCdf.assign(h + 1, 0.0);
  for (size_t r = 0; r < h; ++r) {
    double rowSum = 0;
    for (size_t c = 0; c < w; ++c) {
      texelProbability[r * w + c] = weight[r * w + c] / total;
      rowSum += weight[r * w + c];
      conditionalCdf[r * (w + 1) + c + 1] = rowSum;
    }
    for (size_t c = 1; c <= w; ++c)
      conditionalCdf[r * (w + 1) + c] =
          rowSum > 0 ? conditionalCdf[r * (w + 1) + c] / rowSum : static_cast<double>(c) / w;
    marginalCdf[r + 1] = marginalCdf[r] + rowSum / total;
  }
  marginalCdf[h] = 1.0;
}

namespace {

/// The index i with cdf[i] <= u < cdf[i + 1] among cdf[0..n] (cdf[0] = 0, cdf[n] = 1), skipping
/// empty intervals.
int findInterval(const double* cdf, int n, double u) {
  const double* it = std::upper_bound(cdf, cdf + n + 1, u);
  int i = static_cast<int>(it - cdf) - 1;
  i = std::clamp(i, 0, n - 1);
  while (i < n - 1 && cdf[i + 1] <= cdf[i]) ++i;  // never an interval of probability 0
  return i;
}

}  // namespace

Vec3 EnvironmentMap::sample(double u1, double u2, double& pdfOut) const {
  const int row = findInterval(marginalCdf.data(), height, u1);
  const double* cond = &conditionalCdf[static_cast<size_t>(row) * (static_cast<size_t>(width) + 1)];
  const int col = findInterval(cond, width, u2);
  // Reuse the uniforms' position inside the chosen intervals (stratification preserved).
  const double r0 = marginalCdf[size_t(row)], r1 = marginalCdf[size_t(row) + 1];
  const double c0 = cond[col], c1 = cond[col + 1];
  const double fu = r1 > r0 ? std::clamp((u1 - r0) / (r1 - r0), 0.0, 1.0) : 0.5;
  const double fv = c1 > c0 ? std::clamp((u2 - c0) / (c1 - c0), 0.0, 1.0) : 0.5;
  // Uniform in solid angle within the texel: uniform in cos theta and in phi.
  const double cos0 = std::cos(kPi * row / height), cos1 = std::cos(kPi * (row + 1) / height);
  const double z = cos0 + (cos1 - cos0) * fu;  // cos theta (theta from +Y)
  const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2 * kPi * ((col + fv) / width - 0.5);
  pdfOut = texelProbability[static_cast<size_t>(row) * static_cast<size_t>(width) +
                            static_cast<size_t>(col)] /
           texelSolidAngle(row);
  return {s * std::sin(phi), z, -s * std::cos(phi)};
}

double EnvironmentMap::pdf(Vec3 dir) const {
  int col, row;
  texelOf(dir, col, row);
  return texelProbability[static_cast<size_t>(row) * static_cast<size_t>(width) +
                          static_cast<size_t>(col)] /
         texelSolidAngle(row);
}

std::shared_ptr<const EnvironmentMap> loadEnvironmentMap(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw FileError(file, "", "environment map not found");
  if (std::filesystem::is_directory(path, ec))
    throw FileError(file, "", "is a directory, expected an .hdr or .exr environment map");
  std::string why;
  auto img = readLinearImage(file, why);
  if (!img) throw FileError(file, "", "not a readable environment map: " + why);
  auto map = std::make_shared<EnvironmentMap>();
  map->path = file;
  map->width = img->width;
  map->height = img->height;
  const size_t texels = static_cast<size_t>(img->width) * static_cast<size_t>(img->height);
  map->rgb.resize(texels * 3);
  size_t nonFinite = 0, negative = 0;
  for (size_t i = 0; i < texels; ++i)
    for (int c = 0; c < 3; ++c) {
      float v = img->rgba[i * 4 + static_cast<size_t>(c)];
      if (!std::isfinite(v)) {
        ++nonFinite;
        v = 0;
      } else if (v < 0) {
        ++negative;
        v = 0;
      }
      map->rgb[i * 3 + static_cast<size_t>(c)] = v;
    }
  if (nonFinite > 0)
    map->warnings.push_back(
        FileError(file, "", std::to_string(nonFinite) + " NaN or infinite texel values set to 0")
            .what());
  if (negative > 0)
    map->warnings.push_back(
        FileError(file, "", std::to_string(negative) + " negative texel values set to 0").what());
  map->buildSampling();
  return map;
}

}  // namespace ps
