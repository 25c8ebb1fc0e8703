// engine/examples/forward (cdsm_forward): an application's forward renderer
// with its own shaders that takes its shadows only through the public API
// and cdsm.glsl. Run headless on the default scene, its image must agree
// with the library's own camera pass (cdsm::Renderer) on the opaque
// surfaces — PSNR >= 35 dB over the pixels its stencil marks as opaque
// only — where the shadows of the translucent meshes and the smoke fall,
// and over the whole image; the same run without shadows must not (so the
// mask holds shadows).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "cdsm/cdsm.h"

namespace {

const std::string kOut = std::string(CDSM_TEST_OUTPUT_DIR) + "/forward_example";
const std::string kScene = std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json";
constexpr int kWidth = 360, kHeight = 240;

bool gl_required() {
  const char* e = std::getenv("CDSM_REQUIRE_GL");
  return e && std::strcmp(e, "1") == 0;
}

struct ExampleRun {
  int status = -1;
  std::string output;
};

ExampleRun run_example(const std::string& args) {
  const std::string log = kOut + ".log";
  const std::string cmd = std::string("'") + CDSM_FORWARD_EXE + "' " + args + " > '" + log + "' 2>&1";
  ExampleRun r;
  r.status = std::system(cmd.c_str());
  std::ifstream f(log);
  r.output.assign(std::istreambuf_iterator<char>(f), {});
  return r;
}

cdsm::Image read_pfm(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::string magic;
  cdsm::Image img;
  float scale = 0;
  f >> magic >> img.width >> img.height >> scale;
  f.get();
  EXPECT_EQ(magic, "PF");
  EXPECT_LT(scale, 0.0f) << "little-endian";
  img.rgb.resize(size_t(img.width) * img.height * 3);
  for (int y = img.height - 1; y >= 0; --y)
    f.read(reinterpret_cast<char*>(img.rgb.data() + size_t(y) * img.width * 3), std::streamsize(img.width) * 12);
  EXPECT_TRUE(bool(f)) << path;
  return img;
}

std::vector<unsigned char> read_pgm(const std::string& path, int& w, int& h) {
  std::ifstream f(path, std::ios::binary);
  std::string magic;
  int maxv = 0;
  f >> magic >> w >> h >> maxv;
  f.get();
  std::vector<unsigned char> m(size_t(w) * h);
  f.read(reinterpret_cast<char*>(m.data()), std::streamsize(m.size()));
  EXPECT_EQ(magic, "P5");
  return m;
}

float srgb(float c) {
  c = std::fmin(std::fmax(std::isfinite(c) ? c : 0.0f, 0.0f), 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

// PSNR (peak 1) of the sRGB-encoded images over the masked pixels, as
// cdsm::compare_images measures whole images.
double masked_psnr(const cdsm::Image& a, const cdsm::Image& b, const std::vector<unsigned char>& mask) {
  double se = 0.0;
  size_t n = 0;
  for (size_t p = 0; p < mask.size(); ++p) {
    if (!mask[p]) continue;
    for (int c = 0; c < 3; ++c) {
      const double d = double(srgb(a.rgb[3 * p + c])) - double(srgb(b.rgb[3 * p + c]));
      se += d * d;
    }
    n += 3;
  }
  const double rmse = n ? std::sqrt(se / double(n)) : 1.0;
  return rmse > 0.0 ? 20.0 * std::log10(1.0 / rmse) : 1e9;
}

// The example's image of `scene_file` against the library's camera pass:
// the opaque-only pixels (its mask) and the whole image within 35 dB.
void expect_forward_matches_library(const std::string& scene_file, const std::string& out) {
  const std::string size = " --width " + std::to_string(kWidth) + " --height " + std::to_string(kHeight);
  const ExampleRun run = run_example("'" + scene_file + "' -o '" + out + ".png' --raw '" + out + ".pfm' --mask '" +
                                     out + ".mask.pgm'" + size);
  if (run.status != 0 && run.output.find("no 4.5 context") != std::string::npos && !gl_required())
    GTEST_SKIP() << run.output;
  ASSERT_EQ(run.status, 0) << run.output;
  std::printf("%s", run.output.c_str());
  const cdsm::Image example = read_pfm(out + ".pfm");
  int mw = 0, mh = 0;
  const std::vector<unsigned char> mask = read_pgm(out + ".mask.pgm", mw, mh);
  ASSERT_EQ(example.width, kWidth);
  ASSERT_EQ(mw, kWidth);
  ASSERT_EQ(mh, kHeight);

  cdsm::Scene scene = cdsm::load_scene(scene_file);
  scene.camera.width = kWidth;
  scene.camera.height = kHeight;
  cdsm::Renderer renderer;
  cdsm::RenderOptions opt;
  const cdsm::Image library = renderer.render(scene, opt);
  cdsm::write_png(library, out + ".library.png");

  size_t opaque = 0;
  for (unsigned char m : mask) opaque += m != 0;
  const double share = double(opaque) / double(mask.size());
  const double psnr = masked_psnr(example, library, mask);
  std::printf("[ forward  ] %s: opaque-only pixels %.1f%%, PSNR on them %.2f dB, whole image %.2f dB\n",
              scene_file.c_str(), 100.0 * share, psnr, cdsm::compare_images(example, library).psnr);
  EXPECT_GT(share, 0.5) << "the mask must cover most of the ground and the opaque meshes";
  EXPECT_GE(psnr, 35.0);
  // The whole image too: translucent meshes (their constant media absorbed
  // between front and back faces) and the ray-marched smoke.
  EXPECT_GE(cdsm::compare_images(example, library).psnr, 35.0);
}

TEST(ForwardExample, MatchesTheLibrarysCameraPassOnOpaqueSurfaces) {
  expect_forward_matches_library(kScene, kOut);
  if (HasFatalFailure() || IsSkipped()) return;
  const std::string size = " --width " + std::to_string(kWidth) + " --height " + std::to_string(kHeight);
  cdsm::Scene scene = cdsm::load_scene(kScene);
  scene.camera.width = kWidth;
  scene.camera.height = kHeight;
  cdsm::Renderer renderer;
  const cdsm::Image library = renderer.render(scene, cdsm::RenderOptions{});
  int mw = 0, mh = 0;
  const std::vector<unsigned char> mask = read_pgm(kOut + ".mask.pgm", mw, mh);

  // Without shadows the same pixels differ: the shadows are in the mask.
  const ExampleRun flat = run_example("'" + kScene + "' -o '" + kOut + ".noshadow.png' --raw '" + kOut +
                                      ".noshadow.pfm' --no-shadows" + size);
  ASSERT_EQ(flat.status, 0) << flat.output;
  const double flat_psnr = masked_psnr(read_pfm(kOut + ".noshadow.pfm"), library, mask);
  std::printf("[ forward  ] without shadows: PSNR on the same pixels %.2f dB\n", flat_psnr);
  EXPECT_LT(flat_psnr, 30.0);
}

// Under the sun: the example's shading (cdsm_direction_to_light) and the
// orthographic lookups of cdsm.glsl against the library.
TEST(ForwardExample, MatchesTheLibraryUnderTheSun) {
  expect_forward_matches_library(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/sun_glass.json", kOut + ".sun");
}

// The volumes' light grids (DrawOptions::volume_shadows = LightGrid, what
// the editor draws with): a trilinear fetch per march sample from a grid of
// cdsm_transmittance values per volume and light, a texel per 2^3 voxels,
// and marching a voxel a step. Against the same renderer looking the maps
// up at every half-voxel sample: within 50 dB (61 dB measured at 620x757
// with 4 clusters); grids computed in the first frame, not again while
// nothing changes.
TEST(ForwardExample, VolumeLightGridsMatchLookupsPerSample) {
  const std::string size = " --width " + std::to_string(kWidth) + " --height " + std::to_string(kHeight);
  const ExampleRun exact =
      run_example("'" + kScene + "' -o '" + kOut + ".exact.png' --raw '" + kOut + ".exact.pfm'" + size);
  if (exact.status != 0 && exact.output.find("no 4.5 context") != std::string::npos && !gl_required())
    GTEST_SKIP() << exact.output;
  ASSERT_EQ(exact.status, 0) << exact.output;
  const ExampleRun grid = run_example("'" + kScene + "' -o '" + kOut + ".grid.png' --raw '" + kOut +
                                      ".grid.pfm' --light-grid 2 --step-scale 2 --frames 3" + size);
  ASSERT_EQ(grid.status, 0) << grid.output;
  std::printf("%s", grid.output.c_str());
  EXPECT_NE(grid.output.find("of it 2 light grids"), std::string::npos) << "one grid per volume and light in frame 1";
  EXPECT_NE(grid.output.find("light grids recomputed 0"), std::string::npos) << "an unchanged scene recomputes none";
  const cdsm::Image a = read_pfm(kOut + ".exact.pfm"), b = read_pfm(kOut + ".grid.pfm");
  const double psnr = cdsm::compare_images(b, a).psnr;
  std::printf("[ forward  ] light grids + voxel steps against a lookup per half-voxel sample: %.2f dB\n", psnr);
  EXPECT_GE(psnr, 50.0);
  // ... and the grids hold shadows: the smoke unshadowed is far from both.
  const ExampleRun flat =
      run_example("'" + kScene + "' -o '" + kOut + ".flat.png' --raw '" + kOut + ".flat.pfm' --no-shadows" + size);
  ASSERT_EQ(flat.status, 0) << flat.output;
  EXPECT_LT(cdsm::compare_images(read_pfm(kOut + ".flat.pfm"), a).psnr, psnr - 15.0);
}

// The renderer compiles its lookups for the buffers' node layout
// (cdsm.glsl's CDSM_LAYOUT variants): chunked maps hold the packed maps'
// nodes, so the image is the same to the bit.
TEST(ForwardExample, EveryLayoutDrawsTheSameImage) {
  std::ifstream in(kScene);
  std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = json.find("\"shadows\": {");
  ASSERT_NE(at, std::string::npos);
  const std::string size = " --width 160 --height 120";
  const ExampleRun packed =
      run_example("'" + kScene + "' -o '" + kOut + ".packed.png' --raw '" + kOut + ".packed.pfm'" + size);
  if (packed.status != 0 && packed.output.find("no 4.5 context") != std::string::npos && !gl_required())
    GTEST_SKIP() << packed.output;
  ASSERT_EQ(packed.status, 0) << packed.output;
  const cdsm::Image a = read_pfm(kOut + ".packed.pfm");
  for (const char* layout : {"chunked", "fixed"}) {
    std::string variant = json;
    variant.insert(at + std::strlen("\"shadows\": {"), std::string("\"layout\": \"") + layout + "\", ");
    const std::string path = kOut + "." + layout + ".json";
    std::ofstream(path) << variant;
    const ExampleRun run = run_example("'" + path + "' -o '" + kOut + "." + layout + ".png' --raw '" + kOut + "." +
                                       layout + ".pfm'" + size);
    ASSERT_EQ(run.status, 0) << run.output;
    const cdsm::Image b = read_pfm(kOut + "." + layout + ".pfm");
    ASSERT_EQ(a.rgb.size(), b.rgb.size());
    size_t differ = 0;
    for (size_t i = 0; i < a.rgb.size(); ++i) differ += a.rgb[i] != b.rgb[i];
    EXPECT_EQ(differ, 0u) << layout << " maps: " << differ << " values differ from the packed maps' image";
  }
}

TEST(ForwardExample, BadInputIsAClearError) {
  const ExampleRun missing = run_example("'" + kOut + ".does-not-exist.json' -o '" + kOut + ".x.png'");
  EXPECT_NE(missing.status, 0);
  EXPECT_NE(missing.output.find("does-not-exist.json"), std::string::npos) << missing.output;
  const ExampleRun bad = run_example("'" + kScene + "' -o '" + kOut + ".x.png' --width 0");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.output.find("--width"), std::string::npos) << bad.output;
}

}  // namespace
