// Scene files (engine/src/scene_json.cpp, STYLE.md 8): every bad input
// raises cdsm::Error whose where() names the file and the JSON path (or
// line:column for invalid JSON) and whose problem() says what is wrong.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "cdsm/scene_io.h"
#include "unit_util.h"

using namespace cdsm;
using nlohmann::json;

namespace {

const char* kBase = R"({
  "camera": {"position": [0, 2, 6], "target": [0, 0, 0], "fov_y": 40, "near": 0.1, "far": 50,
             "width": 64, "height": 48},
  "shadows": {"epsilon": 0.02, "resolution": 256, "filtering": false},
  "volumes": [
    {"name": "fog", "grid": {"type": "dense", "size": [2, 2, 2], "fill": 1.0}, "voxel_size": 0.1,
     "transfer": [{"density": 0, "extinction": 0}, {"density": 1, "extinction": 2}]}
  ],
  "objects": [
    {"name": "ground", "mesh": {"type": "ground", "size": [10, 0, 10]}, "casts_shadows": false},
    {"name": "box", "mesh": {"type": "box", "size": [1, 1, 1]}, "transform": {"translate": [0, 0.5, 0]}},
    {"name": "glass", "mesh": {"type": "sphere", "radius": 0.5},
     "material": {"color": [0.2, 0.5, 0.9], "opacity": 0.5}, "interior": {"type": "constant", "sigma": 1.5}},
    {"name": "fog", "interior": {"type": "volume", "volume": "fog"}, "material": {"opacity": 0}}
  ],
  "lights": [{"type": "spot", "position": [2, 5, 2], "target": [0, 0, 0], "outer_cone": 30, "inner_cone": 25}]
})";

json base() { return json::parse(kBase); }

// A value that JSON cannot hold: written as 1e999 (parses to infinity).
constexpr double kInfMarker = 123456.125;

std::string text_of(const json& j) {
  std::string s = j.dump();
  std::string marker = json(kInfMarker).dump();
  for (size_t at = s.find(marker); at != std::string::npos; at = s.find(marker)) s.replace(at, marker.size(), "1e999");
  return s;
}

// Parses `text` and expects a cdsm::Error at `where` (a substring of
// where(), after the file name) saying `problem` (a substring of problem()).
::testing::AssertionResult fails_with(const std::string& text, const std::string& where, const std::string& problem) {
  try {
    parse_scene(text, "scene.json", "/nonexistent-base");
  } catch (const Error& e) {
    std::string w = e.where(), p = e.problem(), what = e.what();
    if (w.rfind("scene.json", 0) != 0)
      return ::testing::AssertionFailure() << "where() '" << w << "' does not start with the file name";
    if (w.find(where) == std::string::npos)
      return ::testing::AssertionFailure() << "where() '" << w << "' lacks '" << where << "' (problem: " << p << ")";
    if (p.find(problem) == std::string::npos)
      return ::testing::AssertionFailure() << "problem() '" << p << "' lacks '" << problem << "' (where: " << w << ")";
    if (what.find(w) == std::string::npos || what.find(p) == std::string::npos)
      return ::testing::AssertionFailure() << "what() '" << what << "' lacks where or problem";
    return ::testing::AssertionSuccess();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "threw a non-cdsm exception: " << e.what();
  }
  return ::testing::AssertionFailure() << "no error";
}

::testing::AssertionResult fails_with(const json& j, const std::string& where, const std::string& problem) {
  return fails_with(text_of(j), where, problem);
}

// The path must be exactly this (the end of where()).
::testing::AssertionResult fails_at(const json& j, const std::string& path, const std::string& problem) {
  ::testing::AssertionResult r = fails_with(j, path, problem);
  if (!r) return r;
  try {
    parse_scene(text_of(j), "scene.json", "/nonexistent-base");
  } catch (const Error& e) {
    std::string expect = "scene.json: " + path;
    if (e.where() != expect)
      return ::testing::AssertionFailure() << "where() '" << e.where() << "' != '" << expect << "'";
  }
  return ::testing::AssertionSuccess();
}

}  // namespace

TEST(SceneJson, BaseSceneParses) {
  Scene s = parse_scene(kBase, "scene.json", "/nonexistent-base");
  ASSERT_EQ(s.objects.size(), 4u);
  EXPECT_FLOAT_EQ(s.objects[2].surface.opacity, 0.5f);
  EXPECT_EQ(s.objects[2].interior, InteriorKind::Constant);
  EXPECT_FLOAT_EQ(s.objects[2].sigma.x, 1.5f);
  EXPECT_TRUE(is_grey(s.objects[2].sigma)) << "a scalar sigma is every channel's";
  EXPECT_EQ(s.objects[3].interior, InteriorKind::Volume);
  EXPECT_EQ(s.objects[3].volume, 0);
  EXPECT_FALSE(s.objects[0].casts_shadows);
  EXPECT_FLOAT_EQ(s.shadows.epsilon, 0.02f);
  EXPECT_EQ(s.shadows.resolution, 256);
  EXPECT_FALSE(s.shadows.filtering);
  EXPECT_EQ(s.camera.width, 64);
  EXPECT_FLOAT_EQ(s.camera.far, 50.0f);
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].type, LightType::Spot);
  EXPECT_FLOAT_EQ(s.lights[0].outer_cone_deg, 30.0f);
  EXPECT_EQ(s.source, "scene.json");
}

TEST(SceneJson, MissingField) {
  json j = base();
  j["camera"].erase("position");
  EXPECT_TRUE(fails_at(j, "/camera/position", "missing required field"));
  j = base();
  j["objects"][1].erase("mesh");
  EXPECT_TRUE(fails_at(j, "/objects/1/mesh", "missing required field"));
  j = base();
  j.erase("objects");
  EXPECT_TRUE(fails_at(j, "/objects", "missing required field"));
  j = base();
  j["volumes"][0]["transfer"][1].erase("extinction");
  EXPECT_TRUE(fails_at(j, "/volumes/0/transfer/1/extinction", "missing required field"));
  j = base();
  j["lights"][0].erase("type");
  EXPECT_TRUE(fails_at(j, "/lights/0/type", "missing required field"));
  j = base();
  j["objects"][2]["interior"].erase("sigma");
  EXPECT_TRUE(fails_at(j, "/objects/2/interior/sigma", "missing required field"));
}

TEST(SceneJson, MistypedField) {
  json j = base();
  j["objects"][2]["material"]["opacity"] = "0.5";
  EXPECT_TRUE(fails_at(j, "/objects/2/material/opacity", "expected a number, found a string"));
  j = base();
  j["camera"]["width"] = 64.5;
  EXPECT_TRUE(fails_at(j, "/camera/width", "expected an integer"));
  j = base();
  j["objects"][0]["casts_shadows"] = 1;
  EXPECT_TRUE(fails_at(j, "/objects/0/casts_shadows", "expected true or false"));
  j = base();
  j["camera"]["position"] = {0, 2};
  EXPECT_TRUE(fails_at(j, "/camera/position", "expected [x, y, z]"));
  j = base();
  j["objects"] = json::object();
  EXPECT_TRUE(fails_at(j, "/objects", "expected an array"));
  j = base();
  j["objects"][1]["transform"] = "identity";
  EXPECT_TRUE(fails_at(j, "/objects/1/transform", "expected an object, found a string"));
  j = base();
  j["objects"][2]["material"]["color"] = {0.2, "red", 0.9};
  EXPECT_TRUE(fails_at(j, "/objects/2/material/color/1", "expected a number, found a string"));
}

// Values a float cannot hold, written as finite JSON numbers: reported at
// their JSON path.
TEST(SceneJson, OutOfFloatRange) {
  json j = base();
  j["shadows"]["epsilon"] = 1e39;
  EXPECT_TRUE(fails_at(j, "/shadows/epsilon", "NaN, infinite or out of float range"));
  j = base();
  j["camera"]["position"] = {0, -4e38, 6};
  EXPECT_TRUE(fails_at(j, "/camera/position/1", "NaN, infinite or out of float range"));
  j = base();
  j["objects"][2]["interior"]["sigma"] = 1e300;
  EXPECT_TRUE(fails_at(j, "/objects/2/interior/sigma", "NaN, infinite or out of float range"));
  j = base();
  j["camera"]["width"] = 1e10;
  EXPECT_TRUE(fails_at(j, "/camera/width", "expected an integer"));
}

// JSON cannot hold NaN or infinity; 1e999 is how a file says "infinite".
// It must be a cdsm::Error naming the file and the place (the JSON path, or
// line:column when the number stops the parser), not a raw nlohmann error.
TEST(SceneJson, NanOrInfinity) {
  struct Case {
    json j;
    std::string path;
  };
  std::vector<Case> cases;
  json j = base();
  j["objects"][2]["material"]["opacity"] = kInfMarker;
  cases.push_back({j, "/objects/2/material/opacity"});
  j = base();
  j["camera"]["position"] = {0, kInfMarker, 6};
  cases.push_back({j, "/camera/position/1"});
  j = base();
  j["objects"][2]["interior"]["sigma"] = kInfMarker;
  cases.push_back({j, "/objects/2/interior/sigma"});
  for (const Case& c : cases) {
    std::string text = text_of(c.j);
    ASSERT_NE(text.find("1e999"), std::string::npos);
    try {
      parse_scene(text, "scene.json", "/nonexistent-base");
      ADD_FAILURE() << "no error for " << c.path;
    } catch (const Error& e) {
      int line = 0, col = 0;
      bool located =
          e.where() == "scene.json: " + c.path || std::sscanf(e.where().c_str(), "scene.json:%d:%d", &line, &col) == 2;
      EXPECT_TRUE(located) << "where() '" << e.where() << "' names neither " << c.path << " nor line:column";
      EXPECT_TRUE(e.problem().find("inf") != std::string::npos || e.problem().find("range") != std::string::npos)
          << e.problem();
    } catch (const std::exception& e) {
      ADD_FAILURE() << c.path << ": threw a non-cdsm exception: " << e.what();
    }
  }
}

TEST(SceneJson, UnknownType) {
  json j = base();
  j["objects"][1]["mesh"]["type"] = "cone";
  EXPECT_TRUE(fails_at(j, "/objects/1/mesh/type", "unknown mesh type 'cone'"));
  j = base();
  j["lights"][0]["type"] = "area";
  EXPECT_TRUE(fails_at(j, "/lights/0/type", "unknown light type 'area'"));
  j = base();
  j["objects"][2]["interior"]["type"] = "glass";
  EXPECT_TRUE(fails_at(j, "/objects/2/interior/type", "unknown interior type 'glass'"));
  j = base();
  j["volumes"][0]["grid"]["type"] = "sparse";
  EXPECT_TRUE(fails_at(j, "/volumes/0/grid/type", "unknown grid type 'sparse'"));
  j = base();
  j["shadows"]["layout"] = "tiled";
  EXPECT_TRUE(fails_at(j, "/shadows/layout", "unknown layout 'tiled'"));
}

TEST(SceneJson, UnknownField) {
  json j = base();
  j["objects"][2]["material"]["opacty"] = 0.5;
  EXPECT_TRUE(fails_at(j, "/objects/2/material/opacty", "unknown field"));
  j = base();
  j["shadow"] = json::object();
  EXPECT_TRUE(fails_at(j, "/shadow", "unknown field"));
  j = base();
  j["camera"]["fov"] = 40;
  EXPECT_TRUE(fails_at(j, "/camera/fov", "unknown field"));
  j = base();
  j["objects"][1]["mesh"]["radius"] = 1;
  EXPECT_TRUE(fails_at(j, "/objects/1/mesh/radius", "unknown field"));
}

TEST(SceneJson, ReferencedFileMissing) {
  const std::string missing = "/nonexistent-dir-cdsm/scene.json";
  try {
    load_scene(missing);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where(), missing);
    EXPECT_NE(e.problem().find("scene file not found"), std::string::npos) << e.problem();
  }
  // A volume grid read from a file that does not exist.
  json j = base();
  j["volumes"][0]["grid"] = {{"type", "raw"}, {"file", "no_such_volume.raw"}, {"dims", {4, 4, 4}}};
  EXPECT_TRUE(fails_with(j, "/volumes/0/grid/file", "not found"));
  // An unknown volume name.
  j = base();
  j["objects"][3]["interior"]["volume"] = "smoke";
  EXPECT_TRUE(fails_at(j, "/objects/3/interior/volume", "no volume named 'smoke'"));
  j = base();
  j["objects"][3]["interior"]["volume"] = 3;
  EXPECT_TRUE(fails_at(j, "/objects/3/interior/volume", "does not exist"));
}

TEST(SceneJson, ImpossibleValues) {
  json j = base();
  j["shadows"]["epsilon"] = -0.01;
  EXPECT_TRUE(fails_at(j, "/shadows/epsilon", "must be within [0, 1], got -0.01"));
  j = base();
  j["shadows"]["resolution"] = 0;
  EXPECT_TRUE(fails_at(j, "/shadows/resolution", "must be within [4, 8192]"));
  j = base();
  j["camera"]["near"] = 10;
  j["camera"]["far"] = 5;
  EXPECT_TRUE(fails_at(j, "/camera", "needs 0 < near < far"));
  j = base();
  j["camera"]["near"] = 5;
  j["camera"]["far"] = 5;
  EXPECT_TRUE(fails_at(j, "/camera", "needs 0 < near < far"));
  j = base();
  j["camera"]["near"] = 0;
  EXPECT_TRUE(fails_at(j, "/camera", "needs 0 < near < far"));
  j = base();
  j["objects"][2]["material"]["opacity"] = 1.5;
  EXPECT_TRUE(fails_at(j, "/objects/2/material/opacity", "must be within [0, 1]"));
  j = base();
  j["objects"][2]["interior"]["sigma"] = -1;
  EXPECT_TRUE(fails_at(j, "/objects/2/interior/sigma", "must be within [0, 1e+38], got -1"));
  j = base();
  j["lights"] = json::array();
  EXPECT_TRUE(fails_at(j, "/lights", "at least one light"));
}

// Values that used to be accepted without a word (issue "Reliability"):
// each is an error naming the field, its value and its range.
TEST(SceneJson, RangesOfEveryKindOfField) {
  struct Case {
    std::function<void(json&)> edit;
    std::string path, problem;
  };
  const Case cases[] = {
      {[](json& j) {
         j["objects"][1]["material"] = {{"color", {0.5, -0.1, 0.5}}};
       },
       "/objects/1/material/color/1", "must be within [0, 100], got -0.1"},
      {[](json& j) {
         j["objects"][1]["material"] = {{"diffuse", -1}};
       },
       "/objects/1/material/diffuse", "got -1"},
      {[](json& j) {
         j["objects"][1]["material"] = {{"specular", -0.5}};
       },
       "/objects/1/material/specular", "got -0.5"},
      {[](json& j) {
         j["objects"][1]["material"] = {{"ambient", -0.5}};
       },
       "/objects/1/material/ambient", "got -0.5"},
      {[](json& j) {
         j["lights"][0]["color"] = {1, 1, -2};
       },
       "/lights/0/color/2", "got -2"},
      {[](json& j) {
         j["volumes"][0]["transfer"][1]["color"] = {-1, 0, 0};
       },
       "/volumes/0/transfer/1/color/0", "got -1"},
      {[](json& j) {
         j["shadows"]["ambient"] = {-1, 0, 0};
       },
       "/shadows/ambient/0", "got -1"},
      {[](json& j) {
         j["background"] = {0.1, -0.2, 0};
       },
       "/background/1", "got -0.2"},
      {[](json& j) { j["volumes"][0]["gradient_scale"] = -3; }, "/volumes/0/gradient_scale",
       "within [0, 1e+06], got -3"},
      {[](json& j) {
         j["volumes"][0]["grid"] = {{"type", "noise"}, {"octaves", -1}};
       },
       "/volumes/0/grid/octaves", "got -1"},
      {[](json& j) {
         j["volumes"][0]["grid"] = {{"type", "noise"}, {"octaves", 2147483647}};
       },
       "/volumes/0/grid/octaves", "within [1, 12]"},
      {[](json& j) {
         j["volumes"][0]["grid"] = {{"type", "noise"}, {"scale", -1}};
       },
       "/volumes/0/grid/scale", "got -1"},
      {[](json& j) {
         j["volumes"][0]["grid"] = {{"type", "noise"}, {"frequency", 0}};
       },
       "/volumes/0/grid/frequency", "got 0"},
      {[](json& j) { j["volumes"][0]["grid"]["fill"] = -1; }, "/volumes/0/grid/fill", "must be >= 0, got -1"},
      {[](json& j) { j["shadows"]["d0"] = 9; }, "/shadows/d0", "within [0, 4], got 9"},
      {[](json& j) { j["shadows"]["bias_slope"] = 1000; }, "/shadows/bias_slope", "within [0, 100], got 1000"},
      {[](json& j) { j["shadows"]["receiver"] = "normal_offset"; }, "/shadows/receiver",
       "unknown receiver 'normal_offset' (plane or slope_bias)"},
      {[](json& j) { j["shadows"]["epsilon"] = 2; }, "/shadows/epsilon", "within [0, 1], got 2"},
      {[](json& j) { j["shadows"]["max_memory"] = -5; }, "/shadows/max_memory", "got -5"},
      {[](json& j) { j["lights"][0]["intensity"] = -1; }, "/lights/0/intensity", "got -1"},
      {[](json& j) {
         j["objects"][1]["material"] = {{"shininess", 1e9}};
       },
       "/objects/1/material/shininess", "within [0, 10000]"},
  };
  for (const Case& c : cases) {
    json j = base();
    c.edit(j);
    EXPECT_TRUE(fails_at(j, c.path, c.problem)) << c.path;
  }
}

// camera.up zero or parallel to the view: a fallback, said in a warning.
TEST(SceneJson, CameraUpParallelToTheViewWarns) {
  for (json up : {json{0, 0, 0}, json{0, -2, -6}}) {
    json j = base();
    j["camera"]["up"] = up;
    std::vector<std::string> lines;
    set_warning_sink([&](const std::string& w) { lines.push_back(w); });
    Scene s = parse_scene(j.dump(), "scene.json", "/nonexistent-base");
    set_warning_sink(nullptr);
    ASSERT_EQ(lines.size(), 1u) << up.dump();
    EXPECT_NE(lines[0].find("scene.json: /camera/up is"), std::string::npos) << lines[0];
    EXPECT_NE(lines[0].find("a perpendicular up is used"), std::string::npos) << lines[0];
  }
}

// Grid sizes are whole numbers of voxels, and their product is checked
// before it can wrap (issue "No silent wrong answers", item 8).
TEST(SceneJson, GridSizes) {
  json j = base();
  j["volumes"][0]["grid"]["size"] = {2.5, 2, 2};
  EXPECT_TRUE(fails_at(j, "/volumes/0/grid/size", "whole number"));
  j = base();
  j["volumes"][0]["grid"]["size"] = {4194304, 4194304, 4194304};
  EXPECT_TRUE(fails_at(j, "/volumes/0/grid/size", "holds 7.3787e+19 voxels, at most"));
  j = base();
  j["volumes"][0]["grid"]["size"] = {0, 2, 2};
  EXPECT_TRUE(fails_at(j, "/volumes/0/grid/size", "within [1,"));
  j = base();
  j["volumes"][0]["grid"] = {{"type", "noise"}, {"size", {16.7, 16, 16}}};
  EXPECT_TRUE(fails_at(j, "/volumes/0/grid/size", "whole number"));
  j = base();
  j["volumes"][0]["grid"] = {{"type", "noise"}, {"size", {1e12, 16, 16}}};
  EXPECT_TRUE(fails_at(j, "/volumes/0/grid/size", "within [2, 1024]"));
}

namespace {

// Expects invalid JSON reported at line:column (1-based, the column of the
// offending character).
::testing::AssertionResult invalid_at(const std::string& text, int line, int col) {
  try {
    parse_scene(text, "scene.json", "/nonexistent-base");
  } catch (const Error& e) {
    std::string expect = "scene.json:" + std::to_string(line) + ":" + std::to_string(col);
    if (e.where() != expect)
      return ::testing::AssertionFailure() << "where() '" << e.where() << "' != '" << expect << "'";
    if (e.problem().find("invalid JSON") == std::string::npos)
      return ::testing::AssertionFailure() << "problem() '" << e.problem() << "'";
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "no error";
}

}  // namespace

TEST(SceneJson, InvalidJsonLineAndColumn) {
  // The stray comma is the 14th character of line 2.
  EXPECT_TRUE(invalid_at("{\n  \"camera\": {,\n}", 2, 14));
  // The 'x' is the first character of line 1.
  EXPECT_TRUE(invalid_at("x", 1, 1));
  // The '}' closing an object after a trailing comma: line 3, column 1.
  EXPECT_TRUE(invalid_at("{\n  \"a\": 1,\n}", 3, 1));
}

TEST(SceneJson, InvalidJsonLineAndColumnRoughly) {
  // Whatever the column convention, the line is right and the column is
  // within one character of the offending one.
  struct Case {
    const char* text;
    int line, col;
  } cases[] = {{"{\n  \"camera\": {,\n}", 2, 14}, {"x", 1, 1}, {"{\n  \"a\": 1,\n}", 3, 1}};
  for (const Case& c : cases) {
    try {
      parse_scene(c.text, "scene.json", "");
      ADD_FAILURE() << "no error for " << c.text;
    } catch (const Error& e) {
      int line = 0, col = 0;
      ASSERT_EQ(std::sscanf(e.where().c_str(), "scene.json:%d:%d", &line, &col), 2) << e.where();
      EXPECT_EQ(line, c.line) << e.where();
      EXPECT_LE(std::abs(col - c.col), 1) << e.where();
      EXPECT_EQ(e.problem(), "invalid JSON");
    }
  }
}

TEST(SceneJson, LoadSceneNamesTheFile) {
  std::string path = std::string(CDSM_TEST_OUTPUT_DIR) + "/unit_bad_scene.json";
  {
    std::ofstream f(path);
    json j = base();
    j["shadows"]["resolution"] = 0;
    f << j.dump(2);
  }
  try {
    load_scene(path);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where(), path + ": /shadows/resolution");
  }
  {
    std::ofstream f(path);
    f << "{\n  \"camera\": [1, 2,, 3]\n}\n";
  }
  try {
    load_scene(path);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().rfind(path + ":2:", 0), 0u) << e.where();
    EXPECT_EQ(e.problem(), "invalid JSON");
  }
  std::remove(path.c_str());
  // The shipped default scene loads.
  Scene s = load_scene(std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json");
  EXPECT_GE(s.objects.size(), 8u);
  EXPECT_EQ(s.volumes.size(), 2u);
  EXPECT_EQ(s.lights.size(), 1u);
}
