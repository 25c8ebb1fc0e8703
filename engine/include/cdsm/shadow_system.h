// The persistent shadow system: a long-lived object that holds a compiled
// scene and its deep shadow maps across frames, so a frame costs only what
// changed (DESIGN.md §8, STYLE.md 13). Objects, volumes and lights are
// added, edited and removed through handles that stay valid while others
// come and go; each edit marks exactly what it invalidates, and update()
// recompiles, re-uploads and rebuilds only that:
//
//   edit                       | update() then costs
//   ---------------------------+--------------------------------------------
//   set_camera                 | nothing (maps rebuild only if clustering
//                              | moves a cluster's frustum)
//   set_transform              | the object's world-space triangles, a BVH
//                              | refit (a rebuild if the tree degraded), a GL
//                              | upload of its triangles; the maps it is in,
//                              | enters or leaves
//   set_surface / set_interior | the maps containing the object; no geometry
//   set_light                  | that light's maps (position, direction,
//                              | cone); colour and intensity: nothing
//   set_settings               | map settings (epsilon, resolution, layout):
//                              | every map, no geometry; lookup settings
//                              | (filtering, bias): nothing
//   add / remove object        | the geometry arrays and BVH of every object
//                              | (O(triangles), no voxel work), a full GL
//                              | upload; the maps whose casters change
//   add / edit / remove volume | that volume's grid (O(its voxels)), the maps
//                              | containing its object
//
// Content identity is taken when content is given: every object carries a
// generation counter bumped by each edit of it; meshes and grids are held
// (shared_ptr) as given and must not be modified in place afterwards — give
// a new mesh or grid (set_mesh, set_volume) instead. Nothing is hashed or
// compared per frame.
//
// Threading: one thread at a time calls a ShadowSystem (it is not
// thread-safe); update() and render() use every core internally (TBB). With
// GL fragments the system makes its own headless context current during
// update() and render().
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/image.h"
#include "cdsm/renderer.h"
#include "cdsm/scene.h"

namespace cdsm {

// Handles: small values, 0 is "none". Valid until the thing is removed;
// never reused for another thing by the same system.
struct ObjectHandle {
  uint64_t id = 0;
  explicit operator bool() const { return id != 0; }
  bool operator==(const ObjectHandle& o) const { return id == o.id; }
};
struct VolumeHandle {
  uint64_t id = 0;
  explicit operator bool() const { return id != 0; }
  bool operator==(const VolumeHandle& o) const { return id == o.id; }
};
struct LightHandle {
  uint64_t id = 0;
  explicit operator bool() const { return id != 0; }
  bool operator==(const LightHandle& o) const { return id == o.id; }
};

struct SystemOptions {
  FragmentSource fragments = FragmentSource::Auto;  // Auto: GL when a context can be made
  std::string source = "shadow system";             // names the content in messages
};

class ShadowSystem {
 public:
  explicit ShadowSystem(const SystemOptions& options = {});
  ~ShadowSystem();
  ShadowSystem(const ShadowSystem&) = delete;
  ShadowSystem& operator=(const ShadowSystem&) = delete;

  // ---- content: cheap to call; the work happens in the next update() ------
  // Volumes: a grid (dense or sparse), placement in its object, transfer
  // function. A volume is the interior of exactly one object (add it
  // first, then the object with interior Volume and this handle).
  VolumeHandle add_volume(Volume volume);
  void set_volume(VolumeHandle h, Volume volume);  // new grid or transfer function
  void remove_volume(VolumeHandle h);              // its object must be gone or not use it

  // Objects. `o.volume` is ignored: `volume` names the interior's volume.
  ObjectHandle add_object(const Object& o, VolumeHandle volume = {});
  void set_transform(ObjectHandle h, const Mat4& transform);
  void set_surface(ObjectHandle h, const SurfaceMaterial& surface);
  void set_interior(ObjectHandle h, InteriorKind interior, Vec3 sigma, VolumeHandle volume = {});
  void set_mesh(ObjectHandle h, std::shared_ptr<const TriangleMesh> mesh);
  void set_casts_shadows(ObjectHandle h, bool casts);
  void remove_object(ObjectHandle h);

  LightHandle add_light(const Light& light);
  void set_light(LightHandle h, const Light& light);
  void remove_light(LightHandle h);

  // ---- per frame: cheap ----------------------------------------------------
  void set_camera(const Camera& camera);
  void set_settings(const ShadowSettings& settings);
  void set_background(Vec3 background);

  // Compiles what changed, builds or reuses the maps. Throws cdsm::Error on
  // invalid content (the edit that caused it is named); the system then
  // keeps its previous state for the parts that failed. Cost: what the
  // edits since the last update touched (table above) plus the clustering.
  void update(FrameStats* stats = nullptr);

  // The camera pass over the maps of the last update(): camera fragments,
  // lookups, shading, compositing. O(pixels x depth complexity). Calls
  // update() first when anything changed since.
  Image render(FrameStats* stats = nullptr);

  // The reference image (exact shadow rays, no maps) of the current state.
  // Costly: small sizes.
  Image render_reference(float step_voxels = 0.25f);

  // Drops every map and the clusters' history (the next update rebuilds
  // all maps and clusters from scratch); the compiled scene stays.
  void reset_maps();

  // The state as a scene value (objects, volumes and lights in handle
  // order): what a fresh Renderer would render for the same picture.
  const Scene& scene() const;
  std::vector<ObjectHandle> objects() const;
  std::vector<LightHandle> lights() const;

  struct Impl;
  Impl& internals();  // for the renderer and tests of this library

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdsm
