// Where the files a scene refers to are looked for, and the warning sink.
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <mutex>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "cdsm/procedural.h"  // content_dir()

namespace cdsm {
namespace {

std::mutex g_sink_mutex;
WarningSink g_sink;

bool is_regular_file(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

bool is_directory(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

std::string join(const std::string& dir, const std::string& rest) {
  if (dir.empty()) return rest;
  return dir.back() == '/' ? dir + rest : dir + "/" + rest;
}

}  // namespace

void set_warning_sink(WarningSink sink) {
  std::lock_guard<std::mutex> lock(g_sink_mutex);
  g_sink = std::move(sink);
}

void warn(const std::string& text) {
  std::lock_guard<std::mutex> lock(g_sink_mutex);
  if (g_sink)
    g_sink(text);
  else
    std::fprintf(stderr, "cdsm: warning: %s\n", text.c_str());
}

std::string data_dir() {
  const char* env = std::getenv("CDSM_DATA_DIR");
  if (env != nullptr && env[0] != '\0') return env;
  return join(content_dir(), "data");
}

std::string resolve_asset(const std::string& ref, const std::string& base_dir, const std::string& where) {
  if (ref.empty()) throw Error(where, "empty file name");
  std::vector<std::string> tried;
  const std::string prefix = "$SHARED/";
  if (ref.compare(0, prefix.size(), prefix) == 0) {
    tried.push_back(join(data_dir(), ref.substr(prefix.size())));
  } else if (ref[0] == '/') {
    tried.push_back(ref);
  } else {
    tried.push_back(join(base_dir, ref));
    tried.push_back(join(data_dir(), ref));
  }
  for (const std::string& p : tried)
    if (is_regular_file(p)) return p;
  for (const std::string& p : tried)
    if (is_directory(p)) throw Error(where, "'" + p + "' is a directory, not a file");
  std::string list;
  for (const std::string& p : tried) list += (list.empty() ? "" : ", ") + p;
  const char* env = std::getenv("CDSM_DATA_DIR");
  const bool from_env = env != nullptr && env[0] != '\0';
  throw Error(where, "file '" + ref + "' not found; looked in: " + list + " (the data directory " + data_dir() +
                         (from_env ? " is $CDSM_DATA_DIR)"
                                   : " is the content directory's data/; $CDSM_DATA_DIR overrides it)"));
}

void require_file(const std::string& path, const std::string& what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw Error(path, what + " not found");
  if (S_ISDIR(st.st_mode)) throw Error(path, "is a directory, not a " + what);
  if (!S_ISREG(st.st_mode)) throw Error(path, "is not a regular file (a " + what + " was expected)");
}

}  // namespace cdsm
