// Headless commands of the cdsm program.
#pragma once

#include <string>
#include <vector>

namespace cdsm::cli {

// Each returns the process exit code.
int cmd_render(const std::vector<std::string>& args);
int cmd_info(const std::vector<std::string>& args);

// Parsing helpers shared by commands: a bad value throws cdsm::Error naming the option.
float parse_float(const std::string& opt, const std::string& v);
int parse_int(const std::string& opt, const std::string& v);

}  // namespace cdsm::cli
