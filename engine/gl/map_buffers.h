// The deep shadow maps of a frame in GL shader storage buffers, in the
// std430 layout cdsm.glsl (content/shaders/cdsm/) reads (DESIGN.md §8): one block of
// frame data (lookup settings, lights, map headers) and the eight arrays of
// the backend's storage (DsmStorage: texel headers, nodes and chunk slots,
// grey and RGB, and the two pools' surface tags), byte for byte, so the
// GLSL lookup reads the offsets the CDSM_HD lookup reads. Buffers are sized
// in whole 4-byte words (the tags are read two to a uint).
//
// Uploads follow the backend's storage_epoch(): while it stays the same the
// arrays only grew at their ends (maps built since), and only those tails
// are uploaded; across a new epoch (a compaction) each array is uploaded
// from the first byte the backend did not keep in place
// (ShadowBackend::storage_kept_bytes: the maps that moved down and the new
// ones), and from its start where it does not know (an emptied store; the
// first sync and another layout upload every array). A buffer that must
// grow keeps its contents by a GL-side copy (glCopyNamedBufferSubData, no
// host traffic) into one 1.5x larger; a buffer more than twice what its
// array needs is re-allocated to the exact size and that array uploaded
// whole. The frame block is re-uploaded only when its bytes changed. So a
// frame in which no map changed uploads nothing.
//
// Every array must fit one storage block (GL_MAX_SHADER_STORAGE_BLOCK_SIZE,
// 128 MiB on llvmpipe): a larger one is refused with cdsm::Error naming the
// array, its size and the limit (the lookup indexes each array in one
// block).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "gl/gl_objects.h"
#include "hd/lights.h"

namespace cdsm::gl {

class Context;
struct Limits;

// The head of the CdsmFrame block (std430): then `map_count` DsmMap.
struct FrameBlockHeader {
  DsmLayout layout;
  uint32_t layers;     // fixed: node slots per texel
  uint32_t filtering;  // 1: bilinear taps
  ReceiverLookup receiver;
  float bias_constant;  // casters' offset from their own plane, world units
  float bias_slope;     // + texel footprints
  uint32_t light_count;
  uint32_t map_count;
  Penumbra penumbra;      // lights with a size
  int32_t penumbra_taps;  // their filter's taps across a penumbra
  uint32_t pad[2];
  LightData lights[kMaxLights];  // lights[i] owns maps [first_map, first_map + map_count)
};
static_assert(sizeof(FrameBlockHeader) == 48 + 64 * kMaxLights, "CdsmFrame header layout (cdsm.glsl)");
static_assert(sizeof(FrameBlockHeader) % 16 == 0, "DsmMap (16-byte aligned in std430) follows the header");

// The blocks of cdsm.glsl, in binding order from CDSM_BINDING_BASE.
enum class MapBlock : int { Frame = 0, Texels, Nodes, Chunks, RgbTexels, RgbNodes, RgbChunks, Tags, RgbTags, Count };
inline constexpr int kMapBlocks = int(MapBlock::Count);
static_assert(kMapBlocks == 1 + kStorageArrays, "the frame block, then the storage arrays in their order");
const char* block_name(MapBlock b);  // "CdsmFrame", ...

// Why a context cannot hold cdsm.glsl's kMapBlocks storage blocks in a
// fragment or compute shader (its per-stage or combined limit is below
// them), or "" when it can. GL 4.5 guarantees only 8 per stage; every
// driver measured reports more (llvmpipe and NVIDIA: docs/gpu.md).
std::string storage_block_shortfall(const Limits& limits);

struct MapUploadStats {
  uint64_t upload_bytes = 0;     // host -> GL bytes of this sync
  uint64_t device_bytes = 0;     // array bytes the DeviceWriter wrote (no host traffic)
  uint64_t copy_bytes = 0;       // GL-side copies of grown buffers
  bool full = false;             // every array uploaded whole (first sync, another layout, nothing kept)
  uint64_t allocated_bytes = 0;  // all blocks' buffers
  uint64_t used_bytes = 0;       // of which holding data
};

// The ranges of one sync for a DeviceWriter (backend/backend.h GlMapWrite:
// bytes [offset, offset + bytes) of a storage array into its GL buffer at
// the same offset; the generation changes with every new buffer object).
using DeviceWriter = std::function<void(const GlMapWrite* writes, int count)>;

class MapBuffers {
 public:
  // `max_block_bytes` 0: the context's GL_MAX_SHADER_STORAGE_BLOCK_SIZE
  // (tests pass less to reach the limit). Throws cdsm::Error when the
  // context cannot hold the blocks (storage_block_shortfall).
  explicit MapBuffers(Context& context, uint64_t max_block_bytes = 0);
  ~MapBuffers();
  MapBuffers(const MapBuffers&) = delete;
  MapBuffers& operator=(const MapBuffers&) = delete;

  // Per storage array, the bytes at its start unchanged since storage epoch
  // `since` (ShadowBackend::storage_kept_bytes).
  using KeptBytes = std::function<void(uint64_t since, uint64_t* kept)>;
  // Brings the buffers to `view` (its lights, maps and storage; the storage
  // of a backend at storage epoch `epoch`, which keeps what `kept` says).
  // The context must be current. With `device`, the arrays' ranges are
  // written by it (see above) and view.storage's spans are only read for
  // their sizes. Without `kept`, a new epoch uploads every array whole.
  MapUploadStats sync(const ShadowView& view, uint64_t epoch, const KeptBytes& kept = {},
                      const DeviceWriter& device = {});

  // Called with a buffer's GL name just before this deletes it or replaces
  // it by another (growth, re-allocation, the destructor), the context
  // current: whoever registered the buffer elsewhere (the cuda backend's
  // CUDA-GL interop, ShadowBackend::gl_buffer_released) lets it go first.
  // Empty: nobody to tell. The hook must not throw.
  using ReleaseHook = std::function<void(GLuint name)>;
  void set_release_hook(ReleaseHook hook) { release_hook_ = std::move(hook); }

  GLuint buffer(MapBlock b) const { return buffers_[int(b)].id(); }
  uint64_t limit_bytes() const { return max_block_; }

  // Binds every block to the binding point `program` declares for it.
  // Throws cdsm::Error naming the program and the blocks it lacks (a program
  // that does not use cdsm.glsl's lookup, or whose compiler dropped it) or
  // two blocks sharing a binding, or a binding point at or past the
  // context's GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS.
  void bind(GLuint program) const;
  // The layout of the last sync's storage (DsmLayout::Packed before any).
  DsmLayout layout() const { return layout_; }

 private:
  // Sizes array `block`'s buffer for `bytes` of which the first `from` are
  // in it already (growing it by a GL-side copy of those, or re-allocating
  // it exactly and writing it whole when it is more than twice the size)
  // and returns the range to write.
  GlMapWrite prepare_array(int block, uint64_t bytes, uint64_t from, MapUploadStats& st);
  void renew(int block);    // the array has a new buffer object
  void release(int block);  // tells the release hook before the block's buffer goes

  Context& context_;
  uint64_t max_block_ = 0;
  Buffer buffers_[kMapBlocks];
  uint64_t used_[kMapBlocks] = {};  // bytes holding data
  uint64_t generation_[kMapBlocks] = {};
  uint64_t epoch_ = 0;  // of the last sync (0: none yet)
  DsmLayout layout_ = DsmLayout::Packed;
  bool synced_ = false;               // a sync has run (the first one is full)
  std::vector<unsigned char> frame_;  // the frame block last uploaded
  ReleaseHook release_hook_;
};

}  // namespace cdsm::gl
