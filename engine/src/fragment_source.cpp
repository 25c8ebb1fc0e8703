#include "fragment_source.h"

#include <algorithm>

#include <stdexcept>
#include <vector>

#include "cdsm/error.h"
#include "backend/backend.h"

#if CDSM_HAVE_GL
#include "gl/context.h"
#include "gl/fragment_raster.h"
#endif

namespace cdsm {

#if CDSM_HAVE_GL
// One headless context and rasterizer per selector, made on first use and
// kept across frames (pools are reused).
struct FragmentSourceSelector::Gl {
  std::unique_ptr<gl::Context> own;  // null on the application's context
  gl::Context* context = nullptr;
  std::unique_ptr<gl::FragmentRasterizer> raster;
  ~Gl() {
    // GL names die with their context current. The application's context
    // may already be gone (or another current): then the names are left to
    // it rather than deleted from whichever context is current.
    if (own || !raster) return;
    bool current = false;
    try {
      context->make_current();
      current = true;
    } catch (...) {
    }
    if (!current) raster.release();
  }
};
#else
struct FragmentSourceSelector::Gl {};
#endif

FragmentSourceSelector::FragmentSourceSelector() = default;
FragmentSourceSelector::~FragmentSourceSelector() = default;

void FragmentSourceSelector::choose(FragmentSource want, std::string& name, std::string& reason) {
  if (chosen_ && want == want_) {
    name = name_;
    reason = reason_;
    return;
  }
  want_ = want;
  use_gl_ = false;
  use_cuda_ = false;
  if (want == FragmentSource::Cuda) {
    if (std::string(backend_->name()) != "cuda")
      throw Error("--fragments cuda",
                  "the CUDA fragment producer runs on the cuda backend (--backend cuda, on a CUDA device)");
    use_cuda_ = true;
    name_ = "cuda";
    reason_ = "requested (the ray caster launched on the CUDA device)";
  } else if (want == FragmentSource::Cpu) {
    name_ = "cpu";
    reason_ = "requested (exact ray casting)";
  } else {
#if CDSM_HAVE_GL
    if (!gl_tried_) {
      gl_tried_ = true;
      std::string why;
      std::unique_ptr<gl::Context> ctx;
      if (!external_) ctx = gl::create_headless_context({}, &why);
      if (ctx || external_) {
        gl_ = std::make_unique<Gl>();
        gl_->own = std::move(ctx);
        gl_->context = external_ ? external_ : gl_->own.get();
        gl::RasterOptions ro;
        if (pool_initial_) ro.initial_pool_bytes = pool_initial_;
        ro.max_pool_bytes = pool_max_;
        gl_->raster = std::make_unique<gl::FragmentRasterizer>(*gl_->context, ro);
        // A pool the backend registered (lists_from_gl) is let go of before
        // the rasterizer replaces it.
        gl_->raster->set_release_hook([this](uint32_t name) {
          if (backend_) backend_->gl_buffer_released(name);
        });
      } else {
        gl_failure_ = why.empty() ? "no OpenGL 4.5 context" : why;
      }
    }
    if (gl_) {
      use_gl_ = true;
      name_ = "gl";
      reason_ = std::string(want == FragmentSource::Gl ? "requested, "
                            : external_                ? "the application's context, "
                                                       : "default when a context exists, ") +
                gl_->context->description();
    } else {
      if (want == FragmentSource::Gl) throw Error("--fragments gl", "no OpenGL context: " + gl_failure_);
      name_ = "cpu";
      reason_ = "no OpenGL context (" + gl_failure_ + "), using the CPU ray caster";
    }
#else
    if (want == FragmentSource::Gl)
      throw Error("--fragments gl", "this build has no OpenGL (configured with CDSM_GL=OFF)");
    name_ = "cpu";
    reason_ = "built without OpenGL (CDSM_GL=OFF)";
#endif
  }
  chosen_ = true;
  name = name_;
  reason = reason_;
}

#if CDSM_HAVE_GL
namespace {

gl::FragmentRasterizer::AppMesh app_mesh(const GpuMesh& m) {
  gl::FragmentRasterizer::AppMesh a;
  a.vertex_buffer = m.source.vertex_buffer;
  a.vertex_offset = m.source.vertex_offset;
  a.vertex_stride = m.source.vertex_stride ? m.source.vertex_stride : 12;
  a.vertex_count = m.source.vertex_count;
  a.index_buffer = m.source.index_buffer;
  a.index_offset = m.source.index_offset;
  a.index_size = m.index_size;
  a.triangles = m.triangles;
  return a;
}

}  // namespace
#endif

uint64_t FragmentSourceSelector::scene_changed(const SceneBuffers& sb, const SceneChange& change,
                                               const std::vector<GpuObject>& gpu) {
  if (!use_gl_) return 0;
#if CDSM_HAVE_GL
  gl::FragmentRasterizer& r = *gl_->raster;
  // Where each GPU mesh's triangles lie: read there on the GPU.
  const auto gather = [&](const GpuObject& g) {
    const ObjectData& od = sb.objects[g.object];
    r.gather_mesh(od.first_tri, app_mesh(*g.mesh), g.transform, mirrors(g.transform));
  };
  if (change.everything) {
    r.upload_scene({sb.tri_vertices.data(), sb.tri_vertices.size()}, {sb.tri_object.data(), sb.tri_object.size()},
                   {sb.objects.data(), sb.objects.size()});
    for (const GpuObject& g : gpu) gather(g);
    return r.last_upload_bytes();
  }
  uint64_t bytes = 0;
  std::vector<uint8_t> gathered(gpu.size(), 0);
  for (const IndexRange& t : change.triangles) {
    size_t on_gpu = gpu.size();
    for (size_t k = 0; k < gpu.size(); ++k)
      if (sb.objects[gpu[k].object].first_tri == t.first) on_gpu = k;
    if (on_gpu < gpu.size()) {  // (moved: the placeholder's range, read again on the GPU)
      gather(gpu[on_gpu]);
      gathered[on_gpu] = 1;
      continue;
    }
    r.update_triangles(t.first, {sb.tri_vertices.data() + size_t(t.first) * 3, size_t(t.count) * 3});
    bytes += r.last_upload_bytes();
  }
  for (size_t k = 0; k < gpu.size(); ++k)
    if (gpu[k].changed && !gathered[k]) gather(gpu[k]);
  return bytes;
#else
  (void)sb;
  (void)change;
  (void)gpu;
  return 0;
#endif
}

Box3 FragmentSourceSelector::gpu_mesh_bounds(const GpuMesh& mesh, const Mat4& transform) {
#if CDSM_HAVE_GL
  if (use_gl_) return gl_->raster->mesh_bounds(app_mesh(mesh), transform);
#endif
  (void)mesh;
  (void)transform;
  throw std::logic_error("gpu_mesh_bounds: the fragment producer is not the GL rasterizer");
}

FragmentProducer FragmentSourceSelector::producer(const SceneBuffers& sb) const {
  if (use_cuda_) {
    // The backend's ray caster: the lists never leave the device.
    // (every view counted before a total is read: one wait for them all)
    return [](ShadowBackend& backend, const ListsRequest* requests, size_t n, ListsId* ids) {
      std::vector<PinholeView> views(n);
      std::vector<ObjectMask> masks(n);
      for (size_t i = 0; i < n; ++i) {
        views[i] = requests[i].view;
        masks[i] = requests[i].mask;
      }
      backend.cast_views(views.data(), masks.data(), n, ids);
    };
  }
#if CDSM_HAVE_GL
  if (use_gl_) {
    gl::FragmentRasterizer* r = gl_->raster.get();
    gl::Context* context = gl_->context;
    return [r, context](ShadowBackend& backend, const ListsRequest* requests, size_t n, ListsId* ids) {
      context->make_current();
      std::vector<gl::FragmentRasterizer::Job> jobs(n);
      for (size_t i = 0; i < n; ++i) jobs[i] = {requests[i].view, requests[i].mask};
      // The backend's memory is where this context's buffers live (the cuda
      // backend, CUDA-GL interop): every view rasterized together, each
      // batch's offsets and each filled pool copied there on the device;
      // the host sends nothing, and reads each batch's offsets once (to
      // size the pool) unless the lists may be made unchecked.
      if (backend.can_write_gl_maps()) {
        // Light views: nothing read at all, their counts checked by the
        // build (lists_from_gl_unchecked), once the backend has a count of
        // each slot to guess from.
        const bool unchecked = std::all_of(requests, requests + n, [](const ListsRequest& q) { return q.unchecked; });
        // (a slot names the lists and their size: the backend's guess)
        std::vector<uint64_t> slots(n);
        for (size_t i = 0; i < n; ++i)
          slots[i] = lists_slot_key(requests[i].slot, requests[i].view.width, requests[i].view.height);
        if (unchecked && backend.lists_from_gl_unchecked(
                             n, slots.data(),
                             [&](uint64_t pool, const ShadowBackend::GlBatchSink& sink, FragmentBuffers* outs) {
                               return r->rasterize_unchecked({jobs.data(), n}, outs, pool, sink);
                             },
                             ids))
          return;
        backend.lists_from_gl(
            n, slots.data(),
            [&](const ShadowBackend::GlTileSink& tiles, const ShadowBackend::GlOffsetsSink& offsets,
                FragmentBuffers* outs) {
              r->rasterize({jobs.data(), n}, outs, tiles, offsets);
            },
            ids);
        return;
      }
      // Else read back together (offsets once, fragments once) and handed
      // over (moved in on the cpu backend).
      std::vector<FragmentBuffers> fb(n);
      r->rasterize({jobs.data(), n}, fb.data());
      size_t i = 0;
      produce_each(backend, requests, n, ids,
                   [&](const ListsRequest&) { return backend.adopt_lists(std::move(fb[i++])); });
    };
  }
#endif
  return cpu_fragment_producer(sb.view());
}

uint64_t FragmentSourceSelector::gl_scene_bytes() const {
#if CDSM_HAVE_GL
  if (gl_) return gl_->raster->scene_buffer_bytes();
#endif
  return 0;
}

}  // namespace cdsm
