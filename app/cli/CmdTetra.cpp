// probestudio tetra: parses its options, calls the core stages and prints what it did; bad
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

namespace ps::cli {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

void registerTetra(CLI::App& app) {
  struct Opts {
    std::string points, out;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd =
      app.add_subcommand("tetra", "Delaunay-tetrahedralize points and write the mesh as JSON");
  cmd->add_option("points", o->points, "Text file, one \"x y z\" per line")->required();
  cmd->add_option("-o,--output", o->out, "JSON file to write")->required();
  cmd->callback([o] {
    const auto pts = readPointsFile(o->points);
    const auto t0 = std::chrono::steady_clock::now();
    Tetrahedralization t;
    try {
      t = tetrahedralize(pts);
    } catch (const ParameterError& e) {
      // Name the file the points came from.
      std::string msg = e.what();
      if (msg.rfind("tetrahedralize: ", 0) == 0) msg = msg.substr(16);
      throw FileError(o->points, "", msg);
    }
    const double secs = secondsSince(t0);
    ojson j;
    j["vertex_of_input"] = t.vertexOfInput;
    ojson verts = ojson::array();
    for (const Vec3& v : t.vertices) verts.push_back(vecToJson(v));  // round-trip doubles
    j["vertices"] = std::move(verts);
    j["tets"] = t.tets;
    j["neighbors"] = t.neighbors;
    writeFileAtomic(o->out, j.dump() + "\n");
    std::printf("%zu points, %zu vertices, %zu tetrahedra in %.3f s -> %s\n", pts.size(),
                t.vertices.size(), t.tets.size(), secs, o->out.c_str());
  });
}

}  // namespace ps::cli
