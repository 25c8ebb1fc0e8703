// Shared helpers of the `gl` tests: one headless context per test binary
// (skipped with the reason when there is none, a failure under
// CDSM_REQUIRE_GL=1), small hand-built scenes, views, and the comparison of
// GL fragment lists against the exact CPU ray caster.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "cdsm/error.h"
#include "cdsm/gl.h"
#include "cdsm/shadow_system.h"
#include "cdsm/scene.h"
#include "scene/fragments.h"
#include "scene_compile.h"
#include "gl/context.h"
#include "gl/fragment_raster.h"

namespace cdsm::test {

// CDSM_REQUIRE_GL=1: a missing GL context fails instead of skipping.
bool gl_required();

// Fixture owning the binary's headless context (made once, destroyed after
// the last test).
class GlTest : public ::testing::Test {
 public:
  static void release_context();

 protected:
  static void SetUpTestSuite();
  static void TearDownTestSuite();
  void SetUp() override;
  static gl::Context& context() { return *s_context; }

 private:
  static std::unique_ptr<gl::Context> s_context;
  static std::string s_reason;
  static bool s_tried;
};

// Triangles of several objects, compiled to the flat arrays + BVH the CPU
// ray caster reads (no scene loader involved).
struct TestScene {
  SceneBuffers sb;
  // Appends `mesh` under `transform` as a new object; returns its index.
  uint32_t add(const TriangleMesh& mesh, const Mat4& transform, bool closed = true);
  // Appends one triangle as (part of) object `object` (creates it if new).
  void add_triangle(Vec3 a, Vec3 b, Vec3 c, uint32_t object);
  void finish();  // builds the BVH; call before cast()
  SceneView view() const { return sb.view(); }
  uint32_t object_count() const { return uint32_t(sb.objects.size()); }
  void upload(gl::FragmentRasterizer& r) const;
  // The CPU reference.
  void cast(const PinholeView& v, ObjectMask mask, FragmentBuffers& out) const;
};

// Several closed meshes (spheres, boxes, a sphere inside a box) on a ground
// slab, none touching another; ~2.5k triangles, finished.
TestScene closed_meshes_scene();
// `count` UV spheres of segments x rings (2*segments*(rings-1) triangles
// each) in a grid on a ground slab, finished. 110 x (96, 48) ~ 1M triangles.
TestScene many_spheres_scene(int count, int segments, int rings);

// A perspective view looking from `eye` at `target` (fov in degrees, vertical).
PinholeView look_at(Vec3 eye, Vec3 target, Vec3 up_hint, float fov_y_deg, int width, int height, float near_plane,
                    float far_plane, Vec2 center = {});
// The six 90-degree faces of an omni light at `eye`.
std::array<PinholeView, 6> omni_faces(Vec3 eye, int resolution, float near_plane, float far_plane);

// The one-row view that casts exactly the rays of row `row` of `v` (same
// float arithmetic in view_direction), for checking huge views row by row.
PinholeView row_view(const PinholeView& v, int row);

// Distance in pixels from image point (u, v) to the boundary of the part of
// triangle `tri` whose view-axis coordinate lies in [near, far], projected.
// +inf when nothing of the triangle is in that range.
double edge_distance_px(const PinholeView& view, const Vec3 tri[3], double u, double v);

// Least share of pixels whose GL and CPU lists are equal. GL samples are
// shifted by half a snapping step (1/512 px, gl/fragment_raster.h) in x, so
// pixels whose centre lies that close to an edge may differ from the ray
// caster; every differing pixel must still be explained by an edge within
// 1/64 px (Comparison::unexplained == 0).
inline constexpr double kMinEqualFraction = 0.998;

struct Comparison {
  uint64_t pixels = 0;
  uint64_t equal = 0;        // lists equal after sorting by (depth, bits)
  uint64_t explained = 0;    // unequal, every disputed fragment within edge_tol of its triangle's edge
  uint64_t order_ties = 0;   // of those: same fragments, order swapped by depths within 1e-4
  uint64_t unexplained = 0;  // unequal otherwise (a bug)
  uint64_t gl_fragments = 0, cpu_fragments = 0;
  double max_rel_depth = 0.0;  // over fragments paired by primitive
  std::string report;          // the first unexplained pixels, for messages
  double mismatch_percent() const { return pixels ? 100.0 * double(pixels - equal) / double(pixels) : 0.0; }
  // Another comparison's counts added (rows of one view compared in turn).
  Comparison& operator+=(const Comparison& c) {
    pixels += c.pixels;
    equal += c.equal;
    explained += c.explained;
    order_ties += c.order_ties;
    unexplained += c.unexplained;
    gl_fragments += c.gl_fragments;
    cpu_fragments += c.cpu_fragments;
    max_rel_depth = max_rel_depth > c.max_rel_depth ? max_rel_depth : c.max_rel_depth;
    if (c.unexplained) report += c.report;
    return *this;
  }
};

// Compares GL and CPU lists of the same view (CDSM_TEST_VERBOSE=1 prints
// the explained mismatches too). Rows [row_a, row_b) of `gl`
// are compared with rows [0, row_b - row_a) of `cpu` (row_view slices) when
// `cpu_rows_offset` says so; by default whole views of equal size.
Comparison compare_fragments(const TestScene& scene, const PinholeView& view, const FragmentBuffers& gl,
                             const FragmentBuffers& cpu, double edge_tol_px = 1.0 / 64.0, int gl_row = -1);

// Closed-mesh check on one producer's lists: per pixel and object, after
// sorting by depth and the walker's silhouette rule (hd/segments.h
// order_crossings), fragments alternate entry (front), exit (back) and come
// in pairs. Returns the pixels where not; `first` describes the first one.
uint64_t count_unpaired_pixels(const TestScene& scene, const FragmentBuffers& lists, std::string* first);

// "" when two producers' lists of one view are equal: the same offsets and,
// per pixel, the same fragments in any order; else the first difference.
std::string lists_differ(const FragmentBuffers& a, const FragmentBuffers& b);

// A shadow system on the test's (current) context with `fragments`.
SystemOptions app_options(FragmentSource fragments = FragmentSource::Gl);

// The message of a call that must throw cdsm::Error (else what it did).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("not a cdsm::Error: ") + e.what();
  }
  return "no error";
}

// "" when the six map arrays in GL buffers `b` (ShadowSystem::gl_buffers)
// begin with `s`'s arrays byte for byte, else which array differs and
// where. The context that owns the buffers must be current.
std::string gl_maps_differ(const GlMapBuffers& b, const DsmStorage& s);

}  // namespace cdsm::test
