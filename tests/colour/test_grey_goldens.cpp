// Grey scenes are unchanged by coloured shadows (issue "Coloured
// shadows"): every shipped scene whose casters are all grey renders the
// same image and builds the same node lists, bit for bit, as before RGB
// transmittance existed. The hashes in grey_goldens.txt were recorded with
// the code before that change (commit named in the file); CPU fragment
// producer (deterministic), small sizes, every layout on the default scene.
//
// Re-record only for a deliberate change of the grey result:
//   CDSM_RECORD_GOLDENS=1 ./colour_grey_goldens  (writes grey_goldens.txt and
//   goldens/<name>.png in the source tree)
// The PNGs are the recorded images as a viewer sees them (8-bit sRGB): when
// an image's hash differs, the test writes the new image and a diff image
// against the recorded one (|difference| x 16, per channel) to
// <build>/test-output/colour/ and prints where they are and how far apart.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include "cdsm/fields.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "frame_snapshot.h"
#include "scene_sync.h"

using namespace cdsm;

namespace {

const std::string kGoldens = std::string(CDSM_COLOUR_TEST_DIR) + "/grey_goldens.txt";
const std::string kGoldenImages = std::string(CDSM_COLOUR_TEST_DIR) + "/goldens";
const std::string kOutput = std::string(CDSM_TEST_OUTPUT_DIR) + "/colour";

using Fnv = Fnv1a;

struct Case {
  std::string name;   // key in the goldens file
  std::string scene;  // content/scenes/<scene>.json
  DsmLayout layout;
};

const std::vector<Case>& cases() {
  static const std::vector<Case> c = {
      {"default_packed", "default", DsmLayout::Packed},
      {"default_fixed", "default", DsmLayout::Fixed},
      {"default_chunked", "default", DsmLayout::Chunked},
      {"primitives", "primitives", DsmLayout::Packed},
      {"teapot_omni", "teapot_omni", DsmLayout::Packed},
      {"ct_xray", "ct_xray", DsmLayout::Packed},
      {"sparse", "sparse", DsmLayout::Packed},
      {"smoke_gltf", "smoke_gltf", DsmLayout::Packed},
  };
  return c;
}

// The scene as it was before transmission colours: the default scene's
// tinted panes made white again (their shadows were grey then).
Scene grey_scene(const Case& c) {
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/" + c.scene + ".json");
  for (Object& o : s.objects) o.surface.transmission_color = {1, 1, 1};
  s.camera.width = 160;
  s.camera.height = 120;
  s.shadows.resolution = 96;
  s.shadows.layout = c.layout;
  return s;
}

// Hashes of the rendered image and of every map's node lists; the image
// itself in `img`.
std::pair<uint64_t, uint64_t> hashes(const Scene& scene, Image& img) {
  SystemOptions opt;
  opt.fragments = FragmentSource::Cpu;
  ShadowSystem sys(opt);
  sync_scene(sys, scene);
  img = sys.render();
  Fnv image;
  image.bytes(img.rgb.data(), img.rgb.size() * sizeof(float));
  Fnv nodes;
  const ShadowFrame& f = FrameSnapshot(sys).frame();
  const ShadowView view = f.view(scene.shadows);
  std::vector<DsmNode> buf(8192);
  for (const DsmMap& m : f.headers) {
    EXPECT_EQ(m.rgb, 0u) << "a grey scene built an RGB map";
    if (m.rgb != 0u) continue;
    nodes.pod(m.res);
    for (int ty = 0; ty < int(m.res); ++ty)
      for (int tx = 0; tx < int(m.res); ++tx) {
        const uint32_t n = read_texel(view.storage, m, tx, ty, buf.data(), uint32_t(buf.size()));
        nodes.pod(n);
        nodes.bytes(buf.data(), std::min<size_t>(n, buf.size()) * sizeof(DsmNode));
      }
  }
  return {image.h, nodes.h};
}

// The image of a changed case beside the test's output, and a diff image
// against the recorded PNG: what moved, for a person to see. Returns a
// line saying where they are and how far apart the two are.
std::string write_what_moved(const std::string& name, const Image& img) {
  std::filesystem::create_directories(kOutput);
  const std::string now = kOutput + "/" + name + ".png";
  write_png(img, now);
  const std::string golden = kGoldenImages + "/" + name + ".png";
  int gw = 0, gh = 0, gc = 0, nw = 0, nh = 0, nc = 0;
  unsigned char* g = stbi_load(golden.c_str(), &gw, &gh, &gc, 3);
  unsigned char* n = stbi_load(now.c_str(), &nw, &nh, &nc, 3);
  std::string out = "image written to " + now;
  if (g == nullptr || n == nullptr || gw != nw || gh != nh) {
    out += "; no recorded image of its size to compare (" + golden + ")";
  } else {
    std::vector<unsigned char> diff(size_t(gw) * gh * 3);
    int worst = 0;
    size_t differ = 0;
    for (size_t i = 0; i < diff.size(); ++i) {
      const int d = std::abs(int(g[i]) - int(n[i]));
      worst = std::max(worst, d);
      differ += d != 0;
      diff[i] = static_cast<unsigned char>(std::min(255, 16 * d));
    }
    const std::string diff_path = kOutput + "/" + name + ".diff.png";
    stbi_write_png(diff_path.c_str(), gw, gh, 3, diff.data(), gw * 3);
    out += ", diff against " + golden + " (x16) to " + diff_path + ": " + std::to_string(differ) +
           " channel values differ, by up to " + std::to_string(worst) + "/255";
  }
  stbi_image_free(g);
  stbi_image_free(n);
  return out;
}

std::map<std::string, std::pair<uint64_t, uint64_t>> read_goldens() {
  std::map<std::string, std::pair<uint64_t, uint64_t>> g;
  std::ifstream in(kGoldens);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string name, a, b;
    ls >> name >> a >> b;
    g[name] = {std::stoull(a, nullptr, 16), std::stoull(b, nullptr, 16)};
  }
  return g;
}

TEST(GreyGoldens, ShippedGreyScenesUnchangedBitForBit) {
  if (std::getenv("CDSM_RECORD_GOLDENS")) {
    std::ofstream out(kGoldens);
    out << "# name image_hash node_hash (FNV-1a 64; tests/colour/test_grey_goldens.cpp)\n";
    std::filesystem::create_directories(kGoldenImages);
    for (const Case& c : cases()) {
      Image img;
      auto h = hashes(grey_scene(c), img);
      write_png(img, kGoldenImages + "/" + c.name + ".png");
      char line[128];
      std::snprintf(line, sizeof line, "%s %016llx %016llx\n", c.name.c_str(), (unsigned long long)h.first,
                    (unsigned long long)h.second);
      out << line;
    }
    GTEST_SKIP() << "recorded " << kGoldens << " and " << kGoldenImages;
  }
  const auto goldens = read_goldens();
  ASSERT_EQ(goldens.size(), cases().size()) << "missing or incomplete " << kGoldens;
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    Image img;
    auto h = hashes(grey_scene(c), img);
    auto it = goldens.find(c.name);
    ASSERT_NE(it, goldens.end());
    EXPECT_EQ(h.first, it->second.first) << "image of grey scene " << c.name << " changed; "
                                         << (h.first != it->second.first ? write_what_moved(c.name, img) : "");
    EXPECT_EQ(h.second, it->second.second) << "node lists of grey scene " << c.name << " changed";
  }
}

}  // namespace
