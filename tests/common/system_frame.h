// Frames for the tests, built the way an engine builds them (DESIGN.md §8,
// "one frame path"): a ShadowSystem with a Scene value's objects, volumes
// and lights registered by sync_scene, one update(), and a FrameSnapshot of
// what it built. No test compiles a scene or builds maps any other way.
#pragma once

#include <memory>
#include <string>

#include "cdsm/renderer.h"
#include "cdsm/scene.h"
#include "cdsm/shadow_system.h"
#include "common/builders.h"
#include "frame.h"
#include "frame_snapshot.h"
#include "hd/camera_pass.h"
#include "scene/fragments.h"
#include "scene/scene_buffers.h"
#include "scene_sync.h"

namespace cdsm_test {

using namespace cdsm;

// What the tests build with unless they say otherwise: the exact CPU ray
// caster's fragment lists (no GL context), the cpu backend.
inline SystemOptions cpu_system_options(Backend backend = Backend::Cpu) {
  SystemOptions o;
  o.fragments = FragmentSource::Cpu;
  o.backend = backend;
  o.source = "test";
  return o;
}

// A system with `scene` synced in and updated (its source names the scene).
inline std::unique_ptr<ShadowSystem> updated_system(const Scene& scene, SystemOptions options = cpu_system_options()) {
  options.source = scene.source;
  auto system = std::make_unique<ShadowSystem>(options);
  sync_scene(*system, scene);
  system->update();
  return system;
}

// One frame of a scene. `sb` and `frame` are copies of what the system
// compiled and built; the maps stay in the system's backend, which `frame`
// (and its views) read, so the system lives as long as this.
struct SystemFrame {
  std::unique_ptr<ShadowSystem> system;
  SceneBuffers sb;
  ShadowFrame frame;

  SystemFrame() = default;
  explicit SystemFrame(const Scene& scene, const SystemOptions& options = cpu_system_options()) {
    build(scene, options);
  }
  void build(const Scene& scene, const SystemOptions& options = cpu_system_options()) {
    system = updated_system(scene, options);
    const FrameSnapshot snap(*system);
    sb = snap.compiled();
    frame = snap.frame();
  }
  FrameSnapshot snapshot() const { return FrameSnapshot(*system); }
  // The lookup over the frame's maps with `s`'s lookup settings.
  ShadowView view(const Scene& s) const { return frame.view(s.shadows); }
  SceneView scene_view() const { return sb.view(); }
};

// One frame rendered as `cdsm render --compare-reference` renders it (CPU
// fragments): its image and stats, which hold the error against the
// reference (transmittance at `error_samples` probe points, the image's).
struct ComparedFrame {
  Image image;
  FrameStats stats;
};
inline ComparedFrame compared_render(const Scene& s, int error_samples = 4000) {
  Renderer r;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  opt.compare_reference = true;
  opt.error_samples = error_samples;
  ComparedFrame out;
  out.image = r.render(s, opt, &out.stats);
  return out;
}

// The camera pass's inputs for `scene`'s camera over the compiled scene
// `sv`, as the system sets them; the ids of the objects that hold the eye
// go to `inside`, which must outlive the result.
inline CameraPassParams camera_pass_params(const Scene& scene, const SceneView& sv, std::vector<uint32_t>& inside) {
  CameraPassParams cam;
  cam.view = camera_view(scene.camera);
  inside = objects_containing(sv, cam.view.eye, ObjectMask{});
  cam.inside = {inside.data(), inside.size()};
  cam.ambient = scene.shadows.ambient_light;
  cam.background = scene.background;
  return cam;
}

// The scene as a ShadowSystem compiles it (geometry arrays, BVH, volumes),
// for tests of what reads a compiled scene (ray casting, segments, the
// reference renderer): the scene without its lights, so no map is built.
// Throws what the system throws for invalid content.
inline SceneBuffers compiled_scene(const Scene& scene) {
  Scene no_lights = scene;
  no_lights.lights.clear();
  const std::unique_ptr<ShadowSystem> system = updated_system(no_lights);
  return FrameSnapshot(*system).compiled();
}

}  // namespace cdsm_test
