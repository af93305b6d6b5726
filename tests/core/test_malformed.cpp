// The malformed-input corpus (tests/data/malformed/, written by make_corpus.py): every file is
// refused by its loader with a ps::FileError whose message starts with the file's path and
// contains the text manifest.tsv gives for it. Volumes are also refused by the header-only
// runtime reader (a reason, not a crash).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/VolumeFile.h"
#include "core/runtime/ps_volume_reader.h"
#include "core/scene/Scene.h"

namespace fs = std::filesystem;

namespace {

const fs::path kCorpus = fs::path(PS_SOURCE_DIR) / "tests" / "data" / "malformed";

std::map<std::string, std::string> manifest() {
  std::map<std::string, std::string> m;
  std::ifstream in(kCorpus / "manifest.tsv");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t tab = line.find('\t');
    EXPECT_NE(tab, std::string::npos) << "manifest line without a tab: " << line;
    if (tab != std::string::npos) m[line.substr(0, tab)] = line.substr(tab + 1);
  }
  return m;
}

std::string loadError(const fs::path& p) {
  const std::string ext = p.extension().string();
  try {
    if (ext == ".json")
      ps::loadProbeSet(p);
    else if (ext == ".psv")
      ps::loadVolume(p);
    else
      ps::loadScene(p);
  } catch (const ps::FileError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("(not a ps::FileError) ") + e.what();
  }
  return "(loaded without an error)";
}

}  // namespace

TEST(MalformedCorpus, EveryFileIsRefusedWithItsExpectedMessage) {
  const auto expected = manifest();
  std::set<std::string> onDisk;
  for (const auto& e : fs::directory_iterator(kCorpus)) {
    const std::string name = e.path().filename().string();
    if (name == "manifest.tsv" || name == "make_corpus.py") continue;
    onDisk.insert(name);
    EXPECT_TRUE(expected.count(name)) << name << " is not in manifest.tsv";
  }
  EXPECT_GE(onDisk.size(), 30u);
  for (const auto& [name, text] : expected) {
    SCOPED_TRACE(name);
    const fs::path p = kCorpus / name;
    ASSERT_TRUE(onDisk.count(name)) << "missing corpus file (run make_corpus.py)";
    const std::string msg = loadError(p);
    EXPECT_EQ(msg.rfind(p.string() + ": ", 0), 0u) << msg;
    EXPECT_NE(msg.find(text), std::string::npos) << "got: " << msg << "\nexpected: " << text;
    if (p.extension() == ".psv") {
      ps_runtime::Volume v;
      std::string why;
      EXPECT_FALSE(ps_runtime::loadVolumeFile(p.c_str(), v, &why));
      EXPECT_FALSE(why.empty());
    }
  }
}
