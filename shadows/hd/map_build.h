// What building a deep shadow map is asked for and what it cost: the
// layout and its parameters (DESIGN.md §3), the per-texel node bounds of the
// light pass, and the statistics of one build. Plain structs shared by the
// backend interface (shadows/backend/backend.h), the light pass over an
// executor (shadows/exec/light_pass.h) and the frame.
#pragma once

#include "hd/dsm.h"
#include "hd/segments.h"

namespace cdsm {

// Which layout the maps of a frame use, and its parameters.
struct DsmLayoutParams {
  DsmLayout layout = DsmLayout::Packed;
  int fixed_layers = 32;  // fixed: L, node slots per texel (>= 2)
  int chunk_nodes = 64;   // chunked: C, node slots per chunk (>= 1)
};

inline constexpr int kDsmTile = 8;  // texels per tile side (the chunked layout's tile, the reservation unit)
// Nodes a texel's light ray is first walked into (node_limit(64) = 56: no
// texel of the shipped scenes has more), and the buffer a texel that needs
// more is walked again into, with the removal heap (its nodes beyond
// node_limit(1024) = 896 are re-compressed, the error recorded).
inline constexpr int kWalkNodes = 64;
inline constexpr int kTexelNodeCapacity = 1024;

// What building one map cost, in its layout. Bytes: index = per-texel
// headers; node bytes allocated = what the layout reserves for nodes, used =
// the nodes stored (chunked: with their links); slack = allocated - used;
// tags = the 2-byte SurfaceTag of every allocated node slot.
struct DsmBuildStats {
  DsmLayout layout = DsmLayout::Packed;
  bool rgb = false;  // RGB nodes (16 bytes; chunked slots 20) instead of scalar (8; 12)
  uint64_t texels = 0;
  uint64_t nodes = 0;                   // nodes stored
  uint32_t max_nodes = 0;               // stored, per texel
  uint32_t max_built_nodes = 0;         // per texel, before the layout's re-compression (fixed)
  uint64_t overflow_texels = 0;         // texels re-compressed (beyond kTexelNodeCapacity, or the layout's L)
  uint64_t layout_overflow_texels = 0;  // of those: re-compressed to fit the fixed layout's L
  uint64_t rewalked_texels = 0;         // walked a second time: more nodes than the first walk's buffer
  float max_extra_error = 0.0f;         // error bound those re-compressions added (max over texels)
  uint64_t index_bytes = 0;
  uint64_t node_bytes_allocated = 0;
  uint64_t node_bytes_used = 0;
  uint64_t slack_bytes = 0;
  uint64_t tag_bytes = 0;
  uint64_t pyramid_bytes = 0;  // its blocker pyramid (hd/blocker_pyramid.h; a light with a size)
  uint64_t chunks = 0;         // chunked: chunks allocated
  WalkStats walk;
};

}  // namespace cdsm
