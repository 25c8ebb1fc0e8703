// OpenGL fragment-list rasterizer (DESIGN.md §2.1): count pass with
// per-pixel atomic counters -> prefix sum (compute) -> fill pass into packed
// per-pixel arrays in SSBOs. Output: the same FragmentBuffers the CPU ray
// caster fills (cpu/fragments_cpu.h), read back once per pass.
//
// What it reproduces of cast_fragments() (and how):
//   - the PinholeView exactly: off-centre window, py = 0 the top row,
//     pixel-centre sampling (GL's own coverage rule at pixel centres,
//     the geometry shifted by half a snapping step, 2^-(GL_SUBPIXEL_BITS+1)
//     pixel, in x so that no snapped vertex lies on a sample: 1/512 pixel
//     with 8 bits);
//   - depth = radial distance |p - eye| of the interpolated eye-relative
//     position (float32), never NDC z;
//   - a fragment is kept iff dot(p - eye, forward) is in [near, far]
//     (GL_DEPTH_CLAMP on, so GL never clips at its own near/far; the test
//     is done per fragment), or, flagged clipped, when its triangle bounds
//     a medium (bounds_medium) and the coordinate is at least
//     media_clip_axial(view);
//   - front-facing iff dot(cross(B-A, C-A), pixel ray) < 0 (the CPU rule),
//     computed per fragment, independent of GL winding;
//   - primitive = the triangle's index in the uploaded array, also when the
//     object mask skips triangles (masked objects are simply not drawn).
// The two producers differ only where a pixel centre lies within float
// round-off of a triangle edge (each has its own tie rule; both are
// watertight) or of the near/far planes.
//
// Memory: counters, offsets, scan levels and the fragment pool are kept
// between calls and only grow. The pool grows when a view needs more (never
// dropping fragments); views whose fragments exceed the largest SSBO
// (GL_MAX_SHADER_STORAGE_BLOCK_SIZE, 128 MiB on llvmpipe) or
// RasterOptions::max_pool_bytes are filled in horizontal tiles (scissor
// rectangles of whole rows; of partial rows only if one row alone is too
// big), the pool read back (or handed over) each time it is full.
//
// Batches: views rasterized together (rasterize(jobs, outs)) are counted
// into one counter buffer, scanned once, read back once, filled one after
// another into the pool and read back (or handed over) once — two waits on
// the GL pipeline for a frame's light views instead of two per view; or,
// handed over unchecked (rasterize_unchecked), counted, scanned and filled
// into a pool of a guessed size with nothing read back at all.
//
// GL state: rasterize() binds its own framebuffer, program, vertex array,
// buffers, viewport and scissor, and on return leaves framebuffer 0, program
// 0, vertex array 0 bound and GL_SCISSOR_TEST, GL_DEPTH_CLAMP and
// GL_CLIP_DISTANCE0 disabled (their defaults). The context must stay alive
// for the rasterizer's lifetime; every call makes it current first.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "backend/backend.h"
#include "scene/fragments.h"
#include "hd/scene_data.h"
#include "hd/view.h"

namespace cdsm::gl {

class Context;

struct RasterStats {
  uint64_t fragments = 0;   // fragments produced by the last rasterize()
  uint32_t tiles = 0;       // tiles the view was split into
  uint32_t pool_grows = 0;  // times the node pool grew (cumulative)
  uint64_t pool_bytes = 0;  // current fragment pool size
  double gpu_ms = 0.0;      // count+scan+fill, wall clock incl. read-back
  uint32_t bands = 0;       // count passes of the last call: one per view (more when
                            // a view's per-pixel counters exceed one SSBO)
  uint32_t scans = 0;       // prefix sums (and offset read-backs) of the last call:
                            // one per batch of views whose counters fit one SSBO
  uint32_t flushes = 0;     // fragment hand-overs (read-backs, or sink calls) of the
                            // last call: one per filled pool
};

struct RasterOptions {
  // First size of the fragment pool (8-byte fragments), bytes.
  uint64_t initial_pool_bytes = uint64_t(8) << 20;
  // Largest pool, bytes; 0 = GL_MAX_SHADER_STORAGE_BLOCK_SIZE. Views needing
  // more are filled in tiles. Tests lower it to exercise tiling.
  uint64_t max_pool_bytes = 0;
  // Most pixels counted per count pass; 0 = as many as one SSBO of uint32
  // counters holds. Views larger than this are counted in bands of rows.
  uint64_t max_band_pixels = 0;
};

class FragmentRasterizer {
 public:
  // Compiles the shaders and allocates the initial buffers on `context`
  // (made current). Throws cdsm::Error on a GL or shader failure.
  explicit FragmentRasterizer(Context& context);
  FragmentRasterizer(Context& context, const RasterOptions& options);
  ~FragmentRasterizer();
  FragmentRasterizer(const FragmentRasterizer&) = delete;
  FragmentRasterizer& operator=(const FragmentRasterizer&) = delete;

  // Uploads world-space triangles (3 vertices each), their object ids and
  // the objects (for which bound media; none when `objects` is empty).
  // Call again when the scene changes. Throws cdsm::Error when
  // tri_vertices.size() != 3 * tri_object.size() or there are more than
  // kMaxPrimitives triangles.
  void upload_scene(Span<const Vec3> tri_vertices, Span<const uint32_t> tri_object,
                    Span<const ObjectData> objects = {});
  // Re-uploads triangles [first_tri, first_tri + n) that moved (3 vertices
  // each; the same triangles, objects and media as uploaded). O(n).
  void update_triangles(uint64_t first_tri, Span<const Vec3> tri_vertices);
  // A mesh in the application's GL buffers (this context's names):
  // positions, 3 floats each, every `vertex_stride` bytes from
  // `vertex_offset` (both multiples of 4); indices of `index_size` bytes (4,
  // 2 or 1) from `index_offset`, or none (index_size 0: triangles of
  // consecutive vertices). The caller checked the ranges against the
  // buffers' sizes.
  struct AppMesh {
    uint32_t vertex_buffer = 0;
    uint64_t vertex_offset = 0;
    uint32_t vertex_stride = 12;
    uint32_t vertex_count = 0;
    uint32_t index_buffer = 0;
    uint64_t index_offset = 0;
    uint32_t index_size = 0;
    uint32_t triangles = 0;
  };
  // Writes triangles [first_tri, first_tri + mesh.triangles) of the uploaded
  // scene from `mesh` on the GPU (content/shaders/gl_mesh_gather.comp): world
  // positions under `model` (winding flipped when `mirrored`) and facing
  // normals, as upload_scene computes them from the same floats on the host.
  // Nothing is read back. Call after the upload_scene / update_triangles
  // that covers the range.
  void gather_mesh(uint64_t first_tri, const AppMesh& mesh, const Mat4& model, bool mirrored);
  // The world box of `mesh`'s triangles under `model`, computed on the GPU:
  // one read-back of 24 bytes (waits for the GL work queued before it).
  // Empty when no triangle is finite.
  Box3 mesh_bounds(const AppMesh& mesh, const Mat4& model);

  // Bytes the last upload_scene / update_triangles sent to GL.
  uint64_t last_upload_bytes() const;
  // GL memory holding the uploaded scene (vertices, facing normals, media bits).
  uint64_t scene_buffer_bytes() const;

  // Rasterizes the triangles of the objects in `mask` for `view` into `out`
  // (unsorted per pixel), exactly like cast_fragments() does by ray casting.
  // out.offsets gets width*height+1 exclusive sums (offsets[n] = total).
  // Throws cdsm::Error when the view is larger than the GL implementation's
  // framebuffer/viewport limits (16384^2 on llvmpipe) or its fragments do
  // not fit 32-bit offsets. (With near <= 0, geometry closer than 1e-6 on
  // the view axis is dropped: GL cannot project points at the eye.)
  void rasterize(const PinholeView& view, ObjectMask mask, FragmentBuffers& out);

  // One view of a batch: the view and the objects drawn into it (the mask's
  // words stay alive for the call).
  struct Job {
    PinholeView view;
    ObjectMask mask;
  };
  // Several views at once, outs[i] job i's lists as rasterize() makes them:
  // every view counted, one scan of all their counts and one read of all
  // their offsets, every view filled into the pool, then one read of all
  // their fragments (2 GL read-backs for the batch while its counters fit
  // one SSBO and its fragments the pool; else one more pair per counter
  // batch, one more fragment read per filled pool).
  void rasterize(Span<const Job> jobs, FragmentBuffers* outs);

  // Where a batch's offsets and fragments go instead of the host: the
  // backend's hand-over (shadows/backend/backend.h, lists_from_gl), job j
  // being view j there. Each batch's scanned offsets go to the offsets sink
  // once, before its fragments (bands re-based by their shift); each time
  // the pool is full (or the batch done) its pieces go to the tile sink,
  // per job in order. Both buffers are written again after the calls
  // return: the sinks copy them before (CUDA-GL interop: mapped once,
  // copied on the device, unmapped). `generation` changes whenever a buffer
  // is a new object.
  using Piece = ShadowBackend::GlPiece;
  using OffsetBand = ShadowBackend::GlOffsets;
  using TileSink = ShadowBackend::GlTileSink;
  using OffsetsSink = ShadowBackend::GlOffsetsSink;
  // rasterize(jobs, outs) handing the offsets to `offsets` and the
  // fragments to `sink`: outs[i] gets its size, outs[i].offsets only the
  // fragment count (one value), outs[i].fragments stays empty. (The host
  // reads each batch's offsets once: they size the pool and its fillings;
  // rasterize_unchecked reads nothing.)
  void rasterize(Span<const Job> jobs, FragmentBuffers* outs, const TileSink& sink, const OffsetsSink& offsets);
  // rasterize(jobs, outs) with nothing read back (lists_from_gl_unchecked):
  // each batch counted, scanned and filled into a pool of at least
  // `pool_fragments` fragments (grown to it), which holds the batch's first
  // fragments up to its size and no more, then handed to `sink` where GL
  // left it. outs[i] gets only its size. False, with nothing done, when no
  // pool can be that large (max_pool_bytes).
  using BatchSink = ShadowBackend::GlBatchSink;
  bool rasterize_unchecked(Span<const Job> jobs, FragmentBuffers* outs, uint64_t pool_fragments, const BatchSink& sink);
  // Called with a buffer's name before this rasterizer deletes or replaces
  // it (a sink that registered it with CUDA lets go of it then): the pool
  // and the offsets buffer.
  void set_release_hook(std::function<void(uint32_t)> hook);

  const RasterStats& stats() const;
  const RasterOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdsm::gl
