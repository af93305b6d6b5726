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
  return map;
}

}  // namespace ps
