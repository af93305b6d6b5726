// libFuzzer target: the probe-set JSON loader. Any input either loads or throws ps::Error;
// anything else (a crash, another exception, a sanitizer report, a leak) is a bug.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const ps::ProbeSet set =
        ps::parseProbeSet(std::string(reinterpret_cast<const char*>(data), size), "fuzz.json");
    for (const ps::Probe& p : set.probes)
      if (p.id == 0 || p.id >= set.nextId) __builtin_trap();  // ids are positive, below next_id
  } catch (const ps::Error&) {
  }
  return 0;
}
