// The probestudio subcommands. Each parses its options, calls core stages, and prints what it
// did; bad input surfaces as ps::Error, caught in main.
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

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

ojson rgbJson(Rgb c) {
  return {c.r, c.g, c.b};
}

bool isVolumePath(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in.gcount() == 8 && std::string(magic, 8) == "PSVOLUM1";
}

/// Scene path stored in a volume's metadata, resolved against the volume's folder.
struct VolumeSource {
  std::string scenePath;
  LightingRig rig;
};
VolumeSource volumeSource(const VolumeFile& vf, const fs::path& volumePath) {
  ojson meta;
  try {
    meta = ojson::parse(vf.metadataJson);
  } catch (const nlohmann::json::parse_error&) {
    throw FileError(volumePath.string(), "metadata", "not valid JSON");
  }
  const JsonField root(volumePath.string(), "metadata", &meta);
  VolumeSource s;
  fs::path scene(root.at("scene").string());
  if (scene.is_relative()) scene = fs::absolute(volumePath).parent_path() / scene;
  s.scenePath = scene.lexically_normal().string();
  s.rig = rigFromJson(root.at("rig"));
  return s;
}

}  // namespace

// ---------------------------------------------------------------- place
void registerPlace(CLI::App& app) {
  struct Opts {
    std::string scene, out, method = "uniform";
    double spacing = 0;
    int budget = 0;
    bool accept = false;
    uint64_t seed = 1;
    RigOptions rig;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand("place", "Propose probe positions for a scene");
  cmd->add_option("scene", o->scene, "glTF scene (.gltf or .glb)")->required();
  cmd->add_option("--method", o->method, "Placement method: uniform");
  cmd->add_option("--spacing", o->spacing, "Grid spacing in metres (uniform)");
  cmd->add_option("--budget", o->budget,
                  "Target probe count (uniform: the spacing giving it within 10 %)");
  cmd->add_flag("--accept", o->accept, "Mark the proposals accepted instead of candidates");
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->add_option("-o,--output", o->out, "Probe set to write (.json)")->required();
  o->rig.add(*cmd);
  cmd->callback([o] {
    if (o->method != "uniform")
      throw ParameterError("--method: unknown method \"" + o->method + "\" (available: uniform)");
    if (o->spacing != 0 && o->budget != 0)
      throw ParameterError("--spacing and --budget: give one, not both");
    const auto t0 = std::chrono::steady_clock::now();
    const Scene scene = loadScene(o->scene);
    const Tracer tracer(scene);
    ProbeSet set;
    set.scenePath = fs::absolute(o->scene).string();
    set.rig = o->rig.build();
    set.placement.method = o->method;
    UniformSettings us;
    us.seed = o->seed;
    std::vector<Vec3> points;
    if (o->budget != 0) {
      auto r = placeUniformBudget(tracer, o->budget, us, terminalProgress("place"));
      points = std::move(r.points);
      us.spacingMeters = r.spacingMeters;
      set.placement.budget = o->budget;
    } else {
      us.spacingMeters =
          o->spacing != 0 ? o->spacing : std::max(0.25, scene.bounds.diagonal() / 10);
      points = placeUniform(tracer, us, terminalProgress("place"));
    }
    set.placement.spacingMeters = us.spacingMeters;
    for (const Vec3& p : points) {
      Probe pr;
      pr.position = p;
      pr.state = o->accept ? ProbeState::Accepted : ProbeState::Candidate;
      pr.method = o->method;
      set.add(pr);
    }
    saveProbeSet(set, o->out);
    std::printf("placed %zu probes (method %s, spacing %.3f m) in %.2f s -> %s\n", points.size(),
                o->method.c_str(), us.spacingMeters, secondsSince(t0), o->out.c_str());
  });
}

// ---------------------------------------------------------------- bake
void registerBake(CLI::App& app) {
  struct Opts {
    std::string set, out;
    int spp = 1024;
    uint64_t seed = 1;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd =
      app.add_subcommand("bake", "Capture the accepted probes and write the runtime volume");
  cmd->add_option("probe_set", o->set, "Probe set (.json)")->required();
  cmd->add_option("-o,--output", o->out, "Volume to write (.psv)")->required();
  cmd->add_option("--spp", o->spp, "Samples per probe")->check(CLI::PositiveNumber);
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->callback([o] {
    const ProbeSet set = loadProbeSet(o->set);
    if (set.scenePath.empty()) throw FileError(o->set, "scene", "the probe set names no scene");
    const Scene scene = loadScene(set.scenePath);
    const Tracer tracer(scene);
    BakeSettings bs;
    bs.capture.samplesPerProbe = o->spp;
    bs.capture.seed = o->seed;
    BakeResult r = bakeProbeSet(set, tracer, bs, terminalProgress("bake"));
    // Store the scene path relative to the volume, like the probe set does.
    ojson meta = ojson::parse(r.file.metadataJson);
    std::error_code ec;
    const fs::path rel = fs::relative(set.scenePath, fs::absolute(o->out).parent_path(), ec);
    if (!ec && !rel.empty()) meta["scene"] = rel.generic_string();
    r.file.metadataJson = meta.dump();
    saveVolume(r.file, o->out);
    std::printf(
        "baked %zu probes, %zu tetrahedra (capture %.2f s at %d spp, tetrahedralize %.3f s) -> "
        "%s\n",
        r.probes, r.file.volume.tets.size(), r.captureSeconds, o->spp, r.tetraSeconds,
        o->out.c_str());
  });
}

// ---------------------------------------------------------------- capture
void registerCapture(CLI::App& app) {
  struct Opts {
    std::string scene, at, pointsFile, mode = "full";
    int spp = 256;
    uint64_t seed = 1;
    bool json = false;
    RigOptions rig;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd =
      app.add_subcommand("capture", "Capture probes at given points and print their SH");
  cmd->add_option("scene", o->scene, "glTF scene")->required();
  auto* at = cmd->add_option("--at", o->at, "One point X,Y,Z");
  auto* pf = cmd->add_option("--points", o->pointsFile, "File with one \"x y z\" per line");
  at->excludes(pf);
  cmd->add_option("--spp", o->spp, "Samples per probe")->check(CLI::PositiveNumber);
  cmd->add_option("--mode", o->mode, "full or indirect")
      ->check(CLI::IsMember({"full", "indirect"}));
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->add_flag("--json", o->json, "Print a JSON array (the only output format for now)");
  o->rig.add(*cmd);
  cmd->callback([o] {
    if (o->at.empty() && o->pointsFile.empty())
      throw ParameterError("capture: give --at X,Y,Z or --points FILE");
    const std::vector<Vec3> pts =
        o->at.empty() ? readPointsFile(o->pointsFile) : std::vector<Vec3>{parseVec3(o->at, "--at")};
    const Scene scene = loadScene(o->scene);
    const Tracer tracer(scene);
    CaptureSettings cs;
    cs.samplesPerProbe = o->spp;
    cs.seed = o->seed;
    cs.mode = o->mode == "indirect" ? CaptureMode::IndirectOnly : CaptureMode::Full;
    const auto caps = captureProbes(tracer, o->rig.build(), pts, cs);
    ojson out = ojson::array();
    const std::pair<const char*, Vec3> axes[6] = {{"+x", {1, 0, 0}}, {"-x", {-1, 0, 0}},
                                                  {"+y", {0, 1, 0}}, {"-y", {0, -1, 0}},
                                                  {"+z", {0, 0, 1}}, {"-z", {0, 0, -1}}};
    for (size_t i = 0; i < pts.size(); ++i) {
      const ProbeCapture& c = caps[i];
      ojson o2;
      o2["position"] = vecToJson(pts[i]);
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
      o2["backface_fraction"] = c.backfaceFraction;
      o2["samples"] = c.samples;
      o2["seconds"] = c.seconds;
      out.push_back(o2);
    }
    std::cout << out.dump(2) << "\n";
  });
}

// ---------------------------------------------------------------- tetra
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

// ---------------------------------------------------------------- query
void registerQuery(CLI::App& app) {
  struct Opts {
    std::string volume, at, pointsFile, normal = "0,1,0", normalsFile;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd =
      app.add_subcommand("query", "Locate points in a volume and interpolate irradiance");
  cmd->add_option("volume", o->volume, "Baked volume (.psv)")->required();
  auto* at = cmd->add_option("--at", o->at, "One point X,Y,Z");
  auto* pf = cmd->add_option("--points", o->pointsFile, "File with one \"x y z\" per line");
  at->excludes(pf);
  auto* nn =
      cmd->add_option("--normal", o->normal, "Normal NX,NY,NZ for every point (default 0,1,0)");
  auto* nf = cmd->add_option("--normals", o->normalsFile, "File with one normal per point");
  nn->excludes(nf);
  cmd->add_flag("--json", o->json, "Print JSON (the only output format for now)");
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
      if (length(normals[i]) == 0) throw ParameterError("normal " + std::to_string(i) + " is zero");
      const VolumeLocation loc = locate(vf.volume, pts[i], hint);
      hint = loc.tet;
      ojson q;
      q["position"] = vecToJson(pts[i]);
      q["tet"] = loc.tet;
      q["outside"] = loc.outside;
      q["weights"] = loc.weights;
      q["irradiance"] = rgbJson(interpolate(vf.volume, loc).irradiance(normalize(normals[i])));
      out.push_back(q);
    }
    std::cout << out.dump(2) << "\n";
  });
}

// ---------------------------------------------------------------- eval
void registerEval(CLI::App& app) {
  struct Opts {
    std::string input;
    int queries = 256, referenceSpp = 1024, spp = 512;
    uint64_t seed = 7;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd =
      app.add_subcommand("eval", "Measure a volume's irradiance error against a reference capture");
  cmd->add_option("input", o->input, "Probe set (.json) or baked volume (.psv)")->required();
  cmd->add_option("--queries", o->queries, "Random query points")->check(CLI::PositiveNumber);
  cmd->add_option("--reference-spp", o->referenceSpp, "Samples per reference query")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--spp", o->spp, "Samples per probe when a probe set must be captured")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--seed", o->seed, "Random seed");
  cmd->add_flag("--json", o->json, "Print JSON");
  cmd->callback([o] {
    std::string scenePath;
    LightingRig rig;
    ProbeVolume volume;
    std::optional<ProbeSet> set;
    if (isVolumePath(o->input)) {
      VolumeFile vf = loadVolume(o->input);
      const VolumeSource src = volumeSource(vf, o->input);
      scenePath = src.scenePath;
      rig = src.rig;
      volume = std::move(vf.volume);
    } else {
      set = loadProbeSet(o->input);
      scenePath = set->scenePath;
      rig = set->rig;
    }
    const Scene scene = loadScene(scenePath);
    const Tracer tracer(scene);
    if (set) {
      BakeSettings bs;
      bs.capture.samplesPerProbe = o->spp;
      volume = bakeProbeSet(*set, tracer, bs, terminalProgress("capture")).file.volume;
    }
    EvalSettings es;
    es.queries = o->queries;
    es.referenceSpp = o->referenceSpp;
    es.seed = o->seed;
    const EvalResult r = evaluateVolume(tracer, rig, volume, es, terminalProgress("eval"));
    if (o->json) {
      ojson j;
      j["probes"] = r.probes;
      j["queries"] = r.queries;
      j["rel_rmse"] = r.relRmse;
      j["p95_rel_error"] = r.p95RelError;
      j["max_rel_error"] = r.maxRelError;
      j["seconds"] = r.seconds;
      std::cout << j.dump(2) << "\n";
    } else {
      std::printf(
          "probes %zu, queries %zu: relative RMS irradiance error %.4f, p95 %.4f, max %.4f (%.2f "
          "s)\n",
          r.probes, r.queries, r.relRmse, r.p95RelError, r.maxRelError, r.seconds);
    }
  });
}

// ---------------------------------------------------------------- info
void registerInfo(CLI::App& app) {
  auto file = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("info", "Print what a probe set or a volume holds");
  cmd->add_option("file", *file, "Probe set (.json) or volume (.psv)")->required();
  cmd->callback([file] {
    if (isVolumePath(*file)) {
      const VolumeFile vf = loadVolume(*file);
      const VolumeSource src = volumeSource(vf, *file);
      std::printf("%s: probe volume, format version 1, SH order 2\n", file->c_str());
      std::printf("  probes %zu, tetrahedra %zu, hull faces %zu\n", vf.volume.probeCount(),
                  vf.volume.tets.size(), vf.volume.hullFaces.size());
      std::printf("  scene %s, %zu rig lights\n", src.scenePath.c_str(), src.rig.lights.size());
      return;
    }
    const ProbeSet set = loadProbeSet(*file);
    size_t counts[3] = {0, 0, 0}, captured = 0, locked = 0;
    for (const Probe& p : set.probes) {
      ++counts[static_cast<int>(p.state)];
      captured += p.sh.has_value();
      locked += p.locked;
    }
    std::printf("%s: probe set, format version %d\n", file->c_str(), ProbeSet::kFormatVersion);
    std::printf("  scene %s\n", set.scenePath.c_str());
    std::printf(
        "  probes %zu: %zu candidate, %zu accepted, %zu rejected; %zu locked, %zu captured\n",
        set.probes.size(), counts[0], counts[1], counts[2], locked, captured);
    std::printf("  placement %s, spacing %.3f m, budget %d; rig: %zu lights, sky [%g, %g, %g]\n",
                set.placement.method.c_str(), set.placement.spacingMeters, set.placement.budget,
                set.rig.lights.size(), set.rig.skyRadiance.r, set.rig.skyRadiance.g,
                set.rig.skyRadiance.b);
  });
}

}  // namespace ps::cli
