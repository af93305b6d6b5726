// libFuzzer target: the glTF loader (.gltf text or .glb binary, told apart by the magic). The
// loader reads files, so each input is written to a private temporary folder first.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/common/Error.h"
#include "core/scene/Scene.h"

namespace {
const std::filesystem::path& inputPath() {
  static const std::filesystem::path p = [] {
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("ps_fuzz_gltf_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir / "input.gltf";
  }();
  return p;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  {
    std::ofstream out(inputPath(), std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    const ps::Scene s = ps::loadScene(inputPath());
    (void)s;
  } catch (const ps::Error&) {
  }
  return 0;
}
