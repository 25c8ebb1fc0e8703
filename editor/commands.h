// Headless commands of the cdsm program.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cdsm::cli {

// Each returns the process exit code.
int cmd_render(const std::vector<std::string>& args);
int cmd_info(const std::vector<std::string>& args);
int cmd_edit(const std::vector<std::string>& args);  // editor/edit/cmd_edit.cpp (CDSM_HAVE_EDITOR)

// Parsing helpers shared by commands: a bad value throws cdsm::Error naming the option.
float parse_float(const std::string& opt, const std::string& v);
int parse_int(const std::string& opt, const std::string& v);
// "N", "NM" (MiB) or "NG" (GiB) -> MiB within [1, 2^30].
int64_t parse_memory_mib(const std::string& opt, const std::string& v);

// Throws cdsm::Error naming `path` unless a file can be written there: its
// folder exists and is writable, and it is not a directory or a read-only
// file. Called before any work, so a bad path costs nothing.
void check_writable(const std::string& path);

}  // namespace cdsm::cli
