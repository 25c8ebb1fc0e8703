// cdsm: the command-line front end and the editor (cdsm edit).
#include <cstdio>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "commands.h"

namespace {

// A command line CLI11 refuses: one line naming the option and the problem.
int refuse(const CLI::App& app, const CLI::ParseError& e) {
  if (dynamic_cast<const CLI::ExtrasError*>(&e)) {
    const CLI::App* where = &app;
    for (const CLI::App* sub : app.get_subcommands()) where = sub;
    const std::vector<std::string> extra = where->remaining();
    const std::string first = extra.empty() ? "?" : extra.front();
    if (where == &app) {
      std::fprintf(stderr, "cdsm: unknown command '%s' (try cdsm --help)\n", first.c_str());
      return 2;
    }
    const std::string verb = where->get_name();
    std::fprintf(stderr, "cdsm: error: %s: %s (try cdsm %s --help)\n", first.c_str(),
                 first.size() > 1 && first[0] == '-' ? "unknown option" : "unexpected argument", verb.c_str());
    return 1;
  }
  std::fprintf(stderr, "cdsm: error: %s\n", e.what());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("cdsm - clustered deep shadow maps", "cdsm");
  app.get_formatter()->column_width(34);
  // A repeated option: the last one counts (lists such as --sweep collect every one).
  app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  std::string command_line = "cdsm";
  for (int i = 1; i < argc; ++i) command_line += std::string(" ") + argv[i];
  try {
    std::vector<cdsm::cli::Command> commands{cdsm::cli::add_render(app), cdsm::cli::add_bench(app, command_line),
                                             cdsm::cli::add_info(app)};
#if CDSM_HAVE_EDITOR
    commands.push_back(cdsm::cli::add_edit(app));
#else
    CLI::App* edit = app.add_subcommand("edit", "the interactive editor (not in this build)");
    edit->allow_extras();
    commands.push_back({edit, []() -> int {
                          throw cdsm::Error("cdsm edit",
                                            "this build has no editor (it needs OpenGL, GLFW 3.3 and libimgui-dev)");
                        }});
#endif
    app.footer("SCENE is a JSON scene file (content/scenes/*.json).");  // after the verbs: theirs are their own
    if (argc < 2) {
      std::fputs(app.help().c_str(), stdout);
      return 2;
    }
    try {
      app.parse(argc, argv);
    } catch (const CLI::CallForHelp&) {
      std::fputs(app.help().c_str(), stdout);  // of the subcommand that asked
      return 0;
    } catch (const CLI::Success&) {  // (after CallForHelp, one of its kind) a flag that printed what was asked
      return 0;
    } catch (const CLI::ParseError& e) {
      return refuse(app, e);
    }
    for (const cdsm::cli::Command& c : commands)
      if (c.app->parsed()) return c.run();
    std::fputs(app.help().c_str(), stdout);
    return 2;
  } catch (const cdsm::Error& e) {
    std::fprintf(stderr, "cdsm: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cdsm: internal error: %s\n", e.what());
    return 3;
  }
}
