// The cuda backend's code on CPU threads (shadows/exec/ over HostExec):
// the two-pass light pass (count -> tile reservation -> write, spilled
// texels in the bounded buffer), the layouts, the store's compaction, the
// camera pass and the ray-cast fragment producer give exactly what the cpu
// backend gives, on the GPU suite's three scenes. Runs in every build: the
// GPU runs this code through cuda/launch.cuh (tests/gpu/test_cuda_backend.cpp).
#include <gtest/gtest.h>

#include <random>

#include "cdsm/shadow_system.h"
#include "cpu/cpu_backend.h"
#include "exec/exec_backend.h"
#include "exec/host_exec.h"
#include "exec/scan.h"
#include "parity.h"
#include "shadow_system_impl.h"

using namespace cdsm;
using HostBackend = exec::ExecBackend<exec::HostExec>;

namespace {

const char* kScenes[] = {"default", "volumes", "depth"};

struct LayoutCase {
  const char* name;
  DsmLayout layout;
};
const LayoutCase kLayouts[] = {{"packed", DsmLayout::Packed}, {"fixed", DsmLayout::Fixed}, {"chunked", DsmLayout::Chunked}};

// Both backends on one scene: every map's node lists and stats, and the image, identical.
void expect_identical_frames(const Scene& s, const std::string& what, HostBackend& ex) {
  SceneBuffers sb = compile_scene(s);
  std::unique_ptr<ShadowBackend> cpu = make_cpu_backend();
  parity::Frame a, b;
  parity::run(s, sb, *cpu, a);
  parity::run(s, sb, ex, b);
  ASSERT_EQ(a.frame.maps.size(), b.frame.maps.size()) << what;
  const DsmStorage sa = cpu->storage(), sx = ex.storage();
  for (size_t k = 0; k < a.frame.maps.size(); ++k) {
    const DsmMap& ma = a.frame.headers[k];
    const DsmMap& mb = b.frame.headers[k];
    ASSERT_EQ(ma.rgb, mb.rgb) << what << " map " << k;
    const parity::MapComparison c = parity::compare_maps(sa, ma, sx, mb);
    EXPECT_EQ(c.identical, c.texels) << what << " map " << k << ": " << c.first_difference;
    const DsmBuildStats& x = a.stats[k];
    const DsmBuildStats& y = b.stats[k];
    EXPECT_EQ(x.nodes, y.nodes) << what << " map " << k;
    EXPECT_EQ(x.max_nodes, y.max_nodes) << what << " map " << k;
    EXPECT_EQ(x.max_built_nodes, y.max_built_nodes) << what << " map " << k;
    EXPECT_EQ(x.overflow_texels, y.overflow_texels) << what << " map " << k;
    EXPECT_EQ(x.layout_overflow_texels, y.layout_overflow_texels) << what << " map " << k;
    EXPECT_EQ(x.max_extra_error, y.max_extra_error) << what << " map " << k;
    EXPECT_EQ(x.index_bytes, y.index_bytes) << what << " map " << k;
    EXPECT_EQ(x.node_bytes_allocated, y.node_bytes_allocated) << what << " map " << k;
    EXPECT_EQ(x.node_bytes_used, y.node_bytes_used) << what << " map " << k;
    EXPECT_EQ(x.walk.unmatched, y.walk.unmatched) << what << " map " << k;
    EXPECT_EQ(x.walk.enclosing_overflow, y.walk.enclosing_overflow) << what << " map " << k;
  }
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  size_t differ = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) differ += a.rgb[i] != b.rgb[i];
  EXPECT_EQ(differ, 0u) << what << ": image values differ";
  EXPECT_EQ(a.walk.unmatched, b.walk.unmatched) << what;
}

// A light view of `s`'s first light with its casters' fragment lists.
struct OneView {
  Scene scene;
  SceneBuffers sb;
  std::vector<uint32_t> casters, inside;
  FragmentBuffers frags;
  LightPassParams params{};
  explicit OneView(Scene s, float eps) : scene(std::move(s)), sb(compile_scene(scene)) {
    const SceneView sv = sb.view();
    LightSetup ls = setup_lights(scene.lights, sb, scene.shadows.resolution);
    casters = sb.mask_where([&](uint32_t o) { return (sb.objects[o].flags & kObjCastsShadows) != 0u; });
    ObjectMask mask{{casters.data(), casters.size()}};
    cast_fragments(sv, ls.maps[0].view, mask, frags);
    inside = objects_containing(sv, ls.maps[0].view.eye, mask);
    params = LightPassParams{ls.maps[0].view, eps, {inside.data(), inside.size()}};
  }
};

DsmLayoutParams layout_params(uint32_t kind) { return {kind, 24, 64}; }

}  // namespace

TEST(ExecBackend, SameMapsAndImageAsCpuBackend) {
  for (const char* name : kScenes)
    for (const LayoutCase& l : kLayouts) {
      Scene s = parity::load(name, 64, 64, 48);
      s.shadows.layout = l.layout;
      HostBackend ex("exec on CPU threads");
      expect_identical_frames(s, std::string(name) + " " + l.name, ex);
    }
}

// The scenes exercise what the kernels must handle: RGB maps, volumes,
// texels with many nodes.
TEST(ExecBackend, SuiteScenesCoverRgbMapsAndDeepTexels) {
  uint32_t rgb_maps = 0, deepest = 0;
  for (const char* name : kScenes) {
    Scene s = parity::load(name, 64, 32, 24);
    SceneBuffers sb = compile_scene(s);
    std::unique_ptr<ShadowBackend> cpu = make_cpu_backend();
    parity::Frame f;
    parity::run(s, sb, *cpu, f);
    for (size_t k = 0; k < f.frame.maps.size(); ++k) {
      rgb_maps += f.frame.headers[k].rgb;
      deepest = std::max(deepest, f.stats[k].max_nodes);
    }
  }
  EXPECT_GT(rgb_maps, 0u);
  EXPECT_GT(deepest, 150u) << "the depth scene should give texels with many nodes";
}

// Texels over node_limit(K) are built in a bounded buffer of K nodes, as the
// cpu driver builds them: a small K makes many texels spill; the nodes, the
// counts and the error bound are the cpu driver's with the same K.
TEST(ExecBackend, SpilledTexelsEqualTheBoundedBuffer) {
  constexpr int K = 16;
  Scene s = parity::load("depth", 48, 32, 24);
  for (bool rgb : {false, true})
    for (uint32_t kind : {kDsmPacked, kDsmFixed, kDsmChunked})
      for (exec::LightPassMode mode : {exec::LightPassMode::TwoPass, exec::LightPassMode::Staged}) {
        const std::string what = std::string(rgb ? "rgb " : "grey ") + std::to_string(kind) +
                                 (mode == exec::LightPassMode::TwoPass ? " two-pass" : " staged");
        OneView v(s, 0.002f);
        v.params.rgb = rgb;
        DsmBuffers ref;
        FragmentBuffers f1 = v.frags;
        const DsmBuildStats rs = build_dsm(v.sb.view(), v.params, f1.lists(), ref, layout_params(kind), K);
        HostBackend ex("exec");
        ex.update_scene(v.sb, SceneChange{true, 0, 0, true});
        ex.light_pass().node_capacity = K;
        ex.light_pass().mode = mode;
        FragmentBuffers f2 = v.frags;
        DsmBuildStats xs;
        const MapId id = ex.build_map(v.params, f2.lists(), layout_params(kind), xs);
        const parity::MapComparison c = parity::compare_maps(ref.storage(), ref.maps[0], ex.storage(), ex.map_header(id));
        EXPECT_EQ(c.identical, c.texels) << what << ": " << c.first_difference;
        EXPECT_GT(rs.overflow_texels, 100u) << what;
        EXPECT_EQ(xs.overflow_texels, rs.overflow_texels) << what;
        EXPECT_EQ(xs.nodes, rs.nodes) << what;
        EXPECT_EQ(xs.max_built_nodes, rs.max_built_nodes) << what;
        // The staged buffer removes by scan (a looser, still valid bound);
        // two-pass spills into the cpu driver's heap buffer: the same bound.
        if (mode == exec::LightPassMode::TwoPass || rgb) {
          EXPECT_EQ(xs.max_extra_error, rs.max_extra_error) << what;
        } else {
          EXPECT_GE(xs.max_extra_error, rs.max_extra_error) << what;
        }
      }
}

// Maps in two-pass mode never go through a per-texel buffer of K nodes:
// with the default K no texel of the suite is re-compressed.
TEST(ExecBackend, TwoPassStoresEveryNodeOfDeepTexels) {
  Scene s = parity::load("depth", 48, 32, 24);
  OneView v(s, 0.0f);  // eps 0: every sample is a node
  HostBackend ex("exec");
  ex.update_scene(v.sb, SceneChange{true, 0, 0, true});
  DsmBuildStats st;
  ex.build_map(v.params, v.frags.lists(), layout_params(kDsmPacked), st);
  EXPECT_EQ(st.overflow_texels, 0u);
  EXPECT_GT(st.max_nodes, 200u);
  EXPECT_EQ(st.slack_bytes, 0u) << "packed: exact allocation";
}

TEST(ExecBackend, BaselinesAsCpuBackend) {
  const ShadowMethod methods[] = {ShadowMethod::ShadowMap, ShadowMethod::OpacitySlices, ShadowMethod::FixedNodes};
  for (ShadowMethod m : methods)
    for (float param : {0.0f, 5.0f}) {
      Scene s = parity::load("volumes", 48, 32, 24);
      s.shadows.method = m;
      s.shadows.method_param = m == ShadowMethod::ShadowMap ? param * 0.1f : param;
      HostBackend ex("exec");
      expect_identical_frames(s, "method " + std::to_string(int(m)) + " param " + std::to_string(param), ex);
    }
}

// Freed maps leave holes; compaction moves the rest (offsets and chunk
// links re-based) and they read as before, as on the cpu backend.
TEST(ExecBackend, FreeAndCompactKeepTheOtherMaps) {
  Scene s = parity::load("depth", 32, 32, 24);
  for (uint32_t kind : {kDsmPacked, kDsmFixed, kDsmChunked}) {
    OneView v(s, 0.005f);
    std::unique_ptr<ShadowBackend> cpu = make_cpu_backend();
    HostBackend ex("exec");
    cpu->update_scene(v.sb, SceneChange{true, 0, 0, true});
    ex.update_scene(v.sb, SceneChange{true, 0, 0, true});
    std::vector<MapId> ids_c, ids_x;
    for (int i = 0; i < 6; ++i) {
      LightPassParams p = v.params;
      p.epsilon = 0.002f * float(i + 1);
      p.rgb = (i % 2) == 1;
      DsmBuildStats st;
      FragmentBuffers f1 = v.frags, f2 = v.frags;
      ids_c.push_back(cpu->build_map(p, f1.lists(), layout_params(kind), st));
      ids_x.push_back(ex.build_map(p, f2.lists(), layout_params(kind), st));
    }
    for (int i : {0, 1, 3, 4}) {
      cpu->free_map(ids_c[size_t(i)]);
      ex.free_map(ids_x[size_t(i)]);
    }
    EXPECT_GT(ex.map_store().compactions, 0u) << "kind " << kind;
    EXPECT_EQ(ex.map_store().compactions, cpu->map_store().compactions);
    EXPECT_EQ(ex.map_store().live_bytes, cpu->map_store().live_bytes);
    for (int i : {2, 5}) {
      const parity::MapComparison c =
          parity::compare_maps(cpu->storage(), cpu->map_header(ids_c[size_t(i)]), ex.storage(), ex.map_header(ids_x[size_t(i)]));
      EXPECT_EQ(c.identical, c.texels) << "kind " << kind << " map " << i << ": " << c.first_difference;
    }
  }
}

// Compaction follows the freed maps' bytes, not the arrays' growth slack:
// five equal maps (the arrays grown by doubling hold room for eight), one
// freed is a fifth of the store and stays; two freed are compacted away.
TEST(ExecBackend, CompactionFollowsHolesNotArrayCapacity) {
  Scene s = parity::load("depth", 32, 32, 24);
  OneView v(s, 0.005f);
  std::unique_ptr<ShadowBackend> cpu = make_cpu_backend();
  HostBackend ex("exec");
  for (ShadowBackend* b : {cpu.get(), static_cast<ShadowBackend*>(&ex)}) {
    b->update_scene(v.sb, SceneChange{true, 0, 0, true});
    std::vector<MapId> ids;
    for (int i = 0; i < 5; ++i) {
      DsmBuildStats st;
      FragmentBuffers f = v.frags;
      ids.push_back(b->build_map(v.params, f.lists(), layout_params(kDsmPacked), st));
    }
    const uint64_t one = b->map_store().live_bytes / 5;
    EXPECT_GT(b->map_store().allocated_bytes, b->map_store().live_bytes) << b->name() << ": growth slack to ignore";
    b->free_map(ids[0]);
    EXPECT_EQ(b->map_store().compactions, 0u) << b->name() << ": a fifth of the store freed";
    EXPECT_EQ(b->map_store().live_bytes, 4 * one);
    b->free_map(ids[1]);
    EXPECT_EQ(b->map_store().compactions, 1u) << b->name() << ": two fifths freed";
    EXPECT_EQ(b->map_store().allocated_bytes, 3 * one) << b->name() << ": compacted exactly";
  }
}

TEST(ExecBackend, FragmentsEqualTheCpuRayCaster) {
  for (const char* name : kScenes) {
    Scene s = parity::load(name, 64, 96, 64);
    SceneBuffers sb = compile_scene(s);
    HostBackend ex("exec");
    ex.update_scene(sb, SceneChange{true, 0, 0, true});
    const PinholeView cam = camera_view(s.camera);
    FragmentBuffers ref, got;
    cast_fragments(sb.view(), cam, ObjectMask{}, ref);
    ex.cast_fragments(cam, ObjectMask{}, got);
    EXPECT_EQ(got.offsets, ref.offsets) << name;
    ASSERT_EQ(got.fragments.size(), ref.fragments.size()) << name;
    size_t differ = 0;
    for (size_t i = 0; i < ref.fragments.size(); ++i)
      differ += got.fragments[i].depth != ref.fragments[i].depth || got.fragments[i].bits != ref.fragments[i].bits;
    EXPECT_EQ(differ, 0u) << name;
    // A light's casters only (a mask).
    std::vector<uint32_t> casters = sb.mask_where([&](uint32_t o) { return (sb.objects[o].flags & kObjCastsShadows) != 0u; });
    cast_fragments(sb.view(), cam, ObjectMask{{casters.data(), casters.size()}}, ref);
    ex.cast_fragments(cam, ObjectMask{{casters.data(), casters.size()}}, got);
    EXPECT_EQ(got.offsets, ref.offsets) << name << " (casters)";
  }
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

TEST(ExecBackend, StageTimesNameEveryLaunch) {
  Scene s = parity::load("default", 32, 32, 24);
  SceneBuffers sb = compile_scene(s);
  HostBackend ex("exec");
  parity::Frame f;
  parity::run(s, sb, ex, f);
  const std::vector<exec::StageTime> t = ex.take_stage_times();
  std::vector<std::string> names;
  for (const exec::StageTime& st : t) names.push_back(st.name);
  for (const char* want : {"light pass: count", "light pass: reserve tiles", "light pass: write", "camera pass"})
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
  EXPECT_TRUE(ex.take_stage_times().empty()) << "taken: the next call starts empty";
}

// Issue 16 item 7: a frame's stages timed inside the backend's kernels
// (StageTimes::kernel_*: CUDA events on the cuda backend, the wall clock of
// each parallel_for here), reported in FrameStats like the host stages; the
// cpu backend reports none.
TEST(ExecBackend, KernelTimesReachFrameStats) {
  Scene s = parity::load("default", 32, 48, 32);
  SystemOptions o;
  o.fragments = FragmentSource::Cpu;
  ShadowSystem cpu(o), ex(o);
  ShadowSystem::Impl& I = ex.internals();
  I.backend = std::make_unique<HostBackend>("exec");
  I.fragments.use_backend(I.backend.get());
  sync_scene(cpu, s);
  sync_scene(ex, s);
  FrameStats sc, se;
  cpu.render(&sc);
  ex.render(&se);
  EXPECT_TRUE(sc.times.kernels.empty());
  EXPECT_EQ(sc.times.kernel_dsm_build_ms + sc.times.kernel_camera_ms, 0.0);

  EXPECT_GT(se.times.kernel_dsm_build_ms, 0.0);
  EXPECT_GT(se.times.kernel_camera_ms, 0.0);
  EXPECT_EQ(se.times.kernel_fragments_ms, 0.0) << "fragments ray cast on the host";
  EXPECT_EQ(se.times.kernel_camera_fragments_ms, 0.0);
  double build = 0.0, camera = 0.0;
  std::vector<std::string> names;
  for (const KernelTime& k : se.times.kernels) {
    EXPECT_GT(k.launches, 0u) << k.name;
    names.push_back(k.name);
    (k.name == "camera pass" ? camera : build) += k.ms;
  }
  for (const char* want : {"light pass: count", "light pass: reserve tiles", "light pass: write", "camera pass"})
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
  EXPECT_DOUBLE_EQ(build, se.times.kernel_dsm_build_ms);
  EXPECT_DOUBLE_EQ(camera, se.times.kernel_camera_ms);

  // A frame that builds no map launches no light pass.
  FrameStats again;
  ex.render(&again);
  EXPECT_EQ(again.maps_rebuilt, 0u);
  EXPECT_EQ(again.times.kernel_dsm_build_ms, 0.0);
  EXPECT_GT(again.times.kernel_camera_ms, 0.0);
}

// The camera pass into a GL pixel buffer needs CUDA-GL interop: the cpu
// backend and the exec backend on CPU threads refuse it (the frame reads
// their image on the host).
TEST(ExecBackend, CameraPassToGlNeedsInterop) {
  HostBackend ex("exec");
  std::unique_ptr<ShadowBackend> cpu = make_cpu_backend();
  WalkStats w;
  for (ShadowBackend* b : {static_cast<ShadowBackend*>(&ex), cpu.get()}) {
    EXPECT_FALSE(b->can_write_gl_maps()) << b->name();
    EXPECT_THROW(b->camera_pass_to_gl(ShadowView{}, CameraPassParams{}, FragmentLists{}, 1u, 16u, 1u, w), std::logic_error)
        << b->name();
  }
}
