#include "core/scene/SceneUnits.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>

#include "core/common/Check.h"
#include "core/scene/Scene.h"

namespace ps {

std::optional<double> parseSceneUnit(std::string_view text) {
  if (text == "m") return 1.0;
  if (text == "cm") return 0.01;
  if (text == "mm") return 0.001;
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || !std::isfinite(v) ||
      !(v > 0))
    return std::nullopt;
  return v;
}

std::string sceneUnitName(double metresPerUnit) {
  if (metresPerUnit == 1.0) return "m";
  if (metresPerUnit == 0.01) return "cm";
  if (metresPerUnit == 0.001) return "mm";
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, metresPerUnit);
  return std::string(buf, r.ptr);
}

void scaleScene(Scene& scene, double metresPerUnit) {
  PS_CHECK_OP(metresPerUnit, >, 0.0);
  PS_CHECK(std::isfinite(metresPerUnit));
  if (metresPerUnit == 1.0) return;
  scene.bounds = Bounds3{};
  for (size_t i = 0; i < scene.positions.size(); i += 3) {
    for (size_t k = 0; k < 3; ++k)
      scene.positions[i + k] = static_cast<float>(double(scene.positions[i + k]) * metresPerUnit);
    scene.bounds.extend(Vec3(scene.positions[i], scene.positions[i + 1], scene.positions[i + 2]));
  }
  for (Light& l : scene.lights) {
    l.position = l.position * metresPerUnit;
    l.rangeMeters *= metresPerUnit;
  }
}

std::optional<double> suggestedSceneUnit(const Bounds3& b) {
  if (b.empty()) return std::nullopt;
  const double height = b.extent().y;
  if (!(height > kUnitHintHeightLimit)) return std::nullopt;
  return height > 10 * kUnitHintHeightLimit ? 0.001 : 0.01;
}

std::string sceneUnitHint(const std::string& sceneName, const Bounds3& b, const std::string& flag) {
  const std::optional<double> unit = suggestedSceneUnit(b);
  if (!unit) return "";
  const Vec3 e = b.extent();
  char buf[512];
  std::snprintf(
      buf, sizeof buf, "%s is %.0f units across and %.0f tall; if it is in %s, pass %s %s",
      sceneName.c_str(), std::max({e.x, e.y, e.z}), e.y,
      *unit == 0.001 ? "millimetres" : "centimetres", flag.c_str(), sceneUnitName(*unit).c_str());
  return buf;
}

}  // namespace ps
