#include "app/cli/Common.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include "core/common/Error.h"
#include "core/io/JsonFields.h"
#include "core/scene/SceneUnits.h"

namespace ps::cli {

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

nlohmann::ordered_json rgbJson(Rgb c) {
  return {c.r, c.g, c.b};
}

bool isVolumePath(const std::filesystem::path& p) {
  if (p.extension() == ".psv") return true;  // a damaged volume is still reported as a volume
  std::ifstream in(p, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in.gcount() == 8 && std::string(magic, 8) == "PSVOLUM1";
}

VolumeSource volumeSource(const VolumeFile& vf, const std::filesystem::path& volumePath) {
  nlohmann::ordered_json meta;
  try {
    meta = nlohmann::ordered_json::parse(vf.metadataJson);
  } catch (const nlohmann::json::exception&) {
    throw FileError(volumePath.string(), "metadata", "not valid JSON");
  }
  const JsonField root(volumePath.string(), "metadata", &meta);
  VolumeSource s;
  std::filesystem::path scene(root.at("scene").string());
  if (scene.is_relative()) scene = std::filesystem::absolute(volumePath).parent_path() / scene;
  s.scenePath = scene.lexically_normal().string();
  s.rig = scaledRig(rigFromJson(root.at("rig")), vf.metresPerUnit);
  if (root.has("domain")) {
    const JsonField domain = root.at("domain");
    for (size_t i = 0; i < domain.arraySize(); ++i) {
      const JsonField box = domain.index(i);
      Bounds3 b;
      b.lo = box.at("min").vec3();
      b.hi = box.at("max").vec3();
      if (!(b.lo.x <= b.hi.x && b.lo.y <= b.hi.y && b.lo.z <= b.hi.z))
        box.fail("expected min <= max on every axis");
      b.lo = b.lo * vf.metresPerUnit;
      b.hi = b.hi * vf.metresPerUnit;
      s.domain.push_back(b);
    }
  }
  return s;
}

std::vector<double> parseNumbers(const std::string& text, const std::string& option) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const double d = std::strtod(item.c_str(), &end);
    if (item.empty() || end == item.c_str() || *end != '\0' || !std::isfinite(d))
      throw ParameterError(option + ": expected comma-separated finite numbers, got \"" + text +
                           "\"");
    v.push_back(d);
  }
  return v;
}

Vec3 parseVec3(const std::string& text, const std::string& option) {
  const auto v = parseNumbers(text, option);
  if (v.size() != 3)
    throw ParameterError(option + ": expected X,Y,Z (3 numbers), got " + std::to_string(v.size()));
  return {v[0], v[1], v[2]};
}

void UnitOptions::add(CLI::App& cmd) {
  cmd.add_option(
      "--units", units,
      "The scene's length unit: m, cm, mm or metres per unit (0.0254: inches). "
      "Positions on the command line and in the files written are in it; physical "
      "settings named in metres (--spacing, --domain-band, ...) stay in metres. Default: "
      "the unit a probe set or volume read was saved with, else m");
}

std::optional<double> UnitOptions::given() const {
  if (units.empty()) return std::nullopt;
  const std::optional<double> unit = parseSceneUnit(units);
  if (!unit)
    throw ParameterError("--units", std::string(kSceneUnitExpected) + ", got \"" + units + "\"");
  return unit;
}

double UnitOptions::agreeWith(double fileUnit, const std::string& file) const {
  const std::optional<double> unit = given();
  if (unit && *unit != fileUnit)
    throw ParameterError("--units", "is " + sceneUnitName(*unit) + ", but " + file +
                                        " was saved in units \"" + sceneUnitName(fileUnit) +
                                        "\" (its positions are in them); leave --units out");
  return fileUnit;
}

Scene loadSceneReporting(const std::string& path, double metresPerUnit, bool unitGiven) {
  Scene scene = loadScene(path, metresPerUnit);
  for (const std::string& w : scene.warnings) std::cerr << "warning: " << w << "\n";
  if (!unitGiven && metresPerUnit == 1.0) {
    const std::string hint = sceneUnitHint(path, scene.bounds, "--units");
    if (!hint.empty()) std::cerr << "warning: " << hint << "\n";
  }
  return scene;
}

void DomainOptions::add(CLI::App& cmd) {
  cmd.add_option("--domain", rule,
                 "Domain of interest without importance volumes: reachable (default: free space "
                 "within --domain-band of walkable ground, only the enclosed part in an "
                 "interior) or bounds (the scene's bounding box)");
  cmd.add_option("--domain-band", reachable.bandMeters,
                 "reachable: height above walkable surfaces, metres (default 3)");
  cmd.add_option("--domain-slope", reachable.maxSlopeDeg,
                 "reachable: steepest walkable surface, degrees from level (default 45)");
  cmd.add_option("--domain-cell", reachable.cellMeters,
                 "reachable: grid cell edge, metres (default 0: 0.25 m, coarser with a note "
                 "where that makes more than 16 million cells; an edge given that makes more "
                 "is refused)");
}

DomainSettings DomainOptions::build() const {
  DomainSettings d;
  d.reachable = reachable;
  try {
    d.rule = parseDomainRule(rule);
    checkReachableSettings(reachable);
  } catch (const ParameterError& e) {
    const std::string flag = e.parameter() == "bandMeters"    ? "--domain-band"
                             : e.parameter() == "maxSlopeDeg" ? "--domain-slope"
                             : e.parameter() == "cellMeters"  ? "--domain-cell"
                                                              : "--domain";
    throw ParameterError(flag, e.problem());
  }
  return d;
}

void RigOptions::add(CLI::App& cmd) {
  cmd.add_option("--sun", suns,
                 "Sun: DX,DY,DZ,E[,R,G,B] — direction from the scene towards the sun, irradiance "
                 "(W/m^2) on a surface facing it, optional colour; repeatable");
  cmd.add_option("--env", env, "Sky: constant radiance R,G,B (W/m^2/sr)");
  cmd.add_option("--env-map", envMap,
                 "Sky: equirectangular .hdr/.exr radiance map (W/m^2/sr, +Y up, centre column "
                 "towards -Z), added to --env");
  cmd.add_option(
      "--point", points,
      "Point light: X,Y,Z,I[,R,G,B] — position (scene units), radiant intensity (W/sr), optional "
      "colour; repeatable");
}

LightingRig RigOptions::build() const {
  LightingRig rig;
  for (const std::string& s : suns) {
    const auto v = parseNumbers(s, "--sun");
    if (v.size() != 4 && v.size() != 7)
      throw ParameterError("--sun: expected DX,DY,DZ,E or DX,DY,DZ,E,R,G,B, got \"" + s + "\"");
    const Vec3 d(v[0], v[1], v[2]);
    if (length(d) == 0) throw ParameterError("--sun: the direction must not be zero");
    if (v[3] < 0) throw ParameterError("--sun: the irradiance must not be negative");
    Light l;
    l.type = LightType::Directional;
    l.name = "sun";
    l.direction = -normalize(d);  // stored as the direction the light travels
    const Rgb colour = v.size() == 7 ? Rgb(v[4], v[5], v[6]) : Rgb(1, 1, 1);
    l.intensity = colour * v[3];
    rig.lights.push_back(l);
  }
  for (const std::string& s : points) {
    const auto v = parseNumbers(s, "--point");
    if (v.size() != 4 && v.size() != 7)
      throw ParameterError("--point: expected X,Y,Z,I or X,Y,Z,I,R,G,B, got \"" + s + "\"");
    if (v[3] < 0) throw ParameterError("--point: the intensity must not be negative");
    Light l;
    l.type = LightType::Point;
    l.name = "point";
    l.position = {v[0], v[1], v[2]};
    const Rgb colour = v.size() == 7 ? Rgb(v[4], v[5], v[6]) : Rgb(1, 1, 1);
    l.intensity = colour * v[3];
    rig.lights.push_back(l);
  }
  if (!env.empty()) {
    const auto v = parseNumbers(env, "--env");
    if (v.size() != 3) throw ParameterError("--env: expected R,G,B, got \"" + env + "\"");
    if (v[0] < 0 || v[1] < 0 || v[2] < 0)
      throw ParameterError("--env: the radiance must not be negative");
    rig.skyRadiance = {v[0], v[1], v[2]};
  }
  if (!envMap.empty()) {
    rig.envMapPath = envMap;
    rig.envMap = loadEnvironmentMap(envMap);  // a bad file fails here, naming it
    for (const std::string& w : rig.envMap->warnings) std::cerr << "warning: " << w << "\n";
  }
  return rig;
}

std::vector<Vec3> readPointsFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw FileError(path.string(), "", "cannot be opened for reading");
  std::vector<Vec3> pts;
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ls(line);
    Vec3 p;
    std::string extra;
    if (!(ls >> p.x >> p.y >> p.z) || (ls >> extra) || !isFinite(p))
      throw FileError(path.string(), "line " + std::to_string(lineNo),
                      "expected three finite numbers \"x y z\", got \"" + line + "\"");
    pts.push_back(p);
  }
  if (pts.empty())
    throw FileError(path.string(), "", "no points (expected one \"x y z\" per line)");
  return pts;
}

void SamplingOptions::add(CLI::App& cmd) {
  auto* fixed =
      cmd.add_option("--spp", spp, "Samples per probe (default " + std::to_string(spp) + ")")
          ->check(CLI::PositiveNumber);
  auto* target = cmd.add_option("--target-error", targetError,
                                "Adaptive: stop each probe when the relative standard error of its "
                                "irradiance is at most E (e.g. 0.02), or at --max-spp")
                     ->check(CLI::Range(1e-6, 1.0));
  target->excludes(fixed);
  cmd.add_option("--max-spp", maxSpp, "Adaptive: most samples per probe (default 65536)")
      ->check(CLI::Range(64, 1 << 24))
      ->needs(target);
}

void SamplingOptions::apply(CaptureSettings& settings) const {
  settings.samplesPerProbe = spp;
  settings.targetRelativeError = targetError;
  settings.maxSamplesPerProbe = maxSpp;
}

std::string SamplingOptions::describe() const {
  if (targetError > 0) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "target error %g (at most %d spp)", targetError, maxSpp);
    return buf;
  }
  return std::to_string(spp) + " spp";
}

ProgressFn terminalProgress(const std::string& label) {
  if (!::isatty(2)) return {};
  return [label, last = -1](double f) mutable {
    const int pct = static_cast<int>(f * 100);
    if (pct != last) {
      std::fprintf(stderr, "\r%s %3d%%%s", label.c_str(), pct, pct >= 100 ? "\n" : "");
      last = pct;
    }
    return true;
  };
}

void addRemovedOption(CLI::App& cmd, const std::string& name, bool takesValue,
                      const std::string& replacement) {
  const auto refuse = [name, replacement] {
    throw ParameterError(name, "removed; " + replacement);
  };
  CLI::Option* o = takesValue ? cmd.add_option_function<std::string>(
                                    name, [refuse](const std::string&) { refuse(); })
                              : cmd.add_flag_function(name, [refuse](int64_t) { refuse(); });
  o->group("");  // hidden from --help
}

}  // namespace ps::cli
