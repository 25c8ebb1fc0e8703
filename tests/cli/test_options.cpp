// The command line's options from the field tables (editor/options.h): an
// option that overrides a field takes its check and its --help from the
// field's row, so a range changed in a table changes both. Shown with a test
// table whose ranges differ from the scene's own (resolution [16, 64], not
// [4, 8192]).
#include <gtest/gtest.h>

#include <string>

#include "options.h"

namespace cdsm {

struct CliTestSettings {
  int32_t resolution = 64;
  float epsilon = 0.5f;
  bool filtering = true;
  DsmLayout layout = DsmLayout::Packed;
  Vec3 direction{0.0f, 0.0f, 1.0f};
};

template <>
struct FieldTable<CliTestSettings> {
  using S = CliTestSettings;
  static constexpr auto fields =
      std::make_tuple(field("resolution", &S::resolution, 16, 64, kAffectsMaps, "test texels per side"),
                      field("epsilon", &S::epsilon, 0.25, 0.75, kAffectsMaps, "test error bound"),
                      field("filtering", &S::filtering, 0, 1, kAffectsLookup, "test lookup"),
                      field("layout", &S::layout, 0, 0, kAffectsMaps, "test layout"),
                      field("direction", &S::direction, -1.0, 1.0, kAffectsPlan, "not on the command line"));
};

namespace {

struct TestRoot {
  CliTestSettings settings;
};

struct Parsed {
  bool ok = false;
  std::string error;  // CLI11's message: the option, then the problem
  CliTestSettings settings;
  std::string help;
};

// `args` parsed by an app with the test table's options, applied to a default root.
Parsed parse(const std::string& args) {
  CLI::App app("test", "test");
  cli::FieldOverrides<TestRoot> overrides;
  overrides.add(app, "--dsm-res", &TestRoot::settings, "resolution");
  overrides.add(app, "--eps", &TestRoot::settings, "epsilon");
  overrides.add(app, "--filtering", &TestRoot::settings, "filtering");
  overrides.add(app, "--layout", &TestRoot::settings, "layout");
  Parsed p;
  p.help = app.help();
  try {
    app.parse(args);
    p.ok = true;
  } catch (const CLI::ParseError& e) {
    p.error = e.what();
  }
  TestRoot root;
  if (p.ok) overrides.apply(root);
  p.settings = root.settings;
  return p;
}

}  // namespace

TEST(CliOptions, ARangeFromTheTableIsTheCheck) {
  Parsed p = parse("--dsm-res 32 --eps 0.3");
  ASSERT_TRUE(p.ok) << p.error;
  EXPECT_EQ(p.settings.resolution, 32);
  EXPECT_FLOAT_EQ(p.settings.epsilon, 0.3f);
  // Within the scene's own [4, 8192], outside this table's [16, 64]: refused by the table's.
  for (const char* bad : {"8", "100", "15", "65"}) {
    p = parse(std::string("--dsm-res ") + bad);
    EXPECT_FALSE(p.ok) << bad;
    EXPECT_EQ(p.error, std::string("--dsm-res: must be within [16, 64], got ") + bad);
  }
  for (const char* good : {"16", "64"}) EXPECT_TRUE(parse(std::string("--dsm-res ") + good).ok) << good;
  p = parse("--eps 0.8");
  EXPECT_EQ(p.error, "--eps: must be within [0.25, 0.75], got 0.8");
  p = parse("--eps nan");
  EXPECT_EQ(p.error, "--eps: expected a finite number, got 'nan'");
  p = parse("--dsm-res 2.5");
  EXPECT_EQ(p.error, "--dsm-res: expected an integer, got '2.5'");
}

TEST(CliOptions, TheHelpShowsTheTablesRangeAndText) {
  const std::string help = parse("").help;
  EXPECT_NE(help.find("--dsm-res INT:[16, 64]"), std::string::npos) << help;
  EXPECT_NE(help.find("--eps FLOAT:[0.25, 0.75]"), std::string::npos) << help;
  EXPECT_NE(help.find("test texels per side; overrides the scene's resolution"), std::string::npos) << help;
  EXPECT_NE(help.find("--filtering on|off"), std::string::npos) << help;
  EXPECT_NE(help.find("--layout packed|fixed|chunked"), std::string::npos) << help;
  EXPECT_EQ(help.find("[4, 8192]"), std::string::npos) << "the scene's range, not the table's: " << help;
}

TEST(CliOptions, TagsAndBooleansByTheirNames) {
  Parsed p = parse("--layout chunked --filtering off");
  ASSERT_TRUE(p.ok) << p.error;
  EXPECT_EQ(p.settings.layout, DsmLayout::Chunked);
  EXPECT_FALSE(p.settings.filtering);
  p = parse("--layout tiled");
  EXPECT_EQ(p.error, "--layout: unknown layout 'tiled' (packed, fixed or chunked)");
  p = parse("--filtering maybe");
  EXPECT_EQ(p.error, "--filtering: unknown value 'maybe' (on or off)");
}

// What the command line does not give keeps the root's value.
TEST(CliOptions, OnlyTheGivenFieldsAreSet) {
  Parsed p = parse("--eps 0.7");
  ASSERT_TRUE(p.ok) << p.error;
  EXPECT_EQ(p.settings.resolution, CliTestSettings{}.resolution);
  EXPECT_EQ(p.settings.layout, CliTestSettings{}.layout);
  EXPECT_TRUE(p.settings.filtering);
}

// A key no row has, or a field with no command-line form, is a programming error.
TEST(CliOptions, AnUnknownKeyIsRefused) {
  CLI::App app;
  cli::FieldOverrides<TestRoot> overrides;
  EXPECT_THROW(overrides.add(app, "--x", &TestRoot::settings, "no_such_key"), std::logic_error);
  EXPECT_THROW(overrides.add(app, "--dir", &TestRoot::settings, "direction"), std::logic_error);
}

}  // namespace cdsm
