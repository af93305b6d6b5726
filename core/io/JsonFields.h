#pragma once
// Internal to core/io and app/cli (includes nlohmann/json; not a public core header).
// JsonField walks a parsed JSON document while remembering the path to the current field, so
// that every validation error names it: `probes[12].position: expected 3 numbers, got 2`.
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "core/common/Error.h"
#include "core/math/Vec3.h"
#include "core/scene/LightingRig.h"
#include "core/scene/SceneUnits.h"

namespace ps {

class JsonField {
 public:
  using Json = nlohmann::ordered_json;
  JsonField(std::string file, std::string path, const Json* j)
      : file_(std::move(file)), path_(std::move(path)), j_(j) {}

  [[noreturn]] void fail(const std::string& problem) const {
    throw FileError(file_, path_, problem);
  }
  bool has(const char* key) const { return j_->is_object() && j_->contains(key); }
  JsonField at(const char* key) const {
    const std::string p = path_.empty() ? key : path_ + "." + key;
    if (!j_->is_object()) fail("expected an object");
    auto it = j_->find(key);
    if (it == j_->end()) throw FileError(file_, p, "missing field");
    return JsonField(file_, p, &*it);
  }
  size_t arraySize() const {
    if (!j_->is_array()) fail("expected an array, got " + typeName());
    return j_->size();
  }
  JsonField index(size_t i) const {
    arraySize();
    return JsonField(file_, path_ + "[" + std::to_string(i) + "]", &(*j_)[i]);
  }
  double number() const {
    if (!j_->is_number()) fail("expected a number, got " + typeName());
    const double v = j_->get<double>();
    if (!std::isfinite(v)) fail("expected a finite number");
    return v;
  }
  int64_t integer64() const {
    if (!j_->is_number_integer()) fail("expected an integer, got " + typeName());
    return j_->get<int64_t>();
  }
  int integer() const {
    const int64_t v = integer64();
    if (v < INT32_MIN || v > INT32_MAX) fail("integer out of range");
    return static_cast<int>(v);
  }
  bool boolean() const {
    if (!j_->is_boolean()) fail("expected true or false, got " + typeName());
    return j_->get<bool>();
  }
  std::string string() const {
    if (!j_->is_string()) fail("expected a string, got " + typeName());
    return j_->get<std::string>();
  }
  Vec3 vec3() const {
    const auto a = numbers(3);
    return {a[0], a[1], a[2]};
  }
  Rgb rgb() const {
    const auto a = numbers(3);
    return {a[0], a[1], a[2]};
  }

 private:
  std::array<double, 3> numbers(size_t n) const {
    if (!j_->is_array()) fail("expected " + std::to_string(n) + " numbers, got " + typeName());
    if (j_->size() != n)
      fail("expected " + std::to_string(n) + " numbers, got " + std::to_string(j_->size()));
    std::array<double, 3> a{};
    for (size_t i = 0; i < n; ++i) a[i] = index(i).number();
    return a;
  }
  std::string typeName() const {
    if (j_->is_null()) return "null";
    if (j_->is_array()) return "an array of " + std::to_string(j_->size());
    if (j_->is_object()) return "an object";
    if (j_->is_string()) return "a string";
    if (j_->is_boolean()) return "a boolean";
    return "a number";
  }
  std::string file_, path_;
  const Json* j_;
};

/// A "units" field (core/scene/SceneUnits.h): "m", "cm", "mm" or a positive number of metres
/// per unit, as text. Returns metres per unit; fails naming the field for anything else.
inline double sceneUnitFromJson(const JsonField& f) {
  const std::string s = f.string();
  const std::optional<double> unit = parseSceneUnit(s);
  if (!unit) f.fail(std::string(kSceneUnitExpected) + ", got \"" + s + "\"");
  return *unit;
}

inline nlohmann::ordered_json vecToJson(Vec3 v) {
  return {v.x, v.y, v.z};
}
inline nlohmann::ordered_json rgbToJson(Rgb c) {
  return {c.r, c.g, c.b};
}

inline const char* lightTypeName(LightType t) {
  switch (t) {
    case LightType::Directional:
      return "directional";
    case LightType::Point:
      return "point";
    case LightType::Spot:
      return "spot";
  }
  return "point";
}

inline nlohmann::ordered_json rigToJson(const LightingRig& rig) {
  nlohmann::ordered_json r;
  r["sky_radiance"] = rgbToJson(rig.skyRadiance);
  // Written only when set, so rigs without a map keep their JSON (and capture-cache keys).
  if (!rig.envMapPath.empty()) r["env_map"] = rig.envMapPath;
  auto lights = nlohmann::ordered_json::array();
  for (const Light& l : rig.lights) {
    nlohmann::ordered_json o;
    o["type"] = lightTypeName(l.type);
    o["name"] = l.name;
    if (l.type != LightType::Directional) o["position"] = vecToJson(l.position);
    if (l.type != LightType::Point) o["direction"] = vecToJson(l.direction);
    o["intensity"] = rgbToJson(l.intensity);
    if (l.rangeMeters > 0) o["range_m"] = l.rangeMeters;
    if (l.type == LightType::Spot) {
      o["inner_cone_rad"] = l.innerConeRad;
      o["outer_cone_rad"] = l.outerConeRad;
    }
    lights.push_back(std::move(o));
  }
  r["lights"] = std::move(lights);
  return r;
}

inline LightingRig rigFromJson(const JsonField& f) {
  LightingRig rig;
  if (f.has("sky_radiance")) rig.skyRadiance = f.at("sky_radiance").rgb();
  // The path only: the map is read when a capture first needs it (environmentOf).
  if (f.has("env_map")) {
    rig.envMapPath = f.at("env_map").string();
    if (rig.envMapPath.empty()) f.at("env_map").fail("expected a file path, got an empty string");
  }
  if (f.has("lights")) {
    const JsonField ls = f.at("lights");
    for (size_t i = 0; i < ls.arraySize(); ++i) {
      const JsonField lf = ls.index(i);
      Light l;
      const std::string type = lf.at("type").string();
      if (type == "directional")
        l.type = LightType::Directional;
      else if (type == "point")
        l.type = LightType::Point;
      else if (type == "spot")
        l.type = LightType::Spot;
      else
        lf.at("type").fail("expected \"directional\", \"point\" or \"spot\", got \"" + type + "\"");
      if (lf.has("name")) l.name = lf.at("name").string();
      if (l.type != LightType::Directional) l.position = lf.at("position").vec3();
      if (l.type != LightType::Point) {
        const Vec3 d = lf.at("direction").vec3();
        if (length(d) == 0) lf.at("direction").fail("expected a non-zero direction");
        // A direction already unit to rounding is kept as written: normalising it again moves
        // its last bits (differently with FMA), and a load and save must write the same bytes.
        l.direction = std::abs(length(d) - 1) <= 1e-12 ? d : normalize(d);
      }
      l.intensity = lf.at("intensity").rgb();
      if (lf.has("range_m")) l.rangeMeters = lf.at("range_m").number();
      if (l.type == LightType::Spot) {
        l.innerConeRad = lf.at("inner_cone_rad").number();
        l.outerConeRad = lf.at("outer_cone_rad").number();
      }
      rig.lights.push_back(l);
    }
  }
  return rig;
}

}  // namespace ps
