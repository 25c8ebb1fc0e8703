// The verbs of the cdsm program, each a subcommand of its command line
// (main.cpp); their options are built from options.h.
#pragma once

#include <string>

#include "options.h"

namespace cdsm::cli {

// Each declares its subcommand on `cdsm`, with every option, and returns it
// with what runs it.
Command add_render(CLI::App& cdsm);  // cmd_render.cpp
Command add_info(CLI::App& cdsm);    // cmd_render.cpp
// `command_line` is recorded in results.md.
Command add_bench(CLI::App& cdsm, const std::string& command_line);  // cmd_bench.cpp
Command add_edit(CLI::App& cdsm);                                    // editor/edit/cmd_edit.cpp (CDSM_HAVE_EDITOR)

}  // namespace cdsm::cli
