// .gltf / .glb bytes -> cdsm::load_gltf_scene_from_memory (the whole-scene
// loader: hierarchy, primitives, materials, lights, camera). Bad input must
// end in cdsm::Error; any other exception or a crash is a finding.
#include <cstdint>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::vector<unsigned char> bytes(data, data + size);
  try {
    cdsm::Scene scene = cdsm::load_gltf_scene_from_memory(bytes, "fuzz.glb");
    // What the loader promises: at least one mesh object and one light.
    if (scene.objects.empty() || scene.lights.empty()) __builtin_trap();
    for (const cdsm::Object& o : scene.objects) {
      if (!o.mesh) __builtin_trap();
      for (uint32_t i : o.mesh->indices)
        if (i >= o.mesh->positions.size()) __builtin_trap();
    }
  } catch (const cdsm::Error&) {
  }
  return 0;
}
