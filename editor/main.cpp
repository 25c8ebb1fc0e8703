// cdsm: the command-line front end and the editor (cdsm edit).
#include <cstdio>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "cmd_bench.h"
#include "commands.h"

namespace {

const char* kHelp =
    "cdsm - clustered deep shadow maps\n"
    "\n"
    "usage: cdsm <command> [options]\n"
    "\n"
    "commands:\n"
    "  render SCENE -o OUT.png [options]  render a scene with deep shadow maps, print times and memory;\n"
    "                                     with --compare-reference also the error against the exact\n"
    "                                     reference (cdsm render --help for all options)\n"
    "  bench SCENE... [options]           speed against error: sweep epsilon, resolution, clusters and the\n"
    "                                     baselines (shadow map, opacity slices, AVSM); CSV, Markdown, plot\n"
    "                                     (cdsm bench --help for all options)\n"
    "  info SCENE                         print what a scene holds (objects, triangles, volumes, lights)\n"
    "  edit SCENE [--script FILE]         the interactive editor: tune epsilon, d0 and clusters live, see what\n"
    "                                     each does (cdsm edit --help)\n"
    "  --help                             this text\n"
    "\n"
    "SCENE is a JSON scene file (content/scenes/*.json).\n";

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    std::fputs(kHelp, stdout);
    return args.empty() ? 2 : 0;
  }
  std::string cmd = args[0];
  args.erase(args.begin());
  try {
    if (cmd == "render") return cdsm::cli::cmd_render(args);
    if (cmd == "info") return cdsm::cli::cmd_info(args);
    if (cmd == "bench") return cdsm::cli::cmd_bench(args);
    if (cmd == "edit") {
#if CDSM_HAVE_EDITOR
      return cdsm::cli::cmd_edit(args);
#else
      throw cdsm::Error("cdsm edit", "this build has no editor (it needs OpenGL, GLFW 3.3 and libimgui-dev)");
#endif
    }
    std::fprintf(stderr, "cdsm: unknown command '%s' (try cdsm --help)\n", cmd.c_str());
    return 2;
  } catch (const cdsm::Error& e) {
    std::fprintf(stderr, "cdsm: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cdsm: internal error: %s\n", e.what());
    return 3;
  }
}
