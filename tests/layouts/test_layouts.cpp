// The three deep-shadow-map layouts (DESIGN.md §3): packed, fixed (thesis
// §4.2.1) and chunked (thesis §4.2.2, Alg. 4.1) hold the same visibility
// functions, report their memory exactly, and re-compress (fixed) or link
// (chunked) texels that need many nodes.
#include <gtest/gtest.h>

#include "common/minimax_fit.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <vector>

#include "cdsm/procedural.h"
#include "cdsm/renderer.h"
#include "common/host_maps.h"
#include "scene_compile.h"
#include "common/system_frame.h"
#include "hd/dsm_chunked.h"

using namespace cdsm;
using cdsm_test::build_host_map;
using cdsm_test::HostMaps;

namespace {

constexpr int kRes = 60;  // not a multiple of 8: edge tiles are partial

// A small scene under a spot light looking down: a translucent box, a
// translucent sphere with a constant medium, a smoke volume and a stack of
// 20 thin translucent slabs (80 surfaces: texels with > 64 nodes).
Scene make_scene() {
  Scene s;
  s.source = "layouts test scene";
  auto box = [](Vec3 size) { return std::make_shared<TriangleMesh>(make_box(size)); };
  Object glass;
  glass.name = "glass";
  glass.mesh = box({0.8f, 0.8f, 0.8f});
  glass.transform = make_transform({-0.7f, 0.4f, -0.5f}, {0, 20, 0}, {1, 1, 1});
  glass.surface.opacity = 0.35f;
  s.objects.push_back(glass);

  Object gel;
  gel.name = "gel";
  gel.mesh = std::make_shared<TriangleMesh>(make_sphere(0.45f, 32, 16));
  gel.transform = make_transform({0.7f, 0.5f, -0.6f}, {0, 0, 0}, {1, 1, 1});
  gel.surface.opacity = 0.2f;
  gel.interior = InteriorKind::Constant;
  gel.sigma = vec3(2.0f);
  s.objects.push_back(gel);

  NoiseVolumeParams np;
  np.nx = np.ny = np.nz = 24;
  np.seed = 5;
  np.plume = 0.0f;
  Volume v;
  v.name = "smoke";
  v.grid = make_noise_volume(np);
  const float vs = 0.04f;
  v.index_to_object.m[0][0] = v.index_to_object.m[1][1] = v.index_to_object.m[2][2] = vs;
  for (int a = 0; a < 3; ++a) v.index_to_object.m[a][3] = -0.48f + 0.5f * vs;  // box [-0.48, 0.48]^3
  v.transfer = {{0.0f, vec3(0.0f), {1, 1, 1}}, {1.0f, vec3(12.0f), {1, 1, 1}}};
  s.volumes.push_back(v);
  Object smoke;
  smoke.name = "smoke";
  smoke.mesh = box({0.96f, 0.96f, 0.96f});
  smoke.transform = make_transform({0.0f, 0.5f, 0.7f}, {0, 0, 0}, {1, 1, 1});
  smoke.surface.opacity = 0.0f;
  smoke.interior = InteriorKind::Volume;
  smoke.volume = 0;
  s.objects.push_back(smoke);

  for (int i = 0; i < 20; ++i) {
    Object slab;
    slab.name = "slab";
    slab.mesh = box({0.5f, 0.02f, 0.5f});
    slab.transform = make_transform({0.75f, 1.2f + 0.05f * float(i), 0.75f}, {0, 0, 0}, {1, 1, 1});
    slab.surface.opacity = 0.03f;
    s.objects.push_back(slab);
  }

  Object ground;
  ground.name = "ground";
  ground.mesh = std::make_shared<TriangleMesh>(make_ground(6.0f, 6.0f));
  ground.casts_shadows = false;
  s.objects.push_back(ground);

  s.lights.push_back(cdsm_test::spot_light({0.0f, 4.0f, 0.5f}, {0.0f, -1.0f, 0.0f}, 30.0f, 25.0f));
  s.camera = cdsm_test::camera_at({0.0f, 2.5f, 4.0f}, {0.0f, 0.4f, 0.0f}, 64, 48);
  return s;
}

PinholeView spot_view(const Light& l, int res) {
  PinholeView v;
  v.eye = l.position;
  v.forward = normalize(l.direction);
  v.right = normalize(cross(v.forward, Vec3{0, 0, -1}));
  v.up = cross(v.right, v.forward);
  v.tan_half_x = v.tan_half_y = std::tan(l.outer_cone_deg * 3.14159265f / 180.0f) * float(res) / float(res - 2);
  v.width = v.height = res;
  v.near = 0.05f;
  v.far = 10.0f;
  return v;
}

struct Fixture {
  Scene scene = make_scene();
  SceneBuffers sb = cdsm_test::compiled_scene(scene);
  SceneView sv = sb.view();
  PinholeView view = spot_view(scene.lights[0], kRes);
  std::vector<uint32_t> casters;
  std::vector<uint32_t> inside;
  FragmentBuffers frags;

  Fixture() {
    casters = sb.mask_where([&](uint32_t o) { return (sb.objects[o].flags & kObjCastsShadows) != 0u; });
    ObjectMask mask{{casters.data(), casters.size()}};
    cast_fragments(sv, view, mask, frags);
    inside = objects_containing(sv, view.eye, mask);
  }

  // One map in `layout` (eps: compression bound; 0 keeps every sample).
  DsmBuildStats build(const DsmLayoutParams& layout, HostMaps& out, float eps = 0.002f, PinholeView v = PinholeView{}) {
    LightPassParams lp{v.width > 1 ? v : view, eps, {inside.data(), inside.size()}};
    if (v.width > 1) {
      FragmentBuffers fb;
      ObjectMask mask{{casters.data(), casters.size()}};
      cast_fragments(sv, v, mask, fb);
      return build_host_map(sb, lp, fb, out, layout);
    }
    return build_host_map(sb, lp, frags, out, layout);
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

DsmLayoutParams packed() { return {DsmLayout::Packed, 32, 64}; }
DsmLayoutParams fixed(int L) { return {DsmLayout::Fixed, L, 64}; }
DsmLayoutParams chunked(int C = 64) { return {DsmLayout::Chunked, 32, C}; }

std::vector<DsmNode> nodes_of(const HostMaps& b, int tx, int ty, int map = 0) {
  std::vector<DsmNode> n(4096);
  uint32_t c = read_texel(b.storage(), b.maps[size_t(map)], tx, ty, n.data(), uint32_t(n.size()));
  n.resize(c);
  return n;
}

// Depths where a texel's function is worth probing: every node, just
// before and after it, midpoints, and beyond both ends.
std::vector<float> probe_depths(const std::vector<DsmNode>& n) {
  std::vector<float> z = {0.0f, 0.5f, 20.0f};
  for (size_t i = 0; i < n.size(); ++i) {
    z.push_back(n[i].z);
    z.push_back(std::nextafter(n[i].z, 0.0f));
    z.push_back(std::nextafter(n[i].z, 1e9f));
    if (i + 1 < n.size()) z.push_back(0.5f * (n[i].z + n[i + 1].z));
  }
  return z;
}

uint32_t packed_count(const HostMaps& b, int tx, int ty) { return b.grey.texels[size_t(ty) * kRes + tx].count; }

TEST(Layouts, SceneHasInterestingTexels) {
  HostMaps p;
  DsmBuildStats st = fixture().build(packed(), p);
  EXPECT_GT(st.max_nodes, 64u) << "the slab stack should need more than one chunk per texel";
  EXPECT_EQ(st.overflow_texels, 0u);
  uint64_t nonempty = 0;
  for (const TexelRange& r : p.grey.texels) nonempty += r.count > 0;
  EXPECT_GT(nonempty, uint64_t(kRes) * kRes / 8);
}

TEST(Layouts, SameLookupsAcrossLayouts) {
  Fixture& f = fixture();
  HostMaps p, x, c;
  f.build(packed(), p);
  DsmBuildStats sx = f.build(fixed(256), x);
  DsmBuildStats sc = f.build(chunked(), c);
  ASSERT_EQ(sx.layout_overflow_texels, 0u) << "L = 256 holds every texel";
  ASSERT_EQ(sx.overflow_texels, 0u);
  DsmStorage sp = p.storage(), sxs = x.storage(), scs = c.storage();
  EXPECT_EQ(sxs.layout, DsmLayout::Fixed);
  EXPECT_EQ(scs.layout, DsmLayout::Chunked);
  // Texel by texel: the same nodes, the same alpha at every probe depth.
  double max_diff = 0.0;
  for (int ty = 0; ty < kRes; ++ty)
    for (int tx = 0; tx < kRes; ++tx) {
      std::vector<DsmNode> np = nodes_of(p, tx, ty);
      std::vector<DsmNode> nx = nodes_of(x, tx, ty);
      std::vector<DsmNode> nc = nodes_of(c, tx, ty);
      ASSERT_EQ(np.size(), nx.size()) << tx << "," << ty;
      ASSERT_EQ(np.size(), nc.size()) << tx << "," << ty;
      for (size_t i = 0; i < np.size(); ++i) {
        EXPECT_EQ(np[i].z, nx[i].z);
        EXPECT_EQ(np[i].alpha, nx[i].alpha);
        EXPECT_EQ(np[i].z, nc[i].z);
        EXPECT_EQ(np[i].alpha, nc[i].alpha);
      }
      for (float z : probe_depths(np)) {
        float a = texel_alpha<1>(sp, p.maps[0], tx, ty, z);
        max_diff = std::max(max_diff, double(std::fabs(a - texel_alpha<1>(sxs, x.maps[0], tx, ty, z))));
        max_diff = std::max(max_diff, double(std::fabs(a - texel_alpha<1>(scs, c.maps[0], tx, ty, z))));
      }
    }
  EXPECT_LE(max_diff, 1e-6);
  // Filtered and nearest lookups at random positions, taps off the map included.
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> uv(-1.5f, kRes + 1.5f), depth(2.0f, 4.6f);
  double max_map = 0.0;
  for (int i = 0; i < 20000; ++i) {
    float u = uv(rng), v = uv(rng), z = depth(rng);
    for (bool filtering : {true, false}) {
      float a = lookup_map<1>(sp, p.maps[0], u, v, z, filtering);
      max_map = std::max(max_map, double(std::fabs(a - lookup_map<1>(sxs, x.maps[0], u, v, z, filtering))));
      max_map = std::max(max_map, double(std::fabs(a - lookup_map<1>(scs, c.maps[0], u, v, z, filtering))));
    }
  }
  EXPECT_LE(max_map, 1e-6);
  EXPECT_EQ(sx.nodes, sc.nodes);
}

TEST(Layouts, PackedHasNoSlack) {
  HostMaps p;
  DsmBuildStats st = fixture().build(packed(), p);
  uint64_t sum = 0;
  for (const TexelRange& r : p.grey.texels) sum += r.count;
  EXPECT_EQ(st.nodes, sum);
  EXPECT_EQ(p.grey.nodes.size(), sum) << "the pool holds exactly the nodes";
  EXPECT_EQ(st.index_bytes, uint64_t(kRes) * kRes * sizeof(TexelRange));
  EXPECT_EQ(st.node_bytes_used, sum * sizeof(DsmNode));
  EXPECT_EQ(st.node_bytes_allocated, st.node_bytes_used);
  EXPECT_EQ(st.slack_bytes, 0u);
  EXPECT_EQ(p.grey.tags.size(), sum) << "one surface tag per node";
  EXPECT_EQ(st.tag_bytes, sum * sizeof(SurfaceTag));
  // Tiles reserve exactly: the headers tile the pool without gaps or overlaps.
  std::vector<TexelRange> r(p.grey.texels.begin(), p.grey.texels.end());
  std::sort(r.begin(), r.end(), [](TexelRange a, TexelRange b) { return a.offset < b.offset; });
  uint64_t at = 0;
  for (TexelRange t : r) {
    if (t.count == 0) continue;
    EXPECT_EQ(t.offset, at);
    at = t.offset + t.count;
  }
  EXPECT_EQ(at, sum);
}

TEST(Layouts, FixedWasteMatchesHandCount) {
  Fixture& f = fixture();
  HostMaps p, x;
  f.build(packed(), p);
  const int L = 128;
  DsmBuildStats st = f.build(fixed(L), x);
  ASSERT_EQ(st.layout_overflow_texels, 0u);
  uint64_t used = 0, pads = 0;
  for (int ty = 0; ty < kRes; ++ty)
    for (int tx = 0; tx < kRes; ++tx) {
      used += packed_count(p, tx, ty);
      Span<const DsmNode> slots = texel_nodes<1>(x.storage(), x.maps[0], tx, ty);
      ASSERT_EQ(slots.size(), uint64_t(L));
      for (const DsmNode& n : slots) pads += n.z == kFixedPadZ;
    }
  const uint64_t slots = uint64_t(kRes) * kRes * L;
  EXPECT_EQ(x.grey.nodes.size(), slots);
  EXPECT_EQ(x.grey.texels.size(), 0u) << "fixed has no per-texel header";
  EXPECT_EQ(st.index_bytes, 0u);
  EXPECT_EQ(st.nodes, used);
  EXPECT_EQ(pads, slots - used);
  EXPECT_EQ(st.node_bytes_allocated, slots * sizeof(DsmNode));
  EXPECT_EQ(st.node_bytes_used, used * sizeof(DsmNode));
  EXPECT_EQ(st.slack_bytes, (slots - used) * sizeof(DsmNode));
  EXPECT_GT(st.slack_bytes, st.node_bytes_used) << "most of a fixed map is waste here";
  EXPECT_EQ(x.grey.tags.size(), slots) << "one surface tag per slot";
  EXPECT_EQ(st.tag_bytes, slots * sizeof(SurfaceTag));
}

TEST(Layouts, ChunkedSlackMatchesHandCount) {
  Fixture& f = fixture();
  HostMaps p;
  f.build(packed(), p);
  for (int C : {64, 7}) {
    HostMaps c;
    DsmBuildStats st = f.build(chunked(C), c);
    // Hand count: per 8x8 tile, ceil(T / C) chunks for its T nodes.
    uint64_t chunks = 0, used = 0;
    for (int y0 = 0; y0 < kRes; y0 += 8)
      for (int x0 = 0; x0 < kRes; x0 += 8) {
        uint64_t t = 0;
        for (int ty = y0; ty < std::min(y0 + 8, kRes); ++ty)
          for (int tx = x0; tx < std::min(x0 + 8, kRes); ++tx) t += packed_count(p, tx, ty);
        chunks += (t + C - 1) / C;
        used += t;
      }
    EXPECT_EQ(st.chunks, chunks) << "C = " << C;
    EXPECT_EQ(c.grey.chunks.size(), chunks * C);
    EXPECT_EQ(st.nodes, used);
    EXPECT_EQ(st.index_bytes, uint64_t(kRes) * kRes * sizeof(TexelRange));
    EXPECT_EQ(st.node_bytes_allocated, chunks * C * sizeof(ChunkNode));
    EXPECT_EQ(st.node_bytes_used, used * sizeof(ChunkNode));
    EXPECT_EQ(st.slack_bytes, (chunks * C - used) * sizeof(ChunkNode));
    EXPECT_EQ(c.grey.tags.size(), chunks * C) << "one surface tag per slot";
    EXPECT_EQ(st.tag_bytes, chunks * C * sizeof(SurfaceTag));
    // The slots no texel list reaches are exactly the slack.
    std::vector<uint8_t> reached(c.grey.chunks.size(), 0);
    for (const TexelRange& h : c.grey.texels) {
      uint32_t slot = h.offset;
      for (uint32_t i = 0; i < h.count; ++i) {
        ASSERT_LT(slot, c.grey.chunks.size());
        ASSERT_EQ(reached[slot], 0) << "two lists share a slot";
        reached[slot] = 1;
        slot = c.grey.chunks[slot].next;
      }
      EXPECT_EQ(slot, kChunkEnd) << "a list ends with kChunkEnd";
    }
    uint64_t unreached = uint64_t(std::count(reached.begin(), reached.end(), uint8_t(0)));
    EXPECT_EQ(unreached, chunks * C - used);
  }
}

TEST(Layouts, ChunkedLinksLongTexelsAcrossChunks) {
  Fixture& f = fixture();
  HostMaps p, c;
  f.build(packed(), p, 0.0f);
  f.build(chunked(), c, 0.0f);
  int long_texels = 0;
  for (int ty = 0; ty < kRes; ++ty)
    for (int tx = 0; tx < kRes; ++tx) {
      const TexelRange h = c.grey.texels[size_t(ty) * kRes + tx];
      if (h.count <= 64) continue;
      ++long_texels;
      std::set<uint32_t> chunks;
      uint32_t slot = h.offset, prev = 0;
      for (uint32_t i = 0; i < h.count; ++i) {
        if (i > 0) {
          EXPECT_GT(slot, prev) << "a tile fills its chunks layer by layer";
        }
        chunks.insert(slot / 64);
        prev = slot;
        slot = c.grey.chunks[slot].next;
      }
      EXPECT_EQ(slot, kChunkEnd);
      EXPECT_GE(chunks.size(), 2u);
      EXPECT_GE(chunks.size(), (h.count + 63) / 64);
      std::vector<DsmNode> a = nodes_of(p, tx, ty), b = nodes_of(c, tx, ty);
      ASSERT_EQ(a.size(), b.size());
      for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].z, b[i].z);
        EXPECT_EQ(a[i].alpha, b[i].alpha);
      }
      for (float z : probe_depths(a))
        EXPECT_EQ(texel_alpha<1>(p.storage(), p.maps[0], tx, ty, z), texel_alpha<1>(c.storage(), c.maps[0], tx, ty, z));
    }
  EXPECT_GT(long_texels, 0);
}

// Tile writer alone: one texel of 150 nodes among short ones.
TEST(Layouts, ChunkedTileWriterLinksThreeChunks) {
  std::vector<std::vector<DsmNode>> texel(64);
  std::vector<uint32_t> counts(64);
  for (int k = 0; k < 64; ++k) {
    int n = k == 9 ? 150 : (k % 5);
    for (int i = 0; i < n; ++i) texel[size_t(k)].push_back({float(i) + 0.01f * k, float(i) / float(n)});
    counts[size_t(k)] = uint32_t(n);
  }
  uint32_t total = 0;
  for (uint32_t n : counts) total += n;
  const uint32_t C = 64, chunks = tile_chunks(total, C), first = 3 * C;  // the tile's chunks start at chunk 3
  std::vector<ChunkNode> pool((3 + chunks) * C, ChunkNode{-1.0f, -1.0f, 12345u});
  std::vector<TexelRange> heads(64);
  uint32_t used = write_chunked_tile(
      counts.data(), 64, [&](int k) { return texel[size_t(k)].data(); },
      [](int) { return static_cast<const SurfaceTag*>(nullptr); }, first, C, pool.data(), nullptr, heads.data());
  EXPECT_EQ(used, total);
  for (uint32_t s = 0; s < first; ++s) EXPECT_EQ(pool[s].next, 12345u) << "wrote outside the tile's chunks";
  for (uint32_t s = first + total; s < pool.size(); ++s) EXPECT_EQ(pool[s].next, kChunkEnd) << "slack not cleared";
  for (int k = 0; k < 64; ++k) {
    EXPECT_EQ(heads[size_t(k)].count, counts[size_t(k)]);
    if (counts[size_t(k)] == 0) {
      EXPECT_EQ(heads[size_t(k)].offset, kChunkEnd);
      continue;
    }
    std::set<uint32_t> visited;
    uint32_t slot = heads[size_t(k)].offset;
    for (uint32_t i = 0; i < counts[size_t(k)]; ++i) {
      ASSERT_GE(slot, first);
      ASSERT_LT(slot, first + total);
      EXPECT_EQ(pool[slot].z, texel[size_t(k)][i].z);
      EXPECT_EQ(pool[slot].alpha, texel[size_t(k)][i].alpha);
      visited.insert(slot / C);
      slot = pool[slot].next;
    }
    EXPECT_EQ(slot, kChunkEnd);
    if (k == 9) {
      EXPECT_GE(visited.size(), 3u) << "150 nodes span at least three chunks";
    }
  }
  // The walk gives the same alpha as a binary search over the same nodes.
  TexelRange h = heads[9];
  Span<const DsmNode> ref{texel[9].data(), texel[9].size()};
  for (float z = -1.0f; z < 152.0f; z += 0.37f)
    EXPECT_EQ(lookup_alpha_chunked(Span<const ChunkNode>{pool.data(), pool.size()}, h, z), lookup_alpha(ref, z));
}

// The same tile written a texel at a time (a thread per texel on a GPU):
// the same pool slots, links, tags and headers as the tile writer, for
// tiles of random node counts (empty texels, one deep texel, whole chunks).
TEST(Layouts, ChunkedTexelWriterEqualsTheTileWriter) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    const uint32_t C = trial % 3 == 0 ? 64u : uint32_t(1 + rng() % 9);
    std::vector<uint32_t> counts(64);
    std::vector<std::vector<DsmNode>> texel(64);
    std::vector<std::vector<SurfaceTag>> tags(64);
    for (int k = 0; k < 64; ++k) {
      const uint32_t n = rng() % 4 == 0 ? 0u : (k == trial % 64 ? 100u + rng() % 60 : rng() % 7);
      counts[size_t(k)] = n;
      for (uint32_t i = 0; i < n; ++i) {
        texel[size_t(k)].push_back({float(i) + 0.01f * float(k), float(i) / float(n)});
        tags[size_t(k)].push_back(SurfaceTag(rng() % 200));
      }
    }
    uint32_t total = 0;
    for (uint32_t n : counts) total += n;
    const uint32_t first = 2 * C, slots = first + tile_chunks(total, C) * C + 5;
    std::vector<ChunkNode> a(slots, ChunkNode{-1.0f, -1.0f, 777u}), b = a;
    std::vector<SurfaceTag> ta(slots, SurfaceTag(999)), tb = ta;
    std::vector<TexelRange> ha(64), hb(64);
    write_chunked_tile(
        counts.data(), 64, [&](int k) { return texel[size_t(k)].data(); },
        [&](int k) { return tags[size_t(k)].data(); }, first, C, a.data(), ta.data(), ha.data());
    for (int k = 63; k >= 0; --k)  // any order: each texel writes its own slots
      write_chunked_texel(counts.data(), 64, k, texel[size_t(k)].data(), tags[size_t(k)].data(), first, C, b.data(),
                          tb.data(), hb[size_t(k)]);
    ASSERT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(ChunkNode)), 0) << "trial " << trial;
    ASSERT_EQ(ta, tb) << "trial " << trial;
    ASSERT_EQ(std::memcmp(ha.data(), hb.data(), ha.size() * sizeof(TexelRange)), 0) << "trial " << trial;
  }
}

// Exact sup |f - g| of two node lists (breakpoints of both, both sides of steps).
double sup_diff(Span<const DsmNode> f, Span<const DsmNode> g) {
  auto right = [](Span<const DsmNode> n, float z) {  // value just after z
    uint32_t j = 0;
    while (j < n.size() && n[j].z <= z) ++j;
    if (j == 0) return 0.0f;
    if (j == n.size() || n[j - 1].z == z) return n[j - 1].alpha;
    return alpha_between(n[j - 1], n[j], z);
  };
  double d = 0.0;
  for (Span<const DsmNode> s : {f, g})
    for (const DsmNode& n : s) {
      d = std::max(d, double(std::fabs(lookup_alpha(f, n.z) - lookup_alpha(g, n.z))));
      d = std::max(d, double(std::fabs(right(f, n.z) - right(g, n.z))));
    }
  return d;
}

bool monotone(Span<const DsmNode> n) {
  for (uint64_t i = 1; i < n.size(); ++i)
    if (n[i].z < n[i - 1].z || n[i].alpha < n[i - 1].alpha) return false;
  return true;
}

TEST(Layouts, FixedRecompressesSmoothTexel) {
  // 200 samples of 1 - exp(-z): the wedge with a larger tolerance fits it.
  std::vector<DsmNode> in;
  for (int i = 0; i < 200; ++i) {
    float z = 1.0f + 0.02f * float(i);
    in.push_back({z, 1.0f - std::exp(-(z - 1.0f))});
  }
  std::vector<DsmNode> slots(8);
  FixedFit fit = write_fixed_texel({in.data(), in.size()}, nullptr, 0.001f, slots.data(), nullptr, 8);
  EXPECT_TRUE(fit.recompressed);
  EXPECT_LE(fit.count, 8);
  EXPECT_GT(fit.extra_error, 0.0f);
  EXPECT_LT(fit.extra_error, 0.1f);
  Span<const DsmNode> out{slots.data(), size_t(fit.count)};
  EXPECT_TRUE(monotone(out));
  double err = sup_diff({in.data(), in.size()}, out);
  EXPECT_LE(err, fit.extra_error + 1e-5);
  EXPECT_GT(err, 0.25 * fit.extra_error) << "the recorded error is a tight bound";
  for (int k = fit.count; k < 8; ++k) {
    EXPECT_EQ(slots[size_t(k)].z, kFixedPadZ);
    EXPECT_EQ(slots[size_t(k)].alpha, out[out.size() - 1].alpha);
  }
}

TEST(Layouts, FixedRecompressesStepsGreedily) {
  // 12 surfaces (24 nodes) cannot fit 6 slots at any wedge tolerance.
  std::vector<DsmNode> in;
  float a = 0.0f;
  for (int i = 0; i < 12; ++i) {
    float z = 1.0f + 0.1f * float(i);
    in.push_back({z, a});
    a = a + (0.05f + 0.01f * float(i % 3)) * (1.0f - a);
    in.push_back({z, a});
  }
  std::vector<DsmNode> slots(6);
  FixedFit fit = write_fixed_texel({in.data(), in.size()}, nullptr, 0.01f, slots.data(), nullptr, 6);
  EXPECT_TRUE(fit.recompressed);
  EXPECT_EQ(fit.count, 6);
  Span<const DsmNode> out{slots.data(), 6};
  EXPECT_TRUE(monotone(out));
  EXPECT_EQ(out[0].z, in.front().z);
  EXPECT_EQ(out[5].z, in.back().z);
  EXPECT_EQ(out[5].alpha, in.back().alpha) << "the final opacity is kept";
  // Independent bounds: the best 6-node fit (exhaustive DP), and the
  // recorded error must cover the true change.
  double change = sup_diff({in.data(), in.size()}, out);
  double best = cdsm_test::minimax_fit_error(in, 6);
  std::printf("[ fixed ] 12 steps into 6 slots: change %.4f, optimum %.4f (x%.2f), recorded %.4f\n", change, best,
              change / best, fit.extra_error);
  EXPECT_LE(change, 2.0 * best + 1e-6);
  EXPECT_GE(double(fit.extra_error) + 1e-6, change);
}

TEST(Layouts, FixedSmallLayersRecordOverflow) {
  Fixture& f = fixture();
  HostMaps p, x;
  f.build(packed(), p);
  const int L = 6;
  DsmBuildStats st = f.build(fixed(L), x);
  uint64_t over = 0;
  for (const TexelRange& r : p.grey.texels) over += r.count > uint32_t(L);
  ASSERT_GT(over, 0u);
  EXPECT_EQ(st.layout_overflow_texels, over);
  EXPECT_EQ(st.overflow_texels, over);
  EXPECT_GT(st.max_extra_error, 0.0f);
  EXPECT_LE(st.max_nodes, uint32_t(L));
  EXPECT_EQ(st.max_built_nodes, [&] {
    uint32_t m = 0;
    for (const TexelRange& r : p.grey.texels) m = std::max(m, r.count);
    return m;
  }());
  double worst = 0.0, worst_ratio = 0.0;
  for (int ty = 0; ty < kRes; ++ty)
    for (int tx = 0; tx < kRes; ++tx) {
      std::vector<DsmNode> a = nodes_of(p, tx, ty), b = nodes_of(x, tx, ty);
      ASSERT_LE(b.size(), size_t(L));
      EXPECT_TRUE(monotone({b.data(), b.size()}));
      double d = sup_diff({a.data(), a.size()}, {b.data(), b.size()});
      if (a.size() <= size_t(L)) {
        EXPECT_EQ(d, 0.0) << "a texel that fits is stored as is";
      } else {
        // Independent: within twice the best L-node fit (exhaustive DP).
        double best = cdsm_test::minimax_fit_error(a, size_t(L));
        EXPECT_LE(d, 2.0 * best + 1e-5) << "texel " << tx << ", " << ty << ": optimum " << best;
        worst_ratio = std::max(worst_ratio, d / std::max(best, 1e-9));
      }
      worst = std::max(worst, d);
      // Lookups through the padded slots agree with the stored nodes.
      for (float z : probe_depths(a))
        EXPECT_EQ(texel_alpha<1>(x.storage(), x.maps[0], tx, ty, z),
                  lookup_alpha(Span<const DsmNode>{b.data(), b.size()}, z));
    }
  EXPECT_GT(worst, 0.0);
  EXPECT_LE(worst, double(st.max_extra_error) + 1e-5) << "the recorded error bounds the change";
  std::printf("[ fixed ] L = %d: worst change %.4f, worst ratio to the optimum %.2f\n", L, worst, worst_ratio);
}

// Two maps in one store (the second's headers, nodes, chunk links and tags
// after the first's) read as each built alone, in every layout; a map of
// another layout is refused by the store.
TEST(Layouts, MapsShareTheStoreInEveryLayout) {
  Fixture& f = fixture();
  PinholeView v2 = f.view;
  v2.eye = v2.eye + Vec3{0.3f, 0.0f, -0.2f};
  v2.width = v2.height = 36;
  for (DsmLayoutParams lp : {packed(), fixed(128), chunked(), chunked(5)}) {
    HostMaps a, b, all;
    f.build(lp, a);
    f.build(lp, b, 0.002f, v2);
    f.build(lp, all);
    f.build(lp, all, 0.002f, v2);
    ASSERT_EQ(all.maps.size(), 2u);
    for (int m = 0; m < 2; ++m) {
      const HostMaps& one = m == 0 ? a : b;
      int res = int(one.maps[0].res);
      for (int ty = 0; ty < res; ty += 3)
        for (int tx = 0; tx < res; tx += 2) {
          std::vector<DsmNode> n = nodes_of(one, tx, ty);
          for (float z : probe_depths(n))
            ASSERT_EQ(texel_alpha<1>(one.storage(), one.maps[0], tx, ty, z),
                      texel_alpha<1>(all.storage(), all.maps[size_t(m)], tx, ty, z))
                << "layout " << uint32_t(lp.layout) << " map " << m;
        }
    }
    EXPECT_THROW(f.build(lp.layout == DsmLayout::Packed ? chunked() : packed(), all), std::logic_error);
  }
}

// End to end: the renderer's image and memory report in each layout.
TEST(Layouts, RendererReportsEachLayout) {
  Scene s = make_scene();
  s.shadows.resolution = 64;
  s.shadows.epsilon = 0.005f;
  s.shadows.fixed_layers = 256;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  Renderer r;
  FrameStats sp, sx, sc;
  s.shadows.layout = DsmLayout::Packed;
  Image ip = r.render(s, opt, &sp);
  s.shadows.layout = DsmLayout::Fixed;
  Image ix = r.render(s, opt, &sx);
  s.shadows.layout = DsmLayout::Chunked;
  Image ic = r.render(s, opt, &sc);
  ASSERT_EQ(ip.rgb.size(), ix.rgb.size());
  ASSERT_EQ(ip.rgb.size(), ic.rgb.size());
  double dx = 0, dc = 0;
  for (size_t i = 0; i < ip.rgb.size(); ++i) {
    dx = std::max(dx, double(std::fabs(ip.rgb[i] - ix.rgb[i])));
    dc = std::max(dc, double(std::fabs(ip.rgb[i] - ic.rgb[i])));
  }
  EXPECT_LE(dx, 1e-6);
  EXPECT_LE(dc, 1e-6);
  EXPECT_EQ(sp.memory.nodes, sx.memory.nodes);
  EXPECT_EQ(sp.memory.nodes, sc.memory.nodes);
  EXPECT_EQ(sp.memory.texels, sx.memory.texels);
  EXPECT_EQ(sp.memory.slack_bytes, 0u);
  EXPECT_EQ(sp.memory.node_bytes, sp.memory.nodes * sizeof(DsmNode));
  EXPECT_EQ(sx.memory.index_bytes, 0u);
  EXPECT_EQ(sx.memory.node_bytes + sx.memory.slack_bytes, sx.memory.texels * 256 * sizeof(DsmNode));
  EXPECT_EQ(sc.memory.index_bytes, sc.memory.texels * sizeof(TexelRange));
  EXPECT_EQ(sc.memory.node_bytes, sc.memory.nodes * sizeof(ChunkNode));
  EXPECT_GT(sc.memory.slack_bytes, 0u);
  EXPECT_LE(sc.memory.slack_bytes, sc.memory.texels / 64 * 63 * sizeof(ChunkNode))
      << "at most one chunk's free slots per 8x8 tile";
}

}  // namespace
