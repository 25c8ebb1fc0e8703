// The tags of cdsm/tags.h: names that read back to their values, messages
// that list every name, and cdsm.glsl's constants equal to the enums' values
// (the shader text has its own names; this is where they are checked).
#include <gtest/gtest.h>

#include <cctype>
#include <fstream>
#include <sstream>
#include <string>

#include <cstdlib>
#include <regex>

#include "cdsm/procedural.h"
#include "cdsm/tags.h"
#include "hd/fragment.h"
#include "hd/lights.h"

namespace cdsm {
namespace {

template <class E>
void expect_names_round_trip() {
  ASSERT_GT(tag_count<E>(), 1u);
  for (uint32_t i = 0; i < tag_count<E>(); ++i) {
    const std::string name = tag_name(E(i));
    E back = E(tag_count<E>() - 1 - i);
    EXPECT_TRUE(parse_tag(name, back)) << name;
    EXPECT_EQ(uint32_t(back), i) << name;
    EXPECT_NE(tag_choices<E>().find(name), std::string::npos) << name;
  }
  E untouched = E(0);
  EXPECT_FALSE(parse_tag("no such name", untouched));
  EXPECT_EQ(uint32_t(untouched), 0u);
  EXPECT_STREQ(tag_name(E(tag_count<E>())), "?");
}

TEST(Tags, NamesReadBackToTheirValues) {
  expect_names_round_trip<InteriorKind>();
  expect_names_round_trip<LightType>();
  expect_names_round_trip<MapMode>();
  expect_names_round_trip<DsmLayout>();
  expect_names_round_trip<ReceiverLookup>();
  expect_names_round_trip<ShadowMethod>();
  EXPECT_EQ(tag_choices<DsmLayout>(), "packed, fixed or chunked");
  EXPECT_EQ(tag_choices<ReceiverLookup>(), "plane or slope_bias");
}

std::string read_glsl() {
  const std::string path = CDSM_GLSL_TEST;  // as joined from its parts (cmake/CdsmGlsl.cmake)
  std::ifstream f(path);
  EXPECT_TRUE(f.good()) << path;
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string upper(std::string s) {
  for (char& c : s) c = char(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// Every value of E appears in cdsm.glsl as `const uint PREFIX_NAME = vu;`
// (or `#define PREFIX_NAME v` when `define`), NAME its tag name in capitals.
template <class E>
void expect_glsl_constants(const std::string& glsl, const std::string& prefix, bool define = false) {
  for (uint32_t i = 0; i < tag_count<E>(); ++i) {
    const std::string name = prefix + upper(tag_name(E(i)));
    const std::string line = define ? "#define " + name + " " + std::to_string(i) + "\n"
                                    : "const uint " + name + " = " + std::to_string(i) + "u;";
    EXPECT_NE(glsl.find(line), std::string::npos) << "cdsm.glsl lacks `" << line << "`";
  }
}

TEST(Tags, TheShaderIncludeNamesTheSameValues) {
  const std::string glsl = read_glsl();
  ASSERT_FALSE(glsl.empty());
  expect_glsl_constants<DsmLayout>(glsl, "CDSM_LAYOUT_", true);
  expect_glsl_constants<LightType>(glsl, "CDSM_LIGHT_");
  expect_glsl_constants<Projection>(glsl, "CDSM_PROJECTION_");
  expect_glsl_constants<MapMode>(glsl, "CDSM_MAPS_");
  expect_glsl_constants<ReceiverLookup>(glsl, "CDSM_RECEIVER_");
  expect_glsl_constants<Penumbra>(glsl, "CDSM_PENUMBRA_");
}

// The value of `const float|int NAME = VALUE;` in cdsm.glsl, as a float
// (NaN when the line is not there).
float glsl_constant(const std::string& glsl, const std::string& name) {
  std::smatch m;
  if (!std::regex_search(glsl, m, std::regex("const (float|int) " + name + " = ([-+0-9.eE]+);"))) return std::nanf("");
  return std::strtof(m[2].str().c_str(), nullptr);
}

// The constants and the 16 search directions cdsm.glsl copies from
// hd/lights.h and hd/fragment.h are the C++ values, float for float.
TEST(Tags, TheShaderIncludeCopiesTheLookupConstants) {
  const std::string glsl = read_glsl();
  ASSERT_FALSE(glsl.empty());
  const std::pair<const char*, float> constants[] = {{"CDSM_PLANE_REACH_TEXELS", kPlaneReachTexels},
                                                     {"CDSM_RELATIVE_DEPTH_OFFSET", kRelativeDepthOffset},
                                                     {"CDSM_SLOPE_BIAS_CONSTANT", kSlopeBiasConstant},
                                                     {"CDSM_SLOPE_BIAS_TEXELS", kSlopeBiasTexels},
                                                     {"CDSM_PENUMBRA_SEARCH_RINGS", float(kPenumbraSearchRings)},
                                                     {"CDSM_PENUMBRA_SEARCH_TEXELS", kPenumbraSearchTexels},
                                                     {"CDSM_PENUMBRA_MIN_ALPHA", kPenumbraMinAlpha}};
  for (const auto& [name, value] : constants) EXPECT_EQ(glsl_constant(glsl, name), value) << name;
  const size_t at = glsl.find("CDSM_PENUMBRA_DIRECTIONS[16] = vec2[16](");
  ASSERT_NE(at, std::string::npos) << "cdsm.glsl lacks the penumbra directions";
  std::string rest = glsl.substr(at);
  const std::regex pair(R"(vec2\(([-+0-9.eE]+), ([-+0-9.eE]+)\))");
  int d = 0;
  for (std::sregex_iterator it(rest.begin(), rest.end(), pair), end; it != end && d < 16; ++it, ++d) {
    const Vec2 want = penumbra_direction(d);
    EXPECT_EQ(std::strtof((*it)[1].str().c_str(), nullptr), want.x) << "direction " << d;
    EXPECT_EQ(std::strtof((*it)[2].str().c_str(), nullptr), want.y) << "direction " << d;
  }
  EXPECT_EQ(d, 16);
}

}  // namespace
}  // namespace cdsm
