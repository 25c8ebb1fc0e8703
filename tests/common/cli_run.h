// Running the cdsm program from a test: its exit code and both streams.
#pragma once

#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace cdsm_test {

struct CliRun {
  int code = -1;
  std::string out, err;
};

// A file's whole text (empty when it cannot be read).
inline std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The test output folder `name` (made when missing).
inline std::string cli_output_dir(const std::string& name) {
  const std::string d = std::string(CDSM_TEST_OUTPUT_DIR) + "/" + name;
  ::mkdir(d.c_str(), 0755);
  return d;
}

// Runs `ENV 'exe' ARGS` (shell words) with its streams captured through
// files in `dir`.
inline CliRun run_program(const std::string& exe, const std::string& env, const std::string& args,
                          const std::string& dir) {
  const std::string out = dir + "/stdout.txt", err = dir + "/stderr.txt";
  const std::string cmd = env + (env.empty() ? "" : " ") + "'" + exe + "' " + args + " >'" + out + "' 2>'" + err + "'";
  const int status = std::system(cmd.c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

}  // namespace cdsm_test
