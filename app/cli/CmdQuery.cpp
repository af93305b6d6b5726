// probestudio query: parses its options, calls the core stages and prints what it did; bad
// input surfaces as ps::Error, caught in main.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/cli/Common.h"
#include "core/bake/Bake.h"
#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/eval/Evaluate.h"
#include "core/io/JsonFields.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/VolumeFile.h"
#include "core/placement/Uniform.h"
#include "core/tessellation/Tetrahedralization.h"
#include "core/traversal/VisibleInterpolation.h"

namespace ps::cli {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

/// How visibleWeights found a point's weights, as query prints it.
const char* fallbackName(VisibleFallback f) {
  switch (f) {
    case VisibleFallback::None:
      return "none";
    case VisibleFallback::Visibility:
      return "visibility";
    case VisibleFallback::Barycentric:
      return "barycentric";
    case VisibleFallback::Neighbours:
      return "neighbours";
  }
  return "none";
}

}  // namespace

void registerQuery(CLI::App& app) {
  struct Opts {
    std::string volume, at, pointsFile, normal = "0,1,0", normalsFile;
    bool json = false, noVisibility = false, normalTerm = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd =
      app.add_subcommand("query", "Locate points in a volume and interpolate irradiance");
  cmd->add_option("volume", o->volume, "Baked volume (.psv)")->required();
  auto* at = cmd->add_option("--at", o->at,
                             "One point X,Y,Z, in the volume's unit (the scene's, as baked)");
  auto* pf = cmd->add_option("--points", o->pointsFile,
                             "File with one \"x y z\" per line, in the volume's unit");
  at->excludes(pf);
  auto* nn =
      cmd->add_option("--normal", o->normal, "Normal NX,NY,NZ for every point (default 0,1,0)");
  auto* nf = cmd->add_option("--normals", o->normalsFile, "File with one normal per point");
  nn->excludes(nf);
  cmd->add_flag("--json", o->json, "Print JSON (the only output format for now)");
  cmd->add_flag("--no-visibility", o->noVisibility,
                "Interpolate with the barycentric weights alone, even when the volume carries "
                "visibility maps (as eval --no-visibility)");
  cmd->add_flag("--visibility-normal-term", o->normalTerm,
                "With visibility: weigh down the probes behind each point's normal (DDGI's smooth "
                "backface term), as a renderer shading a surface would");
  cmd->callback([o] {
    if (o->at.empty() && o->pointsFile.empty())
      throw ParameterError("query: give --at X,Y,Z or --points FILE");
    const VolumeFile vf = loadVolume(o->volume);
    const std::vector<Vec3> pts =
        o->at.empty() ? readPointsFile(o->pointsFile) : std::vector<Vec3>{parseVec3(o->at, "--at")};
    std::vector<Vec3> normals;
    if (!o->normalsFile.empty()) {
      normals = readPointsFile(o->normalsFile);
      if (normals.size() != pts.size())
        throw FileError(o->normalsFile, "",
                        "has " + std::to_string(normals.size()) + " normals for " +
                            std::to_string(pts.size()) + " points");
    } else {
      normals.assign(pts.size(), parseVec3(o->normal, "--normal"));
    }
    ojson out = ojson::array();
    int32_t hint = -1;
    for (size_t i = 0; i < pts.size(); ++i) {
      if (length(normals[i]) == 0) {
        if (o->normalsFile.empty())
          throw ParameterError("--normal: " + o->normal +
                               " has zero length; expected a non-zero normal");
        throw FileError(o->normalsFile, "normal " + std::to_string(i),
                        "has zero length; expected a non-zero normal");
      }
      // The volume is in metres in memory; the points in its file's unit.
      const Vec3 p = pts[i] * vf.metresPerUnit;
      const VolumeLocation loc = locate(vf.volume, p, hint);
      hint = loc.tet;
      const Vec3 n = normalize(normals[i]);
      // As eval and the runtime reader read the volume: the visibility-aware weights when it
      // carries maps (the point is in the air: no normal term unless asked), else barycentric.
      const bool visibility = vf.volume.hasVisibility() && !o->noVisibility;
      const VisibleWeights w =
          visibility ? visibleWeights(vf.volume, loc, p,
                                      o->normalTerm ? std::optional<Vec3>(n) : std::nullopt)
                     : barycentricWeights(vf.volume, loc);
      ojson q;
      q["position"] = vecToJson(pts[i]);
      q["tet"] = loc.tet;
      q["outside"] = loc.outside;
      q["probes"] = std::vector<int32_t>(w.probes.begin(), w.probes.begin() + w.count);
      q["weights"] = std::vector<double>(w.weights.begin(), w.weights.begin() + w.count);
      q["interpolant"] = visibility ? "visible" : "barycentric";
      if (visibility) q["fallback"] = fallbackName(w.fallback);
      q["irradiance"] = rgbJson(interpolate(vf.volume, w).irradiance(n));
      out.push_back(q);
    }
    std::cout << out.dump(2) << "\n";
  });
}

}  // namespace ps::cli
