// libFuzzer target: the .psv volume loader, then a few queries on what it accepted (a loaded
// volume must be safe to query), and the header-only runtime reader on the same bytes.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/common/Error.h"
#include "core/io/VolumeFile.h"
#include "core/runtime/ps_volume_reader.h"
#include "core/traversal/ProbeVolume.h"
#include "core/traversal/VisibleInterpolation.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  bool coreLoaded = false;
  try {
    const ps::VolumeFile vf = ps::parseVolume(bytes, "fuzz.psv");
    coreLoaded = true;
    for (const ps::Vec3 p : {ps::Vec3(0, 0, 0), ps::Vec3(0.3, 0.2, 0.1), ps::Vec3(1e3, -5, 2)}) {
      const ps::VolumeLocation loc = ps::locate(vf.volume, p);
      (void)ps::interpolate(vf.volume, loc);
      (void)ps::interpolate(vf.volume, ps::visibleWeights(vf.volume, loc, p, ps::Vec3(0, 1, 0)));
    }
  } catch (const ps::Error&) {
  }
  ps_runtime::Volume rv;
  std::string why;
  const bool runtimeLoaded = ps_runtime::loadVolumeMemory(data, size, rv, &why);
  if (runtimeLoaded != coreLoaded) __builtin_trap();  // both readers accept the same files
  if (runtimeLoaded) {
    float sh[27];
    const ps_runtime::Location loc = ps_runtime::locate(rv, 0.3, 0.2, 0.1);
    ps_runtime::interpolate(rv, loc, sh);
    const double n[3] = {0, 1, 0};
    ps_runtime::interpolate(rv, ps_runtime::visibleWeights(rv, loc, 0.3, 0.2, 0.1, n), sh);
  }
  return 0;
}
