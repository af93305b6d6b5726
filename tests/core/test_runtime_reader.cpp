// The header-only runtime reader (core/runtime/ps_volume_reader.h) gives the same answers as the
// core's traversal (core/traversal) on a baked volume: same tet, weights, outside flag and SH,
// bit for bit; and it refuses corrupt files with a reason instead of crashing.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "core/bake/Bake.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/VolumeFile.h"
#include "core/placement/Uniform.h"
#include "core/runtime/ps_volume_reader.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"
#include "core/traversal/ProbeVolume.h"
#include "core/traversal/VisibleInterpolation.h"
#include "tests/core/TestFiles.h"

namespace fs = std::filesystem;
using namespace ps;

namespace {

fs::path tempDir() {
  return ps::test::testTempDir("ps_test_runtime_");
}

// A baked volume of the two-rooms scene (uniform placement, low spp), saved as .psv.
const fs::path& bakedVolume() {
  static const fs::path path = [] {
    const fs::path& dir = ps::test::programTempDir("ps_test_runtime_");
    const fs::path scenePath = fs::path(PS_SOURCE_DIR) / "resources/scenes/two-rooms.gltf";
    const Scene scene = loadScene(scenePath);
    const Tracer tracer(scene);
    ProbeSet set;
    set.scenePath = scenePath.string();
    set.rig.skyRadiance = {1, 1, 1};
    UniformSettings us;
    us.spacingMeters = 0.9;
    for (Vec3 p : placeUniform(tracer, us)) {
      Probe probe;
      probe.position = p;
      probe.state = ProbeState::Accepted;
      set.add(probe);
    }
    BakeSettings bs;
    bs.capture.samplesPerProbe = 16;
    const BakeResult r = bakeProbeSet(set, tracer, bs);
    saveVolume(r.file, dir / "v.psv");
    return dir / "v.psv";
  }();
  return path;
}

struct Query {
  Vec3 p;
  int32_t hint;
};

// Points inside, near and far outside the hull, on probe positions, non-finite; cold starts and
// hinted (coherent) walks.
std::vector<Query> queries(const ProbeVolume& v) {
  Bounds3 box;
  for (size_t i = 0; i < v.probeCount(); ++i) box.extend(v.position(static_cast<int32_t>(i)));
  const Vec3 lo = box.lo - box.extent() * 0.2, hi = box.hi + box.extent() * 0.2;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
#if defined(__SANITIZE_ADDRESS__)
  const int n = 600;
#else
  const int n = 4000;
#endif
  std::vector<Query> q;
  int32_t last = -1;
  for (int i = 0; i < n; ++i) {
    Vec3 p;
    for (int a = 0; a < 3; ++a) p[a] = lo[a] + (hi[a] - lo[a]) * u(rng);
    if (i % 10 == 0) p = v.position(static_cast<int32_t>(i % v.probeCount()));
    if (i % 3 == 0) {
      q.push_back({p, -1});
    } else {
      q.push_back({p, last});
    }
    last = locate(v, p, q.back().hint).tet;
  }
  q.push_back({{1e6, -1e6, 3}, -1});
  q.push_back({{std::numeric_limits<double>::quiet_NaN(), 0, 0}, -1});
  q.push_back({{0, std::numeric_limits<double>::infinity(), 0}, 5});
  return q;
}

}  // namespace

TEST(RuntimeReader, AnswersEqualTheCoresOnABakedVolume) {
  const VolumeFile vf = loadVolume(bakedVolume());
  const ProbeVolume& v = vf.volume;
  ps_runtime::Volume rv;
  std::string error;
  ASSERT_TRUE(ps_runtime::loadVolumeFile(bakedVolume().c_str(), rv, &error)) << error;
  EXPECT_EQ(rv.metadataJson, vf.metadataJson);
  EXPECT_EQ(rv.grid, v.locatorGrid);
  size_t outside = 0, ties = 0;
  for (const Query& q : queries(v)) {
    const VolumeLocation a = locate(v, q.p, q.hint);
    const ps_runtime::Location b = ps_runtime::locate(rv, q.p.x, q.p.y, q.p.z, q.hint);
    ASSERT_EQ(a.outside, b.outside);
    if (a.tet != b.tet) {
      // A point on a face or edge two tetrahedra share (outside the hull: the clamp's), which
      // builds that round differently (one contracting to FMA) may place in either: the same
      // probes must get the same weights.
      ++ties;
      ASSERT_GE(a.tet, 0);
      ASSERT_GE(b.tet, 0);
      std::vector<std::pair<int32_t, float>> ba, bb;
      for (int i = 0; i < 4; ++i) {
        if (a.weights[i] > 0) ba.push_back({v.tets[size_t(a.tet)][i], a.weights[i]});
        if (b.weights[i] > 0) bb.push_back({rv.tets[size_t(b.tet)][i], b.weights[i]});
      }
      std::sort(ba.begin(), ba.end());
      std::sort(bb.begin(), bb.end());
      ASSERT_EQ(ba, bb) << q.p.x << " " << q.p.y << " " << q.p.z;
      continue;
    }
    for (int i = 0; i < 4; ++i) ASSERT_EQ(a.weights[i], b.weights[i]);
    const ShRgb sa = interpolate(v, a);
    float sb[27];
    ps_runtime::interpolate(rv, b, sb);
    for (int k = 0; k < kShCoeffCount; ++k)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(static_cast<float>(sa.c[k][c]), sb[3 * k + c]);
    outside += a.outside;
  }
  std::printf("%zu queries, %zu outside the hull, %zu ties\n", queries(v).size(), outside, ties);
  EXPECT_GT(outside, 100u);                       // the hull clamp was exercised
  EXPECT_LE(ties, 1 + queries(v).size() / 1000);  // rounding ties only
}

// The visibility-aware interpolant (VisibleInterpolation.h) and the reader's visibleWeights()
// agree within 1e-5 at 100,000 random points of the bundled two-rooms scene's volume, with and
// without a normal.
TEST(RuntimeReader, VisibilityAwareWeightsAgreeWithTheCore) {
  const VolumeFile vf = loadVolume(bakedVolume());
  const ProbeVolume& v = vf.volume;
  ASSERT_TRUE(v.hasVisibility());
  ps_runtime::Volume rv;
  std::string error;
  ASSERT_TRUE(ps_runtime::loadVolumeFile(bakedVolume().c_str(), rv, &error)) << error;
  ASSERT_EQ(rv.visibilityMapSize, v.visibilityMapSize);
  Bounds3 box;
  for (size_t i = 0; i < v.probeCount(); ++i) box.extend(v.position(static_cast<int32_t>(i)));
  const Vec3 lo = box.lo - box.extent() * 0.1, hi = box.hi + box.extent() * 0.1;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
#if defined(__SANITIZE_ADDRESS__)
  const int n = 10000;
#else
  const int n = 100000;
#endif
  double worst = 0;
  size_t changed = 0, fallbacks = 0, ties = 0, neighbours = 0;
  int32_t hint = -1;
  for (int i = 0; i < n; ++i) {
    Vec3 p;
    for (int a = 0; a < 3; ++a) p[a] = lo[a] + (hi[a] - lo[a]) * u(rng);
    const double z = 1 - 2 * u(rng), phi = 2 * kPi * u(rng);
    const Vec3 nrm{std::sqrt(std::max(0.0, 1 - z * z)) * std::cos(phi),
                   std::sqrt(std::max(0.0, 1 - z * z)) * std::sin(phi), z};
    const bool withNormal = i % 2 == 0;
    const VolumeLocation a = locate(v, p, hint);
    const VisibleWeights wa =
        visibleWeights(v, a, p, withNormal ? std::optional<Vec3>(nrm) : std::nullopt);
    const ShRgb sa = interpolate(v, wa);
    const ps_runtime::Location b = ps_runtime::locate(rv, p.x, p.y, p.z, hint);
    const double nb[3] = {nrm.x, nrm.y, nrm.z};
    const ps_runtime::Weights wb =
        ps_runtime::visibleWeights(rv, b, p.x, p.y, p.z, withNormal ? nb : nullptr);
    float sb[27];
    ps_runtime::interpolate(rv, wb, sb);
    if (wa.tet != wb.tet) {
      // A point on a face (or, clamped, an edge) that two tetrahedra share, to float rounding,
      // lies in either, and the two builds may round differently (an FMA build of one finds
      // the other tetrahedron): each must hold it on a face of its own, a weight near 0.
      ++ties;
      ASSERT_LE(*std::min_element(a.weights.begin(), a.weights.end()), 1e-4f)
          << "core tet " << wa.tet << ", reader tet " << wb.tet;
      ASSERT_LE(*std::min_element(std::begin(b.weights), std::end(b.weights)), 1e-4f)
          << "core tet " << wa.tet << ", reader tet " << wb.tet;
      hint = i % 3 == 0 ? -1 : a.tet;
      continue;
    }
    ASSERT_EQ(int(wa.fallback), wb.fallback);
    ASSERT_EQ(wa.count, wb.count);
    for (int k = 0; k < wa.count; ++k) {
      ASSERT_EQ(wa.probes[size_t(k)], wb.probes[k]);
      worst = std::max(worst, std::abs(wa.weights[size_t(k)] - wb.weights[k]));
    }
    changed += wa.fallback == VisibleFallback::Neighbours ||
               std::abs(wa.weights[0] - double(a.weights[0])) > 1e-3;
    neighbours += wa.fallback == VisibleFallback::Neighbours;
    for (int k = 0; k < kShCoeffCount; ++k)
      for (int c = 0; c < 3; ++c) {
        const double x = static_cast<float>(sa.c[k][c]);
        ASSERT_NEAR(x, sb[3 * k + c], 1e-5 * std::max(1.0, std::abs(x)))
            << "at " << p.x << " " << p.y << " " << p.z;
      }
    fallbacks += wa.fallback != VisibleFallback::None;
    hint = i % 3 == 0 ? -1 : a.tet;
  }
  std::printf(
      "%d queries: largest weight difference %.3g; visibility moved %zu, fallbacks %zu (%zu to "
      "the neighbour search); %zu on a face the two locate to different sides of\n",
      n, worst, changed, fallbacks, neighbours, ties);
  EXPECT_LE(worst, 1e-5);
  EXPECT_LE(ties, size_t(n / 1000));   // rounding ties only, not a walk that differs
  EXPECT_GT(changed, size_t(n / 20));  // the maps were exercised
}

// The same comparison from a program compiled as C++17 without the core (runtime_reader_cpp17).
TEST(RuntimeReader, Cpp17BuildAgreesWithTheCore) {
  const fs::path dir = tempDir();
  const VolumeFile vf = loadVolume(bakedVolume());
  std::FILE* f = std::fopen((dir / "expected.txt").c_str(), "w");
  ASSERT_NE(f, nullptr);
  for (const Query& q : queries(vf.volume)) {
    if (!isFinite(q.p)) continue;  // strtod reads "nan" but keep the file portable
    const VolumeLocation a = locate(vf.volume, q.p, q.hint);
    const ShRgb s = interpolate(vf.volume, a);
    std::fprintf(f, "%a %a %a %d %d %a %a %a %a %d", q.p.x, q.p.y, q.p.z, q.hint, a.tet,
                 double(a.weights[0]), double(a.weights[1]), double(a.weights[2]),
                 double(a.weights[3]), int(a.outside));
    for (const Rgb& c : s.c)
      for (int ch = 0; ch < 3; ++ch) std::fprintf(f, " %a", double(static_cast<float>(c[ch])));
    std::fprintf(f, "\n");
  }
  std::fclose(f);
  const std::string cmd = std::string(PS_RUNTIME_CPP17_PATH) + " " + bakedVolume().string() + " " +
                          (dir / "expected.txt").string() + " > " + (dir / "out.txt").string() +
                          " 2>&1";
  const int rc = std::system(cmd.c_str());
  std::ifstream out(dir / "out.txt");
  const std::string text((std::istreambuf_iterator<char>(out)), {});
  EXPECT_EQ(rc, 0) << text;
  EXPECT_NE(text.find("all identical to the core's"), std::string::npos) << text;
}

TEST(RuntimeReader, CorruptFilesAreRefusedWithAReason) {
  std::ifstream in(bakedVolume(), std::ios::binary);
  const std::string good((std::istreambuf_iterator<char>(in)), {});
  auto error = [](const std::string& bytes) {
    ps_runtime::Volume v;
    std::string e;
    if (ps_runtime::loadVolumeMemory(bytes.data(), bytes.size(), v, &e)) return std::string("ok");
    return e;
  };
  EXPECT_EQ(error(good), "ok");
  EXPECT_NE(error("").find("truncated"), std::string::npos);
  EXPECT_NE(error(std::string(64, 'x')).find("not a ProbeStudio volume"), std::string::npos);
  EXPECT_NE(error(good.substr(0, good.size() - 1)).find("header counts need"), std::string::npos);
  std::string flipped = good;
  flipped[100] ^= 1;
  EXPECT_NE(error(flipped).find("CRC-32 mismatch"), std::string::npos);
  std::string huge = good;
  huge[16] = huge[17] = huge[18] = huge[19] = '\xff';  // 4 billion probes claimed
  EXPECT_NE(error(huge).find("header counts need"), std::string::npos);
  std::string version = good;
  version[8] = 5;
  EXPECT_NE(error(version).find("unsupported version 5"), std::string::npos);
}
