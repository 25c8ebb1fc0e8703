// cdsm.glsl, part 3 of 6 (content/shaders/cdsm/, joined by cmake/CdsmGlsl.cmake): a texel's nodes.

// ---- one texel's visibility function (shadows/hd/dsm.h) ----------------------

// Slot i's surface tag in the grey or the RGB pool.
uint cdsm_tag(bool rgb, uint i) {
  uint w = rgb ? cdsm_rgb_tags[i >> 1u] : cdsm_tags[i >> 1u];
  return (w >> ((i & 1u) * 16u)) & 0xffffu;
}

// Slot i of the grey or RGB pool of the current layout: depth, alpha per
// channel (grey: its one value in each), the chunked layout's link.
void cdsm_slot(bool rgb, uint i, out float z, out vec3 a, out uint next) {
  next = 0u;
  if (CDSM_LAYOUT_IS(CDSM_LAYOUT_CHUNKED)) {
    if (rgb) {
      CdsmChunkRgb c = cdsm_rgb_chunks[i];
      z = c.z;
      a = vec3(c.r, c.g, c.b);
      next = c.next;
    } else {
      CdsmChunk c = cdsm_chunks[i];
      z = c.z;
      a = vec3(c.alpha);
      next = c.next;
    }
  } else if (rgb) {
    vec4 n = cdsm_rgb_nodes[i];
    z = n.x;
    a = n.yzw;
  } else {
    vec2 n = cdsm_nodes[i];
    z = n.x;
    a = vec3(n.y);
  }
}

vec3 cdsm_lerp3(vec3 a, vec3 b, float t) { return vec3(cdsm_lerp(a.x, b.x, t), cdsm_lerp(a.y, b.y, t), cdsm_lerp(a.z, b.z, t)); }

// α(z) of texel (tx, ty) of map m per channel (a grey map: its value in
// every channel), either node kind through cdsm_slot (one search, as
// hd/dsm.h alpha_at_index and lookup_alpha_chunked are one over N). The
// packed and fixed layouts share one binary search: a texel's nodes start
// at its header's offset, or at a fixed stride; chunked texels are walked
// along their links.
vec3 cdsm_texel_alpha(CdsmMap m, int tx, int ty, float z) {
  uint t = m.texel_offset + uint(ty) * m.res + uint(tx);
  bool rgb = m.rgb != 0u;
  float nz;
  vec3 na;
  uint next;
  if (CDSM_LAYOUT_IS(CDSM_LAYOUT_CHUNKED)) {
    uvec2 head = rgb ? cdsm_rgb_texels[t] : cdsm_texels[t];
    float pz = 0.0;
    vec3 pa = vec3(0.0);
    uint slot = head.x;
    for (uint i = 0u; i < head.y; ++i) {
      cdsm_slot(rgb, slot, nz, na, next);
      if (nz >= z) {
        if (nz == z) return na;
        if (i == 0u) return vec3(0.0);
        return cdsm_lerp3(pa, na, (z - pz) / (nz - pz));
      }
      pz = nz;
      pa = na;
      slot = next;
    }
    return pa;
  }
  uvec2 span = CDSM_LAYOUT_IS(CDSM_LAYOUT_FIXED) ? uvec2(t * cdsm_layers, cdsm_layers) : rgb ? cdsm_rgb_texels[t] : cdsm_texels[t];
  uint lo = 0u, hi = span.y;
  while (lo < hi) {
    uint mid = (lo + hi) >> 1;
    cdsm_slot(rgb, span.x + mid, nz, na, next);
    if (nz < z) lo = mid + 1u;
    else hi = mid;
  }
  if (lo >= span.y) {
    if (span.y == 0u) return vec3(0.0);
    cdsm_slot(rgb, span.x + span.y - 1u, nz, na, next);
    return na;
  }
  cdsm_slot(rgb, span.x + lo, nz, na, next);
  if (nz == z) return na;
  if (lo == 0u) return vec3(0.0);
  float bz = nz;
  vec3 ba = na;
  cdsm_slot(rgb, span.x + lo - 1u, nz, na, next);
  return cdsm_lerp3(na, ba, (z - nz) / (bz - nz));
}

