#include "gl/fragment_raster.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "gl/context.h"
#include "gl/gl_objects.h"
#include "gl/prefix_sum.h"
#include "gl/shaders.h"

namespace cdsm::gl {

namespace {

// Uniform locations and SSBO bindings of content/shaders/fragment_lists.glsl.
enum Uniform : GLint {
  kEye = 0,
  kRight = 1,
  kUp = 2,
  kForward = 3,
  kWindow = 4,
  kNearFar = 5,
  kSize = 6,
  kRow0 = 7,
  kFragBase = 8,
  kPass = 9,
  kTriBase = 10,
  kClipZ = 11,
  kXShift = 12,
  kOrtho = 13,
  kCountBase = 14,
  kPoolSize = 15,
};
enum Binding : GLuint { kCounts = 0, kOffsets = 1, kFragments = 2, kNormals = 3, kMedia = 4 };

constexpr uint64_t kFragmentBytes = sizeof(Fragment);
static_assert(kFragmentBytes == 8, "the shader writes 8-byte {float, uint} fragments");

const char* const kWhere = "gl::FragmentRasterizer";

// A maximal run of consecutive triangles of one object.
struct ObjectRun {
  uint32_t first;  // triangle
  uint32_t count;
  uint32_t object;
};

// The draws of one bound range of the normal buffer.
struct DrawChunk {
  uint32_t tri_base = 0;       // first triangle of the bound normal range
  uint32_t tri_count = 0;      // triangles in that range
  std::vector<GLint> first;    // vertices
  std::vector<GLsizei> count;  // vertices
};

// Restores the defaults of the state rasterize() changes, also on a throw.
struct StateReset {
  ~StateReset() {
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glUseProgram(0);
    glBindVertexArray(0);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_DEPTH_CLAMP);
    glDisable(GL_CLIP_DISTANCE0);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  }
};

}  // namespace

struct FragmentRasterizer::Impl {
  Context& context;
  RasterOptions options;
  Program program;
  PrefixSum scan;
  VertexArray vao{"cdsm.fragments.vao"};
  Framebuffer fbo{"cdsm.fragments.fbo"};
  uint64_t uploaded = 0;                         // bytes the last upload / update sent
  Buffer vertices{"cdsm.fragments.vertices"};    // 3 x vec3 per triangle (vertex attribute 0)
  Buffer normals{"cdsm.fragments.tri_normals"};  // cross(B-A, C-A) per triangle
  Buffer media{"cdsm.fragments.tri_media"};      // bit per triangle: bounds a medium
  Buffer counts{"cdsm.fragments.counts"};        // per band pixel; count, then fill cursor
  Buffer offsets{"cdsm.fragments.offsets"};      // exclusive sums of counts, + total
  Buffer pool{"cdsm.fragments.pool"};            // fragments of the current tile

  uint32_t tri_count = 0;
  std::vector<ObjectRun> runs;
  std::vector<float> normal_scratch;
  std::vector<uint32_t> media_scratch;
  std::vector<DrawChunk> chunks;
  uint32_t chunk_tris = 0;  // triangles per bound normal range
  int32_t fbo_width = 0, fbo_height = 0;
  RasterStats stats;
  uint64_t pool_generation = 1;                // a new pool buffer object: a new generation
  std::function<void(uint32_t)> release_hook;  // before the pool is deleted
  // The pool, once its old object (if any) was announced to the hook.
  void release_pool() noexcept {
    if (release_hook && pool.id() != 0) release_hook(pool.id());
  }

  Impl(Context& c, const RasterOptions& o)
      : context(c),
        options(o),
        program(build_program("cdsm.fragments.program",
                              {{GL_VERTEX_SHADER, "fragment_lists.glsl", "#define VERTEX_STAGE 1\n"},
                               {GL_FRAGMENT_SHADER, "fragment_lists.glsl", "#define FRAGMENT_STAGE 1\n"}})),
        scan(c) {
    CDSM_GL(glEnableVertexArrayAttrib(vao.id(), 0));
    CDSM_GL(glVertexArrayAttribFormat(vao.id(), 0, 3, GL_FLOAT, GL_FALSE, 0));
    CDSM_GL(glVertexArrayAttribBinding(vao.id(), 0, 0));
    pool.reserve(std::min<uint64_t>(std::max<uint64_t>(options.initial_pool_bytes, kFragmentBytes), max_pool_bytes()));
    stats.pool_bytes = pool.capacity();
    const uint32_t no_media = 0;
    media.reserve(sizeof(no_media));
    media.upload(&no_media, sizeof(no_media));
    // Normal ranges bound at once must fit one SSBO; their offsets must be
    // multiples of the binding alignment.
    uint64_t align = uint64_t(std::max(context.limits().ssbo_offset_alignment, 1));
    uint64_t per_chunk = uint64_t(context.limits().max_ssbo_block_size) / 12;
    per_chunk = std::min<uint64_t>(per_chunk, uint64_t(1) << 28);
    chunk_tris = uint32_t(std::max<uint64_t>(per_chunk / align * align, align));
  }

  ~Impl() {
    // GL names belong to this context: delete them with it current. When it
    // cannot be made current here (current on another thread, or another
    // window system's context is current on this one), the names are
    // dropped, not deleted from whatever context is current; they die with
    // their context.
    try {
      // Never take the thread's current context away from its owner.
      if (Context::current() != nullptr && Context::current() != &context) throw Error("", "");
      context.make_current();
    } catch (...) {
      program.forget();
      scan.forget();
      vao.forget();
      fbo.forget();
      gather.forget();
      for (Buffer* b : {&vertices, &normals, &media, &counts, &offsets, &pool, &mesh_box, &mesh_indices}) b->forget();
    }
  }

  uint64_t max_pool_bytes() const {
    uint64_t limit = uint64_t(context.limits().max_ssbo_block_size);
    uint64_t cap = options.max_pool_bytes ? std::min(options.max_pool_bytes, limit) : limit;
    return std::max<uint64_t>(cap / kFragmentBytes * kFragmentBytes, kFragmentBytes);
  }

  uint64_t max_band_pixels() const {
    uint64_t limit = uint64_t(context.limits().max_ssbo_block_size) / 4 - 1;  // offsets hold n + 1
    limit = std::min<uint64_t>(limit, 0xfffffffeull);
    return options.max_band_pixels ? std::min(options.max_band_pixels, limit) : limit;
  }

  void upload(Span<const Vec3> tri_vertices, Span<const uint32_t> tri_object, Span<const ObjectData> objects) {
    uint64_t n = tri_object.size();
    if (tri_vertices.size() != 3 * n)
      throw Error(kWhere, "upload_scene: " + std::to_string(tri_vertices.size()) + " vertices for " +
                              std::to_string(n) + " triangles (3 each expected)");
    if (n > kMaxPrimitives)
      throw Error(kWhere, "upload_scene: " + std::to_string(n) + " triangles, at most " +
                              std::to_string(kMaxPrimitives) + " fit a fragment's primitive field");
    context.make_current();
    tri_count = uint32_t(n);
    uploaded = 0;
    // Exactly sized when the scene shrank to under half (removed objects
    // free their GL memory), else grown as needed.
    fit(vertices, n * 36);
    vertices.upload(tri_vertices.data(), n * 36);
    facing_normals(tri_vertices);
    fit(normals, n * 12);
    normals.upload(normal_scratch.data(), n * 12);
    media_scratch.assign(n / 32 + 1, 0u);
    for (uint64_t t = 0; t < n; ++t)
      if (tri_object[t] < objects.size() && bounds_medium(objects[tri_object[t]]))
        media_scratch[t >> 5] |= 1u << (t & 31u);
    fit(media, media_scratch.size() * 4);
    media.upload(media_scratch.data(), media_scratch.size() * 4);
    uploaded = n * 48 + media_scratch.size() * 4;
    CDSM_GL(glVertexArrayVertexBuffer(vao.id(), 0, vertices.id(), 0, sizeof(Vec3)));
    runs.clear();
    for (uint32_t t = 0; t < tri_count; ++t) {
      if (!runs.empty() && runs.back().object == tri_object[t] && runs.back().first + runs.back().count == t)
        ++runs.back().count;
      else
        runs.push_back({t, 1, tri_object[t]});
    }
  }

  // cross(B - A, C - A) per triangle into normal_scratch (the CPU ray
  // caster's facing test uses the same vector).
  void facing_normals(Span<const Vec3> tri_vertices) {
    const uint64_t n = tri_vertices.size() / 3;
    normal_scratch.resize(3 * n);
    for (uint64_t t = 0; t < n; ++t) {
      Vec3 a = tri_vertices[3 * t], b = tri_vertices[3 * t + 1], c = tri_vertices[3 * t + 2];
      Vec3 g = cross(b - a, c - a);
      normal_scratch[3 * t] = g.x;
      normal_scratch[3 * t + 1] = g.y;
      normal_scratch[3 * t + 2] = g.z;
    }
  }

  // Grows `b` to `bytes`, or re-allocates it exactly when it holds more
  // than twice that.
  static void fit(Buffer& b, uint64_t bytes) {
    if (b.capacity() > 2 * bytes + 4096) b.destroy();
    b.reserve(bytes);
  }

  void update_triangles(uint64_t first, Span<const Vec3> tri_vertices) {
    const uint64_t n = tri_vertices.size() / 3;
    if (tri_vertices.size() != 3 * n || first + n > tri_count)
      throw Error(kWhere, "update_triangles: triangles [" + std::to_string(first) + ", " + std::to_string(first + n) +
                              ") are not within the " + std::to_string(tri_count) + " uploaded");
    context.make_current();
    vertices.upload(tri_vertices.data(), n * 36, first * 36);
    facing_normals(tri_vertices);
    normals.upload(normal_scratch.data(), n * 12, first * 12);
    uploaded = n * 48;
  }

  // Draw lists of the triangles of the objects in `mask`, per normal range.
  void build_draws(ObjectMask mask) {
    uint32_t nchunks = tri_count == 0 ? 0 : (tri_count - 1) / chunk_tris + 1;
    chunks.resize(nchunks);
    for (uint32_t c = 0; c < nchunks; ++c) {
      chunks[c].tri_base = c * chunk_tris;
      chunks[c].tri_count = std::min(chunk_tris, tri_count - c * chunk_tris);
      chunks[c].first.clear();
      chunks[c].count.clear();
    }
    auto add_range = [&](uint32_t first, uint32_t count) {
      while (count > 0) {
        DrawChunk& ch = chunks[first / chunk_tris];
        uint32_t n = std::min(count, ch.tri_base + ch.tri_count - first);
        // Merge with the previous draw when contiguous.
        if (!ch.first.empty() && uint32_t(ch.first.back()) + uint32_t(ch.count.back()) == 3 * first) {
          ch.count.back() += GLsizei(3 * n);
        } else {
          ch.first.push_back(GLint(3 * first));
          ch.count.push_back(GLsizei(3 * n));
        }
        first += n;
        count -= n;
      }
    };
    for (const ObjectRun& r : runs)
      if (mask.contains(r.object)) add_range(r.first, r.count);
  }

  void draw() {
    for (const DrawChunk& ch : chunks) {
      if (ch.first.empty()) continue;
      CDSM_GL(glBindBufferRange(GL_SHADER_STORAGE_BUFFER, kNormals, normals.id(), GLintptr(uint64_t(ch.tri_base) * 12),
                                GLsizeiptr(uint64_t(ch.tri_count) * 12)));
      CDSM_GL(glProgramUniform1ui(program.id(), kTriBase, ch.tri_base));
      CDSM_GL(glMultiDrawArrays(GL_TRIANGLES, ch.first.data(), ch.count.data(), GLsizei(ch.first.size())));
    }
  }

  void set_view(const PinholeView& v) {
    GLuint p = program.id();
    CDSM_GL(glProgramUniform3f(p, kEye, v.eye.x, v.eye.y, v.eye.z));
    CDSM_GL(glProgramUniform3f(p, kRight, v.right.x, v.right.y, v.right.z));
    CDSM_GL(glProgramUniform3f(p, kUp, v.up.x, v.up.y, v.up.z));
    CDSM_GL(glProgramUniform3f(p, kForward, v.forward.x, v.forward.y, v.forward.z));
    CDSM_GL(glProgramUniform4f(p, kWindow, v.center.x, v.center.y, v.tan_half_x, v.tan_half_y));
    CDSM_GL(glProgramUniform2f(p, kNearFar, v.near, v.far));
    CDSM_GL(glProgramUniform2i(p, kSize, v.width, v.height));
    CDSM_GL(glProgramUniform1i(p, kOrtho, is_orthographic(v) ? 1 : 0));
    // Drop what lies behind the eye before projection; the exact near test
    // is per fragment, media boundaries are kept closer (view.h
    // media_clip_axial). (Depth clamp disables GL's own near/far clipping.)
    CDSM_GL(glProgramUniform1f(p, kClipZ, media_clip_axial(v)));
    // Half a snapping step (2^-(bits+1) pixel) in NDC units: 2 / width per pixel.
    const int bits = std::clamp(context.limits().subpixel_bits, 1, 16);
    CDSM_GL(glProgramUniform1f(p, kXShift, 2.0f / float(v.width) * std::ldexp(1.0f, -(bits + 1))));
  }

  void bind_pipeline(int32_t width, int32_t height) {
    if (width != fbo_width || height != fbo_height) {
      CDSM_GL(glNamedFramebufferParameteri(fbo.id(), GL_FRAMEBUFFER_DEFAULT_WIDTH, width));
      CDSM_GL(glNamedFramebufferParameteri(fbo.id(), GL_FRAMEBUFFER_DEFAULT_HEIGHT, height));
      GLenum status = CDSM_GLV(glCheckNamedFramebufferStatus(fbo.id(), GL_FRAMEBUFFER));
      if (status != GL_FRAMEBUFFER_COMPLETE)
        throw Error(kWhere, "framebuffer without attachments incomplete at " + std::to_string(width) + "x" +
                                std::to_string(height));
      fbo_width = width;
      fbo_height = height;
    }
    CDSM_GL(glBindFramebuffer(GL_FRAMEBUFFER, fbo.id()));
    CDSM_GL(glViewport(0, 0, width, height));
    CDSM_GL(glDisable(GL_DEPTH_TEST));
    CDSM_GL(glDisable(GL_CULL_FACE));
    CDSM_GL(glDisable(GL_BLEND));
    CDSM_GL(glDisable(GL_RASTERIZER_DISCARD));
    CDSM_GL(glDisable(GL_MULTISAMPLE));
    CDSM_GL(glPolygonMode(GL_FRONT_AND_BACK, GL_FILL));
    CDSM_GL(glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE));
    CDSM_GL(glEnable(GL_DEPTH_CLAMP));
    CDSM_GL(glEnable(GL_CLIP_DISTANCE0));
    CDSM_GL(glEnable(GL_SCISSOR_TEST));
    CDSM_GL(glUseProgram(program.id()));
    CDSM_GL(glBindVertexArray(vao.id()));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kCounts, counts.id()));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kOffsets, offsets.id()));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kFragments, pool.id()));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kMedia, media.id()));
  }

  // Image rows [row_a, row_b), columns [col_a, col_b) -> GL scissor box.
  void scissor(int32_t height, int32_t row_a, int32_t row_b, int32_t col_a, int32_t col_b) {
    CDSM_GL(glScissor(col_a, height - row_b, col_b - col_a, row_b - row_a));
  }

  void ensure_pool(uint64_t fragments) {
    uint64_t need = fragments * kFragmentBytes;
    if (need <= pool.capacity()) return;
    uint64_t grown = std::min(max_pool_bytes(), std::max(need, 2 * pool.capacity()));
    release_pool();
    pool.reserve(grown);
    ++pool_generation;
    ++stats.pool_grows;
    stats.pool_bytes = pool.capacity();
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kFragments, pool.id()));
  }

  // Debug contexts: every fill cursor must be back at zero, i.e. the fill
  // passes wrote exactly the fragments the count pass counted.
  void verify_cursors_consumed(uint64_t n) {
    CDSM_GL(glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT));
    std::vector<uint32_t> left(n);
    counts.download(left.data(), n * 4);
    for (uint64_t i = 0; i < n; ++i)
      if (left[i] != 0)
        throw Error(kWhere, "internal: pixel " + std::to_string(i) + " of the band kept " + std::to_string(left[i]) +
                                " fill slots (count and fill passes rasterized differently)");
  }

  // Application meshes read on the GPU (gl_mesh_gather.comp), made on first use.
  Program gather;
  Buffer mesh_box{"cdsm.fragments.mesh_bounds"};  // 6 ordered uints
  // The mesh's indices copied on the GPU (glCopyNamedBufferSubData) at their
  // offset modulo 4, into whole words: the shader reads 32-bit words, and a
  // last 16- or 8-bit index may end an application buffer mid-word.
  Buffer mesh_indices{"cdsm.fragments.mesh_indices"};

  void dispatch_gather(const AppMesh& m, uint64_t first_tri, const Mat4& model, bool mirrored, uint32_t mode) {
    context.make_current();
    if (!gather) gather = build_program("cdsm.fragments.gather_mesh", {{GL_COMPUTE_SHADER, "gl_mesh_gather.comp"}});
    const GLuint p = gather.id();
    CDSM_GL(glProgramUniform1ui(p, 0, m.triangles));
    CDSM_GL(glProgramUniform1ui(p, 1, GLuint(first_tri)));
    CDSM_GL(glProgramUniform1ui(p, 2, GLuint(m.vertex_offset / 4)));
    CDSM_GL(glProgramUniform1ui(p, 3, m.vertex_stride / 4));
    CDSM_GL(glProgramUniform1ui(p, 4, m.vertex_count));
    const uint64_t index_bytes = m.index_buffer ? uint64_t(m.triangles) * 3 * m.index_size : 0;
    if (index_bytes > 0) {
      mesh_indices.reserve(((m.index_offset & 3) + index_bytes + 3) & ~uint64_t(3));
      CDSM_GL(glCopyNamedBufferSubData(m.index_buffer, mesh_indices.id(), GLintptr(m.index_offset),
                                       GLintptr(m.index_offset & 3), GLsizeiptr(index_bytes)));
    }
    CDSM_GL(glProgramUniform1ui(p, 5, index_bytes > 0 ? m.index_size : 0u));
    CDSM_GL(glProgramUniform1ui(p, 6, GLuint(m.index_offset & 3)));
    for (int r = 0; r < 3; ++r)
      CDSM_GL(glProgramUniform4f(p, 7 + r, model.m[r][0], model.m[r][1], model.m[r][2], model.m[r][3]));
    CDSM_GL(glProgramUniform1ui(p, 10, mirrored ? 1u : 0u));
    CDSM_GL(glProgramUniform1ui(p, 11, mode));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.vertex_buffer));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, index_bytes > 0 ? mesh_indices.id() : media.id()));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, vertices.id()));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, normals.id()));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, mesh_box.id()));
    CDSM_GL(glUseProgram(p));
    CDSM_GL(glDispatchCompute((m.triangles + 63) / 64, 1, 1));
    CDSM_GL(glUseProgram(0));
  }

  // A view's rows [r0, r1), counted at counter `base` of its batch; its
  // first fragment in its view's lists.
  struct Band {
    uint32_t job;
    int32_t r0, r1;
    uint64_t base;
    uint64_t view_first = 0;
  };
  std::vector<uint64_t> view_done;       // per job: its fragments in the batches so far
  std::vector<OffsetBand> offset_bands;  // a batch's, for the offsets sink
  uint64_t offsets_generation = 1;       // a new offsets buffer object: a new generation
  std::vector<Band> bands;               // of the current call
  std::vector<uint32_t> batch_offsets;   // a batch's offsets read back (+ total, overflow flag)
  std::vector<Piece> pieces;             // what the pool holds since its last hand-over
  std::vector<Fragment> staging;         // a pool of several pieces read back at once
  uint32_t drawn_job = ~0u;              // the job whose draws and view are set

  // Draws and view of job j, set when they are not yet.
  void draw_setup(Span<const Job> jobs, uint32_t j) {
    if (drawn_job != j) {
      build_draws(jobs[j].mask);
      set_view(jobs[j].view);
      drawn_job = j;
    }
    bind_pipeline(jobs[j].view.width, jobs[j].view.height);
  }

  void rasterize(Span<const Job> jobs, FragmentBuffers* outs, const TileSink* sink, const OffsetsSink* offsets_sink,
                 const BatchSink* batch_sink = nullptr);
  void rasterize_batch_unchecked(Span<const Job> jobs, const BatchSink& sink, size_t b0, size_t b1, uint64_t n);
  void count_and_scan(Span<const Job> jobs, size_t b0, size_t b1, uint64_t n);
  std::vector<ShadowBackend::GlPart> parts;  // a batch's, for the batch sink
  void rasterize_batch(Span<const Job> jobs, FragmentBuffers* outs, const TileSink* sink,
                       const OffsetsSink* offsets_sink, size_t b0, size_t b1, uint64_t n);
  void flush(FragmentBuffers* outs, const TileSink* sink);
  [[noreturn]] void report_overflow(Span<const Job> jobs, size_t b0, size_t b1, uint64_t n);

  // CDSM_GL_SYNC: passes wait for what came before them, so a fault that
  // goes away with it is one of synchronization (the GL analogue of
  // CDSM_CUDA_SYNC). "1" or "all": glMemoryBarrier(all) + glFinish at every
  // point; "barrier": the barrier alone at every point; else a comma list
  // of the points that finish: clear (after the counts are cleared), count
  // (after the count pass), fill (after each fill tile).
  const std::string sync_mode = [] {
    const char* e = std::getenv("CDSM_GL_SYNC");
    return std::string(e && std::strcmp(e, "0") != 0 ? e : "");
  }();
  void sync(const char* point) {
    if (sync_mode.empty()) return;
    const bool all = sync_mode == "1" || sync_mode == "all";
    if (sync_mode == "barrier") {
      CDSM_GL(glMemoryBarrier(GL_ALL_BARRIER_BITS));
      return;
    }
    if (!all && ("," + sync_mode + ",").find("," + std::string(point) + ",") == std::string::npos) return;
    CDSM_GL(glMemoryBarrier(GL_ALL_BARRIER_BITS));
    CDSM_GL(glFinish());
  }
};

void FragmentRasterizer::Impl::rasterize(Span<const Job> jobs, FragmentBuffers* outs, const TileSink* sink,
                                         const OffsetsSink* offsets_sink, const BatchSink* batch_sink) {
  auto t0 = std::chrono::steady_clock::now();
  context.make_current();
  const Limits& lim = context.limits();
  const uint64_t band_pixels = max_band_pixels();
  stats.tiles = 0;
  stats.bands = 0;
  stats.scans = 0;
  stats.flushes = 0;
  stats.fragments = 0;
  // Every view checked before any GL work; then its bands of rows (one
  // unless its counters exceed one SSBO), batched while they fit one.
  bands.clear();
  for (uint32_t j = 0; j < uint32_t(jobs.size()); ++j) {
    const PinholeView& view = jobs[j].view;
    const int32_t W = view.width, H = view.height;
    if (W <= 0 || H <= 0) throw Error(kWhere, "view of " + std::to_string(W) + "x" + std::to_string(H) + " pixels");
    if (W > std::min(lim.max_framebuffer_width, lim.max_viewport_width) ||
        H > std::min(lim.max_framebuffer_height, lim.max_viewport_height))
      throw Error(kWhere, "view of " + std::to_string(W) + "x" + std::to_string(H) +
                              " pixels exceeds this GL's framebuffer/viewport limit of " +
                              std::to_string(std::min(lim.max_framebuffer_width, lim.max_viewport_width)) + "x" +
                              std::to_string(std::min(lim.max_framebuffer_height, lim.max_viewport_height)));
    if (uint64_t(W) > band_pixels)
      throw Error(kWhere, "one row of " + std::to_string(W) + " pixels exceeds the counter buffer limit");
    const int32_t band_rows =
        int32_t(std::max<uint64_t>(1, std::min<uint64_t>(uint64_t(H), band_pixels / uint64_t(W))));
    for (int32_t r0 = 0; r0 < H; r0 += band_rows) bands.push_back({j, r0, std::min(H, r0 + band_rows), 0});
  }
  view_done.assign(jobs.size(), 0);
  for (uint32_t j = 0; j < uint32_t(jobs.size()); ++j) {
    FragmentBuffers& out = outs[j];
    out.width = jobs[j].view.width;
    out.height = jobs[j].view.height;
    // (with an offsets sink the offsets go there: `out` keeps the total;
    // with a batch sink the host has neither)
    out.offsets.resize(batch_sink ? 0 : offsets_sink ? 1 : uint64_t(out.width) * uint64_t(out.height) + 1);
    out.fragments.clear();
  }
  drawn_job = ~0u;
  StateReset reset;
  for (size_t b0 = 0; b0 < bands.size();) {
    uint64_t n = 0;
    size_t b1 = b0;
    for (; b1 < bands.size(); ++b1) {
      const uint64_t band_n = uint64_t(jobs[bands[b1].job].view.width) * uint64_t(bands[b1].r1 - bands[b1].r0);
      if (b1 > b0 && n + band_n > band_pixels) break;
      bands[b1].base = n;
      n += band_n;
    }
    if (batch_sink)
      rasterize_batch_unchecked(jobs, *batch_sink, b0, b1, n);
    else
      rasterize_batch(jobs, outs, sink, offsets_sink, b0, b1, n);
    b0 = b1;
  }
  if (!batch_sink)
    for (uint32_t j = 0; j < uint32_t(jobs.size()); ++j) outs[j].offsets.back() = uint32_t(view_done[j]);
  stats.pool_bytes = pool.capacity();
  stats.gpu_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Bands [b0, b1) (n counters in all) counted into the counter buffer and
// scanned into the offsets buffer, the scan's carry flag after the total
// (offsets n + 1); nothing read.
void FragmentRasterizer::Impl::count_and_scan(Span<const Job> jobs, size_t b0, size_t b1, uint64_t n) {
  counts.reserve(n * 4);
  if (offsets.capacity() < (n + 2) * 4) {  // a new buffer object: a sink that mapped the old one lets go first
    if (release_hook && offsets.id() != 0) release_hook(offsets.id());
    offsets.reserve((n + 2) * 4);
    ++offsets_generation;
  }
  counts.clear(n * 4);
  sync("clear");
  for (size_t b = b0; b < b1; ++b) {
    const Band& band = bands[b];
    draw_setup(jobs, band.job);
    CDSM_GL(glProgramUniform1i(program.id(), kPass, 0));
    CDSM_GL(glProgramUniform1i(program.id(), kRow0, band.r0));
    CDSM_GL(glProgramUniform1ui(program.id(), kCountBase, GLuint(band.base)));
    scissor(jobs[band.job].view.height, band.r0, band.r1, 0, jobs[band.job].view.width);
    draw();
    ++stats.bands;
  }
  sync("count");
  scan.exclusive_scan(counts, offsets, n);
  scan.write_overflow_flag(offsets, n + 1);
}

// Bands [b0, b1) (n counters in all): counted, scanned, read back once;
// filled into the pool, which is handed on each time it is full.
void FragmentRasterizer::Impl::rasterize_batch(Span<const Job> jobs, FragmentBuffers* outs, const TileSink* sink,
                                               const OffsetsSink* offsets_sink, size_t b0, size_t b1, uint64_t n) {
  count_and_scan(jobs, b0, b1, n);
  // The batch offsets and the overflow flag after them, in one read.
  batch_offsets.resize(n + 2);
  offsets.download(batch_offsets.data(), (n + 2) * 4);
  ++stats.scans;
  if (batch_offsets[n + 1] != 0) report_overflow(jobs, b0, b1, n);
  const uint64_t batch_total = batch_offsets[n];
  auto off = [&](uint64_t i) { return uint64_t(batch_offsets[i]); };
  // Each band's offsets into its view's lists, which count on from the
  // view's earlier bands: written here, or re-based where the sink puts
  // them (the band's values and the next band's start, shifted).
  offset_bands.clear();
  for (size_t b = b0; b < b1; ++b) {
    Band& band = bands[b];
    const FragmentBuffers& out = outs[band.job];
    const uint64_t W = uint64_t(out.width), band_n = W * uint64_t(band.r1 - band.r0);
    const uint64_t before = view_done[band.job], band_total = off(band.base + band_n) - off(band.base);
    if (before + band_total > 0xffffffffull)
      throw Error(kWhere, "more than 2^32-1 fragments in a " + std::to_string(out.width) + "x" +
                              std::to_string(out.height) + " view (offsets are 32-bit)");
    const uint32_t shift = uint32_t(before) - batch_offsets[band.base];  // modulo 2^32
    band.view_first = before;
    if (offsets_sink) {
      offset_bands.push_back({band.job, uint64_t(band.r0) * W, band_n, band.base, shift});
    } else {
      uint32_t* dst = outs[band.job].offsets.data() + uint64_t(band.r0) * W;
      for (uint64_t i = 0; i < band_n; ++i) dst[i] = batch_offsets[band.base + i] + shift;
    }
    view_done[band.job] = before + band_total;
    stats.fragments += band_total;
  }
  if (offsets_sink)
    (*offsets_sink)(offset_bands.data(), offset_bands.size(), offsets.id(), offsets.capacity(), offsets_generation);
  if (!sink)
    for (size_t b = b0; b < b1; ++b) outs[bands[b].job].fragments.resize(view_done[bands[b].job]);

  // Fill tiles: whole rows while they fit the pool cap, else row pieces;
  // into the pool one after another, handed on when the next does not fit.
  const uint64_t cap_fragments = max_pool_bytes() / kFragmentBytes;
  if (batch_total > 0) ensure_pool(std::min(batch_total, cap_fragments));
  const uint64_t pool_fragments = pool.capacity() / kFragmentBytes;
  uint64_t pool_first = 0;  // batch offset of the pool's first fragment
  pieces.clear();
  for (size_t b = b0; b < b1; ++b) {
    const Band& band = bands[b];
    const int32_t W = jobs[band.job].view.width, H = jobs[band.job].view.height;
    const uint64_t band_n = uint64_t(W) * uint64_t(band.r1 - band.r0);
    const uint64_t view_first = band.view_first;  // the band's first fragment in its view's lists
    const uint64_t band_first = off(band.base);
    if (off(band.base + band_n) == band_first) continue;
    draw_setup(jobs, band.job);
    CDSM_GL(glProgramUniform1i(program.id(), kPass, 1));
    CDSM_GL(glProgramUniform1i(program.id(), kRow0, band.r0));
    CDSM_GL(glProgramUniform1ui(program.id(), kCountBase, GLuint(band.base)));
    CDSM_GL(glProgramUniform1ui(program.id(), kPoolSize, GLuint(std::min<uint64_t>(pool_fragments, 0xffffffffu))));
    auto boff = [&](uint64_t i) { return off(band.base + i); };  // batch offset of band pixel i
    uint64_t p = 0;
    while (p < band_n) {
      uint64_t end;
      int32_t row_a = band.r0 + int32_t(p / uint64_t(W));
      int32_t row_b = row_a + 1, col_a = int32_t(p % uint64_t(W)), col_b = W;
      if (p % uint64_t(W) == 0 && boff(p + uint64_t(W)) - boff(p) <= cap_fragments) {
        end = p + uint64_t(W);
        while (end < band_n && boff(end + uint64_t(W)) - boff(p) <= cap_fragments) end += uint64_t(W);
        row_b = band.r0 + int32_t(end / uint64_t(W));
      } else {
        // Pieces of one row: a row alone holds more than the pool cap.
        uint64_t row_end = (p / uint64_t(W) + 1) * uint64_t(W);
        end = p;
        while (end < row_end && boff(end + 1) - boff(p) <= cap_fragments) ++end;
        if (end == p)
          throw Error(kWhere, "pixel (" + std::to_string(p % uint64_t(W)) + ", " + std::to_string(row_a) + ") has " +
                                  std::to_string(boff(p + 1) - boff(p)) + " fragments, more than the pool holds");
        col_b = int32_t(end % uint64_t(W) == 0 ? uint64_t(W) : end % uint64_t(W));
      }
      ++stats.tiles;
      const uint64_t tile_fragments = boff(end) - boff(p);
      if (tile_fragments > 0) {
        if (boff(end) - pool_first > pool_fragments) {
          flush(outs, sink);
          pool_first = boff(p);
        }
        CDSM_GL(glProgramUniform1ui(program.id(), kFragBase, GLuint(pool_first)));
        scissor(H, row_a, row_b, col_a, col_b);
        draw();
        sync("fill");
        const uint64_t first = view_first + (boff(p) - band_first);
        if (!pieces.empty() && pieces.back().view == band.job && pieces.back().first + pieces.back().count == first)
          pieces.back().count += tile_fragments;
        else
          pieces.push_back({band.job, first, tile_fragments, boff(p) - pool_first});
      }
      p = end;
    }
  }
  flush(outs, sink);
  if (context.debug()) verify_cursors_consumed(n);
}

// Bands [b0, b1) (n counters in all) counted, scanned and filled into the
// pool as it is, nothing read back: a fill writes no fragment past the pool
// (the shader's guard), and the sink gets the batch where GL left it, each
// view's bands as one part.
void FragmentRasterizer::Impl::rasterize_batch_unchecked(Span<const Job> jobs, const BatchSink& sink, size_t b0,
                                                         size_t b1, uint64_t n) {
  count_and_scan(jobs, b0, b1, n);
  ++stats.scans;
  parts.clear();
  for (size_t b = b0; b < b1; ++b) {
    const Band& band = bands[b];
    const uint64_t W = uint64_t(jobs[band.job].view.width), band_n = W * uint64_t(band.r1 - band.r0);
    if (!parts.empty() && parts.back().view == band.job)
      parts.back().count += band_n;
    else
      parts.push_back({band.job, uint64_t(band.r0) * W, band_n, band.base});
  }
  const uint64_t pool_fragments = std::min<uint64_t>(pool.capacity() / kFragmentBytes, 0xffffffffu);
  for (size_t b = b0; b < b1; ++b) {
    const Band& band = bands[b];
    draw_setup(jobs, band.job);
    CDSM_GL(glProgramUniform1i(program.id(), kPass, 1));
    CDSM_GL(glProgramUniform1i(program.id(), kRow0, band.r0));
    CDSM_GL(glProgramUniform1ui(program.id(), kCountBase, GLuint(band.base)));
    CDSM_GL(glProgramUniform1ui(program.id(), kFragBase, 0u));
    CDSM_GL(glProgramUniform1ui(program.id(), kPoolSize, GLuint(pool_fragments)));
    scissor(jobs[band.job].view.height, band.r0, band.r1, 0, jobs[band.job].view.width);
    draw();
    sync("fill");
    ++stats.tiles;
  }
  CDSM_GL(glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT));
  ++stats.flushes;
  ShadowBackend::GlBatch batch;
  batch.parts = parts.data();
  batch.n = parts.size();
  batch.offsets_buffer = offsets.id();
  batch.offsets_bytes = offsets.capacity();
  batch.offsets_generation = offsets_generation;
  batch.total_at = n;
  batch.pool_buffer = pool.id();
  batch.pool_bytes = pool.capacity();
  batch.pool_generation = pool_generation;
  batch.pool_fragments = pool_fragments;
  sink(batch);
  if (context.debug()) verify_cursors_consumed(n);
}

// The pool's pieces to their lists: one read-back into the host's lists, or
// one call of the sink.
void FragmentRasterizer::Impl::flush(FragmentBuffers* outs, const TileSink* sink) {
  if (pieces.empty()) return;
  CDSM_GL(glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT));
  ++stats.flushes;
  if (sink) {
    (*sink)(pieces.data(), pieces.size(), pool.id(), pool.capacity(), pool_generation);
  } else if (pieces.size() == 1) {
    const Piece& q = pieces[0];
    pool.download(outs[q.view].fragments.data() + q.first, q.count * kFragmentBytes, q.at * kFragmentBytes);
  } else {
    const uint64_t used = pieces.back().at + pieces.back().count;
    staging.resize(used);
    pool.download(staging.data(), used * kFragmentBytes);
    for (const Piece& q : pieces)
      std::memcpy(outs[q.view].fragments.data() + q.first, staging.data() + q.at, q.count * kFragmentBytes);
  }
  pieces.clear();
}

// Says whether a batch's counts overflow 32 bits or its scan does (a driver
// or synchronization fault): the counts summed on the host. Throws.
void FragmentRasterizer::Impl::report_overflow(Span<const Job> jobs, size_t b0, size_t b1, uint64_t n) {
  CDSM_GL(glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT));
  std::vector<uint32_t> c(n);
  counts.download(c.data(), n * 4);
  uint64_t sum = 0, largest = 0, at = 0;
  for (uint64_t i = 0; i < n; ++i) {
    sum += c[i];
    if (c[i] > largest) largest = c[i], at = i;
  }
  size_t b = b0;
  while (b + 1 < b1 && bands[b + 1].base <= at) ++b;
  const PinholeView& v = jobs[bands[b].job].view;
  const uint64_t in_band = at - bands[b].base;
  const std::string where = std::to_string(b1 - b0) + " band(s) of " + std::to_string(jobs.size()) +
                            " view(s): the counts sum to " + std::to_string(sum) + " (largest " +
                            std::to_string(largest) + " at pixel (" + std::to_string(in_band % uint64_t(v.width)) +
                            ", " + std::to_string(bands[b].r0 + int64_t(in_band / uint64_t(v.width))) + ") of a " +
                            std::to_string(v.width) + "x" + std::to_string(v.height) + " view)";
  if (sum > 0xffffffffull) throw Error(kWhere, "more than 2^32-1 fragments in one batch of views: " + where);
  throw Error(kWhere, "internal: the prefix sum reported a carry out of 32 bits that the counts do not have; " + where);
}

FragmentRasterizer::FragmentRasterizer(Context& context) : FragmentRasterizer(context, RasterOptions{}) {}

FragmentRasterizer::FragmentRasterizer(Context& context, const RasterOptions& options) {
  context.make_current();
  impl_ = std::make_unique<Impl>(context, options);
}

FragmentRasterizer::~FragmentRasterizer() = default;

void FragmentRasterizer::upload_scene(Span<const Vec3> tri_vertices, Span<const uint32_t> tri_object,
                                      Span<const ObjectData> objects) {
  impl_->upload(tri_vertices, tri_object, objects);
}

void FragmentRasterizer::update_triangles(uint64_t first_tri, Span<const Vec3> tri_vertices) {
  impl_->update_triangles(first_tri, tri_vertices);
}

void FragmentRasterizer::gather_mesh(uint64_t first_tri, const AppMesh& mesh, const Mat4& model, bool mirrored) {
  Impl& I = *impl_;
  if (first_tri + mesh.triangles > I.tri_count)
    throw Error(kWhere, "gather_mesh: triangles [" + std::to_string(first_tri) + ", " +
                            std::to_string(first_tri + mesh.triangles) + ") are not within the " +
                            std::to_string(I.tri_count) + " uploaded");
  if (mesh.triangles == 0) return;
  I.mesh_box.reserve(24);  // (bound, unused when gathering)
  I.dispatch_gather(mesh, first_tri, model, mirrored, 0);
  // The draws read the vertices as attributes and the normals as storage.
  CDSM_GL(glMemoryBarrier(GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT));
}

Box3 FragmentRasterizer::mesh_bounds(const AppMesh& mesh, const Mat4& model) {
  Impl& I = *impl_;
  Box3 box;
  if (mesh.triangles == 0) return box;
  // Min keys start at the largest, max keys at the smallest.
  const uint32_t start[6] = {~0u, ~0u, ~0u, 0u, 0u, 0u};
  I.context.make_current();
  I.mesh_box.reserve(24);
  I.mesh_box.upload(start, sizeof start);
  I.dispatch_gather(mesh, 0, model, false, 1);
  CDSM_GL(glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT));
  uint32_t key[6];
  I.mesh_box.download(key, sizeof key);
  if (key[0] == ~0u) return box;  // no finite triangle
  const auto value = [](uint32_t k) {
    const uint32_t u = (k & 0x80000000u) != 0u ? k & 0x7fffffffu : ~k;
    float f;
    std::memcpy(&f, &u, 4);
    return f;
  };
  box.grow(Vec3{value(key[0]), value(key[1]), value(key[2])});
  box.grow(Vec3{value(key[3]), value(key[4]), value(key[5])});
  return box;
}

uint64_t FragmentRasterizer::last_upload_bytes() const { return impl_->uploaded; }

uint64_t FragmentRasterizer::scene_buffer_bytes() const {
  return impl_->vertices.capacity() + impl_->normals.capacity() + impl_->media.capacity();
}

void FragmentRasterizer::rasterize(const PinholeView& view, ObjectMask mask, FragmentBuffers& out) {
  const Job job{view, mask};
  impl_->rasterize({&job, 1}, &out, nullptr, nullptr);
}

void FragmentRasterizer::rasterize(Span<const Job> jobs, FragmentBuffers* outs) {
  impl_->rasterize(jobs, outs, nullptr, nullptr);
}

void FragmentRasterizer::rasterize(Span<const Job> jobs, FragmentBuffers* outs, const TileSink& sink,
                                   const OffsetsSink& offsets) {
  impl_->rasterize(jobs, outs, &sink, &offsets);
}

bool FragmentRasterizer::rasterize_unchecked(Span<const Job> jobs, FragmentBuffers* outs, uint64_t pool_fragments,
                                             const BatchSink& sink) {
  Impl& I = *impl_;
  I.context.make_current();
  if (pool_fragments > I.max_pool_bytes() / kFragmentBytes) return false;
  if (pool_fragments > 0) I.ensure_pool(pool_fragments);
  I.rasterize(jobs, outs, nullptr, nullptr, &sink);
  return true;
}

void FragmentRasterizer::set_release_hook(std::function<void(uint32_t)> hook) { impl_->release_hook = std::move(hook); }

const RasterStats& FragmentRasterizer::stats() const { return impl_->stats; }
const RasterOptions& FragmentRasterizer::options() const { return impl_->options; }

}  // namespace cdsm::gl
