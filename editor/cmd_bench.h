// cdsm bench: speed against error (cmd_bench.cpp; cdsm bench --help).
#pragma once

#include <string>
#include <vector>

namespace cdsm::cli {

// Returns the process exit code; bad options and scenes throw cdsm::Error.
int cmd_bench(const std::vector<std::string>& args);

}  // namespace cdsm::cli
