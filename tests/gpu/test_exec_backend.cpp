// The one backend (shadows/backend/exec_backend.h) on CPU threads — the
// cpu backend, and the cuda backend's code minus the CUDA glue — against a
// small serial reference written here: each texel walked by a plain loop
// into a vector of nodes, each pixel shaded by a plain loop.
//
// What this checks is the backend's orchestration, not the per-texel and
// per-pixel arithmetic: the serial loops call the same CDSM_HD functions
// the backend launches (build_texel, shade_pixel, cast_pixel), so a wrong
// walk or lookup would be wrong on both sides. Checked here, texel by
// texel and pixel by pixel on the GPU suite's three scenes: the light
// pass's batches, first and second walks, tile reservations, layouts and
// tags, the store's compaction, the camera pass's launch over the pixels,
// the ray-cast fragment producer's. The arithmetic itself is checked
// against analytic answers and the independent reference renderer
// (tests/unit: test_dsm_analytic, test_compress, test_reference, ...).
// The GPU runs the same code (tests/gpu/test_cuda_backend.cpp).
#include <type_traits>
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>

#include "backend/exec_backend.h"
#include "cdsm/shadow_system.h"
#include "exec/camera_pass.h"
#include "exec/host_exec.h"
#include "exec/scan.h"
#include "common/pyramid_check.h"
#include "common/sanitized.h"
#include "parity.h"
#include "frame_snapshot.h"
#include "scene_sync.h"
#include "common/system_frame.h"

using namespace cdsm;
using HostBackend = exec::ExecBackend<exec::HostExec>;

namespace {

const char* kScenes[] = {"default", "volumes", "depth"};

DsmLayoutParams layout_params(DsmLayout kind) { return {kind, 24, 64}; }

// A light view of `s`'s first light with its casters' fragment lists.
struct OneView {
  Scene scene;
  SceneBuffers sb;
  std::vector<uint32_t> casters, inside;
  FragmentBuffers frags;
  LightPassParams params{};
  explicit OneView(Scene s, float eps) : scene(std::move(s)), sb(cdsm_test::compiled_scene(scene)) {
    const SceneView sv = sb.view();
    LightSetup ls = setup_lights(scene.lights, sb, scene.shadows.resolution);
    casters = sb.mask_where([&](uint32_t o) { return (sb.objects[o].flags & kObjCastsShadows) != 0u; });
    ObjectMask mask{{casters.data(), casters.size()}};
    cast_fragments(sv, ls.maps[0].view, mask, frags);
    inside = objects_containing(sv, ls.maps[0].view.eye, mask);
    params = LightPassParams{ls.maps[0].view, eps, {inside.data(), inside.size()}};
  }
};

// ---- the serial reference ----------------------------------------------------

// One texel as a plain loop builds it: its light ray walked into a bounded
// buffer of `capacity` nodes with the removal heap (either kind), kept in
// vectors.
struct SerialTexel {
  std::vector<DsmNode> grey;
  std::vector<DsmNodeRgb> rgb;
  std::vector<SurfaceTag> tags;
  bool recompressed = false;
  float extra = 0.0f;
  size_t size() const { return grey.empty() ? rgb.size() : grey.size(); }
};

std::vector<SerialTexel> serial_map(const SceneBuffers& sb, const LightPassParams& p, FragmentBuffers frags,
                                    int capacity) {
  const SceneView sv = sb.view();
  const FragmentLists lists = frags.lists();
  std::vector<SerialTexel> out(size_t(p.view.width) * size_t(p.view.height));
  std::vector<uint32_t> words(4 * size_t(capacity));
  std::vector<float> floats(2 * size_t(capacity));
  for (int ty = 0; ty < p.view.height; ++ty)
    for (int tx = 0; tx < p.view.width; ++tx) {
      SerialTexel& t = out[size_t(ty) * p.view.width + tx];
      t.tags.assign(size_t(capacity), kNoSurface);
      const auto walk = [&](auto& nodes) {
        nodes.resize(size_t(capacity));
        NodeBufferN<std::decay_t<decltype(nodes[0])>::kChannels> b{nodes.data(), capacity};
        b.tags = t.tags.data();
        const uint32_t k = uint32_t(capacity);
        b.scratch = RemovalScratch{words.data(),         words.data() + k, words.data() + 2 * k,
                                   words.data() + 3 * k, floats.data(),    floats.data() + k};
        WalkStats st;
        build_texel(sv, p, lists.pixel(tx, ty), tx, ty, b, st);
        nodes.resize(size_t(b.count));
        t.recompressed = b.removed > 0;
        t.extra = b.extra_error;
      };
      if (p.rgb)
        walk(t.rgb);
      else
        walk(t.grey);
      t.tags.resize(t.size());
    }
  return out;
}

// The backend's map `id` against the serial texels: node for node and tag
// for tag (the fixed layout: the serial nodes through write_fixed_texel).
// Returns the texels compared.
uint64_t expect_map_equals_serial(const ShadowBackend& b, MapId id, const std::vector<SerialTexel>& serial,
                                  const DsmLayoutParams& layout, float eps, const std::string& what) {
  const DsmStorage st = b.storage();
  const DsmMap m = b.map_header(id);
  uint64_t differ = 0, n = 0;
  std::string first;
  const int L = layout.fixed_layers;
  for (int ty = 0; ty < int(m.res); ++ty)
    for (int tx = 0; tx < int(m.res); ++tx) {
      const SerialTexel& s = serial[size_t(ty) * m.res + tx];
      ++n;
      bool same = true;
      std::vector<SurfaceTag> tags(8192), want_tags = s.tags;
      if (m.rgb) {
        std::vector<DsmNodeRgb> got(8192), want = s.rgb;
        if (layout.layout == DsmLayout::Fixed) {
          std::vector<DsmNodeRgb> slots(static_cast<size_t>(L));
          std::vector<SurfaceTag> slot_tags(static_cast<size_t>(L));
          const FixedFit fit = write_fixed_texel(Span<const DsmNodeRgb>{want.data(), want.size()}, want_tags.data(),
                                                 eps, slots.data(), slot_tags.data(), L);
          want.assign(slots.begin(), slots.begin() + fit.count);
          want_tags.assign(slot_tags.begin(), slot_tags.begin() + fit.count);
        }
        const uint32_t c = read_texel(st, m, tx, ty, got.data(), uint32_t(got.size()), tags.data());
        same = c == want.size();
        for (uint32_t i = 0; same && i < c; ++i)
          same = got[i].z == want[i].z && same_channels(got[i].alpha, want[i].alpha) && tags[i] == want_tags[i];
      } else {
        std::vector<DsmNode> got(8192), want = s.grey;
        if (layout.layout == DsmLayout::Fixed) {
          std::vector<DsmNode> slots(static_cast<size_t>(L));
          std::vector<SurfaceTag> slot_tags(static_cast<size_t>(L));
          const FixedFit fit = write_fixed_texel(Span<const DsmNode>{want.data(), want.size()}, want_tags.data(), eps,
                                                 slots.data(), slot_tags.data(), L);
          want.assign(slots.begin(), slots.begin() + fit.count);
          want_tags.assign(slot_tags.begin(), slot_tags.begin() + fit.count);
        }
        const uint32_t c = read_texel(st, m, tx, ty, got.data(), uint32_t(got.size()), tags.data());
        same = c == want.size();
        for (uint32_t i = 0; same && i < c; ++i)
          same = got[i].z == want[i].z && got[i].alpha == want[i].alpha && tags[i] == want_tags[i];
      }
      if (!same && first.empty()) first = "texel (" + std::to_string(tx) + ", " + std::to_string(ty) + ")";
      differ += !same;
    }
  EXPECT_EQ(differ, 0u) << what << ": first at " << first;
  return n;
}

// The serial texels' totals, as DsmBuildStats counts them (packed, chunked).
struct SerialTotals {
  uint64_t nodes = 0, recompressed = 0;
  uint32_t max_nodes = 0;
  float max_extra = 0.0f;
};
SerialTotals totals(const std::vector<SerialTexel>& serial) {
  SerialTotals t;
  for (const SerialTexel& s : serial) {
    t.nodes += s.size();
    t.max_nodes = std::max(t.max_nodes, uint32_t(s.size()));
    if (s.recompressed) {
      ++t.recompressed;
      t.max_extra = std::max(t.max_extra, s.extra);
    }
  }
  return t;
}

}  // namespace

// Every layout, grey and RGB maps, the three scenes: the backend's maps are
// the serial walk's, node for node and tag for tag, and its counts agree.
TEST(ExecBackend, MapsEqualASerialWalk) {
  for (const char* name : kScenes)
    for (bool rgb : {false, true})
      for (DsmLayout kind : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
        const std::string what = std::string(name) + (rgb ? " rgb " : " grey ") + std::string(tag_name(kind));
        OneView v(parity::load(name, 48, 32, 24), 0.002f);
        v.params.rgb = rgb;
        const std::vector<SerialTexel> serial = serial_map(v.sb, v.params, v.frags, kTexelNodeCapacity);
        HostBackend ex("cpu");
        ex.update_scene(v.sb, SceneChange::all());
        FragmentBuffers f = v.frags;
        DsmBuildStats st;
        const MapId id = build_map_from_host(ex, v.params, f, layout_params(kind), st);
        expect_map_equals_serial(ex, id, serial, layout_params(kind), v.params.epsilon, what);
        const SerialTotals t = totals(serial);
        EXPECT_EQ(st.max_built_nodes, t.max_nodes) << what;
        if (kind != DsmLayout::Fixed) {
          EXPECT_EQ(st.nodes, t.nodes) << what;
          EXPECT_EQ(st.max_nodes, t.max_nodes) << what;
          EXPECT_EQ(st.overflow_texels, t.recompressed) << what;
        }
      }
}

// The first walk's buffer holds K nodes; a texel with more is walked again
// into the large buffer — the same nodes, only those texels walked twice,
// whatever K and however small the batches (many batches, many chunks).
TEST(ExecBackend, SecondWalkOnlyForTexelsThatNeedIt) {
  OneView v(parity::load("depth", 48, 32, 24), 0.0005f);
  for (bool rgb : {false, true}) {
    v.params.rgb = rgb;
    const std::vector<SerialTexel> serial = serial_map(v.sb, v.params, v.frags, kTexelNodeCapacity);
    for (int K : {8, 16, 64})
      for (uint64_t batch : {uint64_t(64) << 20, uint64_t(4096)}) {
        const std::string what =
            std::string(rgb ? "rgb" : "grey") + " K " + std::to_string(K) + " batch " + std::to_string(batch);
        HostBackend ex("cpu");
        ex.update_scene(v.sb, SceneChange::all());
        ex.light_pass().walk_nodes = K;
        ex.light_pass().batch_bytes = batch;
        FragmentBuffers f = v.frags;
        DsmBuildStats st;
        const MapId id = build_map_from_host(ex, v.params, f, layout_params(DsmLayout::Packed), st);
        expect_map_equals_serial(ex, id, serial, layout_params(DsmLayout::Packed), v.params.epsilon, what);
        uint64_t need = 0;
        for (const SerialTexel& s : serial) need += s.size() > size_t(node_limit(K));
        EXPECT_EQ(st.rewalked_texels, need) << what;
        if (K == 8) {
          EXPECT_GT(need, 100u) << what << ": the scene must make texels walk twice";
        }
        EXPECT_EQ(st.slack_bytes, 0u) << what << ": packed: exact allocation";
      }
  }
}

// Beyond the large buffer's bound a texel is re-compressed as a serial
// bounded buffer of the same size re-compresses it: the same nodes, the
// error bound recorded and counted.
TEST(ExecBackend, RecompressionEqualsTheBoundedBuffer) {
  constexpr int K = 16;
  OneView v(parity::load("depth", 48, 32, 24), 0.002f);
  for (bool rgb : {false, true})
    for (DsmLayout kind : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
      const std::string what = std::string(rgb ? "rgb " : "grey ") + std::string(tag_name(kind));
      v.params.rgb = rgb;
      const std::vector<SerialTexel> serial = serial_map(v.sb, v.params, v.frags, K);
      HostBackend ex("cpu");
      ex.update_scene(v.sb, SceneChange::all());
      ex.light_pass().walk_nodes = 8;
      ex.light_pass().max_nodes = K;
      FragmentBuffers f = v.frags;
      DsmBuildStats st;
      const MapId id = build_map_from_host(ex, v.params, f, layout_params(kind), st);
      expect_map_equals_serial(ex, id, serial, layout_params(kind), v.params.epsilon, what);
      const SerialTotals t = totals(serial);
      EXPECT_GT(t.recompressed, 100u) << what;
      if (kind != DsmLayout::Fixed) {
        EXPECT_EQ(st.overflow_texels, t.recompressed) << what;
        EXPECT_EQ(st.max_extra_error, t.max_extra) << what;
      }
    }
}

// ε = 0, every sample a node: the default buffers store every node of the
// deepest texels (no re-compression).
TEST(ExecBackend, DeepTexelsKeepEveryNode) {
  OneView v(parity::load("depth", 48, 32, 24), 0.0f);
  HostBackend ex("cpu");
  ex.update_scene(v.sb, SceneChange::all());
  DsmBuildStats st;
  build_map_from_host(ex, v.params, v.frags, layout_params(DsmLayout::Packed), st);
  EXPECT_EQ(st.overflow_texels, 0u);
  EXPECT_GT(st.max_nodes, 200u);
  EXPECT_GT(st.rewalked_texels, 0u);
  EXPECT_EQ(st.slack_bytes, 0u) << "packed: exact allocation";
}

// The benchmark's baselines: the same rays into their own builders.
TEST(ExecBackend, BaselinesEqualASerialWalk) {
  const ShadowMethod methods[] = {ShadowMethod::ShadowMap,   ShadowMethod::OpacitySlices,  ShadowMethod::FixedNodes,
                                  ShadowMethod::DeepOpacity, ShadowMethod::FourierOpacity, ShadowMethod::Moments};
  for (ShadowMethod m : methods)
    for (float param : {0.0f, m == ShadowMethod::Moments ? 8.0f : 5.0f}) {
      OneView v(parity::load("volumes", 48, 32, 24), 0.002f);
      v.params.method = m;
      v.params.method_param = m == ShadowMethod::ShadowMap ? param * 0.1f : param;
      const std::vector<SerialTexel> serial = serial_map(v.sb, v.params, v.frags, kTexelNodeCapacity);
      HostBackend ex("cpu");
      ex.update_scene(v.sb, SceneChange::all());
      FragmentBuffers f = v.frags;
      DsmBuildStats st;
      const MapId id = build_map_from_host(ex, v.params, f, layout_params(DsmLayout::Packed), st);
      expect_map_equals_serial(ex, id, serial, layout_params(DsmLayout::Packed), v.params.epsilon,
                               "method " + std::to_string(int(m)) + " param " + std::to_string(param));
      EXPECT_EQ(st.rewalked_texels, 0u) << "a baseline's buffer holds all its nodes";
    }
}

// Map `id`'s blocker pyramid (hd/blocker_pyramid.h): each cell the least
// opacity depth of its texels; built without one, its top cell says
// unknown.
void expect_pyramid(const HostBackend& ex, MapId id, bool built, const std::string& what) {
  const DsmStorage st = ex.storage();
  const DsmMap m = ex.map_header(id);
  const Span<const float> cells = m.rgb ? st.rgb.pyramid : st.grey.pyramid;
  ASSERT_TRUE(m.rgb ? has_pyramid(st.rgb, m) : has_pyramid(st.grey, m)) << what;
  if (!built) {
    EXPECT_EQ(cells[pyramid_level(m, pyramid_top(m.res, uint32_t(m.view.height))).offset], -kNoOpacityDepth) << what;
    return;
  }
  const cdsm_test::PyramidMismatch p = cdsm_test::pyramid_mismatch(st, m);
  EXPECT_EQ(p.wrong, 0) << what << ": first " << p.first;
}

// A frame's maps built together (build_maps: grey and RGB in one call,
// every layout): each is the serial walk's, and their counters come back in
// one read once the pool (packed: the store; fixed, chunked: staging) holds
// them. The first call reads twice: the depth scene passes the pool's first
// guess of two nodes a texel, so the grey DSM is walked again after it grew
// (the shadow map before it is not: its nodes are kept); the same maps
// again read once and allocate nothing.
TEST(ExecBackend, MapsBuiltTogetherReadTheirCountersOnce) {
  // (32^2 maps under a sanitizer: the same passes at half the texels)
  OneView v(parity::load("depth", CDSM_TEST_SANITIZED ? 32 : 48, 32, 24), 0.0005f);
  // A shadow map first (a node or two a texel: within the first guess); the
  // grey DSM after it passes the guess; RGB maps have their own pool.
  std::vector<LightPassParams> params(3, v.params);
  params[0].method = ShadowMethod::ShadowMap;
  params[0].blocker_pyramid = true;
  params[2].rgb = true;
  std::vector<std::vector<SerialTexel>> serial;
  for (const LightPassParams& p : params) serial.push_back(serial_map(v.sb, p, v.frags, kTexelNodeCapacity));
  for (DsmLayout kind : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
    HostBackend ex("cpu");
    ex.update_scene(v.sb, SceneChange::all());
    ex.light_pass().walk_nodes = 8;  // texels walked twice as well
    for (int call = 0; call < 2; ++call) {
      const std::string what = std::string(tag_name(kind)) + (call ? ", again" : ", first call");
      std::vector<ShadowBackend::MapBuild> builds;
      for (const LightPassParams& p : params) builds.push_back({p, ex.adopt_lists(FragmentBuffers(v.frags))});
      std::vector<MapId> ids(builds.size());
      std::vector<DsmBuildStats> stats(builds.size());
      const exec::ExecCounters before = ex.executor().counters;
      ex.build_maps(builds.data(), builds.size(), layout_params(kind), ids.data(), stats.data());
      const exec::ExecCounters d = ex.executor().counters.since(before);
      for (size_t i = 0; i < ids.size(); ++i) {
        expect_map_equals_serial(ex, ids[i], serial[i], layout_params(kind), params[i].epsilon,
                                 what + ", map " + std::to_string(i));
        if (kind != DsmLayout::Fixed) {
          EXPECT_EQ(stats[i].nodes, totals(serial[i]).nodes) << what << ", map " << i;
        }
        if (i > 0) {
          EXPECT_GT(stats[i].rewalked_texels, 0u) << what << ", map " << i;
        }
      }
      expect_pyramid(ex, ids[0], true, what);
      std::printf("[ together ] %s: nodes %llu %llu %llu for %llu texels each, %llu reads\n", what.c_str(),
                  (unsigned long long)stats[0].nodes, (unsigned long long)stats[1].nodes,
                  (unsigned long long)stats[2].nodes, (unsigned long long)stats[0].texels, (unsigned long long)d.syncs);
      EXPECT_EQ(d.syncs, call ? 1u : 2u) << what;
      EXPECT_EQ(d.bytes_down, d.syncs * builds.size() * sizeof(exec::BuildCounters)) << what;
      if (call) {
        EXPECT_EQ(d.allocations, 0u) << what;
      }
      ex.free_maps(ids);
      for (const ShadowBackend::MapBuild& b : builds) ex.free_lists(b.lists);
    }
  }
}

// Freed maps leave holes; compaction moves the rest (offsets, chunk links,
// tags and blocker pyramids re-based) and they read as the serial walk, in
// every layout.
TEST(ExecBackend, FreeAndCompactKeepTheOtherMaps) {
  OneView v(parity::load("depth", 32, 32, 24), 0.005f);
  for (DsmLayout kind : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
    HostBackend ex("cpu");
    ex.update_scene(v.sb, SceneChange::all());
    std::vector<MapId> ids;
    std::vector<LightPassParams> params;
    for (int i = 0; i < 6; ++i) {
      LightPassParams p = v.params;
      p.epsilon = 0.002f * float(i + 1);
      p.rgb = (i % 2) == 1;
      p.blocker_pyramid = i != 2 && i != 3;
      DsmBuildStats st;
      FragmentBuffers f = v.frags;
      ids.push_back(build_map_from_host(ex, p, f, layout_params(kind), st));
      EXPECT_EQ(st.pyramid_bytes > 0u, p.blocker_pyramid) << "map " << i;
      params.push_back(p);
    }
    for (int i : {0, 1, 3, 4}) ex.free_map(ids[size_t(i)]);
    EXPECT_GT(ex.map_store().compactions, 0u) << "kind " << tag_name(kind);
    for (int i : {2, 5}) {
      const std::string what = "kind " + std::string(tag_name(kind)) + " map " + std::to_string(i);
      expect_map_equals_serial(ex, ids[size_t(i)], serial_map(v.sb, params[size_t(i)], v.frags, kTexelNodeCapacity),
                               layout_params(kind), params[size_t(i)].epsilon, what);
      expect_pyramid(ex, ids[size_t(i)], params[size_t(i)].blocker_pyramid, what);
    }
  }
}

// The bytes of every array of a store (its host view), to compare.
std::vector<std::vector<unsigned char>> store_bytes(const DsmStorage& s) {
  const auto bytes = [](auto span) {
    const auto* p = reinterpret_cast<const unsigned char*>(span.data());
    return std::vector<unsigned char>(p, p + span.size() * sizeof(*span.data()));
  };
  return {bytes(s.grey.texels), bytes(s.grey.nodes), bytes(s.grey.chunks), bytes(s.rgb.texels),   bytes(s.rgb.nodes),
          bytes(s.rgb.chunks),  bytes(s.grey.tags),  bytes(s.rgb.tags),    bytes(s.grey.pyramid), bytes(s.rgb.pyramid)};
}

// A build that fails at any of its steps (each allocation and each launch in
// turn, the failure injected into HostExec) leaves the store and every
// earlier map as they were, and the next build succeeds (issue 26 item 4).
TEST(ExecBackend, AFailedBuildLeavesTheStoreAsItWas) {
  OneView v(parity::load("depth", 32, 32, 24), 0.002f);
  for (DsmLayout kind : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
    int failures = 0;
    for (int64_t n = 0; n < 1000; ++n) {
      HostBackend ex("cpu");
      ex.update_scene(v.sb, SceneChange::all());
      ex.light_pass().walk_nodes = 8;  // texels walked twice as well: every step of a build
      std::vector<MapId> ids;
      for (int i = 0; i < 2; ++i) {
        LightPassParams p = v.params;
        p.rgb = i == 1;
        p.blocker_pyramid = i == 0;
        DsmBuildStats st;
        FragmentBuffers f = v.frags;
        ids.push_back(build_map_from_host(ex, p, f, layout_params(kind), st));
      }
      const auto before = store_bytes(ex.storage());
      const DsmMap h0 = ex.map_header(ids[0]), h1 = ex.map_header(ids[1]);
      const MapStoreStats ms = ex.map_store();
      ex.executor().fail_after = n;
      bool threw = false;
      DsmBuildStats st;
      try {
        LightPassParams p = v.params;
        p.blocker_pyramid = true;  // its launches fail too
        FragmentBuffers f = v.frags;
        build_map_from_host(ex, p, f, layout_params(kind), st);
      } catch (const std::runtime_error&) {
        threw = true;
      }
      ex.executor().fail_after = -1;
      if (!threw) {
        EXPECT_GE(failures, 6) << "kind " << tag_name(kind) << ": a build has that many steps to fail";
        std::printf("[ failure  ] layout %u: a failure injected at each of %d steps left the store intact\n",
                    unsigned(kind), failures);
        break;
      }
      ++failures;
      const std::string what = "kind " + std::string(tag_name(kind)) + ", failure at step " + std::to_string(n);
      EXPECT_TRUE(store_bytes(ex.storage()) == before) << what << ": the store changed";
      const DsmMap a0 = ex.map_header(ids[0]), a1 = ex.map_header(ids[1]);
      EXPECT_EQ(std::memcmp(&h0, &a0, sizeof h0), 0) << what;
      EXPECT_EQ(std::memcmp(&h1, &a1, sizeof h1), 0) << what;
      EXPECT_EQ(ex.map_store().live_bytes, ms.live_bytes) << what;
      EXPECT_EQ(ex.map_store().maps, ms.maps) << what;
      // The store works on: the map builds, and reads as the serial walk.
      FragmentBuffers f = v.frags;
      const MapId id = build_map_from_host(ex, v.params, f, layout_params(kind), st);
      expect_map_equals_serial(ex, id, serial_map(v.sb, v.params, v.frags, kTexelNodeCapacity), layout_params(kind),
                               v.params.epsilon, what);
    }
  }
}

// Compaction follows the freed maps' bytes, not the arrays' growth slack:
// five equal maps (the arrays grown by half hold room for more), one freed
// is a fifth of the store and stays; two freed are compacted away.
TEST(ExecBackend, CompactionFollowsHolesNotArrayCapacity) {
  OneView v(parity::load("depth", 32, 32, 24), 0.005f);
  HostBackend b("cpu");
  b.update_scene(v.sb, SceneChange::all());
  std::vector<MapId> ids;
  for (int i = 0; i < 5; ++i) {
    DsmBuildStats st;
    FragmentBuffers f = v.frags;
    ids.push_back(build_map_from_host(b, v.params, f, layout_params(DsmLayout::Packed), st));
  }
  const uint64_t one = b.map_store().live_bytes / 5;
  EXPECT_GT(b.map_store().allocated_bytes, b.map_store().live_bytes) << "growth slack to ignore";
  b.free_map(ids[0]);
  EXPECT_EQ(b.map_store().compactions, 0u) << "a fifth of the store freed";
  EXPECT_EQ(b.map_store().live_bytes, 4 * one);
  const uint64_t allocated = b.map_store().allocated_bytes;
  b.free_map(ids[1]);
  EXPECT_EQ(b.map_store().compactions, 1u) << "two fifths freed";
  EXPECT_EQ(b.map_store().live_bytes, 3 * one);
  EXPECT_EQ(b.map_store().allocated_bytes, allocated) << "compacted inside the arrays, which keep their capacity";
}

// Compaction moves the maps inside their arrays, which keep their capacity:
// a frame that replaces a map (freed, compacted, built again) allocates
// nothing once warm, and the maps read as the serial walk; when far more
// was freed than is left, the next build gives the memory back.
TEST(ExecBackend, CompactionInPlaceKeepsTheArrays) {
  OneView v(parity::load("depth", 32, 32, 24), 0.005f);
  const std::vector<SerialTexel> serial = serial_map(v.sb, v.params, v.frags, kTexelNodeCapacity);
  for (DsmLayout kind : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
    const std::string what(tag_name(kind));
    HostBackend b("cpu");
    b.update_scene(v.sb, SceneChange::all());
    std::vector<MapId> ids;
    std::vector<bool> pyramids;  // per map of ids
    const auto build = [&](bool pyramid) {
      LightPassParams p = v.params;
      p.blocker_pyramid = pyramid;
      DsmBuildStats st;
      FragmentBuffers f = v.frags;
      ids.push_back(build_map_from_host(b, p, f, layout_params(kind), st));
      pyramids.push_back(pyramid);
    };
    for (int i = 0; i < 3; ++i) build(i == 1);
    // A map's blocker pyramid cells, as they lie in the store.
    const auto cells = [&](MapId id) {
      const DsmStorage st = b.storage();
      const DsmMap m = b.map_header(id);
      const Span<const float> p = st.grey.pyramid;
      const uint64_t first = m.texel_offset / 2u, n = uint64_t(m.res) * uint64_t(m.view.height) / 2u;
      return std::vector<float>(p.begin() + first, p.begin() + first + n);
    };
    for (int frame = 0; frame < 3; ++frame) {  // the first map replaced: its hole leads the store
      std::vector<std::vector<float>> kept;
      for (size_t i = 1; i < ids.size(); ++i) kept.push_back(cells(ids[i]));
      const exec::ExecCounters before = b.executor().counters;
      const uint64_t compactions = b.map_store().compactions;
      b.free_map(ids[0]);
      ids.erase(ids.begin());
      pyramids.erase(pyramids.begin());
      build(frame % 2 == 0);
      EXPECT_EQ(b.map_store().compactions, compactions + 1) << what << ", frame " << frame;
      if (frame > 0) {
        EXPECT_EQ(b.executor().counters.since(before).allocations, 0u) << what << ", frame " << frame;
      }
      for (size_t i = 0; i + 1 < ids.size(); ++i)
        EXPECT_TRUE(cells(ids[i]) == kept[i]) << what << ", frame " << frame << ": map " << i << "'s pyramid moved";
      for (size_t i = 0; i < ids.size(); ++i) {
        const std::string where = what + ", frame " + std::to_string(frame) + ", map " + std::to_string(i);
        expect_map_equals_serial(b, ids[i], serial, layout_params(kind), v.params.epsilon, where);
        expect_pyramid(b, ids[i], pyramids[i], where);
      }
    }
    for (int i = 0; i < 6; ++i) build(false);
    std::vector<MapId> gone(ids.begin(), ids.end() - 1);
    b.free_maps(gone);
    build(false);  // the frame's builds done: capacity past three times what is held goes back
    EXPECT_LE(b.map_store().allocated_bytes, 3 * b.map_store().live_bytes) << what << ": memory given back";
    for (size_t i = ids.size() - 2; i < ids.size(); ++i)
      expect_map_equals_serial(b, ids[i], serial, layout_params(kind), v.params.epsilon, what + ", the last two");
  }
}

// What a compaction leaves in place, per storage array
// (storage_kept_bytes), is what a mirror of the storage may keep (the GL
// map buffers, issue 45 item 5): a mirror taken before the compaction, its
// first kept bytes kept and the rest copied, equals the storage after it —
// when the maps after a hole move down (the first map stays), and when the
// last maps go and nothing moves but the arrays end earlier, where the next
// map is then built (a different one: a larger epsilon).
TEST(ExecBackend, CompactionSaysWhatItKeptInPlace) {
  OneView v(parity::load("depth", 32, 32, 24), 0.005f);
  using Bytes = std::vector<unsigned char>;
  const auto arrays = [](const ShadowBackend& b) {
    std::vector<Bytes> out;
    const DsmStorage s = b.storage();
    for (int a = 0; a < kStorageArrays; ++a) {
      const StorageBytes x = storage_bytes(s, StorageArray(a));
      const auto* p = static_cast<const unsigned char*>(x.data);
      out.push_back(p ? Bytes(p, p + x.bytes) : Bytes{});
    }
    return out;
  };
  for (DsmLayout kind : {DsmLayout::Packed, DsmLayout::Fixed, DsmLayout::Chunked}) {
    for (bool tail : {false, true}) {
      const std::string what =
          std::string(tag_name(kind)) + (tail ? ", the last maps freed" : ", a hole after the first");
      HostBackend b("cpu");
      b.update_scene(v.sb, SceneChange::all());
      const auto build = [&](float epsilon) {
        LightPassParams p = v.params;
        p.epsilon = epsilon;
        DsmBuildStats st;
        FragmentBuffers f = v.frags;
        return build_map_from_host(b, p, f, layout_params(kind), st);
      };
      std::vector<MapId> ids;
      for (int i = 0; i < 4; ++i) ids.push_back(build(v.params.epsilon));
      const uint64_t epoch = b.storage_epoch();
      const std::vector<Bytes> before = arrays(b);
      b.free_maps(tail ? std::vector<MapId>{ids[2], ids[3]} : std::vector<MapId>{ids[1], ids[2]});
      ASSERT_EQ(b.map_store().compactions, 1u) << what;
      ASSERT_GT(b.storage_epoch(), epoch) << what;
      build(4.0f * v.params.epsilon);
      uint64_t kept[kStorageArrays];
      b.storage_kept_bytes(epoch, kept);
      const std::vector<Bytes> after = arrays(b);
      bool kept_any = false;
      for (int a = 0; a < kStorageArrays; ++a) {
        SCOPED_TRACE(what + ", array " + std::to_string(a));
        const size_t from = size_t(std::min<uint64_t>({kept[a], before[a].size(), after[a].size()}));
        Bytes mirror(before[a].begin(), before[a].begin() + std::ptrdiff_t(from));
        mirror.insert(mirror.end(), after[a].begin() + std::ptrdiff_t(from), after[a].end());
        EXPECT_TRUE(mirror == after[a]) << "kept " << kept[a] << " of " << before[a].size() << " bytes";
        EXPECT_LT(from, after[a].size() + (after[a].empty() ? 1 : 0)) << "the map built after it is new";
        kept_any = kept_any || from > 0;
      }
      EXPECT_TRUE(kept_any) << what << ": the first map stays where it is";
      uint64_t now[kStorageArrays];
      b.storage_kept_bytes(b.storage_epoch(), now);
      for (int a = 0; a < kStorageArrays; ++a)
        EXPECT_EQ(now[a], ~uint64_t(0)) << what << ": the current epoch keeps all";
      b.storage_kept_bytes(0, now);
      for (int a = 0; a < kStorageArrays; ++a) EXPECT_EQ(now[a], 0u) << what << ": before the first store";
    }
  }
}

// The camera pass: every pixel as a plain loop over shade_pixel shades it,
// bit for bit, over the backend's maps.
TEST(ExecBackend, ImageEqualsASerialCameraPass) {
  for (const char* name : kScenes) {
    Scene s = parity::load(name, 48, 40, 30);
    parity::Frame f;
    parity::run(s, std::make_unique<HostBackend>("cpu"), f);
    const SceneBuffers& sb = FrameSnapshot(*f.system).compiled();
    const ShadowView sv = f.frame.view(s.shadows);
    std::vector<uint32_t> inside;
    const CameraPassParams cam = cdsm_test::camera_pass_params(s, sb.view(), inside);
    FragmentBuffers fb;
    cast_fragments(sb.view(), cam.view, ObjectMask{}, fb);
    const FragmentLists lists = fb.lists();
    const DsmVisibility vis{sv};
    size_t differ = 0;
    for (int py = 0; py < cam.view.height; ++py)
      for (int px = 0; px < cam.view.width; ++px) {
        NoRecorder rec;
        WalkStats st;
        const PixelResult r = shade_pixel(sb.view(), sv.lights, vis, cam, lists.pixel(px, py), px, py, rec, st);
        const float* got = &f.rgb[3 * (size_t(py) * cam.view.width + px)];
        differ += got[0] != r.color.x || got[1] != r.color.y || got[2] != r.color.z;
      }
    EXPECT_EQ(differ, 0u) << name;
  }
}

// Several views cast together (cast_views, a frame's views with
// --fragments cuda): every view counted before a total is read, so one host
// synchronization for all of them, and each view's lists exactly those of
// cast_lists alone (different sizes and masks, a partial last block).
TEST(ExecBackend, ViewsCastTogetherReadTheirTotalsOnce) {
  Scene s = parity::load("depth", 64, 96, 64);
  SceneBuffers sb = cdsm_test::compiled_scene(s);
  HostBackend ex("cpu");
  ex.update_scene(sb, SceneChange::all());
  std::vector<uint32_t> casters =
      sb.mask_where([&](uint32_t o) { return (sb.objects[o].flags & kObjCastsShadows) != 0u; });
  PinholeView partial = camera_view(s.camera);
  partial.width = 37;
  partial.height = 23;
  const std::vector<PinholeView> views{camera_view(s.camera), partial, camera_view(s.camera), partial};
  const std::vector<ObjectMask> masks{ObjectMask{}, ObjectMask{{casters.data(), casters.size()}},
                                      ObjectMask{{casters.data(), casters.size()}}, ObjectMask{}};
  std::vector<ListsId> ids(views.size());
  const exec::ExecCounters before = ex.executor().counters;
  ex.cast_views(views.data(), masks.data(), views.size(), ids.data());
  EXPECT_EQ(ex.executor().counters.since(before).syncs, 1u) << "one read of the four views' totals";
  for (size_t i = 0; i < views.size(); ++i) {
    FragmentBuffers got, alone;
    ex.read_lists(ids[i], got);
    const ListsId one = ex.cast_lists(views[i], masks[i]);
    ex.read_lists(one, alone);
    ex.free_lists(one);
    ex.free_lists(ids[i]);
    EXPECT_EQ(got.width, alone.width) << "view " << i;
    EXPECT_EQ(got.offsets, alone.offsets) << "view " << i;
    ASSERT_EQ(got.fragments.size(), alone.fragments.size()) << "view " << i;
    EXPECT_GT(got.fragments.size(), 0u) << "view " << i;
    EXPECT_EQ(std::memcmp(got.fragments.data(), alone.fragments.data(), got.fragments.size() * sizeof(Fragment)), 0)
        << "view " << i;
  }
}

// The ray-cast fragment producer on the executor against a plain loop over
// the pixels (hd/cast.h cast_pixel).
// The backend's lists (on CPU threads: each ray cast once, blocks of
// kHostCastBlock pixels held until the scan) and the GPU's count-then-fill
// way run over CPU threads both equal a serial cast, bit for bit, for a
// view of whole blocks and one whose last block is partial.
TEST(ExecBackend, FragmentsEqualASerialRayCast) {
  for (const char* name : kScenes) {
    Scene s = parity::load(name, 64, 96, 64);
    SceneBuffers sb = cdsm_test::compiled_scene(s);
    HostBackend ex("cpu");
    ex.update_scene(sb, SceneChange::all());
    PinholeView partial = camera_view(s.camera);
    partial.width = 37;
    partial.height = 23;
    std::vector<uint32_t> casters =
        sb.mask_where([&](uint32_t o) { return (sb.objects[o].flags & kObjCastsShadows) != 0u; });
    for (const PinholeView& cam : {camera_view(s.camera), partial})
      for (ObjectMask mask : {ObjectMask{}, ObjectMask{{casters.data(), casters.size()}}}) {
        const std::string what =
            std::string(name) + " " + std::to_string(cam.width) + " x " + std::to_string(cam.height);
        std::vector<uint32_t> offsets{0};
        std::vector<Fragment> fragments;
        const bool media = mask_has_media(sb.view(), mask);
        for (int py = 0; py < cam.height; ++py)
          for (int px = 0; px < cam.width; ++px) {
            cast_pixel(sb.view(), cam, mask, media, px, py, [&](Fragment fr) { fragments.push_back(fr); });
            offsets.push_back(uint32_t(fragments.size()));
          }
        FragmentBuffers got;
        const ListsId id = ex.cast_lists(cam, mask);
        ex.read_lists(id, got);
        ex.free_lists(id);
        exec::HostExec hx;
        exec::ExecArray<uint32_t, exec::HostExec> counts(hx), twice_offsets(hx);
        exec::ExecArray<Fragment, exec::HostExec> twice_fragments(hx);
        exec::ExecArray<unsigned long long, exec::HostExec> sums(hx);
        exec::cast_fragments_twice(hx, sb.view(), cam, mask, media, counts, twice_offsets, twice_fragments, sums);
        FragmentBuffers twice;
        twice_offsets.read(twice.offsets);
        twice_fragments.read(twice.fragments);
        for (const FragmentBuffers* lists : {&got, &twice}) {
          const char* way = lists == &got ? " (once)" : " (twice)";
          EXPECT_EQ(lists->offsets, offsets) << what << way;
          ASSERT_EQ(lists->fragments.size(), fragments.size()) << what << way;
          size_t differ = 0;
          for (size_t i = 0; i < fragments.size(); ++i)
            differ += lists->fragments[i].depth != fragments[i].depth || lists->fragments[i].bits != fragments[i].bits;
          EXPECT_EQ(differ, 0u) << what << way;
        }
      }
  }
}

// Fragment lists are held by the backend where its kernels read them: host
// lists are moved in on CPU threads (no bytes), copies are made on the
// executor (no bytes), only a read to the host moves them; a freed or
// unknown id, malformed lists and lists of another size than the camera's
// view are refused by name.
TEST(ExecBackend, FragmentListsAreHeldWhereTheyAreUsed) {
  Scene s = parity::load("default", 48, 40, 30);
  SceneBuffers sb = cdsm_test::compiled_scene(s);
  HostBackend ex("cpu");
  ex.update_scene(sb, SceneChange::all());
  ex.take_counters();
  const PinholeView cam = camera_view(s.camera);
  FragmentBuffers host;
  cast_fragments(sb.view(), cam, ObjectMask{}, host);
  ASSERT_GT(host.total(), 0u);
  const FragmentBuffers original = host;

  const ListsId adopted = ex.adopt_lists(std::move(host));
  const ListsId cast = ex.cast_lists(cam, ObjectMask{});
  const ListsId copy = ex.copy_lists(adopted);
  EXPECT_EQ(ex.take_counters().bytes_up, 0u) << "moved in, cast and copied in the executor's memory";
  const uint64_t bytes = (original.offsets.size()) * sizeof(uint32_t) + original.total() * sizeof(Fragment);
  for (ListsId id : {adopted, cast, copy}) {
    EXPECT_EQ(ex.lists_fragments(id), original.total());
    EXPECT_EQ(ex.lists_bytes(id), bytes);
    FragmentBuffers back;
    ex.read_lists(id, back);
    EXPECT_EQ(back.offsets, original.offsets) << "lists " << id;
    ASSERT_EQ(back.fragments.size(), original.fragments.size());
    EXPECT_EQ(std::memcmp(back.fragments.data(), original.fragments.data(), back.fragments.size() * sizeof(Fragment)),
              0);
  }
  EXPECT_EQ(ex.take_counters().bytes_down, 3 * bytes) << "reads to the host are counted";
  EXPECT_EQ(ex.map_store().lists, 3u);
  EXPECT_EQ(ex.map_store().list_bytes, 3 * bytes);

  // The camera pass sorts the lists it reads, in place: the adopted vector
  // itself on CPU threads; the copy stays as it was.
  CameraPassParams cp;
  cp.view = cam;
  std::vector<float> rgb;
  WalkStats w;
  ex.camera_pass(ShadowView{}, cp, adopted, rgb, w);
  FragmentBuffers sorted, unsorted;
  ex.read_lists(adopted, sorted);
  ex.read_lists(copy, unsorted);
  EXPECT_EQ(std::memcmp(unsorted.fragments.data(), original.fragments.data(), original.total() * sizeof(Fragment)), 0);
  size_t out_of_order = 0, moved = 0;
  for (int p = 0; p < cam.width * cam.height; ++p)
    for (uint32_t i = sorted.offsets[p] + 1; i < sorted.offsets[p + 1]; ++i)
      out_of_order += sorted.fragments[i].depth < sorted.fragments[i - 1].depth;
  for (size_t i = 0; i < original.total(); ++i) moved += sorted.fragments[i].depth != original.fragments[i].depth;
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_GT(moved, 0u) << "the camera pass sorted the held lists";

  ex.free_lists(copy);
  EXPECT_EQ(ex.map_store().lists, 2u);
  auto message = [](auto f) {
    try {
      f();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // (a broken contract: CDSM_CHECK's message starts with what was expected)
  const auto starts = [](const std::string& m, const std::string& with) { return m.rfind(with, 0) == 0; };
  std::string m = message([&] { ex.free_lists(copy); });
  EXPECT_TRUE(starts(m, "free_lists: fragment lists " + std::to_string(copy) + " are not held")) << m;
  m = message([&] { ex.lists_fragments(99); });
  EXPECT_TRUE(starts(m, "lists_fragments: fragment lists 99 are not held")) << m;
  FragmentBuffers bad;
  bad.width = 4;
  bad.height = 4;
  bad.offsets.assign(16, 0u);
  EXPECT_EQ(message([&] { ex.adopt_lists(std::move(bad)); }),
            "adopt_lists: 16 offsets for lists of 4x4 pixels (width * height + 1 expected)");
  cp.view.width = cam.width + 1;
  EXPECT_EQ(message([&] { ex.camera_pass(ShadowView{}, cp, cast, rgb, w); }),
            "camera_pass: fragment lists of " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                " pixels for a view of " + std::to_string(cam.width + 1) + "x" + std::to_string(cam.height));
  ex.free_lists(adopted);
  ex.free_lists(cast);
  EXPECT_EQ(ex.map_store().lists, 0u);
  EXPECT_EQ(ex.map_store().list_bytes, 0u);
}

TEST(ExecScan, ExclusiveSumAcrossChunks) {
  exec::HostExec ex;
  std::mt19937 rng(3);
  for (uint64_t n : {1ull, 2ull, 1023ull, 1024ull, 1025ull, 5000ull, 70000ull}) {
    std::vector<uint32_t> in(n);
    for (uint32_t& v : in) v = rng() % 100;
    exec::ExecArray<uint32_t, exec::HostExec> a(ex), b(ex);
    exec::ExecArray<unsigned long long, exec::HostExec> sums(ex);
    a.assign(in);
    b.resize_discard(n);
    const uint64_t total = exec::exclusive_scan(ex, a.data(), b.data(), n, sums);
    std::vector<uint32_t> out;
    b.read(out);
    uint64_t run = 0;
    for (uint64_t i = 0; i < n; ++i) {
      ASSERT_EQ(out[i], run) << "n " << n << " i " << i;
      run += in[i];
    }
    EXPECT_EQ(total, run);
  }
}

const char* const kLightPassLaunches[] = {"light pass: walk", "light pass: reserve tiles", "light pass: copy"};

TEST(ExecBackend, StageTimesNameEveryLaunch) {
  Scene s = parity::load("default", 32, 32, 24);
  parity::Frame f;
  parity::run(s, std::make_unique<HostBackend>("cpu"), f);
  // The system took the backend's stage times into its FrameStats.
  std::vector<std::string> names;
  for (const KernelTime& k : f.frame_stats.times.kernels) names.push_back(k.name);
  for (const char* want : kLightPassLaunches)
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
  EXPECT_NE(std::find(names.begin(), names.end(), "camera pass"), names.end());
  EXPECT_TRUE(f.backend().take_stage_times().empty()) << "taken: the next call starts empty";
}

// A frame's stages timed inside the backend's kernels (StageTimes::kernel_*:
// CUDA events on the cuda backend, the wall clock of each parallel_for on
// CPU threads), reported in FrameStats like the host stages.
TEST(ExecBackend, KernelTimesReachFrameStats) {
  Scene s = parity::load("default", 32, 48, 32);
  SystemOptions o;
  o.fragments = FragmentSource::Cpu;
  o.backend = Backend::Cpu;
  ShadowSystem sys(o);
  sync_scene(sys, s);
  FrameStats se;
  sys.render(&se);
  EXPECT_GT(se.times.kernel_dsm_build_ms, 0.0);
  EXPECT_GT(se.times.kernel_camera_ms, 0.0);
  EXPECT_EQ(se.times.kernel_fragments_ms, 0.0) << "the frame's fragments are cast by the producer, not the backend";
  double build = 0.0, camera = 0.0;
  std::vector<std::string> names;
  for (const KernelTime& k : se.times.kernels) {
    EXPECT_GT(k.launches, 0u) << k.name;
    names.push_back(k.name);
    (k.name == "camera pass" ? camera : build) += k.ms;
  }
  for (const char* want : kLightPassLaunches)
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
  EXPECT_DOUBLE_EQ(build, se.times.kernel_dsm_build_ms);
  EXPECT_DOUBLE_EQ(camera, se.times.kernel_camera_ms);

  // A frame that builds no map launches no light pass.
  FrameStats again;
  sys.render(&again);
  EXPECT_EQ(again.maps_rebuilt, 0u);
  EXPECT_EQ(again.times.kernel_dsm_build_ms, 0.0);
  EXPECT_GT(again.times.kernel_camera_ms, 0.0);
}

// The camera pass into a GL pixel buffer needs CUDA-GL interop: on CPU
// threads it is refused (the frame reads the image on the host).
TEST(ExecBackend, CameraPassToGlNeedsInterop) {
  std::unique_ptr<ShadowBackend> cpu = make_cpu_backend();
  WalkStats w;
  EXPECT_FALSE(cpu->can_write_gl_maps());
  EXPECT_THROW(cpu->camera_pass_to_gl(ShadowView{}, CameraPassParams{}, ListsId{0}, 1u, 16u, 1u, w), std::logic_error);
}
