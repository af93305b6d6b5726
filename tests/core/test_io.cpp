// Probe-set JSON and volume binary: round trips, stable output, and clear errors naming the file
// and the field for malformed input.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <chrono>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/io/VolumeFile.h"
#include "core/runtime/ps_volume_reader.h"
#include "core/scene/SceneUnits.h"
#include "tests/core/TestFiles.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

fs::path tempDir() {
  return ps::test::testTempDir("ps_test_io_");
}

void writeText(const fs::path& p, const std::string& s) {
  std::ofstream(p, std::ios::binary) << s;
}

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

ProbeSet sampleSet(const fs::path& dir) {
  ProbeSet s;
  s.scenePath = (dir / "scenes" / "room.gltf").string();
  s.rig.skyRadiance = {0.1, 0.2, 0.3};
  Light sun;
  sun.type = LightType::Directional;
  sun.name = "sun";
  sun.direction = normalize(Vec3(0.3, -1, 0.2));
  sun.intensity = {3, 2.5, 2};
  s.rig.lights.push_back(sun);
  s.placement.method = "uniform";
  s.placement.spacingMeters = 0.75;
  s.sceneHash = 0x0123456789abcdefull;
  s.importanceVolumes.push_back({"stairs", {-1, 0, -2}, {1.5, 3, 2}, 4.0});
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-10, 10);
  for (int i = 0; i < 20; ++i) {
    Probe p;
    p.position = {u(rng), u(rng), u(rng)};
    p.state = static_cast<ProbeState>(i % 3);
    p.locked = i % 4 == 0;
    p.method = i % 2 ? "uniform" : "manual";
    p.score = u(rng);
    if (i % 3 == 1) {
      ShRgb sh;
      for (auto& c : sh.c) c = {u(rng), u(rng), u(rng)};
      p.sh = sh;
      p.captureSceneHash = i % 2 ? s.sceneHash : 0xfedcba9876543210ull;
    }
    s.add(p);
  }
  return s;
}

std::string loadError(const fs::path& p) {
  try {
    loadProbeSet(p);
  } catch (const FileError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(ProbeSetFile, RoundTripKeepsEverythingExactly) {
  const fs::path dir = tempDir();
  const ProbeSet s = sampleSet(dir);
  saveProbeSet(s, dir / "set.json");
  const ProbeSet r = loadProbeSet(dir / "set.json");
  EXPECT_EQ(fs::path(r.scenePath), fs::path(s.scenePath).lexically_normal());
  ASSERT_EQ(r.probes.size(), s.probes.size());
  for (size_t i = 0; i < s.probes.size(); ++i) {
    EXPECT_EQ(r.probes[i].id, s.probes[i].id);
    EXPECT_EQ(r.probes[i].position, s.probes[i].position);  // doubles round-trip exactly
    EXPECT_EQ(r.probes[i].state, s.probes[i].state);
    EXPECT_EQ(r.probes[i].locked, s.probes[i].locked);
    EXPECT_EQ(r.probes[i].method, s.probes[i].method);
    EXPECT_EQ(r.probes[i].score, s.probes[i].score);
    EXPECT_EQ(r.probes[i].sh.has_value(), s.probes[i].sh.has_value());
    if (s.probes[i].sh) {
      EXPECT_EQ(*r.probes[i].sh, *s.probes[i].sh);
      EXPECT_EQ(r.probes[i].captureSceneHash, s.probes[i].captureSceneHash);
    }
  }
  EXPECT_EQ(r.nextId, s.nextId);
  EXPECT_EQ(r.rig.skyRadiance, s.rig.skyRadiance);
  ASSERT_EQ(r.rig.lights.size(), 1u);
  EXPECT_EQ(r.rig.lights[0].intensity, s.rig.lights[0].intensity);
  EXPECT_EQ(r.placement.spacingMeters, 0.75);
  EXPECT_EQ(r.sceneHash, s.sceneHash);
  ASSERT_EQ(r.importanceVolumes.size(), 1u);
  EXPECT_EQ(r.importanceVolumes[0].name, "stairs");
  EXPECT_EQ(r.importanceVolumes[0].lo, Vec3(-1, 0, -2));
  EXPECT_EQ(r.importanceVolumes[0].hi, Vec3(1.5, 3, 2));
  EXPECT_EQ(r.importanceVolumes[0].weight, 4.0);
}

// The file holds lengths in the set's scene unit; memory holds metres.
TEST(ProbeSetFile, SceneUnitScalesTheFileAndReadsBackInMetres) {
  const fs::path dir = tempDir();
  ProbeSet s = sampleSet(dir);
  s.metresPerUnit = 0.01;
  Light lamp;
  lamp.type = LightType::Point;
  lamp.position = {1, 2, 3};
  lamp.rangeMeters = 5;
  s.rig.lights.push_back(lamp);
  saveProbeSet(s, dir / "cm.json");
  const auto j = nlohmann::json::parse(readText(dir / "cm.json"));
  EXPECT_EQ(j["units"], "cm");
  EXPECT_NEAR(j["probes"][3]["position"][1].get<double>(), 100 * s.probes[3].position.y, 1e-9);
  EXPECT_NEAR(j["importance_volumes"][0]["max"][1].get<double>(), 300, 1e-9);
  EXPECT_NEAR(j["rig"]["lights"][1]["position"][2].get<double>(), 300, 1e-9);
  EXPECT_EQ(j["rig"]["lights"][1]["range_m"].get<double>(), 5);  // metres in every unit
  EXPECT_EQ(j["placement"]["spacing_m"].get<double>(), 0.75);
  const ProbeSet r = loadProbeSet(dir / "cm.json");
  EXPECT_EQ(r.metresPerUnit, 0.01);
  for (size_t i = 0; i < s.probes.size(); ++i)
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(r.probes[i].position[a], s.probes[i].position[a], 1e-12);
  EXPECT_NEAR(r.importanceVolumes[0].hi.y, 3, 1e-12);
  EXPECT_NEAR(r.rig.lights[1].position.z, 3, 1e-12);
}

TEST(SceneUnits, NamesParseAndTheHintTellsMetresFromCentimetresAndMillimetres) {
  EXPECT_EQ(parseSceneUnit("m"), 1.0);
  EXPECT_EQ(parseSceneUnit("cm"), 0.01);
  EXPECT_EQ(parseSceneUnit("mm"), 0.001);
  EXPECT_EQ(parseSceneUnit("0.0254"), 0.0254);
  for (const char* bad : {"", "km", "0", "-1", "1e999", "nan", "1 m", "mm "})
    EXPECT_FALSE(parseSceneUnit(bad).has_value()) << bad;
  for (double u : {1.0, 0.01, 0.001, 0.0254, 0.3048})
    EXPECT_EQ(parseSceneUnit(sceneUnitName(u)), u);
  auto box = [](double x, double y, double z) { return Bounds3{{0, 0, 0}, {x, y, z}}; };
  EXPECT_FALSE(suggestedSceneUnit(box(12.5, 3.4, 6.4)));         // two-rooms, metres
  EXPECT_FALSE(suggestedSceneUnit(box(200, 14.3, 60)));          // the generated full level
  EXPECT_FALSE(suggestedSceneUnit(box(4000, 150, 4000)));        // an open world in metres
  EXPECT_EQ(suggestedSceneUnit(box(1250, 340, 640)), 0.01);      // two-rooms in cm
  EXPECT_EQ(suggestedSceneUnit(box(12500, 3400, 6400)), 0.001);  // two-rooms in mm
  EXPECT_EQ(suggestedSceneUnit(box(10240, 2600, 8000)), 0.001);  // a hotel room in mm
  EXPECT_EQ(sceneUnitHint("a.gltf", box(10240, 2600, 8000), "--units"),
            "a.gltf is 10240 units across and 2600 tall; if it is in millimetres, pass --units mm");
  EXPECT_EQ(sceneUnitHint("a.gltf", box(12.5, 3.4, 6.4), "--units"), "");
}

TEST(ProbeSetFile, Version1IsMigrated) {
  const fs::path dir = tempDir();
  writeText(dir / "v1.json",
            R"({"format": "probestudio.probeset", "version": 1, "scene": "room.gltf",
    "rig": {"sky_radiance": [1, 1, 1], "lights": []},
    "placement": {"method": "uniform", "spacing_m": 1.5, "budget": 0}, "next_id": 3,
    "probes": [{"id": 1, "position": [0, 1, 2], "state": "accepted", "locked": true,
                "method": "manual", "score": 0.5,
                "sh": [[1,1,1],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0]]},
               {"id": 2, "position": [3, 1, 2], "state": "candidate"}]})");
  const ProbeSet r = loadProbeSet(dir / "v1.json");
  EXPECT_EQ(r.sceneHash, 0u);
  EXPECT_TRUE(r.importanceVolumes.empty());
  ASSERT_EQ(r.probes.size(), 2u);
  EXPECT_TRUE(r.probes[0].locked);
  ASSERT_TRUE(r.probes[0].sh.has_value());
  EXPECT_EQ(r.probes[0].sh->c[0], Rgb(1, 1, 1));
  EXPECT_EQ(r.probes[0].captureSceneHash, 0u);
  // The migrated capture has no scene hash: reported as possibly stale, never silently fresh.
  const StaleCaptures st = staleCaptures(r, 42);
  EXPECT_TRUE(st.changed.empty());
  EXPECT_EQ(st.unknown, std::vector<uint64_t>{1});
  // Saving writes the current version.
  saveProbeSet(r, dir / "v3.json");
  EXPECT_NE(readText(dir / "v3.json").find("\"version\": 3"), std::string::npos);
  EXPECT_NE(readText(dir / "v3.json").find("\"units\": \"m\""), std::string::npos);
}

TEST(ProbeSetFile, StaleCapturesAreNamedWhenTheSceneChanges) {
  const fs::path dir = tempDir();
  fs::create_directories(dir / "scenes");
  writeText(dir / "scenes" / "room.gltf", R"({"asset": {"version": "2.0"},
    "buffers": [{"uri": "room.bin", "byteLength": 4}]})");
  writeText(dir / "scenes" / "room.bin", "abcd");
  const uint64_t h0 = sceneContentHash(dir / "scenes" / "room.gltf");
  EXPECT_NE(h0, 0u);
  EXPECT_EQ(h0, sceneContentHash(dir / "scenes" / "room.gltf"));
  ProbeSet s = sampleSet(dir);
  for (Probe& p : s.probes)
    if (p.sh) p.captureSceneHash = h0;
  EXPECT_FALSE(staleCaptures(s, h0).any());
  // Changing the external buffer (not the .gltf) changes the hash.
  writeText(dir / "scenes" / "room.bin", "abce");
  const uint64_t h1 = sceneContentHash(dir / "scenes" / "room.gltf");
  EXPECT_NE(h1, h0);
  const StaleCaptures st = staleCaptures(s, h1);
  std::vector<uint64_t> captured;
  for (const Probe& p : s.probes)
    if (p.sh) captured.push_back(p.id);
  EXPECT_EQ(st.changed, captured);
  const std::string msg = describeStaleCaptures(s, st);
  EXPECT_NE(msg.find(std::to_string(captured.size()) + " of " + std::to_string(captured.size()) +
                     " captures are stale"),
            std::string::npos)
      << msg;
  EXPECT_NE(msg.find("probes " + std::to_string(captured[0]) + ", "), std::string::npos) << msg;
  EXPECT_THROW(sceneContentHash(dir / "scenes" / "missing.gltf"), FileError);
}

TEST(ProbeSetFile, AHugeFileIsRefusedBeforeItIsRead) {
  const fs::path dir = tempDir();
  writeText(dir / "huge.json", "{");
  fs::resize_file(dir / "huge.json", uintmax_t(3) << 30);  // sparse: no disk space used
  EXPECT_NE(loadError(dir / "huge.json").find("above the probe-set limit"), std::string::npos);
  fs::remove(dir / "huge.json");
}

// Sets placed with leak refinement hold probes of method "leak": they load as any other probe
// (their provenance kept), and so does a placement block naming the setting.
TEST(ProbeSetFile, LeakProbesAndTheRefinementSettingStillLoad) {
  const fs::path dir = tempDir();
  ProbeSet set;
  set.scenePath = (dir / "room.gltf").string();
  for (int i = 0; i < 3; ++i) {
    Probe p;
    p.position = Vec3(i, 1, 0);
    p.state = ProbeState::Accepted;
    p.method = i == 2 ? "leak" : "uniform";
    p.score = i == 2 ? 3 : 0;
    set.add(p);
  }
  saveProbeSet(set, dir / "set.json");
  auto j = nlohmann::ordered_json::parse(readText(dir / "set.json"));
  j["placement"]["refine_leaks"] = true;
  writeText(dir / "set.json", j.dump(2));
  const ProbeSet r = loadProbeSet(dir / "set.json");
  ASSERT_EQ(r.probes.size(), 3u);
  EXPECT_EQ(r.probes[2].method, "leak");
  EXPECT_EQ(r.probes[2].state, ProbeState::Accepted);
  EXPECT_EQ(r.probes[2].score, 3);
}

TEST(ProbeSetFile, NewerVersionIsRefusedWithAClearMessage) {
  const fs::path dir = tempDir();
  writeText(dir / "v9.json", R"({"format": "probestudio.probeset", "version": 9, "probes": []})");
  EXPECT_EQ(loadError(dir / "v9.json"),
            (dir / "v9.json").string() +
                ": version: version 9 is newer than this build reads (3); update ProbeStudio");
}

TEST(ProbeSetFile, SceneIsStoredRelativeToTheFile) {
  const fs::path dir = tempDir();
  saveProbeSet(sampleSet(dir), dir / "set.json");
  EXPECT_NE(readText(dir / "set.json").find("\"scene\": \"scenes/room.gltf\""), std::string::npos);
}

TEST(ProbeSetFile, SavingTwiceGivesIdenticalBytes) {
  const fs::path dir = tempDir();
  const ProbeSet s = sampleSet(dir);
  saveProbeSet(s, dir / "a.json");
  saveProbeSet(loadProbeSet(dir / "a.json"), dir / "b.json");
  EXPECT_EQ(readText(dir / "a.json"), readText(dir / "b.json"));
}

TEST(ProbeSetFile, MalformedInputNamesFileAndField) {
  const fs::path dir = tempDir();
  const fs::path p = dir / "bad.json";
  const std::string head = R"({"format":"probestudio.probeset","version":1,"scene":"x.gltf",)";
  struct Case {
    std::string text, expected;
  };
  const Case cases[] = {
      {"{not json", "not valid JSON"},
      {"[1,2,3]", "expected a JSON object"},
      {R"({"format":"other","version":1,"scene":"","probes":[]})",
       "format: expected \"probestudio.probeset\""},
      {R"({"format":"probestudio.probeset","version":99,"scene":"","probes":[]})",
       "version: version 99 is newer than this build reads"},
      {R"({"format":"probestudio.probeset","version":"1","scene":"","probes":[]})",
       "version: expected an integer, got a string"},
      {head + R"("probes":[{"id":1,"position":[1,2],"state":"accepted"}]})",
       "probes[0].position: expected 3 numbers, got 2"},
      {head +
           R"("probes":[{"id":1,"position":[1,2,3],"state":"accepted"},{"id":2,"position":[1,2,"a"],"state":"accepted"}]})",
       "probes[1].position[2]: expected a number, got a string"},
      {head + R"("probes":[{"id":1,"position":[1,2,3],"state":"maybe"}]})",
       "probes[0].state: expected one of"},
      {head + R"("probes":[{"position":[1,2,3],"state":"accepted"}]})",
       "probes[0].id: missing field"},
      {head +
           R"("probes":[{"id":1,"position":[1,2,3],"state":"accepted"},{"id":1,"position":[1,2,3],"state":"accepted"}]})",
       "probes[1].id: duplicate id 1"},
      {head + R"("probes":[{"id":1,"position":[1,2,3],"state":"accepted","sh":[[1,2,3]]}]})",
       "probes[0].sh: expected 9 coefficients, got 1"},
      {head + R"("probes":{}})", "probes: expected an array"},
      {head + R"("rig":{"lights":[{"type":"laser"}]},"probes":[]})",
       "rig.lights[0].type: expected"},
      {R"({"format":"probestudio.probeset","version":1,"probes":[]})", "scene: missing field"},
  };
  for (const Case& c : cases) {
    writeText(p, c.text);
    const std::string msg = loadError(p);
    EXPECT_NE(msg.find(p.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.expected), std::string::npos)
        << "got: " << msg << "\nexpected: " << c.expected;
  }
  EXPECT_NE(loadError(dir / "missing.json").find("no such file"), std::string::npos);
}

TEST(ProbeSetFile, FailedSaveLeavesThePreviousFileIntact) {
  const fs::path dir = tempDir();
  const ProbeSet s = sampleSet(dir);
  saveProbeSet(s, dir / "set.json");
  const std::string before = readText(dir / "set.json");
  EXPECT_THROW(saveProbeSet(s, dir / "no-such-folder" / "set.json"), FileError);
  EXPECT_EQ(readText(dir / "set.json"), before);
  // No temporary files are left behind.
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1u);
}

namespace {

VolumeFile oneTetVolume() {
  VolumeFile vf;
  ProbeVolume& v = vf.volume;
  v.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  v.sh.assign(4 * 27, 0.f);
  for (int i = 0; i < 4 * 27; ++i) v.sh[i] = 0.01f * i;
  v.tets = {{1, 2, 3, 0}};
  v.neighbors = {{-1, -1, -1, -1}};
  v.matrices = {{1, 0, 0, 0, 1, 0, 0, 0, 1}};
  v.hullFaces = {{0, 0}, {0, 1}, {0, 2}, {0, 3}};
  vf.metadataJson = R"({"scene":"a.gltf"})";
  return vf;
}

/// Every array `saveVolume` writes, and the metadata, read back equal.
void expectSameVolume(const VolumeFile& r, const VolumeFile& vf) {
  EXPECT_EQ(r.volume.positions, vf.volume.positions);
  EXPECT_EQ(r.volume.sh, vf.volume.sh);
  EXPECT_EQ(r.volume.tets, vf.volume.tets);
  EXPECT_EQ(r.volume.neighbors, vf.volume.neighbors);
  EXPECT_EQ(r.volume.matrices, vf.volume.matrices);
  EXPECT_EQ(r.volume.hullFaces, vf.volume.hullFaces);
  EXPECT_EQ(r.volume.visibility, vf.volume.visibility);
  EXPECT_EQ(r.volume.probeInside, vf.volume.probeInside);
  EXPECT_EQ(r.metadataJson, vf.metadataJson);
}

std::string volumeError(const fs::path& p) {
  try {
    loadVolume(p);
  } catch (const FileError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(VolumeFile, RoundTripIsBitExact) {
  const fs::path dir = tempDir();
  const VolumeFile vf = oneTetVolume();
  saveVolume(vf, dir / "v.psv");
  expectSameVolume(loadVolume(dir / "v.psv"), vf);
}

// A volume of a scene in millimetres: the file holds its lengths in mm (what an engine reads),
// the metadata says so, and the loader gives the volume back in metres.
TEST(VolumeFile, SceneUnitScalesTheFileAndReadsBackInMetres) {
  const fs::path dir = tempDir();
  VolumeFile vf = oneTetVolume();
  vf.metresPerUnit = 0.001;
  saveVolume(vf, dir / "mm.psv");
  ps_runtime::Volume raw;
  std::string why;
  ASSERT_TRUE(ps_runtime::loadVolumeFile((dir / "mm.psv").c_str(), raw, &why)) << why;
  ASSERT_EQ(raw.positions.size(), vf.volume.positions.size());
  for (size_t i = 0; i < raw.positions.size(); ++i)
    EXPECT_EQ(raw.positions[i], vf.volume.positions[i] * 1000.f);
  EXPECT_NE(raw.metadataJson.find("\"units\":\"mm\""), std::string::npos) << raw.metadataJson;
  const VolumeFile r = loadVolume(dir / "mm.psv");
  EXPECT_EQ(r.metresPerUnit, 0.001);
  EXPECT_EQ(r.volume.positions, vf.volume.positions);
  for (size_t k = 0; k < 9; ++k)
    EXPECT_NEAR(r.volume.matrices[0][k], vf.volume.matrices[0][k], 1e-6);
  // A malformed unit names the metadata field. (saveVolume writes its own unit: the field is
  // renamed in the bytes, and the CRC made good.)
  VolumeFile bad = oneTetVolume();
  bad.metadataJson = R"({"scene":"a.gltf","unitz":"furlong"})";
  saveVolume(bad, dir / "bad.psv");
  std::string bytes = readText(dir / "bad.psv");
  bytes.replace(bytes.find("unitz"), 5, "units");
  const uint32_t crc = crc32(bytes.data(), bytes.size() - 4);
  std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  writeText(dir / "bad.psv", bytes);
  EXPECT_EQ(volumeError(dir / "bad.psv"), (dir / "bad.psv").string() + ": metadata.units: " +
                                              kSceneUnitExpected + ", got \"furlong\"");
}

namespace {

/// `bytes` (a version 1 or 4 file of P probes, T tets, H hull faces) rewritten with the leak-cut
/// section of versions 2 and 3 (the layout docs/formats.md keeps for them): version 2 from 1,
/// 3 from 4, the cut plane count C after the metadata count, then after the hull faces T + 1
/// cut starts (0, then C for every tet after the first) and C planes x = 0.25 hiding vertex 0
/// on their positive side. The CRC is recomputed.
std::string withCutSection(std::string bytes, uint32_t C) {
  uint32_t version, P, T, H;
  std::memcpy(&version, bytes.data() + 8, 4);
  std::memcpy(&P, bytes.data() + 16, 4);
  std::memcpy(&T, bytes.data() + 20, 4);
  std::memcpy(&H, bytes.data() + 24, 4);
  const bool maps = version == 4;
  const uint32_t old = maps ? 3 : 2;
  std::memcpy(bytes.data() + 8, &old, 4);
  const size_t header = 8 + 6 * 4 + (maps ? 4 : 0);
  const size_t hullEnd = header + size_t(P) * 120 + size_t(T) * 68 + size_t(H) * 8;
  std::string cuts;
  for (uint32_t t = 0; t <= T; ++t) {
    const uint32_t start = t == 0 ? 0 : C;
    cuts.append(reinterpret_cast<const char*>(&start), 4);
  }
  for (uint32_t c = 0; c < C; ++c) {
    const float plane[4] = {1, 0, 0, 0.25f};
    const uint32_t hide = 0x1;
    cuts.append(reinterpret_cast<const char*>(plane), 16);
    cuts.append(reinterpret_cast<const char*>(&hide), 4);
  }
  bytes.insert(hullEnd, cuts);
  bytes.insert(8 + 6 * 4, std::string(reinterpret_cast<const char*>(&C), 4));
  const uint32_t crc = crc32(bytes.data(), bytes.size() - 4);
  std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  return bytes;
}

/// oneTetVolume() with 1 x 1 visibility maps (each probe sees a surface 2 m away).
VolumeFile oneTetVolumeWithMaps() {
  VolumeFile vf = oneTetVolume();
  vf.volume.visibilityMapSize = 1;
  vf.volume.visibility = {2, 4, 2, 4, 2, 4, 2, 4};
  vf.volume.probeInside = {0, 0, 0, 0};
  return vf;
}

}  // namespace

// The written versions: 1 without visibility maps (every reader of version 1 reads it), 4 with
// them; both read back exactly.
TEST(VolumeFile, WritesVersion1WithoutMapsAnd4WithThem) {
  const fs::path dir = tempDir();
  for (const VolumeFile& vf : {oneTetVolume(), oneTetVolumeWithMaps()}) {
    saveVolume(vf, dir / "v.psv");
    const std::string bytes = readText(dir / "v.psv");
    EXPECT_EQ(bytes[8], vf.volume.hasVisibility() ? 4 : 1);
    // 32-byte header (36 with maps), 120 per probe, 68 per tet, 8 per hull face, the maps.
    const size_t mapBytes = vf.volume.hasVisibility() ? 4 + 4 * (1 + 8) : 0;
    EXPECT_EQ(bytes.size(), 32 + 4 * 120 + 68 + 4 * 8 + mapBytes + vf.metadataJson.size() + 4);
    expectSameVolume(loadVolume(dir / "v.psv"), vf);
  }
}

// Versions 2 and 3 hold a leak-cut section. Without planes (C = 0: every volume baked without
// the cuts) they read as the same volume; with planes the file is refused, naming the file and
// the field and saying to re-bake, by the core and by the runtime reader alike.
TEST(VolumeFile, OldVersionsReadWithoutCutsAndAreRefusedWithThem) {
  const fs::path dir = tempDir();
  for (const VolumeFile& vf : {oneTetVolume(), oneTetVolumeWithMaps()}) {
    saveVolume(vf, dir / "v.psv");
    const std::string current = readText(dir / "v.psv");
    writeText(dir / "uncut.psv", withCutSection(current, 0));
    EXPECT_EQ(readText(dir / "uncut.psv")[8], vf.volume.hasVisibility() ? 3 : 2);
    expectSameVolume(loadVolume(dir / "uncut.psv"), vf);
    ps_runtime::Volume rv;
    std::string why;
    EXPECT_TRUE(ps_runtime::loadVolumeFile((dir / "uncut.psv").string().c_str(), rv, &why)) << why;

    writeText(dir / "cut.psv", withCutSection(current, 2));
    const std::string error = volumeError(dir / "cut.psv");
    EXPECT_NE(error.find((dir / "cut.psv").string() + ": cut_plane_count: the volume holds 2 "
                                                      "leak cut planes"),
              std::string::npos)
        << error;
    EXPECT_NE(error.find("Re-bake the volume"), std::string::npos) << error;
    EXPECT_FALSE(ps_runtime::loadVolumeFile((dir / "cut.psv").string().c_str(), rv, &why));
    EXPECT_NE(why.find("cut.psv: cut_plane_count: 2 leak cut planes"), std::string::npos) << why;
    EXPECT_NE(why.find("re-bake"), std::string::npos) << why;
  }
}

TEST(VolumeFile, Crc32MatchesTheStandardCheckValue) {
  // The CRC-32 (IEEE 802.3) check value of "123456789" is 0xCBF43926.
  EXPECT_EQ(crc32("123456789", 9), 0xCBF43926u);
}

TEST(VolumeFile, CorruptFilesAreRefusedWithTheReason) {
  const fs::path dir = tempDir();
  saveVolume(oneTetVolume(), dir / "v.psv");
  const std::string good = readText(dir / "v.psv");
  const fs::path p = dir / "bad.psv";
  auto expectError = [&](const std::string& bytes, const std::string& expected) {
    writeText(p, bytes);
    const std::string msg = volumeError(p);
    EXPECT_NE(msg.find(p.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find(expected), std::string::npos)
        << "got: " << msg << "\nexpected: " << expected;
  };
  expectError("", "magic: truncated");
  expectError("NOTAVOLUMEFILE-----------------------", "not a ProbeStudio volume");
  expectError(good.substr(0, good.size() / 2), "header: counts");
  std::string flipped = good;
  flipped[40] ^= 0x5A;
  expectError(flipped, "crc32: checksum mismatch");
  std::string version = good;
  version[8] = 9;
  expectError(version, "version: unsupported version 9");
  std::string huge = good;
  huge[16] = huge[17] = huge[18] = '\xff';  // probe count ~16 million in a tiny file
  expectError(huge, "header: counts");
}

// A process killed (SIGKILL) at any moment of a save leaves either the previous file or the new
// one, whole and loadable: never a torn file (writeFileAtomic: temp file, fsync, rename).
TEST(ProbeSetFile, SaveKilledMidWayLeavesALoadableFile) {
  const fs::path dir = tempDir();
  const fs::path target = dir / "set.json";
  ProbeSet a = sampleSet(dir);
  ProbeSet b = a;
  // Big enough that a save takes a while, so kills land inside it.
  for (int i = 0; i < 3000; ++i) {
    Probe p;
    p.position = {i * 0.001, 1.0 / (i + 3), -i * 0.5};
    p.sh = ShRgb{};
    b.add(p);
  }
  saveProbeSet(a, target);
  const std::string bytesA = readText(target);
  // Kills are timed against how long one save takes here (a sanitizer build or a busy machine
  // is many times slower), so that they land inside saves.
  const auto t0 = std::chrono::steady_clock::now();
  saveProbeSet(b, target);
  const double saveMicros =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  const std::string bytesB = readText(target);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> delay(0.5 * saveMicros, 4.0 * saveMicros);
#if defined(__SANITIZE_ADDRESS__)
  const int rounds = 20;
#else
  const int rounds = 60;
#endif
  // The kills must land inside saves at least once (they then leave temporary files behind,
  // never the target torn); more rounds up to 10x when the timing keeps missing the window.
  auto tempsLeft = [&] {
    size_t temps = 0;
    for (const auto& e : fs::directory_iterator(dir))
      temps += e.path().filename().string().find(".tmp-") != std::string::npos;
    return temps;
  };
  int killedWhileRunning = 0, round = 0;
  for (; round < rounds || (tempsLeft() == 0 && round < 10 * rounds); ++round) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      for (int k = 0;; ++k) saveProbeSet(k % 2 ? a : b, target);  // until killed
    }
    ::usleep(useconds_t(delay(rng)));
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    killedWhileRunning += WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
    const std::string now = readText(target);
    ASSERT_TRUE(now == bytesA || now == bytesB)
        << "torn file after kill " << round << ", " << now.size() << " bytes";
    EXPECT_NO_THROW(loadProbeSet(target));
  }
  EXPECT_EQ(killedWhileRunning, round);
  EXPECT_GT(tempsLeft(), 0u) << "no kill landed inside a save in " << round << " rounds (one save "
                             << saveMicros << " us)";
}
