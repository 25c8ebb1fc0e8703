// The cdsm program as a user runs it (tests/cli): every bad option or
// output path is one error line naming it, exit code 1, found before any
// rendering work; the summary and --stats report the frame's counters.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cdsm/fields.h"
#include "cdsm/scene_io.h"
#include "cdsm/error.h"
#include "common/cli_run.h"
#if CDSM_HAVE_EDITOR
#include "script_commands.h"
#endif

namespace {

using cdsm_test::CliRun;
using cdsm_test::slurp;

std::string output_dir() { return cdsm_test::cli_output_dir("cli"); }

// Runs `cdsm ARGS` (a shell word list) and captures its streams.
CliRun run_cdsm(const std::string& args) { return cdsm_test::run_program(CDSM_EXE, "", args, output_dir()); }

const std::string kScene = std::string(CDSM_CONTENT_DIR_TEST) + "/scenes/default.json";

// The README's text between the marker lines `open` (its end included) and
// `close`; npos-free: a missing marker fails the calling test.
std::string readme_between(const std::string& open, const std::string& close) {
  const std::string readme = slurp(std::string(CDSM_SOURCE_DIR_TEST) + "/README.md");
  const size_t a = readme.find(open), b = readme.find(close);
  EXPECT_NE(a, std::string::npos) << "README.md has no " << open;
  EXPECT_NE(b, std::string::npos) << "README.md has no " << close;
  if (a == std::string::npos || b == std::string::npos || b < a + open.size()) return "<missing>";
  return readme.substr(a + open.size(), b - a - open.size());
}

}  // namespace

// Output paths that cannot be written are refused before the render: one
// error line naming the path, exit 1, nothing rendered (no summary), and
// nothing the user had is touched.
TEST(Cli, UnwritableOutputsFailBeforeRendering) {
  const std::string dir = output_dir();
  ::mkdir((dir + "/a_directory.png").c_str(), 0755);
  struct Case {
    std::string args, names;
  } cases[] = {
      {"-o /nonexistent-dir/out.png", "/nonexistent-dir/out.png"},
      {"-o '" + dir + "/a_directory.png'", dir + "/a_directory.png"},
      {"-o '" + dir + "/ok.png' --stats /nonexistent-dir/s.json", "/nonexistent-dir/s.json"},
      {"-o '" + dir + "/ok.png' --stats '" + dir + "'", dir},
      {"-o '" + dir + "/a_directory.png' --compare-reference", dir + "/a_directory.png"},
  };
  for (const Case& c : cases) {
    CliRun r = run_cdsm("render '" + kScene + "' --width 32 --height 24 " + c.args);
    EXPECT_EQ(r.code, 1) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find("cdsm: error: " + c.names), std::string::npos) << c.args << ": " << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
    EXPECT_EQ(r.out.find("scene "), std::string::npos) << "rendered before refusing: " << r.out;
  }
  // The sibling images of --compare-reference are checked too.
  ::mkdir((dir + "/sib.reference.png").c_str(), 0755);
  CliRun r = run_cdsm("render '" + kScene + "' --width 32 --height 24 -o '" + dir + "/sib.png' --compare-reference");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(dir + "/sib.reference.png"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("scene "), std::string::npos);
}

// The walker's counters are in the summary and in --stats.
TEST(Cli, SummaryAndStatsReportTheSegmentCounters) {
  const std::string dir = output_dir();
  CliRun r = run_cdsm("render '" + kScene + "' --width 48 --height 32 --dsm-res 64 --fragments cpu -o '" + dir +
                      "/counters.png' --stats '" + dir + "/counters.json'");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("segments     unmatched fragments 0, enclosing overflow 0, rays with > 32 objects 0, "
                       "march steps lengthened 0"),
            std::string::npos)
      << r.out;
  nlohmann::json j = nlohmann::json::parse(slurp(dir + "/counters.json"));
  for (const char* key : {"unmatched_fragments", "enclosing_overflow", "ray_object_overflow", "march_steps_lengthened"})
    EXPECT_TRUE(j.contains(key)) << key;
}

// --max-memory: a too-small limit refuses the frame up front, naming the
// setting that needs the memory; a bad value is an error naming the option.
TEST(Cli, MaxMemory) {
  const std::string dir = output_dir();
  CliRun r = run_cdsm("render '" + kScene + "' --max-memory 8 -o '" + dir + "/mem.png'");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("needs an estimated"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("more than the limit of 8 MiB (--max-memory)"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("scene "), std::string::npos);
  for (const char* bad : {"abc", "0", "-5", "2T"}) {
    r = run_cdsm("render '" + kScene + "' --max-memory " + bad + " -o '" + dir + "/mem.png'");
    EXPECT_EQ(r.code, 1) << bad;
    EXPECT_NE(r.err.find("cdsm: error: --max-memory"), std::string::npos) << bad << ": " << r.err;
  }
  r = run_cdsm("render '" + kScene + "' --max-memory 4G --width 32 --height 24 --dsm-res 64 --fragments cpu -o '" +
               dir + "/mem.png'");
  EXPECT_EQ(r.code, 0) << r.err;
}

// Options that override a scene setting take their range from its row of
// the field table (cdsm/fields.h): the check and --help say the table's
// range, whatever it is (tests/cli/test_options.cpp: with another table).
TEST(Cli, OptionRangesAreTheFieldTables) {
  const std::string help = run_cdsm("render --help").out;
  auto check = [&](const std::string& option, const auto& row) {
    const std::string range = "[" + std::to_string(int64_t(row.lo)) + ", " + std::to_string(int64_t(row.hi)) + "]";
    EXPECT_NE(help.find(option + " INT:" + range), std::string::npos) << option << " " << range << "\n" << help;
    for (const int64_t bad : {int64_t(row.lo) - 1, int64_t(row.hi) + 1}) {
      CliRun r =
          run_cdsm("render '" + kScene + "' -o '" + output_dir() + "/range.png' " + option + " " + std::to_string(bad));
      EXPECT_EQ(r.code, 1) << option << " " << bad;
      EXPECT_EQ(r.err, "cdsm: error: " + option + ": must be within " + range + ", got " + std::to_string(bad) + "\n");
      EXPECT_EQ(r.out.find("scene "), std::string::npos) << "rendered before refusing: " << r.out;
    }
  };
  auto row = [&](auto table, const char* key, const std::string& option) {
    cdsm::for_each_field<decltype(table)>([&](const auto& f) {
      if (std::string(f.key) == key) check(option, f);
    });
  };
  row(cdsm::ShadowSettings{}, "resolution", "--dsm-res");
  row(cdsm::ShadowSettings{}, "clusters", "--clusters");
  row(cdsm::ShadowSettings{}, "fixed_layers", "--fixed-layers");
  row(cdsm::Camera{}, "width", "--width");
}

// What ships (the installed shaders, the docs, the README, --help) cites no
// document that is not shipped: the design notes stay with the team.
TEST(Cli, ShippedFilesCiteOnlyShippedDocuments) {
  namespace fs = std::filesystem;
  const fs::path root = fs::path(CDSM_SOURCE_DIR_TEST);
  std::vector<fs::path> files = {root / "README.md"};
  for (const char* dir : {"content/shaders", "docs"})
    for (const auto& e : fs::recursive_directory_iterator(root / dir))
      if (e.is_regular_file() && (e.path().extension() == ".glsl" || e.path().extension() == ".md"))
        files.push_back(e.path());
  ASSERT_GT(files.size(), 3u);
  for (const fs::path& f : files) {
    std::ifstream in(f);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text.find("DESIGN.md"), std::string::npos) << f;
  }
  for (const char* cmd : {"render --help", "bench --help", "--help"})
    EXPECT_EQ(run_cdsm(cmd).out.find("DESIGN.md"), std::string::npos) << cmd;
}

// `cdsm info` on a volume file says what it is and how a scene names it
// (it said "invalid JSON"): a .vdb with its grid, a .raw with its size.
TEST(Cli, InfoOnAVolumeFileSaysHowASceneUsesIt) {
  const std::string data = std::string(CDSM_CONTENT_DIR_TEST) + "/data";
  const CliRun vdb = run_cdsm("info '" + data + "/vdb/vpt_box_fog.vdb'");
  EXPECT_EQ(vdb.code, 0) << vdb.err;
  EXPECT_NE(vdb.out.find("an OpenVDB volume, not a scene"), std::string::npos) << vdb.out;
  EXPECT_NE(vdb.out.find("\"type\": \"vdb\""), std::string::npos) << vdb.out;
  const CliRun raw = run_cdsm("info '" + data + "/raw/bucky_32x32x32_uint8.raw'");
  EXPECT_EQ(raw.code, 0) << raw.err;
  EXPECT_NE(raw.out.find("a raw volume (32768 bytes), not a scene"), std::string::npos) << raw.out;
  EXPECT_NE(raw.out.find("\"type\": \"raw\""), std::string::npos) << raw.out;
}

// The scene-file fields, one table per struct (cdsm/fields.h): `cdsm info
// --fields` prints them with the C++ member each key sets, the README holds
// that print; the README's short table names only keys (or values) the
// tables have; what the reference says a scene must have, the reader
// refuses to go without.
TEST(Cli, SceneFieldReferenceIsTheFieldTables) {
  const CliRun fields = run_cdsm("info --fields");
  EXPECT_EQ(fields.code, 0) << fields.err;
  EXPECT_EQ(fields.out, cdsm::scene_field_reference());
  EXPECT_NE(fields.out.find("| `outer_cone` | `outer_cone_deg` | 30 |"), std::string::npos) << fields.out;
  EXPECT_NE(fields.out.find("| `angular_diameter` | `angular_diameter_deg` | 0 |"), std::string::npos);
  EXPECT_NE(fields.out.find("| `clusters` | `max_clusters` | 1 |"), std::string::npos);
  EXPECT_EQ(readme_between("<!-- scene-fields: the output of `cdsm info --fields` -->\n", "<!-- /scene-fields -->"),
            fields.out)
      << "README.md's field reference differs from cdsm info --fields";
  const std::string readme = slurp(std::string(CDSM_SOURCE_DIR_TEST) + "/README.md");

  // The short table's rows for structs with a field table: every
  // `backticked` word a key of that table, one of its tags' names, or a
  // key only the reader knows (a light's target).
  auto known = [](auto* of, std::set<std::string> extra) {
    using S = std::remove_pointer_t<decltype(of)>;
    std::set<std::string> names = std::move(extra);
    cdsm::for_each_field<S>([&](const auto& f) {
      names.insert(f.key);
      using T = std::remove_cv_t<std::remove_reference_t<decltype(S{}.*f.member)>>;
      if constexpr (std::is_enum_v<T>)
        for (uint32_t i = 0; i < cdsm::tag_count<T>(); ++i) names.insert(cdsm::tag_name(T(i)));
      if (cdsm::zero_is_auto(f)) names.insert("auto");
    });
    return names;
  };
  const std::map<std::string, std::set<std::string>> rows = {
      {"| camera |", known(static_cast<cdsm::Camera*>(nullptr), {})},
      {"| shadows |", known(static_cast<cdsm::ShadowSettings*>(nullptr), {})},
      {"| lights[] |", known(static_cast<cdsm::Light*>(nullptr), {"target"})}};
  for (const auto& [row, names] : rows) {
    const size_t at = readme.find("\n" + row);
    ASSERT_NE(at, std::string::npos) << row;
    const std::string line = readme.substr(at + 1, readme.find('\n', at + 1) - at - 1);
    for (size_t q = line.find('`'); q != std::string::npos; q = line.find('`', q + 1)) {
      const size_t e = line.find('`', q + 1);
      const std::string word = line.substr(q + 1, e - q - 1);
      EXPECT_TRUE(names.count(word)) << "README's " << row << " row names `" << word << "`, no field of its table";
      q = e;
    }
  }

  // The required fields: a scene without one is refused, naming it.
  const char* scene = R"({"camera": {"position": [0, 2, 6], "target": [0, 0, 0]},
    "objects": [{"mesh": {"type": "box", "size": [1, 1, 1]}}],
    "lights": [{"type": "point", "position": [0, 4, 0]}]})";
  EXPECT_NO_THROW(cdsm::parse_scene(scene, "minimal", "."));
  for (const auto& [pointer, message] : std::vector<std::pair<std::string, std::string>>{
           {"/camera", "/camera: missing required field"},
           {"/objects", "/objects: missing required field"},
           {"/lights", "/lights: missing required field"},
           {"/camera/position", "/camera/position: missing required field"},
           {"/camera/target", "/camera/target: missing required field"},
           {"/objects/0/mesh", "/objects/0/mesh: missing required field"},
           {"/lights/0/type", "/lights/0/type: missing required field"},
           {"/lights/0/position", "/lights/0/position: missing required field"}}) {
    nlohmann::json j = nlohmann::json::parse(scene);
    const nlohmann::json::json_pointer ptr(pointer);
    j[ptr.parent_pointer()].erase(ptr.back());
    try {
      cdsm::parse_scene(j.dump(), "minimal", ".");
      ADD_FAILURE() << "a scene without " << pointer << " was read";
    } catch (const cdsm::Error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
}

#if CDSM_HAVE_EDITOR
// The editor's script commands, one table (editor/edit/script_commands.h):
// `cdsm edit --script-help` prints it, the README shows that print, and
// the parser (script.cpp) runs exactly the table's commands.
TEST(Cli, ScriptCommandsAreOneTable) {
  const CliRun help = run_cdsm("edit --script-help");
  EXPECT_EQ(help.code, 0) << help.err;
  EXPECT_EQ(help.out, cdsm::editor::script_help());
  EXPECT_EQ(readme_between("<!-- script-commands: the output of `cdsm edit --script-help` -->\n```text\n",
                           "```\n<!-- /script-commands -->"),
            help.out)
      << "README.md's list differs from cdsm edit --script-help";
  // Every `cmd == "NAME"` the parser tests is a table command, and back.
  const std::string parser = slurp(std::string(CDSM_SOURCE_DIR_TEST) + "/editor/edit/script.cpp");
  std::set<std::string> handled, table;
  for (size_t at = parser.find("cmd == \""); at != std::string::npos; at = parser.find("cmd == \"", at + 1)) {
    const size_t from = at + 8, to = parser.find('"', from);
    handled.insert(parser.substr(from, to - from));
  }
  for (const cdsm::editor::ScriptCommand& c : cdsm::editor::kScriptCommands) table.insert(c.name);
  EXPECT_EQ(handled, table);
}
#endif

// Each option's text once in --help: an option over a field says the
// table's description and only what it adds (--penumbra said it twice).
TEST(Cli, HelpSaysEachOptionsTextOnce) {
  for (const char* cmd : {"render --help", "bench --help"}) {
    const std::string help = run_cdsm(cmd).out;
    size_t lines = 0;
    for (size_t at = help.find("blockers from the maps"); at != std::string::npos;
         at = help.find("blockers from the maps", at + 1))
      ++lines;
    EXPECT_LE(lines, 1u) << cmd << "\n" << help;
  }
  EXPECT_NE(run_cdsm("render --help").out.find("--penumbra"), std::string::npos);
}

// A command line the program cannot use is one line naming the option (or
// the argument) and the problem, exit 1, before any work.
TEST(Cli, BadCommandLinesAreOneLineNamingTheOption) {
  const std::string out = " -o '" + output_dir() + "/bad.png'";
  struct Case {
    std::string args, starts;
  } cases[] = {
    {"render '" + kScene + "'" + out + " --eps", "cdsm: error: --eps: "},
    {"render '" + kScene + "'" + out + " --eps 2", "cdsm: error: --eps: must be within ["},
    {"render '" + kScene + "'" + out + " --dsm-res 64x", "cdsm: error: --dsm-res: expected an integer, got '64x'"},
    {"render '" + kScene + "'" + out + " --layout tiled",
     "cdsm: error: --layout: unknown layout 'tiled' (packed, fixed or chunked)"},
    {"render '" + kScene + "'" + out + " --filtering maybe", "cdsm: error: --filtering: unknown value 'maybe'"},
    {"render '" + kScene + "'" + out + " --splits 1", "cdsm: error: --splits: must be 0 (off) or at least 2, got 1"},
    {"render '" + kScene + "'" + out + " --no-such-option", "cdsm: error: --no-such-option: unknown option"},
    {"render '" + kScene + "' second.json" + out, "cdsm: error: second.json: unexpected argument"},
    {"render '" + kScene + "'", "cdsm: error: --output is required"},
    {"bench '" + kScene + "' --sweep res=2 --out '" + output_dir() + "/bench'",
     "cdsm: error: --sweep res: must be within ["},
    {"bench '" + kScene + "' --methods osm0 --out '" + output_dir() + "/bench'", "cdsm: error: --methods osm0: "},
    {"bench '" + kScene + "' --methods mom6 --out '" + output_dir() + "/bench'",
     "cdsm: error: --methods mom6: moments: 4 or 8"},
    {"bench '" + kScene + "' --repeat 0", "cdsm: error: --repeat: must be within [1, 1000], got 0"},
#if CDSM_HAVE_EDITOR
    {"edit '" + kScene + "' --width 10", "cdsm: error: --width: must be within [640, 8192], got 10"},
#endif
  };
  for (const Case& c : cases) {
    CliRun r = run_cdsm(c.args);
    EXPECT_EQ(r.code, 1) << c.args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind(c.starts, 0), 0u) << c.args << ": " << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
    EXPECT_TRUE(r.out.empty()) << c.args << ": " << r.out;
  }
}

// The issue-31 baselines run in the bench, and their memory is what an
// engine stores: texels x numbers per texel x 4 bytes (deep opacity maps
// N + 1, Fourier N + 2, moments N + 3), not their tabulated nodes.
TEST(Cli, BenchRunsTheSeriesBaselinesAndCountsTheirStoredNumbers) {
  const std::string out = output_dir() + "/bench_series";
  const CliRun r = run_cdsm("bench '" + kScene +
                            "' --methods dom8,fom8,mom4 --sweep res=64 --width 32 --height 24 --fragments cpu "
                            "--repeat 1 --warmup 0 --error-samples 200 --no-plot --out '" +
                            out + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream csv(out + "/results.csv");
  ASSERT_TRUE(csv) << out;
  std::string line;
  std::getline(csv, line);
  auto split = [](const std::string& l) {
    std::vector<std::string> f;
    std::stringstream ss(l);
    for (std::string c; std::getline(ss, c, ',');) f.push_back(c);
    return f;
  };
  const std::vector<std::string> head = split(line);
  auto column = [&](const char* name) { return size_t(std::find(head.begin(), head.end(), name) - head.begin()); };
  const size_t label = column("label"), texels = column("texels"), memory = column("memory_bytes"),
               rmse = column("t_rmse");
  ASSERT_LT(memory, head.size());
  ASSERT_LT(rmse, head.size());
  std::map<std::string, int> components = {{"dom8", 9}, {"fom8", 10}, {"mom4", 7}};
  int rows = 0;
  while (std::getline(csv, line)) {
    const std::vector<std::string> f = split(line);
    if (f.size() != head.size()) continue;
    const std::string method = f[label].substr(0, f[label].find(' '));  // "dom8 res=64"
    if (!components.count(method)) continue;
    ++rows;
    EXPECT_GT(std::stod(f[texels]), 0.0) << line;
    EXPECT_DOUBLE_EQ(std::stod(f[memory]), std::stod(f[texels]) * components[method] * 4.0) << line;
    EXPECT_TRUE(std::isfinite(std::stod(f[rmse]))) << line;
  }
  EXPECT_EQ(rows, 3);
}

// The bench's reference cache knows a light's size: each radius of
// --sweep radius is its own scene variant, rendered once (an area light's
// reference is not a point light's) and read from the cache the next time.
TEST(Cli, BenchReferenceCacheKnowsTheLightSize) {
  const std::string cache = output_dir() + "/refcache_sizes";
  std::system(("rm -rf '" + cache + "'").c_str());
  const std::string args = "bench '" + kScene +
                           "' --methods dsm --sweep res=64 --sweep radius=0,0.2 --width 32 --height 24 "
                           "--fragments cpu --repeat 1 --warmup 0 --error-samples 200 --no-plot --cache '" +
                           cache + "' --out '" + output_dir() + "/bench_sizes'";
  auto count = [](const std::string& s, const std::string& what) {
    size_t n = 0;
    for (size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
    return n;
  };
  const CliRun first = run_cdsm(args);
  ASSERT_EQ(first.code, 0) << first.err;
  EXPECT_EQ(count(first.err, ": rendering"), 2u) << first.err;
  EXPECT_NE(first.out.find("default@r0.2"), std::string::npos) << first.out;
  const CliRun again = run_cdsm(args);
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_EQ(count(again.err, ": cached"), 2u) << again.err;
}
