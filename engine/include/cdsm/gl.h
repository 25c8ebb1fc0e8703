// OpenGL integration: a headless context cdsm can make for an application
// that has none (a window for tools: cdsm/gl_window.h), the
// description of a mesh that lives in the application's own GL buffers, and
// the GLSL include. A shadow system created with
// SystemOptions::gl_context = GlContextUse::Application works on the
// application's current context instead of its own (cdsm/shadow_system.h).
//
// No GL header is needed to include this one: GL names and enums are plain
// integers here.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "cdsm/error.h"
#include "cdsm/tags.h"

namespace cdsm {

// An OpenGL 4.5 core context made by cdsm. Current on the creating thread
// after creation.
class GlContext {
 public:
  // Headless, no surface: an EGL device (a GPU on a server) or Mesa's
  // surfaceless platform (llvmpipe without a GPU). nullptr + `*reason`
  // (every attempt and why it failed) when none can be made.
  static std::unique_ptr<GlContext> create_headless(std::string* reason = nullptr);
  virtual ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void make_current();
  void release();
  // "EGL surfaceless (Mesa) | llvmpipe (LLVM 15.0.6, 256 bits) | 4.5 (Core Profile) Mesa 22.3.6"
  const std::string& description() const;
  // GL_MAX_SHADER_STORAGE_BLOCK_SIZE, bytes.
  int64_t max_storage_block_bytes() const;

  struct Impl;

 protected:
  explicit GlContext(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// A triangle mesh in the application's GL buffers. The shadow system reads
// it back once (ShadowSystem::read_gl_mesh), when it is registered or
// edited, never per frame: the BVH, the closed-mesh check and the CPU
// kernels need the triangles on the host. Counts and offsets are checked
// against the buffers' sizes.
struct GlMeshSource {
  uint32_t vertex_buffer = 0;  // GL buffer name holding positions, 3 floats each (object space)
  uint64_t vertex_offset = 0;  // bytes from the buffer's start to the first position
  uint32_t vertex_stride = 0;  // bytes between positions; 0: tightly packed (12)
  uint32_t vertex_count = 0;
  uint32_t index_buffer = 0;     // 0: not indexed (vertex_count / 3 triangles)
  uint64_t index_offset = 0;     // bytes to the first index
  uint32_t index_type = 0x1405;  // GL_UNSIGNED_INT (0x1405), GL_UNSIGNED_SHORT (0x1403), GL_UNSIGNED_BYTE (0x1401)
  uint32_t index_count = 0;      // a multiple of 3
  uint32_t normal_buffer = 0;    // optional shading normals, 3 floats per vertex; 0: none
  uint64_t normal_offset = 0;
  uint32_t normal_stride = 0;  // 0: tightly packed

  // Named construction, counts as GL gives them (GLsizei converts without
  // narrowing; a negative or too large count is a cdsm::Error):
  //   auto src = cdsm::GlMeshSource::indexed(vbo, 24, vertex_count, ibo, GL_UNSIGNED_INT, index_count)
  //                  .positions_at(0)
  //                  .normals(vbo, 12, 24);  // interleaved: normal after position
  static GlMeshSource indexed(uint32_t vertex_buffer, int64_t vertex_stride, int64_t vertex_count,
                              uint32_t index_buffer, uint32_t index_type, int64_t index_count) {
    GlMeshSource s;
    s.vertex_buffer = vertex_buffer;
    s.vertex_stride = count32(vertex_stride, "vertex_stride");
    s.vertex_count = count32(vertex_count, "vertex_count");
    s.index_buffer = index_buffer;
    s.index_type = index_type;
    s.index_count = count32(index_count, "index_count");
    return s;
  }
  // Triangles as consecutive vertex triples (no index buffer).
  static GlMeshSource unindexed(uint32_t vertex_buffer, int64_t vertex_stride, int64_t vertex_count) {
    return indexed(vertex_buffer, vertex_stride, vertex_count, 0, 0x1405, 0);
  }
  GlMeshSource& positions_at(uint64_t byte_offset) {
    vertex_offset = byte_offset;
    return *this;
  }
  GlMeshSource& indices_at(uint64_t byte_offset) {
    index_offset = byte_offset;
    return *this;
  }
  GlMeshSource& normals(uint32_t buffer, uint64_t byte_offset, int64_t stride) {
    normal_buffer = buffer;
    normal_offset = byte_offset;
    normal_stride = count32(stride, "normal_stride");
    return *this;
  }

 private:
  static uint32_t count32(int64_t v, const char* what) {
    if (v < 0 || v > int64_t(0xffffffffu))
      throw Error("GlMeshSource", std::string(what) + " must be within [0, 2^32 - 1], got " + std::to_string(v));
    return uint32_t(v);
  }
};

// The GL buffer names of a frame's maps after ShadowSystem::update(), one
// per storage block of cdsm.glsl (binding CDSM_BINDING_BASE + the order
// below). Valid until the next update(), which may replace them when they
// grow.
struct GlMapBuffers {
  uint32_t frame = 0;            // CdsmFrame: lookup settings, lights, map headers
  uint32_t texels = 0;           // CdsmTexels: per-texel {offset, count}
  uint32_t nodes = 0;            // CdsmNodes: scalar nodes {z, alpha}
  uint32_t chunks = 0;           // CdsmChunks: chunked layout slots
  uint32_t rgb_texels = 0;       // CdsmRgbTexels
  uint32_t rgb_nodes = 0;        // CdsmRgbNodes: {z, r, g, b}
  uint32_t rgb_chunks = 0;       // CdsmRgbChunks
  uint32_t tags = 0;             // CdsmTags: the grey pool's surface tags, 16 bits per slot
  uint32_t rgb_tags = 0;         // CdsmRgbTags
  int default_binding_base = 8;  // CDSM_BINDING_BASE when the shader does not define it
  // The node layout of the maps in these buffers (the settings' DsmLayout;
  // cdsm_layout in the shader). A shader compiled with `#define CDSM_LAYOUT
  // n` (n = uint32_t(layout)) before the include reads only that layout,
  // and needs recompiling when this changes (cdsm.glsl, "Shader variants").
  DsmLayout layout = DsmLayout::Packed;
};

// The text of cdsm.glsl (installed as share/cdsm/shaders/cdsm.glsl) as this library was built with it
// (embedded), to paste after the application shader's #version line.
// Throws cdsm::Error in a build without OpenGL.
std::string glsl_include();

}  // namespace cdsm
