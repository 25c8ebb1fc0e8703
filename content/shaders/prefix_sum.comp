#version 450 core
// Blocked exclusive prefix sum of uint32 values (engine/gl/prefix_sum.cpp).
// SCAN_BLOCKS: each workgroup scans one block of BLOCK = 256 x 4 values
//   (in -> out, exclusive within the block) and writes the block's total to
//   block_sums[block]; a carry out of 32 bits sets status.overflow.
// ADD_OFFSETS: out[i] += block_sums[i / BLOCK] (block_sums already scanned).
// Blocks beyond 65535 use a 2D dispatch: block = y * num_groups.x + x.
// `in` and `out` may be the same buffer: a workgroup reads its whole block
// before it writes any of it.

#define THREADS 256u
#define PER_THREAD 4u
#define BLOCK (THREADS * PER_THREAD)

layout(local_size_x = 256) in;

layout(location = 0) uniform uint u_n;  // values in this level

layout(std430, binding = 0) readonly buffer InValues { uint in_values[]; };
layout(std430, binding = 1) buffer OutValues { uint out_values[]; };
layout(std430, binding = 2) buffer BlockSums { uint block_sums[]; };
layout(std430, binding = 3) buffer Status { uint overflow; } status;

uint block_index() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }

#if defined(SCAN_BLOCKS)

shared uint s_partial[THREADS];

void main() {
  uint block = block_index();
  uint lid = gl_LocalInvocationID.x;
  uint first = block * BLOCK + lid * PER_THREAD;
  uint v[PER_THREAD];
  uint sum = 0u;
  bool carry = false;
  for (uint j = 0u; j < PER_THREAD; ++j) {
    uint i = first + j;
    v[j] = i < u_n ? in_values[i] : 0u;
    uint t = sum + v[j];
    carry = carry || t < sum;
    sum = t;
  }
  s_partial[lid] = sum;
  barrier();
  // Inclusive Hillis-Steele scan of the 256 per-thread sums.
  for (uint offset = 1u; offset < THREADS; offset <<= 1u) {
    uint add = lid >= offset ? s_partial[lid - offset] : 0u;
    barrier();
    uint t = s_partial[lid] + add;
    carry = carry || t < add;
    s_partial[lid] = t;
    barrier();
  }
  uint running = lid > 0u ? s_partial[lid - 1u] : 0u;
  for (uint j = 0u; j < PER_THREAD; ++j) {
    uint i = first + j;
    if (i < u_n) out_values[i] = running;
    running += v[j];
  }
  if (lid == THREADS - 1u && block * BLOCK < u_n) block_sums[block] = s_partial[lid];
  if (carry) atomicOr(status.overflow, 1u);
}

#elif defined(ADD_OFFSETS)

void main() {
  uint block = block_index();
  uint first = block * BLOCK + gl_LocalInvocationID.x * PER_THREAD;
  if (block == 0u || first >= u_n) return;
  uint add = block_sums[block];
  for (uint j = 0u; j < PER_THREAD; ++j) {
    uint i = first + j;
    if (i < u_n) out_values[i] += add;
  }
}

#else
#error define SCAN_BLOCKS or ADD_OFFSETS
#endif
