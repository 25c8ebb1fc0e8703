// The OpenGL fragment-list rasterizer against the exact CPU ray caster
// (DESIGN.md §2.1, §9): camera, spot and omni views of closed meshes, deep
// stacks, pool growth, tiled 4096^2 views and watertightness.
#include <cmath>
#include <random>

#include "cdsm/error.h"
#include "exec/host_exec.h"
#include "exec/scan.h"
#include "cdsm/procedural.h"
#include "hd/fragment.h"
#include "cluster/light_views.h"
#include "frame.h"
#include "hd/segments.h"
#include "gl/gl_objects.h"
#include "gl_test_util.h"

namespace cdsm::test {
namespace {

struct ViewRun {
  FragmentBuffers gl, cpu;
  Comparison cmp;
};

ViewRun run_view(gl::FragmentRasterizer& r, const TestScene& s, const PinholeView& v, ObjectMask mask = {}) {
  ViewRun out;
  r.rasterize(v, mask, out.gl);
  s.cast(v, mask, out.cpu);
  out.cmp = compare_fragments(s, v, out.gl, out.cpu);
  return out;
}

void expect_agreement(const ViewRun& run, const char* name) {
  const Comparison& c = run.cmp;
  std::printf(
      "[  compare ] %-12s %7llu px, %8llu GL / %8llu CPU fragments, %.4f%% pixels differ "
      "(%llu at edges, %llu order ties, %llu unexplained), max rel depth %.2e\n",
      name, (unsigned long long)c.pixels, (unsigned long long)c.gl_fragments, (unsigned long long)c.cpu_fragments,
      c.mismatch_percent(), (unsigned long long)(c.explained - c.order_ties), (unsigned long long)c.order_ties,
      (unsigned long long)c.unexplained, c.max_rel_depth);
  EXPECT_GT(c.cpu_fragments, 0u) << name;
  EXPECT_GE(double(c.equal), kMinEqualFraction * double(c.pixels)) << name;
  EXPECT_EQ(c.unexplained, 0u) << name << ": pixels differing away from every triangle edge:\n" << c.report;
  EXPECT_LE(c.max_rel_depth, 1e-4) << name;
}

class FragmentRaster : public GlTest {};

TEST_F(FragmentRaster, FacingFollowsTheCpuConvention) {
  // Counter-clockwise as seen from the eye (at the origin, looking down -z):
  // front. The same triangle wound the other way: back.
  TestScene s;
  s.add_triangle({-1, -1, -2}, {1, -1, -2}, {0, 1, -2}, 0);
  s.add_triangle({-1, -1, -3}, {0, 1, -3}, {1, -1, -3}, 1);
  s.finish();
  PinholeView v = look_at({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60.0f, 64, 48, 0.1f, 10.0f);
  gl::FragmentRasterizer r(context());
  s.upload(r);
  ViewRun run = run_view(r, s, v);
  // Triangle 0 must be front-facing everywhere, triangle 1 back-facing.
  for (const FragmentBuffers* b : {&run.gl, &run.cpu}) {
    uint64_t seen[2] = {0, 0}, wrong = 0;
    for (const Fragment& f : b->fragments) {
      ++seen[frag_prim(f)];
      wrong += frag_front(f) != (frag_prim(f) == 0);
    }
    const char* who = b == &run.gl ? "GL" : "CPU";
    EXPECT_GT(seen[0], 100u) << who;
    EXPECT_GT(seen[1], 100u) << who;
    EXPECT_EQ(wrong, 0u) << who << ": fragments with the wrong facing";
  }
  // Depth is radial: the length of the pixel ray to the plane z = -2, not 2.
  Vec3 dir = pixel_ray(v, 24, 30);
  float expected = 2.0f / dot(dir, v.forward);
  EXPECT_GT(expected, 2.04f);  // off-axis: longer than the axial 2
  size_t i = size_t(30) * 64 + 24;
  bool found = false;
  for (uint32_t k = run.gl.offsets[i]; k < run.gl.offsets[i + 1]; ++k)
    if (frag_prim(run.gl.fragments[k]) == 0) {
      found = true;
      EXPECT_NEAR(run.gl.fragments[k].depth, expected, 1e-5f * expected);
    }
  EXPECT_TRUE(found);
  expect_agreement(run, "facing");
}

TEST_F(FragmentRaster, MatchesCpuForCameraSpotAndOmniViews) {
  TestScene s = closed_meshes_scene();
  gl::FragmentRasterizer r(context());
  s.upload(r);

  ViewRun cam = run_view(r, s, look_at({0.5f, 2.5f, 6.5f}, {0, 0.6f, 0}, {0, 1, 0}, 50.0f, 320, 240, 0.1f, 50.0f));
  expect_agreement(cam, "camera");
  EXPECT_EQ(count_unpaired_pixels(s, cam.gl, nullptr), count_unpaired_pixels(s, cam.cpu, nullptr));

  // Off-centre window (a focused cluster frustum).
  ViewRun off = run_view(
      r, s, look_at({-3.0f, 3.0f, 4.0f}, {0, 0.5f, 0}, {0, 1, 0}, 30.0f, 200, 150, 0.5f, 20.0f, Vec2{0.21f, -0.13f}));
  expect_agreement(off, "off-centre");

  ViewRun spot = run_view(r, s, look_at({2.5f, 6.0f, 2.0f}, {0, 0, 0}, {0, 1, 0}, 70.0f, 256, 256, 0.5f, 30.0f));
  expect_agreement(spot, "spot");

  // Near and far planes cutting through the objects.
  ViewRun cut = run_view(r, s, look_at({0.0f, 1.0f, 4.0f}, {0, 0.6f, 0}, {0, 1, 0}, 60.0f, 160, 120, 3.5f, 5.3f));
  expect_agreement(cut, "near/far cut");

  // Orthographic (a directional light's map over the casters, at a generic
  // elevation): parallel rays, depths from the window's plane.
  Box3 box;
  for (size_t o = 0; o < s.sb.objects.size(); ++o) box.grow(s.sb.object_bounds[o]);
  const PinholeView sun = cluster::directional_view(normalize(Vec3{0.43f, -0.71f, -0.37f}), box, 192);
  ASSERT_TRUE(is_orthographic(sun));
  expect_agreement(run_view(r, s, sun), "orthographic");

  // (A generic position: from (0.2, 2.2, -0.9) the ground's diagonal would
  // pass exactly through a row of pixel centres, a tie the watertight test covers.)
  auto faces = omni_faces({0.23f, 2.17f, -0.86f}, 128, 0.05f, 30.0f);
  const char* names[6] = {"omni +x", "omni -x", "omni +y", "omni -y", "omni +z", "omni -z"};
  for (int f = 0; f < 6; ++f) expect_agreement(run_view(r, s, faces[size_t(f)]), names[f]);
}

TEST_F(FragmentRaster, ObjectMaskKeepsGlobalPrimitiveIds) {
  TestScene s = closed_meshes_scene();
  gl::FragmentRasterizer r(context());
  s.upload(r);
  // Objects 1, 3, 6 only (object 7 exists: words cover it).
  std::vector<uint32_t> words = {(1u << 1) | (1u << 3) | (1u << 6)};
  ObjectMask mask{{words.data(), words.size()}};
  ViewRun run =
      run_view(r, s, look_at({0.5f, 2.5f, 6.5f}, {0, 0.6f, 0}, {0, 1, 0}, 50.0f, 200, 150, 0.1f, 50.0f), mask);
  expect_agreement(run, "masked");
  for (const Fragment& f : run.gl.fragments) {
    uint32_t o = s.sb.tri_object[frag_prim(f)];
    ASSERT_TRUE(o == 1 || o == 3 || o == 6) << "primitive " << frag_prim(f) << " of object " << o;
  }
  // An empty selection draws nothing.
  std::vector<uint32_t> none = {0u};
  FragmentBuffers empty;
  r.rasterize(look_at({0, 2, 6}, {0, 0, 0}, {0, 1, 0}, 50.0f, 64, 64, 0.1f, 50.0f),
              ObjectMask{{none.data(), none.size()}}, empty);
  EXPECT_EQ(empty.total(), 0u);
  EXPECT_EQ(empty.offsets.back(), 0u);
}

TEST_F(FragmentRaster, DepthComplexityAbove32) {
  // 40 large squares at random depths, rotations and offsets, some facing
  // away: every pixel of the view is covered by all of them.
  TestScene s;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  const int kQuads = 40;
  for (int q = 0; q < kQuads; ++q) {
    float z = -1.0f - 2.0f * float(q) / kQuads - 0.01f * U(rng);
    float a = 6.2831853f * U(rng), ox = 0.2f * (U(rng) - 0.5f), oy = 0.2f * (U(rng) - 0.5f);
    Vec3 c[4];
    for (int k = 0; k < 4; ++k) {
      float ang = a + 1.5707963f * float(k);
      c[k] = {ox + 6.0f * std::cos(ang), oy + 6.0f * std::sin(ang), z};
    }
    if (q % 3 == 0) std::swap(c[1], c[3]);  // clockwise from the eye: back-facing
    s.add_triangle(c[0], c[1], c[2], uint32_t(q));
    s.add_triangle(c[0], c[2], c[3], uint32_t(q));
  }
  s.finish();
  gl::FragmentRasterizer r(context());
  s.upload(r);
  PinholeView v = look_at({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60.0f, 128, 128, 0.1f, 10.0f);
  ViewRun run = run_view(r, s, v);
  expect_agreement(run, "depth 40");
  uint64_t deep = 0;
  for (size_t i = 0; i + 1 < run.gl.offsets.size(); ++i) deep += run.gl.offsets[i + 1] - run.gl.offsets[i] == kQuads;
  EXPECT_EQ(deep, uint64_t(128 * 128)) << "pixels with all 40 layers";
}

TEST_F(FragmentRaster, GrowsThePoolAndReusesItInSteadyState) {
  TestScene s = closed_meshes_scene();
  gl::RasterOptions o;
  o.initial_pool_bytes = 4096;  // 512 fragments
  gl::FragmentRasterizer r(context(), o);
  s.upload(r);
  PinholeView v = look_at({0.5f, 2.5f, 6.5f}, {0, 0.6f, 0}, {0, 1, 0}, 50.0f, 256, 192, 0.1f, 50.0f);
  ViewRun run = run_view(r, s, v);
  expect_agreement(run, "pool grow");
  EXPECT_GT(r.stats().pool_grows, 0u);
  EXPECT_GE(r.stats().pool_bytes, r.stats().fragments * sizeof(Fragment));
  EXPECT_EQ(r.stats().fragments, run.gl.total());
  EXPECT_EQ(r.stats().tiles, 1u);
  // The same view again: no further growth, identical lists.
  const uint32_t grows = r.stats().pool_grows;
  const uint64_t bytes = r.stats().pool_bytes;
  FragmentBuffers again;
  r.rasterize(v, {}, again);
  EXPECT_EQ(r.stats().pool_grows, grows);
  EXPECT_EQ(r.stats().pool_bytes, bytes);
  EXPECT_EQ(again.offsets, run.gl.offsets);
}

TEST_F(FragmentRaster, TilesHugeViews) {
  // 4096^2 with a pool capped at 32 MiB (llvmpipe would tile anyway above
  // 128 MiB): compare with the CPU on every 128th row.
  TestScene s;
  s.add(make_sphere(1.0f, 24, 12), make_transform({0.0f, 0.0f, 0.0f}, {0, 0, 0}, {1, 1, 1}));
  s.add(make_box({1.2f, 0.8f, 1.6f}), make_transform({0.9f, -0.4f, -1.0f}, {20, 35, 0}, {1, 1, 1}));
  s.finish();
  gl::RasterOptions o;
  o.max_pool_bytes = uint64_t(32) << 20;
  gl::FragmentRasterizer r(context(), o);
  s.upload(r);
  PinholeView v = look_at({0.3f, 0.8f, 3.2f}, {0.2f, -0.1f, -0.3f}, {0, 1, 0}, 60.0f, 4096, 4096, 0.1f, 20.0f);
  FragmentBuffers gl;
  r.rasterize(v, {}, gl);
  std::printf("[  tiles   ] 4096^2: %llu fragments, %u tiles, %u bands, pool %.1f MiB, %.0f ms\n",
              (unsigned long long)r.stats().fragments, r.stats().tiles, r.stats().bands,
              double(r.stats().pool_bytes) / (1 << 20), r.stats().gpu_ms);
  EXPECT_GT(r.stats().tiles, 1u);
  EXPECT_LE(r.stats().pool_bytes, o.max_pool_bytes);
  EXPECT_GT(r.stats().fragments, uint64_t(32) << 20 >> 3) << "the view must not fit one pool";
  ASSERT_EQ(gl.offsets.size(), size_t(4096) * 4096 + 1);
  EXPECT_EQ(gl.offsets.back(), gl.total());
  Comparison sum;
  for (int row = 0; row < 4096; row += 128) {
    FragmentBuffers cpu;
    s.cast(row_view(v, row), {}, cpu);
    sum += compare_fragments(s, v, gl, cpu, 1.0 / 64.0, row);
  }
  std::printf("[  compare ] 4096^2 rows  %llu px, %llu GL / %llu CPU fragments, %.4f%% pixels differ\n",
              (unsigned long long)sum.pixels, (unsigned long long)sum.gl_fragments,
              (unsigned long long)sum.cpu_fragments, sum.mismatch_percent());
  EXPECT_GE(double(sum.equal), kMinEqualFraction * double(sum.pixels));
  EXPECT_EQ(sum.unexplained, 0u) << sum.report;
}

TEST_F(FragmentRaster, TilesAtTheSsboLimitWithDefaultOptions) {
  // A sphere filling a 4096^2 view: ~2 fragments per pixel, 256 MiB of
  // fragments, more than llvmpipe's largest SSBO (128 MiB), so the default
  // pool cap forces tiles there. (On a GPU with larger SSBOs one tile may do.)
  TestScene s;
  s.add(make_sphere(1.0f, 32, 16), Mat4{});
  s.finish();
  gl::FragmentRasterizer r(context());
  s.upload(r);
  PinholeView v = look_at({0.05f, 0.1f, 1.6f}, {0, 0, 0}, {0, 1, 0}, 55.0f, 4096, 4096, 0.1f, 20.0f);
  FragmentBuffers gl;
  r.rasterize(v, {}, gl);
  const uint64_t ssbo = uint64_t(context().limits().max_ssbo_block_size);
  std::printf(
      "[  tiles   ] 4096^2 default options: %llu fragments (%.0f MiB), %u tiles, pool %.0f MiB "
      "(SSBO limit %.0f MiB), %.0f ms\n",
      (unsigned long long)r.stats().fragments, double(r.stats().fragments * 8) / (1 << 20), r.stats().tiles,
      double(r.stats().pool_bytes) / (1 << 20), double(ssbo) / (1 << 20), r.stats().gpu_ms);
  EXPECT_LE(r.stats().pool_bytes, ssbo);
  if (r.stats().fragments * sizeof(Fragment) > ssbo) {
    EXPECT_GT(r.stats().tiles, 1u);
  }
  Comparison sum;
  for (int row = 37; row < 4096; row += 256) {
    FragmentBuffers cpu;
    s.cast(row_view(v, row), {}, cpu);
    sum += compare_fragments(s, v, gl, cpu, 1.0 / 64.0, row);
  }
  EXPECT_GE(double(sum.equal), kMinEqualFraction * double(sum.pixels));
  EXPECT_EQ(sum.unexplained, 0u) << sum.report;
}

TEST_F(FragmentRaster, CountsAreEqualWhenCountedInBands) {
  // Forcing several count passes (bands) must not change anything.
  TestScene s = closed_meshes_scene();
  gl::RasterOptions banded;
  banded.max_band_pixels = 160 * 37;  // bands of 37 rows
  banded.max_pool_bytes = 64 << 10;   // and tiles within them
  gl::FragmentRasterizer a(context()), b(context(), banded);
  s.upload(a);
  s.upload(b);
  PinholeView v = look_at({0.5f, 2.5f, 6.5f}, {0, 0.6f, 0}, {0, 1, 0}, 50.0f, 160, 120, 0.1f, 50.0f);
  FragmentBuffers fa, fb;
  a.rasterize(v, {}, fa);
  b.rasterize(v, {}, fb);
  EXPECT_GT(b.stats().bands, 1u);
  EXPECT_GT(b.stats().tiles, b.stats().bands);
  EXPECT_EQ(lists_differ(fa, fb), "");  // the same fragments per pixel, in any order
}

TEST_F(FragmentRaster, SplitsRowsWhenOneRowExceedsThePool) {
  // A pool of 48 fragments: rows of this view hold more, so tiles are pieces
  // of rows; the result must not change.
  TestScene s = closed_meshes_scene();
  gl::RasterOptions tiny;
  tiny.max_pool_bytes = 48 * sizeof(Fragment);
  gl::FragmentRasterizer a(context()), b(context(), tiny);
  s.upload(a);
  s.upload(b);
  PinholeView v = look_at({0.5f, 2.5f, 6.5f}, {0, 0.6f, 0}, {0, 1, 0}, 50.0f, 64, 48, 0.1f, 50.0f);
  FragmentBuffers fa, fb;
  a.rasterize(v, {}, fa);
  b.rasterize(v, {}, fb);
  EXPECT_GT(b.stats().tiles, uint32_t(v.height));
  EXPECT_EQ(b.stats().pool_bytes, tiny.max_pool_bytes);
  ASSERT_EQ(fa.offsets, fb.offsets);
  uint32_t widest = 0;
  for (int y = 0; y < v.height; ++y)
    widest = std::max(widest, fa.offsets[size_t(y + 1) * 64] - fa.offsets[size_t(y) * 64]);
  EXPECT_GT(widest, 48u) << "no row exceeds the pool: the row-splitting path was not taken";
  EXPECT_EQ(lists_differ(fa, fb), "");
}

// Views rasterized together (a frame's light views: counted into one
// counter buffer, scanned and read back once, filled into one pool) give
// each view the lists it gets alone: with default limits in one scan and
// one hand-over (two GL read-backs), and with a counter limit that splits
// views across batches and bands and a pool that several views' pieces
// share and that is handed over many times.
TEST_F(FragmentRaster, ViewsRasterizedTogetherEqualViewsOneByOne) {
  TestScene s = closed_meshes_scene();
  std::vector<gl::FragmentRasterizer::Job> jobs;
  const uint32_t first_only = 1u, all_but_first = ~1u;
  const PinholeView cam = look_at({0.5f, 2.5f, 6.5f}, {0, 0.6f, 0}, {0, 1, 0}, 50.0f, 96, 72, 0.1f, 50.0f);
  jobs.push_back({cam, {}});
  jobs.push_back({look_at({2.0f, 4.0f, 3.0f}, {0, 0, 0}, {0, 1, 0}, 60.0f, 64, 64, 0.1f, 50.0f), {{&first_only, 1}}});
  for (const PinholeView& f : cube_face_views({0.2f, 1.9f, 0.4f}, 40, 0.05f, 30.0f)) jobs.push_back({f, {}});
  jobs.push_back(
      {look_at({-3.0f, 1.0f, 2.0f}, {0, 0.5f, 0}, {0, 1, 0}, 40.0f, 50, 30, 0.1f, 50.0f), {{&all_but_first, 1}}});
  gl::FragmentRasterizer alone(context());
  s.upload(alone);
  std::vector<FragmentBuffers> want(jobs.size());
  for (size_t j = 0; j < jobs.size(); ++j) alone.rasterize(jobs[j].view, jobs[j].mask, want[j]);

  gl::RasterOptions limited;
  limited.max_band_pixels = 96 * 20;                // the camera view in bands; batches end mid-list
  limited.max_pool_bytes = 300 * sizeof(Fragment);  // many hand-overs, pieces of several views in one
  limited.initial_pool_bytes = 64;
  for (const gl::RasterOptions& o : {gl::RasterOptions{}, limited}) {
    gl::FragmentRasterizer r(context(), o);
    s.upload(r);
    std::vector<FragmentBuffers> got(jobs.size());
    const uint64_t reads = gl::thread_gl_counters().readbacks;
    r.rasterize({jobs.data(), jobs.size()}, got.data());
    const uint64_t read = gl::thread_gl_counters().readbacks - reads;
    const bool defaults = o.max_pool_bytes == 0;
    uint64_t total = 0;
    for (size_t j = 0; j < jobs.size(); ++j) {
      SCOPED_TRACE("view " + std::to_string(j) + (defaults ? ", default limits" : ", limited"));
      ASSERT_EQ(got[j].width, want[j].width);
      ASSERT_EQ(got[j].height, want[j].height);
      EXPECT_EQ(lists_differ(got[j], want[j]), "");
      total += want[j].total();
    }
    EXPECT_EQ(r.stats().fragments, total);
    EXPECT_GT(total, 8 * 300u) << "the limited pool must be handed over several times";
    if (defaults) {
      EXPECT_EQ(r.stats().bands, jobs.size());
      EXPECT_EQ(r.stats().scans, 1u);
      EXPECT_EQ(r.stats().flushes, 1u);
      EXPECT_EQ(read, 2u) << "one read of every view's offsets, one of their fragments";
    } else {
      EXPECT_GT(r.stats().bands, jobs.size());
      EXPECT_GT(r.stats().scans, 2u);
      EXPECT_GT(r.stats().flushes, r.stats().scans);
      EXPECT_EQ(read, uint64_t(r.stats().scans) + r.stats().flushes);
    }
  }
}

// Views handed over unchecked (rasterize_unchecked, nothing read back),
// taken as a device takes them (exec::take_gl_part over the GL buffers'
// bytes, here on CPU threads) into lists of a given capacity: with room
// enough, each view's lists equal the view rasterized alone (also with the
// camera view in bands across batches); with the pool or a view's capacity
// too small, the lists say they did not fit, their true count is still
// right, and every offset stays within the arrays (monotone, at most the
// capacity) so a build over them reads no memory past them.
TEST_F(FragmentRaster, ViewsHandedOverUncheckedEqualViewsOneByOneOrSayTheyDidNotFit) {
  TestScene s = closed_meshes_scene();
  std::vector<gl::FragmentRasterizer::Job> jobs;
  const PinholeView cam = look_at({0.5f, 2.5f, 6.5f}, {0, 0.6f, 0}, {0, 1, 0}, 50.0f, 96, 72, 0.1f, 50.0f);
  jobs.push_back({cam, {}});
  for (const PinholeView& f : cube_face_views({0.2f, 1.9f, 0.4f}, 40, 0.05f, 30.0f)) jobs.push_back({f, {}});
  gl::FragmentRasterizer alone(context());
  s.upload(alone);
  std::vector<FragmentBuffers> want(jobs.size());
  uint64_t total = 0;
  for (size_t j = 0; j < jobs.size(); ++j) {
    alone.rasterize(jobs[j].view, jobs[j].mask, want[j]);
    total += want[j].total();
  }
  ASSERT_GT(want[0].total(), 1000u);

  struct Case {
    const char* what;
    uint64_t band_pixels, pool, capacity_scale_percent;
    bool fit;
  };
  for (const Case& c :
       {Case{"room enough", 0, total, 100, true},
        Case{"the camera view in bands across batches", 96 * 20, total, 100, true},
        Case{"a pool too small", 0, total / 2, 100, false}, Case{"capacities too small", 96 * 20, total, 60, false}}) {
    SCOPED_TRACE(c.what);
    gl::RasterOptions o;
    o.max_band_pixels = c.band_pixels;
    o.initial_pool_bytes = 64;
    gl::FragmentRasterizer r(context(), o);
    s.upload(r);
    exec::HostExec ex;
    struct Lists {
      std::vector<uint32_t> offsets;
      std::vector<Fragment> fragments;
      unsigned long long status[2] = {0, 0};
    };
    std::vector<Lists> got(jobs.size());
    std::vector<FragmentBuffers> outs(jobs.size());
    for (size_t j = 0; j < jobs.size(); ++j) got[j].fragments.resize(want[j].total() * c.capacity_scale_percent / 100);
    uint64_t batches = 0;
    std::vector<unsigned char> offs, pool;
    const uint64_t reads = gl::thread_gl_counters().readbacks;
    ASSERT_TRUE(
        r.rasterize_unchecked({jobs.data(), jobs.size()}, outs.data(), c.pool, [&](const ShadowBackend::GlBatch& b) {
          ++batches;
          // (the device maps these buffers; the test reads their bytes)
          offs.resize(b.offsets_bytes);
          pool.resize(b.pool_bytes);
          glGetNamedBufferSubData(b.offsets_buffer, 0, GLsizeiptr(b.offsets_bytes), offs.data());
          glGetNamedBufferSubData(b.pool_buffer, 0, GLsizeiptr(b.pool_bytes), pool.data());
          ASSERT_LE(b.pool_fragments * sizeof(Fragment), b.pool_bytes);
          for (size_t p = 0; p < b.n; ++p) {
            const ShadowBackend::GlPart& q = b.parts[p];
            Lists& l = got[q.view];
            l.offsets.resize(uint64_t(outs[q.view].width) * uint64_t(outs[q.view].height) + 1);
            ASSERT_LE(q.first + q.count + 1, l.offsets.size());
            exec::take_gl_part(ex, reinterpret_cast<const uint32_t*>(offs.data()), q.at, q.count, b.total_at,
                               reinterpret_cast<const Fragment*>(pool.data()), b.pool_fragments, l.offsets.data(),
                               q.first, l.fragments.data(), l.fragments.size(), l.status);
          }
        }));
    EXPECT_EQ(gl::thread_gl_counters().readbacks - reads, 0u) << "the rasterizer read nothing back";
    EXPECT_EQ(batches, uint64_t(r.stats().scans));
    if (c.band_pixels) {
      EXPECT_GT(batches, 1u);
    }
    bool any_short = false;
    for (size_t j = 0; j < jobs.size(); ++j) {
      SCOPED_TRACE("view " + std::to_string(j));
      const Lists& l = got[j];
      EXPECT_EQ(l.status[0], want[j].total()) << "the true count, fit or not";
      ASSERT_EQ(l.offsets.size(), want[j].offsets.size());
      EXPECT_EQ(l.offsets[0], 0u);
      EXPECT_TRUE(std::is_sorted(l.offsets.begin(), l.offsets.end()));
      EXPECT_LE(l.offsets.back(), l.fragments.size());
      any_short = any_short || l.status[1] != 0;
      if (l.status[1] != 0) continue;
      FragmentBuffers fb;
      fb.width = outs[j].width;
      fb.height = outs[j].height;
      fb.offsets = l.offsets;
      fb.fragments.assign(l.fragments.begin(), l.fragments.begin() + l.offsets.back());
      EXPECT_EQ(lists_differ(fb, want[j]), "");
    }
    EXPECT_EQ(any_short, !c.fit);
  }
}

TEST_F(FragmentRaster, RejectsBadInputWithErrors) {
  gl::FragmentRasterizer r(context());
  std::vector<Vec3> v(4);
  std::vector<uint32_t> o(1);
  EXPECT_THROW(r.upload_scene({v.data(), v.size()}, {o.data(), o.size()}), Error);
  FragmentBuffers out;
  PinholeView huge = look_at({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60.0f, 1 << 20, 16, 0.1f, 10.0f);
  EXPECT_THROW(r.rasterize(huge, {}, out), Error);
  PinholeView empty = huge;
  empty.width = 0;
  EXPECT_THROW(r.rasterize(empty, {}, out), Error);
  // Still usable afterwards, and an empty scene gives empty lists.
  PinholeView ok = look_at({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60.0f, 32, 16, 0.1f, 10.0f);
  r.upload_scene({}, {});
  r.rasterize(ok, {}, out);
  EXPECT_EQ(out.total(), 0u);
  EXPECT_EQ(out.offsets.size(), size_t(32 * 16 + 1));
}

// Watertightness: closed meshes whose every vertex lies on a pixel-centre
// ray, so edges and vertices pass exactly through pixel centres. Every pixel
// must see entries and exits in pairs, in both producers.
TEST_F(FragmentRaster, WatertightOnPixelCentres) {
  // View: eye at the origin looking down -z; W = 128, H = 64, tan_half 2 x 1,
  // so pixel-centre directions are dyadic: exact in float.
  PinholeView v;
  v.eye = {0, 0, 0};
  v.right = {1, 0, 0};
  v.up = {0, 1, 0};
  v.forward = {0, 0, -1};
  v.tan_half_x = 2.0f;
  v.tan_half_y = 1.0f;
  v.width = 128;
  v.height = 64;
  v.near = 0.5f;
  v.far = 10.0f;
  // The point at axial distance z on the ray through the centre of pixel (px, py).
  auto at = [&](int px, int py, float z) {
    float sx = (2.0f * (float(px) + 0.5f) / float(v.width) - 1.0f) * v.tan_half_x;
    float sy = (1.0f - 2.0f * (float(py) + 0.5f) / float(v.height)) * v.tan_half_y;
    return Vec3{sx * z, sy * z, -z};
  };
  TestScene s;
  auto quad = [&](Vec3 a, Vec3 b, Vec3 c, Vec3 d, uint32_t o) {  // a-b-c-d counter-clockwise from outside
    s.add_triangle(a, b, c, o);
    s.add_triangle(a, c, d, o);
  };
  {
    // A truncated pyramid: front square (pixels 20..44) at z = 2, back square
    // (8..56) at z = 4, wound counter-clockwise seen from outside.
    Vec3 f00 = at(20, 20, 2), f10 = at(44, 20, 2), f11 = at(44, 44, 2), f01 = at(20, 44, 2);
    Vec3 b00 = at(8, 8, 4), b10 = at(56, 8, 4), b11 = at(56, 56, 4), b01 = at(8, 56, 4);
    // Image y grows downwards; from the eye, (20,44)->(44,44)->(44,20) is counter-clockwise.
    quad(f01, f11, f10, f00, 0);  // front, facing the eye
    quad(b00, b10, b11, b01, 0);  // back, facing away
    quad(f00, f10, b10, b00, 0);  // top side
    quad(f10, f11, b11, b10, 0);  // right side
    quad(f11, f01, b01, b11, 0);  // bottom side
    quad(f01, f00, b00, b01, 0);  // left side
  }
  {
    // A bipyramid: equator at z = 3 through pixels (88,16) (104,32) (88,48)
    // (72,32), apexes on the ray of pixel (88,32) at z = 2 and z = 5.
    Vec3 e[4] = {at(88, 16, 3), at(104, 32, 3), at(88, 48, 3), at(72, 32, 3)};
    Vec3 near_apex = at(88, 32, 2), far_apex = at(88, 32, 5);
    for (int k = 0; k < 4; ++k) {
      Vec3 a = e[k], b = e[(k + 1) % 4];
      s.add_triangle(near_apex, b, a, 1);
      s.add_triangle(far_apex, a, b, 1);
    }
  }
  s.sb.objects[0].flags |= kObjClosed;
  s.sb.objects[1].flags |= kObjClosed;
  s.finish();
  gl::FragmentRasterizer r(context());
  s.upload(r);
  ViewRun run = run_view(r, s, v);
  std::string first;
  EXPECT_EQ(count_unpaired_pixels(s, run.gl, &first), 0u) << "GL: " << first;
  first.clear();
  EXPECT_EQ(count_unpaired_pixels(s, run.cpu, &first), 0u) << "CPU: " << first;
  // Every pixel inside the silhouettes is crossed (twice), none outside.
  auto count = [&](const FragmentBuffers& b, int px, int py) {
    size_t i = size_t(py) * size_t(b.width) + size_t(px);
    return b.offsets[i + 1] - b.offsets[i];
  };
  EXPECT_EQ(count(run.gl, 32, 32), 2u);  // front + back face
  EXPECT_EQ(count(run.gl, 12, 30), 2u);  // side + back face
  EXPECT_EQ(count(run.gl, 88, 32), 2u);  // both apexes
  EXPECT_EQ(count(run.gl, 4, 4), 0u);
  EXPECT_EQ(count(run.cpu, 32, 32), 2u);
  EXPECT_EQ(count(run.cpu, 88, 32), 2u);
  std::printf("[  watertight ] GL %llu, CPU %llu fragments; %.3f%% pixels differ (ties broken differently)\n",
              (unsigned long long)run.gl.total(), (unsigned long long)run.cpu.total(), run.cmp.mismatch_percent());
  EXPECT_EQ(run.cmp.unexplained, 0u) << run.cmp.report;
}

// Closed boxes (like the 12-triangle volume proxies) leave no unmatched
// fragment in the segment walker with either producer: at a silhouette an
// object's exit can sort a few ulps (GL: up to ~1e-3 relative) before its own
// entry, and GL snaps vertices onto pixel centres; views face-on, edge-on,
// aimed exactly at silhouette corners (odd sizes put them on a pixel centre)
// and random, at several resolutions.
TEST_F(FragmentRaster, ClosedBoxesLeaveNoUnmatchedFragments) {
  TestScene s;
  s.add(make_box({2, 2, 2}), Mat4{});
  s.add(make_box({6, 6, 5.5f}), make_transform({0, 0, -4.25f}, {0, 0, 0}, {1, 1, 1}));  // proxy-like, off-origin
  for (ObjectData& o : s.sb.objects) {
    o.opacity = 0.0f;
    o.interior = InteriorKind::Constant;  // a medium: the walker's matching decides its segments
    o.sigma = vec3(1.0f);
  }
  s.finish();
  gl::FragmentRasterizer r(context());
  s.upload(r);
  struct View {
    std::string name;
    PinholeView v;
  };
  const SceneView sv = s.view();
  std::vector<View> views;
  for (int res : {63, 64, 127, 256, 511}) {
    const std::string at = " " + std::to_string(res) + "px";
    views.push_back({"face-on" + at, look_at({0, 0, 6}, {0, 0, 0}, {0, 1, 0}, 30.0f, res, res, 0.1f, 50.0f)});
    views.push_back({"edge-on" + at, look_at({0, 1, 6}, {0, 1, 0}, {0, 1, 0}, 30.0f, res, res, 0.1f, 50.0f)});
    views.push_back(
        {"edge-on side" + at, look_at({1, 0.3f, 6}, {1, 0.3f, 0}, {0, 1, 0}, 40.0f, res, res, 0.1f, 50.0f)});
    for (Vec3 corner : {Vec3{1, -1, 1}, Vec3{1, 1, -1}, Vec3{-1, 1, 1}, Vec3{3, -3, -1.5f}})
      views.push_back({"corner" + at, look_at({4, 3, 5}, corner, {0, 1, 0}, 30.0f, res, res, 0.1f, 50.0f)});
  }
  // A spot light's map (tests/unit/test_view_clipping.cpp) in which the big
  // box's corner (3, -3, -1.5) projects 1e-4 px from the centre of texel
  // (165, 233): GL snaps it onto the centre.
  views.push_back(
      {"vertex on a pixel centre", light_view({3, 3, 1}, normalize(Vec3{-3, -3, -9}), {0, 1, 0},
                                              std::tan(40.0f * 3.14159265f / 180.0f), 256, 1, 1e-3f, 30.0f)});
  std::mt19937 rng(5u);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 240; ++i) {
    int res = 32 + (i % 7) * 37;
    Vec3 eye = normalize(Vec3{u(rng), u(rng), u(rng)}) * (3.5f + 3.0f * std::fabs(u(rng)));
    if (!objects_containing(sv, eye, ObjectMask{}).empty()) continue;  // the pair check assumes an eye outside
    Vec3 aim = i % 2 ? Vec3{std::round(u(rng)), std::round(u(rng)), std::round(u(rng))} : Vec3{u(rng), u(rng), u(rng)};
    views.push_back({"random " + std::to_string(i),
                     look_at(eye, aim, {0, 1, 0}, 30.0f + 40.0f * std::fabs(u(rng)), res, res, 0.1f, 50.0f)});
  }
  struct Count {
    uint64_t unmatched = 0, unpaired = 0, fragments = 0;
    std::string first;
  } gl_count, cpu_count;
  for (const View& view : views) {
    FragmentBuffers gl, cpu;
    r.rasterize(view.v, ObjectMask{}, gl);
    s.cast(view.v, ObjectMask{}, cpu);
    for (auto [lists, count] : {std::pair{&gl, &gl_count}, std::pair{&cpu, &cpu_count}}) {
      std::string first;
      count->unpaired += count_unpaired_pixels(s, *lists, &first);
      FragmentLists fl = lists->lists();
      std::vector<uint32_t> inside = objects_containing(sv, view.v.eye, ObjectMask{});
      WalkStats st;
      for (int py = 0; py < fl.height; ++py)
        for (int px = 0; px < fl.width; ++px) {
          struct Quiet {
            bool surface(float, uint32_t, bool) { return true; }
            bool segment(float, float, const SegmentMedia&) { return true; }
          } quiet;
          uint64_t before = st.unmatched;
          walk_ray(sv, fl.pixel(px, py), {inside.data(), inside.size()}, 0.0f, 100.0f, quiet, st);
          if (st.unmatched != before && count->first.empty())
            count->first = view.name + " pixel (" + std::to_string(px) + ", " + std::to_string(py) + ")";
        }
      count->unmatched += st.unmatched;
      count->fragments += lists->total();
    }
  }
  std::printf("[  closed   ] %zu views: GL %llu fragments, %llu unmatched; CPU %llu fragments, %llu unmatched\n",
              views.size(), (unsigned long long)gl_count.fragments, (unsigned long long)gl_count.unmatched,
              (unsigned long long)cpu_count.fragments, (unsigned long long)cpu_count.unmatched);
  EXPECT_GT(gl_count.fragments, 100000u);
  EXPECT_EQ(gl_count.unmatched, 0u) << "GL, first at " << gl_count.first;
  EXPECT_EQ(gl_count.unpaired, 0u) << "GL";
  EXPECT_EQ(cpu_count.unmatched, 0u) << "CPU, first at " << cpu_count.first;
  EXPECT_EQ(cpu_count.unpaired, 0u) << "CPU";
}

}  // namespace
}  // namespace cdsm::test
