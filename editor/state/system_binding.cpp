#include "state/system_binding.h"

#include <type_traits>

#include "cdsm/error.h"

namespace cdsm::editor {

SystemBinding::SystemBinding(ShadowSystem& system, const Scene& scene) : system_(system) {
  system_.set_settings(scene.shadows);
  system_.set_camera(scene.camera);
  system_.set_background(scene.background);
  for (const Volume& v : scene.volumes) volumes_.push_back(system_.add_volume(v));
  for (const Object& o : scene.objects)
    objects_.push_back(
        system_.add_object(o, o.interior == InteriorKind::Volume && o.volume >= 0 && size_t(o.volume) < volumes_.size()
                                  ? volumes_[size_t(o.volume)]
                                  : VolumeHandle{}));
  for (const Light& l : scene.lights) {
    lights_.push_back(system_.add_light(l));
    light_values_.push_back(l);
  }
}

void SystemBinding::apply(const Edit& e, const Scene& scene_after) {
  if (!e.refused.empty()) throw Error("editor", "a refused edit reached the shadow system: " + e.refused);
  std::visit(
      [&](const auto& c) {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, change::Settings>) {
          system_.set_settings(c.after);
        } else if constexpr (std::is_same_v<T, change::Camera>) {
          system_.set_camera(c.after);
        } else if constexpr (std::is_same_v<T, change::Background>) {
          system_.set_background(c.after);
        } else if constexpr (std::is_same_v<T, change::Light>) {
          system_.set_light(lights_.at(c.light), c.after);
          light_values_.at(c.light) = c.after;
        } else if constexpr (std::is_same_v<T, change::AddLight>) {
          // The system appends: lights after the insertion point go and come back.
          std::vector<Light> tail(light_values_.begin() + ptrdiff_t(c.light), light_values_.end());
          for (size_t i = lights_.size(); i-- > c.light;) system_.remove_light(lights_[i]);
          lights_.resize(c.light);
          light_values_.resize(c.light);
          tail.insert(tail.begin(), c.value);
          for (const Light& l : tail) {
            lights_.push_back(system_.add_light(l));
            light_values_.push_back(l);
          }
        } else if constexpr (std::is_same_v<T, change::RemoveLight>) {
          system_.remove_light(lights_.at(c.light));
          lights_.erase(lights_.begin() + ptrdiff_t(c.light));
          light_values_.erase(light_values_.begin() + ptrdiff_t(c.light));
        } else if constexpr (std::is_same_v<T, change::Transform>) {
          system_.set_transform(objects_.at(c.object), c.after);
        } else if constexpr (std::is_same_v<T, change::Surface>) {
          system_.set_surface(objects_.at(c.object), c.after);
        } else if constexpr (std::is_same_v<T, change::ObjectInterior>) {
          const VolumeHandle v =
              c.after.kind == InteriorKind::Volume ? volumes_.at(size_t(c.after.volume)) : VolumeHandle{};
          system_.set_interior(objects_.at(c.object), c.after.kind, c.after.sigma, v);
        } else if constexpr (std::is_same_v<T, change::CastsShadows>) {
          system_.set_casts_shadows(objects_.at(c.object), c.after);
        } else {
          Volume v = scene_after.volumes.at(c.volume);
          v.transfer = c.after;
          system_.set_volume(volumes_.at(c.volume), std::move(v));
        }
      },
      e.what);
}

}  // namespace cdsm::editor
