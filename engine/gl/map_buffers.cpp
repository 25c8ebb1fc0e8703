#include "gl/map_buffers.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <string>

#include "cdsm/error.h"
#include "gl/context.h"

namespace cdsm::gl {

namespace {

constexpr uint64_t kMinBytes = 16;  // a zero-size buffer cannot be bound

std::string mib(uint64_t bytes) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f MiB", double(bytes) / (1024.0 * 1024.0));
  return b;
}

}  // namespace

std::string storage_block_shortfall(const Limits& l) {
  struct Limit {
    int32_t value;
    const char* name;
  };
  const Limit limits[] = {{l.max_fragment_ssbo_blocks, "GL_MAX_FRAGMENT_SHADER_STORAGE_BLOCKS"},
                          {l.max_compute_ssbo_blocks, "GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS"},
                          {l.max_combined_ssbo_blocks, "GL_MAX_COMBINED_SHADER_STORAGE_BLOCKS"},
                          {l.max_ssbo_bindings, "GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS"}};
  std::string why;
  for (const Limit& x : limits)
    if (x.value < kMapBlocks) why += std::string(why.empty() ? "" : "; ") + x.name + " is " + std::to_string(x.value);
  if (why.empty()) return why;
  return "cdsm.glsl needs " + std::to_string(kMapBlocks) +
         " shader storage blocks in the shader that includes it, and this context allows fewer: " + why;
}

const char* block_name(MapBlock b) {
  switch (b) {
    case MapBlock::Frame: return "CdsmFrame";
    case MapBlock::Texels: return "CdsmTexels";
    case MapBlock::Nodes: return "CdsmNodes";
    case MapBlock::Chunks: return "CdsmChunks";
    case MapBlock::RgbTexels: return "CdsmRgbTexels";
    case MapBlock::RgbNodes: return "CdsmRgbNodes";
    case MapBlock::RgbChunks: return "CdsmRgbChunks";
    case MapBlock::Tags: return "CdsmTags";
    case MapBlock::RgbTags: return "CdsmRgbTags";
    case MapBlock::Count: break;
  }
  return "?";
}

MapBuffers::MapBuffers(Context& context, uint64_t max_block_bytes) : context_(context) {
  if (const std::string why = storage_block_shortfall(context.limits()); !why.empty())
    throw Error("GL context (" + context.description() + ")", why);
  const uint64_t limit = uint64_t(std::max<int64_t>(context.limits().max_ssbo_block_size, 0));
  max_block_ = max_block_bytes ? std::min(max_block_bytes, limit) : limit;
  for (int b = 0; b < kMapBlocks; ++b) {
    buffers_[b] = Buffer(std::string("cdsm.maps.") + block_name(MapBlock(b)));
    buffers_[b].reserve(kMinBytes);
    renew(b);
  }
}

MapBuffers::~MapBuffers() {
  try {
    context_.make_current();  // the names belong to it
  } catch (...) {
  }
  for (int b = 0; b < kMapBlocks; ++b) release(b);  // before the members delete them
}

void MapBuffers::release(int b) {
  const GLuint name = buffers_[b].id();
  if (name == 0 || !release_hook_) return;
  try {
    release_hook_(name);
  } catch (...) {  // a hook that throws must not keep the buffer alive or leak it
  }
}

void MapBuffers::renew(int b) {
  static std::atomic<uint64_t> next{1};  // unique across instances: names may be reused by GL
  generation_[b] = next.fetch_add(1);
}

GlMapWrite MapBuffers::prepare_array(int b, uint64_t bytes, uint64_t from, MapUploadStats& st) {
  if (bytes > max_block_)
    throw Error(std::string("GL map buffers: ") + block_name(MapBlock(b)),
                "the frame's maps need " + mib(bytes) + " in one storage block, more than this GL implementation's " +
                    "largest (" + mib(max_block_) +
                    ", GL_MAX_SHADER_STORAGE_BLOCK_SIZE): lower the map resolution or " +
                    "the number of clusters, or raise epsilon");
  Buffer& buf = buffers_[b];
  GlMapWrite w;
  w.array = StorageArray(b - int(MapBlock::Texels));  // the blocks after the frame block, in storage order
  from = std::min({from, used_[b], bytes});
  const uint64_t want = (std::max(bytes, kMinBytes) + 3) & ~uint64_t(3);  // whole words
  if (buf.capacity() > 2 * want && bytes < used_[b]) from = 0;            // shrunk to under half: re-allocated
  if (from == 0) {
    if (want > buf.capacity() || buf.capacity() > 2 * want) {
      release(b);
      buf.destroy();
      buf.reserve(want);
      renew(b);
    }
  } else if (bytes > buf.capacity()) {  // grow, keeping the contents (a GL-side copy)
    const uint64_t grown =
        (std::min(std::max(bytes, buf.capacity() + buf.capacity() / 2), std::max(max_block_, bytes)) + 3) &
        ~uint64_t(3);
    Buffer next(buf.label());
    next.reserve(grown);
    CDSM_GL(glCopyNamedBufferSubData(buf.id(), next.id(), 0, 0, GLsizeiptr(from)));
    st.copy_bytes += from;
    release(b);
    buf = std::move(next);  // deletes the old buffer object
    renew(b);
  }
  w.offset = from;
  w.bytes = bytes - from;
  used_[b] = bytes;
  w.gl_buffer = buf.id();
  w.gl_buffer_bytes = buf.capacity();
  w.gl_buffer_generation = generation_[b];
  return w;
}

MapUploadStats MapBuffers::sync(const ShadowView& view, uint64_t epoch, const KeptBytes& kept,
                                const DeviceWriter& device) {
  context_.make_current();
  MapUploadStats st;
  const DsmStorage& s = view.storage;
  // Per array, the bytes the buffers hold that are still the storage's.
  uint64_t from[kStorageArrays];
  const bool whole = !synced_ || s.layout != layout_ || epoch_ == 0;
  for (int a = 0; a < kStorageArrays; ++a) from[a] = whole ? 0 : ~uint64_t(0);
  if (!whole && epoch != epoch_) {
    if (kept)
      kept(epoch_, from);
    else
      for (int a = 0; a < kStorageArrays; ++a) from[a] = 0;
  }
  st.full = std::all_of(from, from + kStorageArrays, [](uint64_t f) { return f == 0; });
  const void* data[kMapBlocks] = {};
  uint64_t bytes[kMapBlocks] = {};
  for (int b = int(MapBlock::Texels); b < kMapBlocks; ++b) {
    const StorageBytes array = storage_bytes(s, StorageArray(b - int(MapBlock::Texels)));
    data[b] = array.data;
    bytes[b] = array.bytes;
  }
  // The same ranges on both paths: what changed since the last sync.
  GlMapWrite writes[kMapBlocks];
  int count = 0;
  for (int b = int(MapBlock::Texels); b < kMapBlocks; ++b) {
    const GlMapWrite w = prepare_array(b, bytes[b], from[b - int(MapBlock::Texels)], st);
    if (w.bytes > 0) writes[count++] = w;
  }
  if (device) {
    try {
      if (count > 0) device(writes, count);
    } catch (...) {
      epoch_ = 0;  // the buffers may miss these ranges: the next sync writes every array
      throw;
    }
    for (int i = 0; i < count; ++i) st.device_bytes += writes[i].bytes;
  } else {
    for (int i = 0; i < count; ++i) {
      const GlMapWrite& w = writes[i];
      const int b = int(w.array) + int(MapBlock::Texels);
      buffers_[b].upload(static_cast<const unsigned char*>(data[b]) + w.offset, w.bytes, w.offset);
      st.upload_bytes += w.bytes;
    }
  }
  epoch_ = epoch;
  layout_ = s.layout;
  synced_ = true;

  // The frame block: settings, lights, map headers.
  if (view.lights.size() > uint64_t(kMaxLights))
    throw Error("GL map buffers", "more than " + std::to_string(kMaxLights) + " lights");
  FrameBlockHeader h{};
  h.layout = s.layout;
  h.layers = s.layers;
  h.filtering = view.filtering ? 1u : 0u;
  h.receiver = view.receiver;
  h.penumbra = view.penumbra;
  h.penumbra_taps = view.penumbra_taps;
  h.bias_constant = view.bias_constant;
  h.bias_slope = view.bias_slope;
  h.light_count = uint32_t(view.lights.size());
  h.map_count = uint32_t(view.maps.size());
  for (uint64_t i = 0; i < view.lights.size(); ++i) h.lights[i] = view.lights[i];
  for (const DsmMap& m : view.maps)
    if (m.texel_offset > 0xffffffffull) throw Error("GL map buffers", "a map's texel offset does not fit 32 bits");
  std::vector<unsigned char> frame(sizeof h + view.maps.size() * sizeof(DsmMap));
  std::memcpy(frame.data(), &h, sizeof h);
  if (!view.maps.empty()) std::memcpy(frame.data() + sizeof h, view.maps.data(), view.maps.size() * sizeof(DsmMap));
  if (frame != frame_) {
    const uint64_t bytes = frame.size();
    Buffer& buf = buffers_[int(MapBlock::Frame)];
    if (bytes > buf.capacity() || buf.capacity() > 2 * bytes) {
      release(int(MapBlock::Frame));
      buf.destroy();
      buf.reserve(bytes);
    }
    buf.upload(frame.data(), bytes, 0);
    st.upload_bytes += bytes;
    used_[int(MapBlock::Frame)] = bytes;
    frame_ = std::move(frame);
  }
  for (int b = 0; b < kMapBlocks; ++b) {
    st.allocated_bytes += buffers_[b].capacity();
    st.used_bytes += used_[b];
  }
  return st;
}

void MapBuffers::bind(GLuint program) const {
  context_.make_current();
  const std::string where = "GL program " + std::to_string(program);
  if (program == 0 || !glIsProgram(program)) throw Error(where, "is not a GL program name of the current context");
  GLint linked = GL_FALSE;
  CDSM_GL(glGetProgramiv(program, GL_LINK_STATUS, &linked));
  if (!linked) throw Error(where, "is not linked");
  GLint binding[kMapBlocks];
  std::string missing;
  for (int b = 0; b < kMapBlocks; ++b) {
    const GLuint idx = CDSM_GLV(glGetProgramResourceIndex(program, GL_SHADER_STORAGE_BLOCK, block_name(MapBlock(b))));
    binding[b] = -1;
    if (idx == GL_INVALID_INDEX) {
      missing += std::string(missing.empty() ? "" : ", ") + block_name(MapBlock(b));
      continue;
    }
    const GLenum prop = GL_BUFFER_BINDING;
    CDSM_GL(glGetProgramResourceiv(program, GL_SHADER_STORAGE_BLOCK, idx, 1, &prop, 1, nullptr, &binding[b]));
  }
  if (!missing.empty())
    throw Error(where, "lacks the storage blocks " + missing +
                           " of cdsm.glsl: include cdsm.glsl (cdsm::glsl_include(), or share/cdsm/shaders/cdsm.glsl) "
                           "and call cdsm_transmittance or "
                           "cdsm_surface_transmittance in the program (unused blocks are removed by the compiler)");
  const int32_t points = context_.limits().max_ssbo_bindings;
  for (int b = 0; b < kMapBlocks; ++b)
    if (binding[b] < 0 || binding[b] >= points)
      throw Error(where, std::string("binds ") + block_name(MapBlock(b)) + " to point " + std::to_string(binding[b]) +
                             ", and this context has points 0.." + std::to_string(points - 1) +
                             " (GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS): #define CDSM_BINDING_BASE lower before "
                             "including cdsm.glsl");
  for (int a = 0; a < kMapBlocks; ++a)
    for (int b = a + 1; b < kMapBlocks; ++b)
      if (binding[a] == binding[b])
        throw Error(where, std::string("binds ") + block_name(MapBlock(a)) + " and " + block_name(MapBlock(b)) +
                               " to the same point " + std::to_string(binding[a]));
  for (int b = 0; b < kMapBlocks; ++b)
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, GLuint(binding[b]), buffers_[b].id()));
}

}  // namespace cdsm::gl
