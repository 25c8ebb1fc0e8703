// OpenVDB -> NanoVDB: the shared fog volumes, generated fixtures (rotated
// and non-uniformly scaled transforms, repeated names, other value types,
// active tiles), broken files, the analytic constant-density box through
// the reference renderer and the DSM path, empty-space skipping against
// brute force, and the leaf hull's marched-sample reduction.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include <sys/resource.h>

#include <fstream>

#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "frame.h"
#include "scene_compile.h"
#include "hd/bvh.h"
#include "hd/lights.h"
#include "hd/segments.h"
#include "hd/volume.h"
#include "loader_test_util.h"
#include "reference/reference.h"
#include "vdb_fixtures.h"
#include "common/system_frame.h"

namespace cdsm_test {
namespace {

using namespace cdsm;

// A scene with one volume object (proxy box or leaves), a transfer
// function density -> extinction that is linear through (0,0) and (1,sigma),
// and one spot light at `light` aimed at `target`.
Scene volume_scene(const VdbVolume& vdb, float sigma, VolumeProxy proxy, Vec3 light = {0, 0, 5},
                   Vec3 target = {0, 0, 0}, float threshold = 0.0f) {
  Scene s;
  s.source = "vdb-test";
  Volume v;
  v.name = "v";
  v.sparse = vdb.grid;
  v.index_to_object = vdb.index_to_object;
  v.transfer = {{0.0f, vec3(0.0f), {1, 1, 1}}};
  if (threshold > 0.0f) v.transfer.push_back({threshold, vec3(0.0f), {1, 1, 1}});
  v.transfer.push_back({1.0f, vec3(sigma), {1, 1, 1}});
  v.transfer.push_back({1000.0f, vec3(sigma * 1000.0f), {1, 1, 1}});
  s.volumes.push_back(v);
  Object o;
  o.name = "v";
  o.mesh = std::make_shared<TriangleMesh>(make_volume_proxy(v, proxy));
  o.surface.opacity = 0.0f;
  o.interior = InteriorKind::Volume;
  o.volume = 0;
  s.objects.push_back(o);
  s.lights.push_back(spot_light(light, target - light, 4.0f, 3.0f));
  s.shadows.epsilon = 1e-4f;
  s.shadows.resolution = 64;
  s.shadows.filtering = true;
  return s;
}

// Chord of the ray org + t dir through the index box [lo, hi] of an affine
// index->world map (slab test in index space; t is shared).
double index_box_chord(const Mat4& index_to_world, Vec3 lo, Vec3 hi, Vec3 org, Vec3 dir) {
  Mat4 w2i;
  invert(index_to_world, w2i);
  Vec3 qo = w2i.point(org), qd = w2i.vector(dir);
  double t0 = -1e30, t1 = 1e30;
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(qd[a]) < 1e-12) {
      if (qo[a] < lo[a] || qo[a] > hi[a]) return 0.0;
      continue;
    }
    double ta = (double(lo[a]) - qo[a]) / qd[a], tb = (double(hi[a]) - qo[a]) / qd[a];
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  }
  return std::max(0.0, t1 - std::max(t0, 0.0)) * length(dir);
}

// Transmittance from the light to p through the DSM path: light pass ->
// compressed nodes -> bilinear lookup (what the camera pass does).
float dsm_transmittance(const Scene& scene, Vec3 p) {
  const SystemFrame f(scene);
  ShadowView sv = f.view(scene);
  return 1.0f - grey_of(shadow_alpha(sv, f.frame.setup.lights[0], p));
}

float reference_transmittance(const Scene& scene, Vec3 a, Vec3 b) {
  SceneBuffers sb = compiled_scene(scene);
  ReferenceRenderer ref(sb.view(), {});
  return grey_of(ref.transmittance_segment(a, b));
}

// ---- the shared data ------------------------------------------------------

TEST(Vdb, SharedGridsMatchTheManifest) {
  struct Case {
    const char* file;
    const char* grid;
    uint64_t active;
    int dims[3];
    float background;
  } cases[] = {{"vdb/openvdb_smoke1_density.vdb", "density", 1049275, {111, 222, 112}, 0.0f},
               {"vdb/vpt_box_fog.vdb", "density", 9261, {21, 21, 21}, 1.0f},
               {"vdb/arnoldusd_torus_fog.vdb", "voxel_fog_density", 2450, {22, 9, 22}, 0.0f}};
  for (const Case& c : cases) {
    VdbVolume v = load_vdb(data_path(c.file), c.grid);
    ASSERT_TRUE(v.grid) << c.file;
    EXPECT_EQ(v.grid->name, c.grid);
    EXPECT_EQ(v.grid->active_voxels, c.active) << c.file;
    for (int a = 0; a < 3; ++a)
      EXPECT_EQ(v.grid->active_max[a] - v.grid->active_min[a] + 1, c.dims[a]) << c.file << " axis " << a;
    EXPECT_EQ(v.grid->background, c.background) << c.file;
    // The NanoVDB bytes agree.
    SceneBuffers sb = compiled_scene(volume_scene(v, 1.0f, VolumeProxy::Box));
    const auto* g = reinterpret_cast<const nanovdb::FloatGrid*>(sb.view().nano_pool.data());
    EXPECT_EQ(g->activeVoxelCount(), c.active) << c.file;
    EXPECT_EQ(g->tree().background(), c.background) << c.file;
  }
  VdbVolume smoke = load_vdb(data_path("vdb/openvdb_smoke1_density.vdb"));
  EXPECT_NEAR(smoke.grid->min_value, 1e-5f, 1e-5f);
  EXPECT_NEAR(smoke.grid->max_value, 5.715f, 2e-3f);  // stored as half floats
  EXPECT_NEAR(smoke.index_to_object.m[0][0], 0.476f, 1e-3f);
  VdbVolume torus = load_vdb(data_path("vdb/arnoldusd_torus_fog.vdb"), "voxel_fog_density");
  EXPECT_NEAR(torus.grid->max_value, 100.0f, 1e-3f);
  // The torus' grid is not called "density": the error lists what there is.
  expect_error(
      [&] { load_vdb(data_path("vdb/arnoldusd_torus_fog.vdb")); },
      {"arnoldusd_torus_fog.vdb", "no grid named 'density'", "'voxel_fog_density' (float, 2450 active voxels)"});
}

// vpt_box_fog: 21^3 voxels of density 1 and background 1.0. With extinction
// sigma per unit density the transmittance through the proxy box is
// exp(-sigma * chord) exactly; a loader that took the background as 0
// would lose density in the outer half voxel (~4e-3 here).
TEST(Vdb, ConstantBoxFogMatchesBeerLambert) {
  VdbVolume v = load_vdb(data_path("vdb/vpt_box_fog.vdb"));
  ASSERT_EQ(v.grid->background, 1.0f);
  const float sigma = 1.0f;
  const Vec3 lo{-10.5f, -10.5f, -10.5f}, hi{10.5f, 10.5f, 10.5f};
  struct Ray {
    const char* what;
    Vec3 through, dir;
  } rays[] = {{"axis", {0.01f, -0.02f, 0.0f}, {0, 0, -1}},
              {"diagonal", {0.03f, -0.02f, 0.01f}, normalize(Vec3{-1, -1, -1})}};
  for (const Ray& r : rays) {
    const Vec3 light = r.through - r.dir * 4.0f, p = r.through + r.dir * 1.5f;
    const double chord = index_box_chord(v.index_to_object, lo, hi, light, r.dir);
    const double expected = std::exp(-sigma * chord);
    EXPECT_GT(chord, 1.0) << r.what;
    Scene s = volume_scene(v, sigma, VolumeProxy::Box, light, r.through);
    EXPECT_NEAR(reference_transmittance(s, light, p), expected, 1e-3) << r.what << " (reference)";
    EXPECT_NEAR(dsm_transmittance(s, p), expected, 1e-3) << r.what << " (DSM)";
  }
}

// ---- generated fixtures ---------------------------------------------------

Mat4 rotated_scaled() {
  // T * Rz(30) * Rx(20) * S(0.1, 0.2, 0.05).
  return make_transform({0.3f, -0.2f, 0.1f}, {20, 0, 30}, {1, 1, 1}) *
         make_transform({0, 0, 0}, {0, 0, 0}, {0.1f, 0.2f, 0.05f});
}

TEST(VdbFixture, RotatedAndNonUniformlyScaledTransform) {
  std::string dir = scratch_dir();
  VdbFixtureGrid g;
  g.lo[0] = -3, g.lo[1] = 2, g.lo[2] = -8;
  g.hi[0] = 6, g.hi[1] = 7, g.hi[2] = 15;
  g.value = 2.0f;
  g.background = 2.0f;  // constant everywhere: an exact chord test
  g.index_to_world = rotated_scaled();
  write_vdb(dir + "/rot.vdb", {g});
  VdbVolume v = load_vdb(dir + "/rot.vdb");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(v.index_to_object.m[r][c], g.index_to_world.m[r][c], 1e-6f) << r << c;
  EXPECT_EQ(v.grid->active_voxels, 10u * 6u * 24u);
  // The proxy box is the active index box (+- half a voxel) under the map.
  Volume vol;
  vol.sparse = v.grid;
  vol.index_to_object = v.index_to_object;
  TriangleMesh box = make_volume_proxy(vol);
  EXPECT_TRUE(is_closed(box));
  Box3 expect_bounds;
  for (int i = 0; i < 8; ++i)
    expect_bounds.grow(
        g.index_to_world.point({(i & 1) ? 6.5f : -3.5f, (i & 2) ? 7.5f : 1.5f, (i & 4) ? 15.5f : -8.5f}));
  Box3 b = world_bounds(box, Mat4{});
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(b.lo[a], expect_bounds.lo[a], 1e-5f);
    EXPECT_NEAR(b.hi[a], expect_bounds.hi[a], 1e-5f);
  }
  // Transmittance along oblique rays: exp(-sigma * 2 * chord in the rotated box).
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const Vec3 centre = g.index_to_world.point({1.5f, 4.5f, 3.5f});
  for (int k = 0; k < 6; ++k) {
    Vec3 dir = normalize(Vec3{u(rng), u(rng), u(rng)});
    Vec3 through = centre + Vec3{u(rng), u(rng), u(rng)} * 0.05f;
    Vec3 light = through - dir * 3.0f, p = through + dir * 3.0f;
    double chord = index_box_chord(g.index_to_world, {-3.5f, 1.5f, -8.5f}, {6.5f, 7.5f, 15.5f}, light, dir);
    Scene s = volume_scene(v, 1.5f, VolumeProxy::Box, light, through);
    EXPECT_NEAR(reference_transmittance(s, light, p), std::exp(-1.5 * 2.0 * chord), 1e-4) << k;
  }
}

TEST(VdbFixture, RepeatedGridNamesAreAnErrorListingTheGrids) {
  std::string dir = scratch_dir();
  VdbFixtureGrid a, b, t;
  b.hi[0] = 15;  // 16*8*8 active voxels
  t.name = "temperature";
  write_vdb(dir + "/dup.vdb", {a, t, b});
  expect_error([&] { load_vdb(dir + "/dup.vdb"); },
               {dir + "/dup.vdb", "2 grids are named 'density'", "'density[0]' to 'density[1]'",
                "'density' (float, 512 active voxels)", "'temperature' (float, 512 active voxels)",
                "'density' (float, 1024 active voxels)"});
  EXPECT_EQ(load_vdb(dir + "/dup.vdb", "density[1]").grid->active_voxels, 1024u);
  EXPECT_EQ(load_vdb(dir + "/dup.vdb", "density[0]").grid->active_voxels, 512u);
  EXPECT_EQ(load_vdb(dir + "/dup.vdb", "temperature").grid->active_voxels, 512u);
  expect_error([&] { load_vdb(dir + "/dup.vdb", "density[2]"); },
               {"no grid 'density[2]'", "2 grids are named 'density'", "'density[0]' to 'density[1]'"});
  // One grid of that name: an index beyond it says so (not "'density[0]' to 'density[0]'").
  write_vdb(dir + "/one.vdb", {a, t});
  expect_error([&] { load_vdb(dir + "/one.vdb", "density[1]"); },
               {"no grid 'density[1]'", "only one grid is named 'density'", "use 'density' or 'density[0]'"});
  EXPECT_EQ(load_vdb(dir + "/one.vdb", "density[0]").grid->active_voxels, 512u);
  expect_error([&] { load_vdb(dir + "/dup.vdb", "velocity"); }, {"no grid named 'velocity'", "'temperature'"});
}

TEST(VdbFixture, ValueTypes) {
  std::string dir = scratch_dir();
  VdbFixtureGrid g;
  g.value = 0.75f;
  for (auto kind : {VdbFixtureGrid::Kind::Vec3, VdbFixtureGrid::Kind::Int32}) {
    g.kind = kind;
    write_vdb(dir + "/t.vdb", {g});
    expect_error([&] { load_vdb(dir + "/t.vdb"); }, {dir + "/t.vdb", "'density'", "not a scalar float grid"});
  }
  for (auto kind : {VdbFixtureGrid::Kind::Double, VdbFixtureGrid::Kind::Half}) {
    g.kind = kind;
    write_vdb(dir + "/t.vdb", {g});
    VdbVolume v = load_vdb(dir + "/t.vdb");
    EXPECT_EQ(v.grid->active_voxels, 512u);
    EXPECT_FLOAT_EQ(v.grid->max_value, 0.75f);
    SceneBuffers sb = compiled_scene(volume_scene(v, 1.0f, VolumeProxy::Box));
    EXPECT_FLOAT_EQ(density_at_index(sb.view(), sb.volumes[0], {3.5f, 3.5f, 3.5f}), 0.75f);
  }
}

TEST(VdbFixture, ActiveTilesAndANonZeroBackground) {
  std::string dir = scratch_dir();
  VdbFixtureGrid g;
  g.lo[0] = g.lo[1] = g.lo[2] = -16;
  g.hi[0] = g.hi[1] = g.hi[2] = 15;  // 32^3 of constant value: tiles after pruning
  g.active_tiles = true;
  g.value = 0.5f;
  g.background = 0.25f;
  write_vdb(dir + "/tiles.vdb", {g});
  VdbVolume v = load_vdb(dir + "/tiles.vdb");
  EXPECT_EQ(v.grid->active_voxels, 32768u);
  const float sigma = 0.1f;
  Scene s = volume_scene(v, sigma, VolumeProxy::Box, {0.05f, 0.03f, 5}, {0.05f, 0.03f, 0});
  SceneBuffers sb = compiled_scene(s);
  SceneView sv = sb.view();
  EXPECT_FLOAT_EQ(density_at_index(sv, sv.volumes[0], {0.3f, 0.2f, 0.1f}), 0.5f);
  EXPECT_FLOAT_EQ(density_at_index(sv, sv.volumes[0], {100.0f, 0.2f, 0.1f}), 0.25f);
  // Along z through the proxy [-16.5, 15.5]: 31 voxel widths at 0.5 between
  // the centres -16 and 15, and at each end half a voxel ramping from 0.5
  // towards the background 0.25 (mean 0.4375). Voxels are 1 unit.
  const double expected_tau = sigma * (31.0 * 0.5 + 2.0 * 0.5 * 0.4375);
  const float T = reference_transmittance(s, {0.05f, 0.03f, 40}, {0.05f, 0.03f, -40});
  EXPECT_NEAR(T, std::exp(-expected_tau), 1e-4);
}

TEST(VdbBad, NaNInTheGridOrTheTransform) {
  std::string dir = scratch_dir();
  VdbFixtureGrid g;
  g.nan_voxel = true;
  write_vdb(dir + "/nan.vdb", {g});
  expect_error([&] { load_vdb(dir + "/nan.vdb"); }, {dir + "/nan.vdb", "NaN or infinite value at voxel 0,0,0"});
  // vpt_box_fog's map stores its voxel size 0.05 as six doubles: make them NaN.
  std::vector<char> b = read_bytes(data_path("vdb/vpt_box_fog.vdb"));
  double v05 = 0.05, nan = std::nan("");
  int patched = 0;
  for (size_t i = 0; i + 8 <= b.size(); ++i)
    if (std::memcmp(b.data() + i, &v05, 8) == 0) {
      std::memcpy(b.data() + i, &nan, 8);
      ++patched;
    }
  ASSERT_EQ(patched, 6);
  write_bytes(dir + "/nan_map.vdb", b);
  expect_error([&] { load_vdb(dir + "/nan_map.vdb"); }, {dir + "/nan_map.vdb"});
}

TEST(VdbBad, TruncatedCorruptMissing) {
  std::string dir = scratch_dir();
  for (const char* f : {"vdb/vpt_box_fog.vdb", "vdb/openvdb_smoke1_density.vdb", "vdb/arnoldusd_torus_fog.vdb"}) {
    std::string src = data_path(f);
    size_t size = read_bytes(src).size();
    for (double frac : {0.0, 0.001, 0.01, 0.03, 0.1, 0.25, 0.5, 0.75, 0.9, 0.999}) {
      std::string cut = truncated_copy(src, size_t(double(size) * frac), dir + "/cut.vdb");
      expect_error([&] { load_vdb(cut); }, {cut});
    }
    expect_error([&] { load_vdb(truncated_copy(src, size - 1, dir + "/cut1.vdb")); }, {"cut1.vdb"});
  }
  // Corrupted bytes (flipped, or 8 random bytes, with or without
  // truncation): loads or a clear error, never a crash. OpenVDB 10 itself
  // overflows the heap on some of these (see vdb_openvdb.cpp).
  for (const char* f : {"vdb/vpt_box_fog.vdb", "vdb/arnoldusd_torus_fog.vdb"}) {
    const std::vector<char> good = read_bytes(data_path(f));
    std::mt19937 rng(11);
    int errors = 0, count = 64;
    for (int k = 0; k < count; ++k) {
      std::vector<char> b = good;
      for (int n = 0, flips = 1 + int(rng() % 6); n < flips; ++n) {
        size_t at = rng() % b.size();
        if (k % 2 == 0)
          b[at] ^= char(1 + rng() % 255);
        else
          for (size_t j = at; j < at + 8 && j < b.size(); ++j) b[j] = char(rng());
      }
      if (k % 5 == 4) b.resize(rng() % b.size());
      write_bytes(dir + "/corrupt.vdb", b);
      try {
        load_vdb(dir + "/corrupt.vdb",
                 std::string(f).find("torus") != std::string::npos ? "voxel_fog_density" : "density");
      } catch (const Error& e) {
        ++errors;
        EXPECT_NE(std::string(e.what()).find("corrupt.vdb"), std::string::npos) << e.what();
      }
    }
    std::printf("%s with corrupted bytes: %d of %d rejected, the rest loaded\n", f, errors, count);
  }
  write_text(dir + "/text.vdb", "this is not a VDB file\n");
  expect_error([&] { load_vdb(dir + "/text.vdb"); }, {dir + "/text.vdb", "not a VDB file"});
  expect_error([&] { load_vdb(dir + "/missing.vdb"); }, {dir + "/missing.vdb", "missing"});
}

// Inputs found by fuzz_vdb (tests/fuzz/corpus/fuzz_vdb/) that made the
// loader allocate what a corrupt or tiny file asked for: 4 GiB strings
// from descriptors the prologue never checked (unchecked file versions, or
// a descriptor read where a corrupt grid's data happened to end), and a
// 13 KB file of active tiles voxelized into gigabytes. Each is now a clear
// error, and reading all of them raises the peak memory by little.
long peak_rss_kib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

TEST(VdbBad, FuzzFindingsAreClearErrorsWithoutHugeAllocations) {
  const std::string corpus = content_dir() + "/../tests/fuzz/corpus/fuzz_vdb/";
  const long before = peak_rss_kib();
  expect_error([&] { load_vdb(corpus + "active_tiles_voxelized.vdb"); }, {"active_tiles_voxelized.vdb", "VDB file"});
  expect_error([&] { load_vdb(corpus + "prologue_skipped_version_4GiB_descriptor.vdb"); },
               {"prologue_skipped_version_4GiB_descriptor.vdb", "VDB file version", "not supported"});
  expect_error([&] { load_vdb(corpus + "prologue_skipped_version_80GiB_stream.vdb"); },
               {"prologue_skipped_version_80GiB_stream.vdb", "not supported"});
  expect_error([&] { load_vdb(corpus + "prologue_desync_huge_descriptor.vdb"); },
               {"prologue_desync_huge_descriptor.vdb", "VDB file"});
  // Metadata whose size field disagrees with its type (a 12-byte "mat4d"):
  // OpenVDB read 128 bytes, lost its place and allocated a 1.8 GB name.
  expect_error([&] { load_vdb(corpus + "grid_pos_elsewhere_huge_metadata.vdb"); },
               {"grid_pos_elsewhere_huge_metadata.vdb", "'file_bbox_min' of type mat4d has 12 bytes, not 128"});
  // A transform whose type name claims 1.8 GB.
  expect_error([&] { load_vdb(corpus + "transform_name_1_8GB.vdb"); },
               {"transform_name_1_8GB.vdb", "transform of grid 'density' of 1862270976 bytes"});
  // Tiles voxelizing to 107 and 67 million voxels (2.5 GB under ASan, 12 s).
  for (const char* f : {"inactive_tiles_voxelized_oom.vdb", "tiles_voxelized_slow.vdb"})
    expect_error([&] { load_vdb(corpus + f); }, {f, "more than the loader's limit of 33554432 tile voxels"});
  const long grown_mib = (peak_rss_kib() - before) / 1024;
  std::printf("peak resident memory grew by %ld MiB over the eight files\n", grown_mib);
  EXPECT_LT(grown_mib, 256);

  // The same kind of tiles made here: one active root tile of 4096^3 voxels.
  openvdb::initialize();
  const std::string dir = scratch_dir();
  auto g = openvdb::FloatGrid::create(0.0f);
  g->setName("density");
  g->tree().addTile(3, openvdb::Coord(0, 0, 0), 0.5f, true);
  openvdb::io::File(dir + "/tile.vdb").write({g});
  expect_error([&] { load_vdb(dir + "/tile.vdb"); }, {"tile.vdb", "68719476736 voxels", "limit"});
  // A file written as a stream has no grid offsets to check: refused.
  {
    std::ofstream out(dir + "/stream.vdb", std::ios::binary);
    auto small = openvdb::FloatGrid::create(0.0f);
    small->setName("density");
    small->tree().setValue(openvdb::Coord(1, 2, 3), 1.0f);
    openvdb::io::Stream(out).write({small});
  }
  expect_error([&] { load_vdb(dir + "/stream.vdb"); }, {"stream.vdb", "without grid offsets"});
}

// ---- empty-space skipping and proxies ----------------------------------------

// Along a segment with no skipping at all: the optical depth by a fine
// midpoint rule, and the largest excess of a sample's extinction over its
// macro-cell's stored maximum (which must bound it: > 0 would skip data).
double brute_tau(const SceneView& s, const VolumeData& v, Vec3 a, Vec3 b, int n, double& excess) {
  double tau = 0.0, len = length(b - a);
  const float bg = apply_transfer(v.tf, v.background).extinction.x;
  for (int i = 0; i < n; ++i) {
    Vec3 p = a + (b - a) * ((float(i) + 0.5f) / float(n));
    float ext = apply_transfer(v.tf, density_at(s, v, p)).extinction.x;
    float mx = macro_max_at(s, v, v.world_to_index.point(p));
    excess = std::max(excess, double(ext - (mx < 0.0f ? bg : mx)));
    tau += ext * len / n;
  }
  return tau;
}

TEST(VdbSkipping, LeafMaximaSkipOnlyEmptySpace) {
  VdbVolume v = load_vdb(data_path("vdb/openvdb_smoke1_density.vdb"));
  // Threshold 0.3: much of the plume's fringe maps to zero extinction.
  Scene s = volume_scene(v, 0.05f, VolumeProxy::Box, {0, 0, 5}, {0, 0, 0}, 0.3f);
  SceneBuffers sb = compiled_scene(s);
  SceneView sv = sb.view();
  const VolumeData& vd = sv.volumes[0];
  uint32_t empty = 0;
  for (uint32_t i = 0; i < uint32_t(vd.mx); ++i) empty += sv.macro_max[vd.macro_offset + i] <= 0.0f;
  std::printf("smoke1, threshold 0.3: %u of %d leaves (apron included) have zero extinction\n", empty, vd.mx);
  EXPECT_GT(empty, 0u);
  ReferenceRenderer ref(sv, {});
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const Box3 box = sb.object_bounds[0];
  double excess = 0.0;
  for (int k = 0; k < 40; ++k) {
    Vec3 a = box.lo + (box.hi - box.lo) * Vec3{u(rng), u(rng), -0.2f};
    Vec3 b = box.lo + (box.hi - box.lo) * Vec3{u(rng), u(rng), 1.2f};
    double T = grey_of(ref.transmittance_segment(a, b));
    double Tb = std::exp(-brute_tau(sv, vd, a, b, 20000, excess));
    EXPECT_NEAR(T, Tb, 1e-3) << k;  // two quadratures of the same integral
  }
  EXPECT_LE(excess, 1e-6) << "a macro-cell maximum is below a sample inside it";
}

struct MarchCount {
  uint64_t samples = 0, skips = 0;
  double inside = 0.0;
};

// Marches the DSM path's sampler (march_segment) over the proxy's inside
// intervals of a grid of rays from `eye` across the volume.
MarchCount count_marching(const Scene& scene, Vec3 eye, int n) {
  SceneBuffers sb = compiled_scene(scene);
  SceneView sv = sb.view();
  MarchCount mc;
  const Box3 box = sb.object_bounds[0];
  SegmentMedia media;
  media.volume_count = 1;
  media.volume[0] = 0;
  media.volume_object[0] = 0;
  media.step = sv.volumes[0].step;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      Vec3 target = box.lo + (box.hi - box.lo) * Vec3{(i + 0.5f) / n, (j + 0.5f) / n, 0.5f};
      Vec3 dir = normalize(target - eye);
      std::vector<float> ts;
      for_each_hit(sv, ObjectMask{}, eye, dir, 0.0f, 3e38f, [&](uint32_t, const TriHit& h) { ts.push_back(h.t); });
      std::sort(ts.begin(), ts.end());
      for (size_t k = 0; k + 1 < ts.size(); k += 2) {
        mc.inside += ts[k + 1] - ts[k];
        march_segment(
            sv, media, eye, dir, ts[k], ts[k + 1], [&](const MarchSample&) { return ++mc.samples, true; },
            [&](float, float) { ++mc.skips; });
      }
    }
  return mc;
}

TEST(VdbProxy, LeafHullIsClosedTighterAndMarchesFewerSamples) {
  VdbVolume v = load_vdb(data_path("vdb/openvdb_smoke1_density.vdb"));
  Volume vol;
  vol.sparse = v.grid;
  vol.index_to_object = v.index_to_object;
  TriangleMesh box = make_volume_proxy(vol, VolumeProxy::Box), hull = make_volume_proxy(vol, VolumeProxy::Leaves);
  EXPECT_TRUE(is_closed(hull));
  EXPECT_GT(signed_volume(hull), 0.0);
  const double vb = signed_volume(box), vh = signed_volume(hull);
  EXPECT_LT(vh, vb);
  Box3 bb = world_bounds(box, Mat4{}), hb = world_bounds(hull, Mat4{});
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(hb.lo[a], bb.lo[a], 1e-4f);  // the hull touches the active box
    EXPECT_NEAR(hb.hi[a], bb.hi[a], 1e-4f);
  }
  // Same transmittance (outside the leaves there is only background 0), to
  // the reference's convergence (1e-4: the hull splits the ray into other
  // intervals, so Simpson's panels fall elsewhere).
  Scene sbox = volume_scene(v, 0.2f, VolumeProxy::Box), shull = volume_scene(v, 0.2f, VolumeProxy::Leaves);
  const Box3 wb = world_bounds(box, Mat4{});
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  SceneBuffers b1 = compiled_scene(sbox), b2 = compiled_scene(shull);
  ReferenceRenderer r1(b1.view(), {}), r2(b2.view(), {});
  for (int k = 0; k < 20; ++k) {
    Vec3 a = wb.lo + (wb.hi - wb.lo) * Vec3{u(rng), u(rng), -0.3f};
    Vec3 b = wb.lo + (wb.hi - wb.lo) * Vec3{u(rng), u(rng), 1.3f};
    EXPECT_NEAR(grey_of(r1.transmittance_segment(a, b)), grey_of(r2.transmittance_segment(a, b)), 1e-4) << k;
  }
  // Marched samples of the DSM path's sampler over the same rays.
  const Vec3 eye = wb.center() + Vec3{0.3f, 0.4f, 1.0f} * (2.0f * length(wb.extent()));
  MarchCount mb = count_marching(sbox, eye, 96), mh = count_marching(shull, eye, 96);
  std::printf("smoke1 proxies, %d rays: box %zu tris, volume %.0f, inside %.0f, samples %llu, skip steps %llu\n",
              96 * 96, box.triangle_count(), vb, mb.inside, (unsigned long long)mb.samples,
              (unsigned long long)mb.skips);
  std::printf("                          leaves %zu tris, volume %.0f, inside %.0f, samples %llu, skip steps %llu\n",
              hull.triangle_count(), vh, mh.inside, (unsigned long long)mh.samples, (unsigned long long)mh.skips);
  std::printf("  reduction: volume %.1f%%, inside length %.1f%%, marched samples %.1f%%, samples+skips %.1f%%\n",
              100.0 * (1.0 - vh / vb), 100.0 * (1.0 - mh.inside / mb.inside),
              100.0 * (1.0 - double(mh.samples) / double(mb.samples)),
              100.0 * (1.0 - double(mh.samples + mh.skips) / double(mb.samples + mb.skips)));
  ::testing::Test::RecordProperty("marched_samples_box", std::to_string(mb.samples));
  ::testing::Test::RecordProperty("marched_samples_leaves", std::to_string(mh.samples));
  EXPECT_LE(mh.samples, mb.samples);
  EXPECT_LT(mh.inside, mb.inside);
}

}  // namespace
}  // namespace cdsm_test
