// probestudio capture: parses its options, calls the core stages and prints what it did; bad
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
#include "core/capture/VirtualOffset.h"
#include "core/common/Error.h"
#include "core/eval/Evaluate.h"
#include "core/io/JsonFields.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/VolumeFile.h"
#include "core/placement/Uniform.h"
#include "core/tessellation/Tetrahedralization.h"

namespace ps::cli {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

void registerCapture(CLI::App& app) {
  struct Opts {
    std::string scene, at, pointsFile, mode = "full";
    SamplingOptions sampling{256};
    uint64_t seed = 1;
    bool json = false, histograms = false, virtualOffset = false;
    RigOptions rig;
    UnitOptions units;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd =
      app.add_subcommand("capture", "Capture probes at given points and print their SH");
  cmd->add_option("scene", o->scene, "glTF scene")->required();
  auto* at = cmd->add_option("--at", o->at, "One point X,Y,Z (in the scene's unit, --units)");
  auto* pf = cmd->add_option("--points", o->pointsFile,
                             "File with one \"x y z\" per line (in the scene's unit)");
  at->excludes(pf);
  o->sampling.add(*cmd);
  cmd->add_option("--mode", o->mode, "full or indirect")
      ->check(CLI::IsMember({"full", "indirect"}));
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->add_flag("--json", o->json, "Print a JSON array (the only output format for now)");
  cmd->add_flag("--virtual-offset", o->virtualOffset,
                "Move points inside geometry (more than 25 % of 64 rays hit back faces) to the "
                "nearest valid point outside before capturing; \"position\" is where it was "
                "captured");
  cmd->add_flag("--histograms", o->histograms,
                "Add luminance_histogram and hue_histogram (layout in core/capture/Capture.h) "
                "to each object");
  o->rig.add(*cmd);
  o->units.add(*cmd);
  cmd->callback([o] {
    if (o->at.empty() && o->pointsFile.empty())
      throw ParameterError("capture: give --at X,Y,Z or --points FILE");
    std::vector<Vec3> pts =
        o->at.empty() ? readPointsFile(o->pointsFile) : std::vector<Vec3>{parseVec3(o->at, "--at")};
    // Points and the rig's positions in the scene's unit, the core's in metres.
    const std::optional<double> given = o->units.given();
    const double unit = given.value_or(1.0);
    for (Vec3& p : pts) p = p * unit;
    const Scene scene = loadSceneReporting(o->scene, unit, given.has_value());
    const Tracer tracer(scene);
    if (o->virtualOffset)
      for (Vec3& p : pts)
        if (const auto q = ps::virtualOffset(tracer, p, VirtualOffsetSettings{})) p = *q;
    CaptureSettings cs;
    o->sampling.apply(cs);
    cs.seed = o->seed;
    cs.mode = o->mode == "indirect" ? CaptureMode::IndirectOnly : CaptureMode::Full;
    const auto caps = captureProbes(tracer, scaledRig(o->rig.build(), unit), pts, cs);
    ojson out = ojson::array();
    const std::pair<const char*, Vec3> axes[6] = {{"+x", {1, 0, 0}}, {"-x", {-1, 0, 0}},
                                                  {"+y", {0, 1, 0}}, {"-y", {0, -1, 0}},
                                                  {"+z", {0, 0, 1}}, {"-z", {0, 0, -1}}};
    for (size_t i = 0; i < pts.size(); ++i) {
      const ProbeCapture& c = caps[i];
      ojson o2;
      o2["position"] = vecToJson(pts[i] * (1.0 / unit));
      ojson sh = ojson::array(), se = ojson::array();
      for (int k = 0; k < kShCoeffCount; ++k) {
        sh.push_back(rgbJson(c.sh.c[k]));
        se.push_back(rgbJson(c.shStdError.c[k]));
      }
      o2["sh"] = sh;
      o2["sh_std_error"] = se;
      ojson irr;
      for (const auto& [name, n] : axes) irr[name] = rgbJson(c.sh.irradiance(n));
      o2["irradiance"] = irr;
      o2["validity"] = 1.0 - c.backfaceFraction;
      o2["samples"] = c.samples;
      o2["seconds"] = c.seconds;
      if (o->histograms) {
        o2["luminance_histogram"] = c.luminanceHistogram;
        o2["hue_histogram"] = c.hueHistogram;
      }
      out.push_back(o2);
    }
    std::cout << out.dump(2) << "\n";
  });
}

}  // namespace ps::cli
