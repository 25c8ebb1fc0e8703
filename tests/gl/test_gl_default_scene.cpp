// GL fragment lists against the exact CPU ray caster on the default scene
// (camera view, the spot light's view, an omni light's six faces), and the
// final image from GL fragments against the image from CPU fragments.
#include <gtest/gtest.h>

#include "cdsm/image.h"
#include "cdsm/renderer.h"
#include "cdsm/scene_io.h"
#include "frame.h"
#include "gl_test_util.h"
#include "common/system_frame.h"

namespace cdsm {
namespace {

class GlDefaultScene : public test::GlTest {};

Scene default_scene() {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json");
  s.camera.width = 360;
  s.camera.height = 240;
  return s;
}

void expect_match(const test::TestScene& ts, gl::FragmentRasterizer& r, const PinholeView& view,
                  const std::string& what) {
  FragmentBuffers gl_lists, cpu_lists;
  r.rasterize(view, ObjectMask{}, gl_lists);
  ts.cast(view, ObjectMask{}, cpu_lists);
  test::Comparison c = test::compare_fragments(ts, view, gl_lists, cpu_lists);
  SCOPED_TRACE(what);
  // Coincident surfaces (a lid resting on a body, caps inside shells) give
  // fragments whose depths agree within 1e-4 but sort in either order:
  // the same lists within the depth tolerance.
  uint64_t same = c.equal + c.order_ties;
  std::printf("%-12s %llu pixels: %.4f%% differ (%.4f%% only by order of depth ties), max rel. depth error %.2g\n",
              what.c_str(), (unsigned long long)c.pixels, 100.0 * double(c.pixels - same) / double(c.pixels),
              100.0 * double(c.order_ties) / double(c.pixels), c.max_rel_depth);
  EXPECT_GT(c.cpu_fragments, 0u);
  EXPECT_GE(double(same), test::kMinEqualFraction * double(c.pixels));
  EXPECT_EQ(c.unexplained, 0u) << c.report;
  EXPECT_LE(c.max_rel_depth, 1e-4);
}

TEST_F(GlDefaultScene, ListsMatchTheRayCasterInCameraSpotAndOmniViews) {
  Scene s = default_scene();
  test::TestScene ts;
  ts.sb = cdsm_test::compiled_scene(s);
  gl::FragmentRasterizer r(context());
  ts.upload(r);
  expect_match(ts, r, camera_view(s.camera), "camera");
  LightSetup ls = setup_lights(s.lights, ts.sb, 512);
  ASSERT_EQ(ls.maps.size(), 1u);
  expect_match(ts, r, ls.maps[0].view, "spot light");
  // An omni light among the objects: its six faces.
  std::vector<PinholeView> faces = cube_face_views({0.13f, 0.83f, 0.27f}, 256, 1e-3f, 20.0f);
  for (size_t f = 0; f < faces.size(); ++f) expect_match(ts, r, faces[f], "omni face " + std::to_string(f));
}

TEST_F(GlDefaultScene, ImageFromGlFragmentsMatchesImageFromCpuFragments) {
  Scene s = default_scene();
  Renderer gl_renderer, cpu_renderer;
  RenderOptions o;
  FrameStats gs, cs;
  o.fragments = FragmentSource::Gl;
  Image a = gl_renderer.render(s, o, &gs);
  o.fragments = FragmentSource::Cpu;
  Image b = cpu_renderer.render(s, o, &cs);
  EXPECT_EQ(gs.fragment_source, "gl");
  EXPECT_EQ(cs.fragment_source, "cpu");
  ImageError e = compare_images(a, b);
  std::printf("GL vs CPU fragments: image RMSE %.5f, PSNR %.2f dB\n", e.rmse, e.psnr);
  EXPECT_GE(e.psnr, 40.0);
}

}  // namespace
}  // namespace cdsm
