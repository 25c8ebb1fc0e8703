// The fragment producer of a shadow system: the OpenGL rasterizer when a
// context can be created (and the build has GL), else the CPU ray caster.
// Chosen once; the scene's triangles reach GL only when they change (a full
// upload after objects were added or removed, the moved triangles' range
// after a move), never per frame.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "cdsm/gl.h"
#include "cdsm/renderer.h"
#include "frame.h"

namespace cdsm {

namespace gl {
class Context;
}

// A mesh that stays in the application's GL buffers
// (ShadowSystem::add_gpu_object): where it is, checked against the buffers'
// sizes (check_gl_mesh), and what the application asserts of it.
struct GpuMesh {
  GlMeshSource source;
  uint32_t index_size = 0;  // bytes per index; 0: not indexed
  uint32_t triangles = 0;
  bool closed = false;        // asserted by the application
  bool bounds_given = false;  // `bounds` (object space) from the application, else computed on the GPU
  Box3 bounds;
};

class FragmentSourceSelector {
 public:
  FragmentSourceSelector();
  ~FragmentSourceSelector();
  // Rasterize on `context` (the application's, adopted; it outlives the
  // selector) instead of a headless context of the selector's own. Call
  // before the first choose().
  void use_context(gl::Context* context) { external_ = context; }
  // The backend whose device casts the fragments for FragmentSource::Cuda
  // (an exec backend; the cuda one), told when the rasterizer replaces a
  // buffer it may have registered (lists_from_gl). Call before the first
  // choose().
  void use_backend(ShadowBackend* backend) { backend_ = backend; }
  // The rasterizer's fragment pool: its first and largest size in bytes (0:
  // the defaults). Tests use it to reach pool growth and tiling; call
  // before the first choose().
  void limit_pool(uint64_t initial_bytes, uint64_t max_bytes) {
    pool_initial_ = initial_bytes;
    pool_max_ = max_bytes;
  }
  // Picks the producer on the first call (GL, when wanted and a context
  // can be made); later calls keep it unless `want` changes. `name` is "gl",
  // "cuda" or "cpu", `reason` says why. Throws cdsm::Error when GL is requested
  // and unavailable.
  void choose(FragmentSource want, std::string& name, std::string& reason);
  // Tells the producer what changed in `sb`; returns the bytes sent to GL.
  // The triangles of the meshes in `gpu` (object index -> mesh, with the
  // object's transform) are read from the application's buffers on the GPU
  // instead of sent (they hold placeholders in `sb`).
  struct GpuObject {
    uint32_t object = 0;
    const GpuMesh* mesh = nullptr;
    Mat4 transform;
    bool changed = false;  // its vertices changed on the GPU (read again even where `change` names none)
  };
  uint64_t scene_changed(const SceneBuffers& sb, const SceneChange& change, const std::vector<GpuObject>& gpu = {});
  // The world box of a GPU mesh under `transform`, computed on the GPU (one
  // read-back of 24 bytes). Only with the GL producer.
  Box3 gpu_mesh_bounds(const GpuMesh& mesh, const Mat4& transform);
  // The producer over the scene last given to scene_changed().
  FragmentProducer producer(const SceneBuffers& sb) const;
  // GL memory holding the scene (0 for the CPU producer).
  uint64_t gl_scene_bytes() const;

 private:
  struct Gl;
  std::unique_ptr<Gl> gl_;
  bool use_gl_ = false;
  bool chosen_ = false;
  FragmentSource want_ = FragmentSource::Auto;
  std::string name_, reason_;
  gl::Context* external_ = nullptr;
  ShadowBackend* backend_ = nullptr;
  bool use_cuda_ = false;
  [[maybe_unused]] bool gl_tried_ = false;  // (builds without GL never try)
  uint64_t pool_initial_ = 0, pool_max_ = 0;
  std::string gl_failure_;
};

}  // namespace cdsm
