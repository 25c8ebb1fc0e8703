// A whole Scene value into a ShadowSystem (the research harness, the
// editor's documents and the tests hold scenes as values).
#pragma once

#include "cdsm/scene.h"
#include "cdsm/shadow_system.h"

namespace cdsm {

// Brings `system` to the content of `scene` by edits (by index: objects,
// volumes and lights of the same place are compared by identity — mesh and
// grid pointers, transforms, materials — never by their bytes). Volumes
// added, removed or re-assigned between objects re-add every object.
void sync_scene(ShadowSystem& system, const Scene& scene);

}  // namespace cdsm
