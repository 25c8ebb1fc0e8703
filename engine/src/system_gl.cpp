#include "system_gl.h"

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/shadow_system.h"
#include "shadow_system_impl.h"

#if CDSM_HAVE_GL
#include "gl/context.h"
#include "gl/gl_objects.h"
#include "gl/map_buffers.h"
#include "gl/shaders.h"
#include "gl/state_guard.h"
#endif

namespace cdsm {

#if CDSM_HAVE_GL

struct SystemGl {
  std::unique_ptr<gl::Context> context;
  std::unique_ptr<gl::MapBuffers> maps;
  uint64_t block_limit = 0;
};

void SystemGlDeleter::operator()(SystemGl* p) const {
  if (!p) return;
  // GL objects die with their context current; if another one is, they are
  // left to the application's context (destroyed with it).
  bool current = false;
  try {
    p->context->make_current();
    current = true;
  } catch (...) {
  }
  if (!current && p->maps) p->maps.release();  // leaked into the (gone or other) context on purpose
  // The backend the release hook names is gone by now (ShadowSystem::Impl
  // declares it after `gl`), and it unregistered its GL buffers as it died.
  if (p->maps) p->maps->set_release_hook({});
  delete p;
}

SystemGlPtr make_system_gl(const std::string& where) {
  std::string why;
  auto ctx = gl::adopt_current_context(&why);
  if (!ctx) throw Error(where, "GlContextUse::Application needs the application's OpenGL 4.5 context current: " + why);
  SystemGlPtr g(new SystemGl);
  g->context = std::move(ctx);
  return g;
}

gl::Context* system_context(SystemGl& g) { return g.context.get(); }

void try_make_current(SystemGl& g) noexcept {
  try {
    g.context->make_current();
  } catch (...) {
  }
}

struct SystemGlScope::Guard {
  gl::StateGuard state;
};

static void warn_pending(GLenum e, std::vector<std::string>* warnings) {
  if (e != GL_NO_ERROR && warnings)
    warnings->push_back(std::string("the application left the GL error ") + gl::error_name(e) +
                        " pending before a shadow-system call; it was cleared");
}

SystemGlScope::SystemGlScope(SystemGl* g, std::vector<std::string>* warnings) {
  if (!g) return;
  g->context->make_current();  // throws naming what is current instead
  guard_ = std::make_unique<Guard>();
  warn_pending(guard_->state.pending_error(), warnings);
}
SystemGlScope::~SystemGlScope() = default;

void sync_gl_maps(SystemGl& g, ShadowView view, ShadowBackend& backend, UpdateStats& st) {
  if (!g.maps) g.maps = std::make_unique<gl::MapBuffers>(*g.context, g.block_limit);
  g.context->make_current();
  // A buffer the backend may have registered (CUDA-GL interop) is released
  // to it before GL deletes or replaces it (system_gl.h).
  g.maps->set_release_hook([&backend](GLuint name) { backend.gl_buffer_released(name); });
  gl::MapUploadStats m;
  // What a compaction left in place is not sent again.
  const auto kept = [&backend](uint64_t since, uint64_t* bytes) { backend.storage_kept_bytes(since, bytes); };
  if (backend.can_write_gl_maps()) {
    // The backend writes the ranges from its own memory: sizes only here.
    view.storage = backend.storage_extent();
    m = g.maps->sync(view, backend.storage_epoch(), kept,
                     [&backend](const GlMapWrite* w, int n) { backend.write_gl_maps(w, n); });
  } else {
    view.storage = backend.storage();
    m = g.maps->sync(view, backend.storage_epoch(), kept);
  }
  st.gl_map_upload_bytes += m.upload_bytes;
  st.gl_map_device_bytes += m.device_bytes;
  st.gl_map_copy_bytes += m.copy_bytes;
  st.gl_map_full_upload = st.gl_map_full_upload || m.full;
  st.gl_map_bytes = m.allocated_bytes;
}

void require_gl_current(SystemGl& g, std::vector<std::string>* warnings) {
  g.context->make_current();
  warn_pending(gl::drain_gl_errors(), warnings);
}

GlMapBuffers gl_map_buffers(const SystemGl& g) {
  GlMapBuffers b;
  if (!g.maps) return b;
  b.frame = g.maps->buffer(gl::MapBlock::Frame);
  b.texels = g.maps->buffer(gl::MapBlock::Texels);
  b.nodes = g.maps->buffer(gl::MapBlock::Nodes);
  b.chunks = g.maps->buffer(gl::MapBlock::Chunks);
  b.rgb_texels = g.maps->buffer(gl::MapBlock::RgbTexels);
  b.rgb_nodes = g.maps->buffer(gl::MapBlock::RgbNodes);
  b.rgb_chunks = g.maps->buffer(gl::MapBlock::RgbChunks);
  b.tags = g.maps->buffer(gl::MapBlock::Tags);
  b.rgb_tags = g.maps->buffer(gl::MapBlock::RgbTags);
  b.layout = g.maps->layout();
  return b;
}

void bind_gl_maps(SystemGl& g, uint32_t program) {
  if (!g.maps) throw Error("ShadowSystem::bind_gl", "no maps yet: call update() first");
  g.maps->bind(program);
}

void set_gl_map_block_limit(SystemGl& g, uint64_t bytes) {
  g.block_limit = bytes;
  g.maps.reset();
}

namespace {

// `count` vec3 of `buffer` from `offset` every `stride` bytes (0: 12): the
// bytes they span, checked against the buffer's size. Reads nothing.
uint64_t vec3_span(GLuint buffer, uint64_t offset, uint32_t stride, uint32_t count, const std::string& where,
                   const char* what) {
  if (buffer == 0 || !glIsBuffer(buffer))
    throw Error(where,
                std::string(what) + " buffer " + std::to_string(buffer) + " is not a GL buffer of the current context");
  if (stride == 0) stride = 12;
  if (stride < 12)
    throw Error(where,
                std::string(what) + " stride " + std::to_string(stride) + " is below the 12 bytes of a position");
  if (count == 0) return 0;
  GLint64 size = 0;
  CDSM_GL(glGetNamedBufferParameteri64v(buffer, GL_BUFFER_SIZE, &size));
  const uint64_t span = uint64_t(count - 1) * stride + 12;
  if (offset + span > uint64_t(size))
    throw Error(where, std::string(what) + " buffer " + std::to_string(buffer) + " holds " + std::to_string(size) +
                           " bytes; " + std::to_string(count) + " vec3 at offset " + std::to_string(offset) +
                           " stride " + std::to_string(stride) + " need " + std::to_string(offset + span));
  return span;
}

// One attribute stream of an application buffer: `count` vec3 from `offset`
// every `stride` bytes, read back in one call over the range they span.
std::vector<Vec3> read_vec3(GLuint buffer, uint64_t offset, uint32_t stride, uint32_t count, const std::string& where,
                            const char* what, uint64_t& bytes) {
  const uint64_t span = vec3_span(buffer, offset, stride, count, where, what);
  if (count == 0) return {};
  if (stride == 0) stride = 12;
  std::vector<unsigned char> raw(span);
  CDSM_GL(glGetNamedBufferSubData(buffer, GLintptr(offset), GLsizeiptr(span), raw.data()));
  ++gl::thread_gl_counters().readbacks;
  bytes += span;
  std::vector<Vec3> out(count);
  for (uint32_t i = 0; i < count; ++i) {
    float v[3];
    std::memcpy(v, raw.data() + uint64_t(i) * stride, sizeof v);
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
      throw Error(where, std::string(what) + " " + std::to_string(i) + " is not finite");
    out[i] = {v[0], v[1], v[2]};
  }
  return out;
}

}  // namespace

GlMeshExtent check_gl_mesh(const GlMeshSource& s, const std::string& where) {
  GlMeshExtent e;
  vec3_span(s.vertex_buffer, s.vertex_offset, s.vertex_stride, s.vertex_count, where, "vertex");
  if (s.normal_buffer) vec3_span(s.normal_buffer, s.normal_offset, s.normal_stride, s.vertex_count, where, "normal");
  if (s.index_buffer == 0) {
    if (s.vertex_count % 3 != 0)
      throw Error(where,
                  "a mesh without indices needs a multiple of 3 vertices, got " + std::to_string(s.vertex_count));
    e.triangles = s.vertex_count / 3;
    return e;
  }
  switch (s.index_type) {
    case GL_UNSIGNED_INT: e.index_size = 4; break;
    case GL_UNSIGNED_SHORT: e.index_size = 2; break;
    case GL_UNSIGNED_BYTE: e.index_size = 1; break;
    default: {
      char hex[16];
      std::snprintf(hex, sizeof hex, "0x%04x", s.index_type);
      throw Error(where,
                  std::string("index_type ") + hex + " is not GL_UNSIGNED_INT, GL_UNSIGNED_SHORT or GL_UNSIGNED_BYTE");
    }
  }
  if (s.index_count % 3 != 0)
    throw Error(where, "index_count " + std::to_string(s.index_count) + " is not a multiple of 3");
  if (!glIsBuffer(s.index_buffer))
    throw Error(where, "index buffer " + std::to_string(s.index_buffer) + " is not a GL buffer of the current context");
  GLint64 size = 0;
  CDSM_GL(glGetNamedBufferParameteri64v(s.index_buffer, GL_BUFFER_SIZE, &size));
  const uint64_t span = uint64_t(s.index_count) * e.index_size;
  if (s.index_offset % e.index_size != 0)
    throw Error(where, "index_offset " + std::to_string(s.index_offset) + " is not aligned to its type");
  if (s.index_offset + span > uint64_t(size))
    throw Error(where, "index buffer " + std::to_string(s.index_buffer) + " holds " + std::to_string(size) +
                           " bytes; " + std::to_string(s.index_count) + " indices at offset " +
                           std::to_string(s.index_offset) + " need " + std::to_string(s.index_offset + span));
  e.triangles = s.index_count / 3;
  return e;
}

std::shared_ptr<TriangleMesh> read_gl_mesh(SystemGl& g, const GlMeshSource& s, const std::string& where,
                                           uint64_t& bytes) {
  (void)g;
  const GlMeshExtent e = check_gl_mesh(s, where);
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->positions =
      read_vec3(s.vertex_buffer, s.vertex_offset, s.vertex_stride, s.vertex_count, where, "vertex", bytes);
  if (s.normal_buffer)
    mesh->normals =
        read_vec3(s.normal_buffer, s.normal_offset, s.normal_stride, s.vertex_count, where, "normal", bytes);
  if (s.index_buffer == 0) {
    mesh->indices.resize(s.vertex_count);
    for (uint32_t i = 0; i < s.vertex_count; ++i) mesh->indices[i] = i;
    return mesh;
  }
  const uint64_t span = uint64_t(s.index_count) * e.index_size;
  std::vector<unsigned char> raw(span);
  if (span) {
    CDSM_GL(glGetNamedBufferSubData(s.index_buffer, GLintptr(s.index_offset), GLsizeiptr(span), raw.data()));
    ++gl::thread_gl_counters().readbacks;
  }
  bytes += span;
  mesh->indices.resize(s.index_count);
  for (uint32_t i = 0; i < s.index_count; ++i) {
    uint32_t v = 0;
    if (e.index_size == 4)
      std::memcpy(&v, raw.data() + 4 * uint64_t(i), 4);
    else if (e.index_size == 2) {
      uint16_t h;
      std::memcpy(&h, raw.data() + 2 * uint64_t(i), 2);
      v = h;
    } else {
      v = raw[i];
    }
    if (v >= s.vertex_count)
      throw Error(where, "index " + std::to_string(i) + " is " + std::to_string(v) + ", past the " +
                             std::to_string(s.vertex_count) + " vertices");
    mesh->indices[i] = v;
  }
  return mesh;
}

std::string glsl_include() { return gl::shader_source("cdsm.glsl"); }

GlWork thread_gl_work() {
  const gl::GlCounters& c = gl::thread_gl_counters();
  return {c.allocations, c.readbacks};
}

#else  // no OpenGL in this build

struct SystemGl {};
void SystemGlDeleter::operator()(SystemGl* p) const { delete p; }
SystemGlPtr make_system_gl(const std::string& where) {
  throw Error(where, "GlContextUse::Application needs OpenGL, and this build has none (configured with CDSM_GL=OFF)");
}
gl::Context* system_context(SystemGl&) { return nullptr; }
void try_make_current(SystemGl&) noexcept {}
struct SystemGlScope::Guard {};
SystemGlScope::SystemGlScope(SystemGl*, std::vector<std::string>*) {}
SystemGlScope::~SystemGlScope() = default;
void sync_gl_maps(SystemGl&, ShadowView, ShadowBackend&, UpdateStats&) {}
GlMapBuffers gl_map_buffers(const SystemGl&) { return {}; }
void require_gl_current(SystemGl&, std::vector<std::string>*) {}
void bind_gl_maps(SystemGl&, uint32_t) {}
std::shared_ptr<TriangleMesh> read_gl_mesh(SystemGl&, const GlMeshSource&, const std::string&, uint64_t&) { return {}; }
GlMeshExtent check_gl_mesh(const GlMeshSource&, const std::string&) { return {}; }
void set_gl_map_block_limit(SystemGl&, uint64_t) {}
GlWork thread_gl_work() { return {}; }
std::string glsl_include() {
  throw Error("cdsm::glsl_include", "this build has no OpenGL (configured with CDSM_GL=OFF)");
}

#endif

// ---- ShadowSystem's GL methods (cdsm/shadow_system.h, engine integration) --

std::shared_ptr<const TriangleMesh> ShadowSystem::read_gl_mesh(const GlMeshSource& source) {
  Impl& I = *impl_;
  const std::string where = I.scene.source + ": read_gl_mesh";
  if (!I.gl)
    throw Error(where,
                "needs a system created on the application's GL context (SystemOptions::gl_context = "
                "GlContextUse::Application)");
  std::vector<std::string> warnings;
  SystemGlScope scope(I.gl.get(), &warnings);
  const uint64_t reads = thread_gl_work().readbacks;
  auto mesh = cdsm::read_gl_mesh(*I.gl, source, where, I.gl_readback_bytes);
  I.gl_readbacks += thread_gl_work().readbacks - reads;
  return mesh;
}

namespace {

// `triangles` degenerate triangles: what a GPU mesh's Object holds on the
// host (its count sizes the scene arrays; nothing reads its positions).
std::shared_ptr<const TriangleMesh> placeholder_mesh(uint32_t triangles) {
  auto m = std::make_shared<TriangleMesh>();
  m->positions.assign(1, Vec3{0, 0, 0});
  m->indices.assign(size_t(triangles) * 3, 0u);
  return m;
}

void check_gpu_bounds(const Box3& b, const std::string& where) {
  if (!is_finite(b.lo) || !is_finite(b.hi) || b.empty())
    throw Error(where, "bounds must be finite with lo <= hi in every axis");
}

// A GPU mesh's source checked against the application's buffers (the
// context current): its extent.
GpuMesh gpu_mesh(const GlMeshSource& source, const std::string& where) {
  if (source.vertex_offset % 4 != 0 || source.vertex_stride % 4 != 0)
    throw Error(where,
                "a mesh that stays on the GPU needs vertex_offset and vertex_stride in multiples of 4 bytes, got " +
                    std::to_string(source.vertex_offset) + " and " + std::to_string(source.vertex_stride));
  const GlMeshExtent e = check_gl_mesh(source, where);
  if (e.triangles >= kMaxPrimitives)
    throw Error(where, std::to_string(e.triangles) + " triangles, at most " + std::to_string(kMaxPrimitives - 1));
  GpuMesh g;
  g.source = source;
  g.index_size = e.index_size;
  g.triangles = e.triangles;
  return g;
}

}  // namespace

ObjectHandle ShadowSystem::add_gpu_object(const Object& o, const GlMeshSource& source, const GpuMeshOptions& options) {
  Impl& I = *impl_;
  const std::string where = object_location(I.scene.source, I.objects.size(), o.name) + ": add_gpu_object";
  if (!I.gl)
    throw Error(where,
                "needs a system created on the application's GL context (SystemOptions::gl_context = "
                "GlContextUse::Application): the mesh lives in its buffers");
  if (I.options.private_fragment_context)
    throw Error(where,
                "the system rasterizes on a context of its own (SystemOptions::private_fragment_context), which "
                "cannot read the application's buffers");
  if (o.interior != InteriorKind::None)
    throw Error(where, "a mesh that stays on the GPU has no interior (medium or volume)");
  std::vector<std::string> warnings;
  SystemGlScope scope(I.gl.get(), &warnings);
  auto g = std::make_shared<GpuMesh>(gpu_mesh(source, where));
  g->closed = options.closed;
  if (!(options.bounds.lo.x > options.bounds.hi.x && options.bounds.lo.y > options.bounds.hi.y &&
        options.bounds.lo.z > options.bounds.hi.z)) {  // given (the default Box3 is empty in every axis)
    check_gpu_bounds(options.bounds, where);
    g->bounds_given = true;
    g->bounds = options.bounds;
  }
  Object copy = o;
  copy.mesh = placeholder_mesh(g->triangles);
  copy.mesh_source = R"({"type":"gl_buffers"})";
  const ObjectHandle h = add_object(copy);
  I.objects[I.object_index(h)].gpu = std::move(g);
  return h;
}

void ShadowSystem::mark_changed(ObjectHandle h, const Box3* object_bounds, const GlMeshSource* source) {
  Impl& I = *impl_;
  const size_t i = I.object_index(h);
  const std::string where = I.object_where(i) + ": mark_changed";
  Impl::ObjectRec& rec = I.objects[i];
  if (!rec.gpu)
    throw Error(where,
                "is for meshes that stay on the GPU (add_gpu_object); give this object's new mesh to set_mesh()");
  if (object_bounds) check_gpu_bounds(*object_bounds, where);
  if (source) {
    std::vector<std::string> warnings;
    SystemGlScope scope(I.gl.get(), &warnings);
    GpuMesh g = gpu_mesh(*source, where);
    g.closed = rec.gpu->closed;
    g.bounds_given = rec.gpu->bounds_given;
    g.bounds = rec.gpu->bounds;
    if (g.triangles != rec.gpu->triangles) {  // the scene's triangle arrays change size
      I.scene.objects[i].mesh = placeholder_mesh(g.triangles);
      I.structure_dirty = true;
    }
    *rec.gpu = g;
  }
  if (object_bounds) {
    rec.gpu->bounds_given = true;
    rec.gpu->bounds = *object_bounds;
  }
  rec.gpu_changed = true;  // (its placeholder on the host is unchanged: nothing of it is sent)
  I.touch_object(i);
}

GlMapBuffers ShadowSystem::gl_buffers() const {
  const Impl& I = *impl_;
  if (!I.gl)
    throw Error(I.scene.source + ": gl_buffers",
                "needs a system created on the application's GL context (SystemOptions::gl_context = "
                "GlContextUse::Application)");
  return gl_map_buffers(*I.gl);
}

void ShadowSystem::bind_gl(uint32_t program) {
  Impl& I = *impl_;
  const std::string where = I.scene.source + ": bind_gl";
  if (!I.gl)
    throw Error(where,
                "needs a system created on the application's GL context (SystemOptions::gl_context = "
                "GlContextUse::Application)");
  bind_gl_maps(*I.gl, program);  // checks the context; changes exactly the program's cdsm bindings
}

int ShadowSystem::gl_light_index(LightHandle light) const { return int(impl_->light_index(light)); }

uint32_t ShadowSystem::gl_object_id(ObjectHandle object) const {
  const size_t i = impl_->object_index(object);
  return impl_->scene.objects[i].casts_shadows ? uint32_t(i) : kNoObject;
}

}  // namespace cdsm
