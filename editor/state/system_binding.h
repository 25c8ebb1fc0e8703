// A document's shadow system through its public handles (STYLE.md 13):
// created from the scene once, then kept in step edit by edit with the
// narrowest ShadowSystem call each edit needs, so a frame costs what the
// edit invalidates (invalidation_of) and nothing else.
#pragma once

#include <cstddef>
#include <vector>

#include "cdsm/shadow_system.h"
#include "state/edit.h"

namespace cdsm::editor {

class SystemBinding {
 public:
  // Gives the system everything of `scene`: settings, camera, background,
  // volumes, objects (volume interiors by their volume's handle), lights,
  // in the scene's order. The system should be empty.
  SystemBinding(ShadowSystem& system, const Scene& scene);

  // One ShadowSystem call per edit: set_settings, set_camera,
  // set_background, set_light, add_light, remove_light, set_transform,
  // set_surface, set_interior, set_casts_shadows, set_volume (a transfer
  // function: the volume's grid is given again, as the system has no
  // narrower call). A light inserted before others (undoing a removal)
  // re-adds the lights after it, so the system's light order stays the
  // document's. `scene_after`: the document after the edit (or later);
  // only a volume's grid and placement are read from it, the rest comes
  // from the edit. Throws cdsm::Error for a refused edit.
  void apply(const Edit& e, const Scene& scene_after);

  ObjectHandle object(size_t i) const { return objects_.at(i); }
  LightHandle light(size_t i) const { return lights_.at(i); }
  VolumeHandle volume(size_t i) const { return volumes_.at(i); }
  size_t light_count() const { return lights_.size(); }

 private:
  ShadowSystem& system_;
  std::vector<ObjectHandle> objects_;
  std::vector<VolumeHandle> volumes_;
  std::vector<LightHandle> lights_;
  std::vector<Light> light_values_;  // for re-adding lights after an insertion
};

}  // namespace cdsm::editor
