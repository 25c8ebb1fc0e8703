// Grey scenes are unchanged by coloured shadows (issue "Coloured
// shadows"): every shipped scene whose casters are all grey renders the
// same image and builds the same node lists, bit for bit, as before RGB
// transmittance existed. The hashes in grey_goldens.txt were recorded with
// the code before that change (commit named in the file); CPU fragment
// producer (deterministic), small sizes, every layout on the default scene.
//
// Re-record only for a deliberate change of the grey result:
//   CDSM_RECORD_GOLDENS=1 ./colour_grey_goldens  (writes grey_goldens.txt in the source tree)
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "shadow_system_impl.h"

using namespace cdsm;

namespace {

const std::string kGoldens = std::string(CDSM_COLOUR_TEST_DIR) + "/grey_goldens.txt";

struct Fnv {
  uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  }
  template <class T>
  void value(const T& v) {
    bytes(&v, sizeof v);
  }
};

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

// Hashes of the rendered image and of every map's node lists.
std::pair<uint64_t, uint64_t> hashes(const Scene& scene) {
  SystemOptions opt;
  opt.fragments = FragmentSource::Cpu;
  ShadowSystem sys(opt);
  sync_scene(sys, scene);
  Image img = sys.render();
  Fnv image;
  image.bytes(img.rgb.data(), img.rgb.size() * sizeof(float));
  Fnv nodes;
  const ShadowFrame& f = internals(sys).frame;
  const ShadowView view = f.view(scene.shadows);
  std::vector<DsmNode> buf(8192);
  for (const DsmMap& m : f.headers) {
    EXPECT_EQ(m.rgb, 0u) << "a grey scene built an RGB map";
    if (m.rgb != 0u) continue;
    nodes.value(m.res);
    for (int ty = 0; ty < int(m.res); ++ty)
      for (int tx = 0; tx < int(m.res); ++tx) {
        const uint32_t n = read_texel(view.storage, m, tx, ty, buf.data(), uint32_t(buf.size()));
        nodes.value(n);
        nodes.bytes(buf.data(), std::min<size_t>(n, buf.size()) * sizeof(DsmNode));
      }
  }
  return {image.h, nodes.h};
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
    for (const Case& c : cases()) {
      auto h = hashes(grey_scene(c));
      char line[128];
      std::snprintf(line, sizeof line, "%s %016llx %016llx\n", c.name.c_str(), (unsigned long long)h.first,
                    (unsigned long long)h.second);
      out << line;
    }
    GTEST_SKIP() << "recorded " << kGoldens;
  }
  const auto goldens = read_goldens();
  ASSERT_EQ(goldens.size(), cases().size()) << "missing or incomplete " << kGoldens;
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    auto h = hashes(grey_scene(c));
    auto it = goldens.find(c.name);
    ASSERT_NE(it, goldens.end());
    EXPECT_EQ(h.first, it->second.first) << "image of grey scene " << c.name << " changed";
    EXPECT_EQ(h.second, it->second.second) << "node lists of grey scene " << c.name << " changed";
  }
}

}  // namespace
