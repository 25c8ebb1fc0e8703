// The persistent shadow system: a long-lived object that holds a compiled
// scene and its deep shadow maps across frames, so a frame costs only what
// changed. Objects, volumes and lights are
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
//   nothing registered (or     | nothing: an empty system is valid; removing
//   everything removed)        | everything frees every map
//
// Content identity is taken when content is given: every object carries a
// generation counter bumped by each edit of it; meshes and grids are held
// (shared_ptr) as given and must not be modified in place afterwards — give
// a new mesh or grid (set_mesh, set_volume) instead. No mesh, grid or
// scene content is hashed or compared per frame; each map's key (its view,
// its members' ids and generations, the map settings) is.
//
// Threading: one thread at a time calls a ShadowSystem (it is not
// thread-safe); update() and render() use every core internally (TBB). With
// GL fragments the system makes its own headless context current during
// update() and render() — unless it was created on the application's
// context (below).
//
// Engine integration (SystemOptions::gl_context = Application): the system
// is created while the application's GL 4.5 context is current on the
// calling thread and keeps working on that context: fragment lists are
// rasterized there, and after each update() every map of the frame lives
// in GL shader storage buffers that the application's shaders read through
// cdsm.glsl (share/cdsm/shaders/cdsm.glsl, or glsl_include(); bind_gl()). Rules and costs of that mode:
//   - update(), render(), read_gl_mesh(), bind_gl() and the destructor need
//     that context current on the calling thread; another one current (or
//     none: the context destroyed) is a cdsm::Error naming both, never a
//     crash. Destroy the system before its context.
//   - GL state: update(), render() and read_gl_mesh() restore everything
//     they change (program, vertex array, draw/read framebuffers, viewport,
//     scissor box and test, polygon mode, colour mask, GL_DEPTH_CLAMP,
//     GL_CLIP_DISTANCE0, depth test, face culling, blending, rasterizer
//     discard, multisampling, the generic and indexed 0..7 shader storage
//     bindings). bind_gl() changes exactly the
//     nine indexed shader storage bindings the program declares for
//     cdsm.glsl. GL errors the application left pending are cleared on entry
//     and reported in FrameStats::warnings.
//   - Per frame: update() uploads only what changed — the triangles of
//     moved objects, the nodes of maps built this frame (appended to the
//     buffers), the frame block when lights or map headers changed; a frame
//     with no change uploads nothing (FrameStats::update.gl_map_upload_bytes).
//     bind_gl() is cheap (nine binds, a few queries); call it whenever the
//     program is used after an update().
//   - Limits: the shader that includes cdsm.glsl uses nine storage blocks
//     (GL 4.5 guarantees only 8 per stage; llvmpipe and NVIDIA allow 16 and
//     more). A context with fewer is refused when the system is created,
//     naming the GL limit; bind_gl() refuses a binding point past
//     GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS (lower CDSM_BINDING_BASE).
//   - Application buffers are read back once, in read_gl_mesh(), never per
//     frame (FrameStats::update.gl_readback_bytes of the next update()).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/backend.h"
#include "cdsm/frame_stats.h"
#include "cdsm/gl.h"
#include "cdsm/image.h"
#include "cdsm/scene.h"

namespace cdsm {

// Handles: a slot and its generation (0 is "none"); a lookup is O(1).
// Valid until the thing is removed, and kept by the others when one is
// removed. A removed thing's handle is refused (cdsm::Error "... names an
// object removed from this system"), also after its slot holds a new thing:
// the same value is never given out twice by the same system.
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

// Whose OpenGL context a shadow system works on.
enum class GlContextUse {
  Own,          // its own headless context, made when GL fragments are first needed
  Application,  // the application's, current on the constructing thread; maps in GL buffers
};

struct SystemOptions {
  FragmentSource fragments = FragmentSource::Auto;  // Auto: GL when a context can be made
  std::string source = "shadow system";             // names the content in messages
  // Where the kernels run. Auto: the cuda backend where it can serve (a CUDA
  // device, and with GlContextUse::Application the application's context on
  // it), else the CPU threads; FrameStats::backend and ::backend_reason say
  // which and why. Reference is not a map backend.
  Backend backend = Backend::Auto;
  GlContextUse gl_context = GlContextUse::Own;  // Application: work on the caller's current GL context
  // With GlContextUse::Application: rasterize the fragment lists on a
  // headless context of the system's own (made on the thread of the first
  // build()) instead of the application's, so build() may run with GL
  // fragments on a worker thread — always the same one, where that context
  // stays current. The maps still go to the application's buffers in
  // publish(). The editor's choice: GL fragments are ~10x faster than the
  // CPU ray caster on llvmpipe.
  bool private_fragment_context = false;
  // Keep the light-view fragment lists of the current maps between updates
  // (FrameStats::update.fragment_cache_bytes), so that a map rebuilt with
  // the same view, members and scene content (an edit of epsilon, layout or
  // method) reuses them instead of rasterizing again; any content edit
  // drops them. The editor's choice: epsilon with four clusters of the
  // default scene refines ~0.1 s sooner on llvmpipe. Off: nothing kept.
  bool keep_fragment_lists = false;
};

// How a mesh that stays on the GPU is given (ShadowSystem::add_gpu_object).
struct GpuMeshOptions {
  // The application asserts the mesh is closed (watertight, outward
  // facing): the system cannot check it without the triangles.
  bool closed = false;
  // Object-space bounds (every vertex, over all the frames it will have)
  // when the application knows them; empty (the default): computed on the
  // GPU when it is added and at each mark_changed(), one read-back of 24
  // bytes each (counted in FrameStats::counters.gl_readbacks).
  Box3 bounds;
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

  // Two phases of update(), for an application that keeps drawing while
  // maps build (the editor): build() is the CPU part — compile, fragment
  // lists, map builds; publish() the GL part — uploading what build() made
  // to the map buffers (GlContextUse::Application; nothing otherwise).
  // update() = build() + publish(). With FragmentSource::Cpu (or
  // SystemOptions::private_fragment_context), build() makes no GL call on
  // the application's context and may run on a worker thread while the context's thread
  // keeps calling bind_gl() and gl_buffers() (they read only the buffers of
  // the last publish()) and nothing else of this system; publish() then
  // runs on the context's thread. With GL fragments on the application's
  // context build() needs that context like update(). build() fills `stats` like update();
  // publish() adds only the GL figures of FrameStats::update (gl_map_*,
  // gl_readback_bytes) to `stats`.
  void build(FrameStats* stats = nullptr);
  void publish(FrameStats* stats = nullptr);
  // Maps built / maps to build by the build() running now (or the last
  // one); safe to read from any thread.
  struct BuildProgress {
    uint32_t built = 0;
    uint32_t to_build = 0;
  };
  BuildProgress build_progress() const;

  // The camera pass over the maps of the last update(): camera fragments,
  // lookups, shading, compositing. O(pixels x depth complexity). Calls
  // update() first when anything changed since.
  Image render(FrameStats* stats = nullptr);

  // The reference image (exact shadow rays, no maps) of the current state.
  // Costly: small sizes.
  // `progress` (optional): fraction of rows done; its cancel flag stops the
  // render, which then throws cdsm::Error naming the cancellation.
  Image render_reference(float step_voxels = 0.25f, RenderProgress* progress = nullptr);

  // ---- engine integration (SystemOptions::gl_context = Application) -------
  // A mesh from the application's GL buffers, read back now (its bytes are
  // counted in the next update's FrameStats::update.gl_readback_bytes); give
  // it to add_object() / set_mesh() like any mesh. Throws cdsm::Error naming
  // the field for a buffer that is not a GL buffer of the context, too
  // small for the counts, offsets and strides given, an index type that is
  // not one of the three, an index past the vertices, a non-finite
  // position. Costs a GPU->host copy of the ranges read; needs the context.
  std::shared_ptr<const TriangleMesh> read_gl_mesh(const GlMeshSource& source);

  // A mesh that stays on the GPU: one the application changes there every
  // frame (skinned, simulated, animated in a shader), registered by its GL
  // buffers and never read back. Whenever one of its maps is rebuilt, the
  // GL rasterizer reads its triangles where they are (a compute pass on
  // the GPU: stride, offsets and index type as given, positions transformed
  // by `o.transform`, the same floats an upload would give). After the application
  // changed the vertices, mark_changed() rebuilds its maps and nothing else.
  // `o.mesh` is ignored (the system keeps a placeholder). Positions must lie
  // at offsets and strides that are multiples of 4 bytes.
  //
  // What such a mesh cannot do, refused by name: fragments from a ray
  // caster (FragmentSource::Cpu or Cuda: they need the triangles on the
  // host), render() and render_reference() (they shade on the host), an
  // interior (medium or volume), set_mesh(), writing the scene to a file
  // (its triangles are not in it), a system on its own context
  // (GlContextUse::Own or private_fragment_context: the buffers are the
  // application's). Not checked, taken as given: closedness (`closed`),
  // indices within the vertices and finite positions (a triangle that
  // breaks either draws nothing). Auto resolution does not count it as a
  // receiver, and a light inside a closed one is not detected.

  // Throws cdsm::Error naming the field for a buffer that is not a GL buffer
  // of the context or too small, and for the refusals above. Needs the
  // context.
  ObjectHandle add_gpu_object(const Object& o, const GlMeshSource& source, const GpuMeshOptions& options = {});
  // The application changed a GPU mesh's vertices (or its buffers: `source`
  // checked again when given): its maps rebuild in the next update().
  // `object_bounds` replaces the bounds given so far (null: keep them, or
  // compute them on the GPU again when none were given).
  void mark_changed(ObjectHandle h, const Box3* object_bounds = nullptr, const GlMeshSource* source = nullptr);
  // The GL buffers of the last update()'s maps (names change only when a
  // buffer grows). Cheap.
  GlMapBuffers gl_buffers() const;
  // Binds the map buffers to the binding points `program` (a linked GL
  // program that includes cdsm.glsl and calls its lookups) declares for
  // them. Throws cdsm::Error naming the blocks the program lacks. Cheap;
  // needs the context.
  void bind_gl(uint32_t program);
  // The `light` argument of cdsm_transmittance() for a light: its index
  // among the system's lights (handle order; it changes when an earlier
  // light is removed). Throws cdsm::Error for an unknown handle. Cheap.
  int gl_light_index(LightHandle light) const;
  // The `object` argument of cdsm_surface_transmittance() for an object's
  // surfaces: its index among the system's objects (handle order) when it
  // casts shadows (its lookups leave out exactly its own step in the maps),
  // 0xffffffff (CDSM_NO_OBJECT) when it only receives. It changes when an
  // earlier object is removed. Throws cdsm::Error for an unknown handle. Cheap.
  uint32_t gl_object_id(ObjectHandle object) const;

  // ---- inspection of the last update()'s maps (the editor's views) --------
  struct MapInfo {
    int light = 0;                  // light index (handle order)
    int slot = 0;                   // map within its light: cluster, cube face or split
    int res = 0;                    // texels per side
    bool rgb = false;               // RGB nodes (a coloured caster among its members)
    bool rebuilt = false;           // built by the last update()
    std::vector<int> members;       // the caster objects in it (object indices, handle order)
    Vec3 corners[8];                // its frustum: near plane, then far plane (world)
    float near = 0.0f, far = 0.0f;  // view-axis range of its depths
    uint64_t nodes = 0;
    uint32_t max_nodes = 0;  // per texel
    uint64_t index_bytes = 0, node_bytes = 0, slack_bytes = 0;
  };
  std::vector<MapInfo> maps() const;  // cheap
  // Per texel of map `map` (row 0 at the top, res x res): its node count,
  // or its opacity at radial depth `depth` (RGB maps: the channel mean).
  // O(texels) (x nodes per texel for alpha).
  std::vector<uint32_t> map_node_counts(int map) const;
  std::vector<float> map_alpha(int map, float depth) const;

  // One texel's visibility function against the uncompressed one: for the
  // map of light `light` that serves point p (the cube face holding it, or
  // the map with the largest opacity at p among those whose window holds
  // it), the texel whose centre is nearest to p's projection; its stored
  // nodes and the same light ray walked with epsilon 0 (every sample a
  // node, the map's own segments and march steps). Costs one light ray's
  // fragments and walk. With `object` (its index, handle order) and the
  // unit normal `plane` of the surface p lies on, also what that surface
  // reads from the texel (its own step left out).
  struct AlphaSample {
    float z;          // radial depth from the light
    Vec3 alpha;       // per channel (grey maps: equal)
    int object = -1;  // the object whose surface's step ends at this node (-1: none)
  };
  struct TexelInspection {
    bool found = false;
    std::string why;  // when not found
    int map = -1, light = -1, slot = -1, tx = -1, ty = -1;
    float depth = 0.0f;  // p's radial depth from the light
    float epsilon = 0.0f;
    bool rgb = false;
    std::vector<AlphaSample> nodes;  // the map's
    std::vector<AlphaSample> exact;  // epsilon 0
    // sup over depths and channels of |alpha_map - alpha_exact|, a surface
    // step matched within 2e-5 of its depth (the exact ray is cast on the
    // CPU; GL fragments put steps up to ~1e-5 of the depth elsewhere)
    float max_deviation = 0.0f;
    // What the surface (object, plane) reads from this texel: the texel's
    // centre ray crosses its plane at `receiver_depth`; `own_node` is the
    // node of its own step, left out (-1: none found: a receive-only
    // surface, or the texel past its edge); `received` its alpha there.
    bool receiver = false;
    float receiver_depth = 0.0f;
    int own_node = -1;
    Vec3 received{0, 0, 0};
  };
  TexelInspection inspect_texel(int light, Vec3 p, int object = -1, Vec3 plane = Vec3{0, 0, 0}) const;

  // Drops every map and the clusters' history (the next update rebuilds
  // all maps and clusters from scratch); the compiled scene stays.
  void reset_maps();

  // The state as a scene value (objects, volumes and lights in handle
  // order): what a fresh Renderer would render for the same picture.
  const Scene& scene() const;
  std::vector<ObjectHandle> objects() const;
  std::vector<VolumeHandle> volumes() const;
  std::vector<LightHandle> lights() const;

  struct Impl;  // the library's own

 private:
  // The library's own: its read-only snapshot of the built frame (the
  // research harness, the tests), its test hooks and its Scene-value sync.
  friend class FrameSnapshot;
  friend struct SystemHooks;
  friend void sync_scene(ShadowSystem& system, const Scene& scene);
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdsm
