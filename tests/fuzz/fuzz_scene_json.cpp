// Scene JSON text -> cdsm::parse_scene. Bad input must end in cdsm::Error;
// any other exception or a crash is a finding.
#include <cstdint>
#include <string>

#include "cdsm/error.h"
#include "cdsm/scene_io.h"
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    cdsm::parse_scene(text, "fuzz.json", "/nonexistent");
  } catch (const cdsm::Error&) {
  }
  return 0;
}
