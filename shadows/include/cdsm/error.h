// Errors of the public API. Bad input (a scene file, an asset, an option)
// raises cdsm::Error naming the file and the place in it.
#pragma once

#include <cstdio>
#include <stdexcept>
#include <string>

namespace cdsm {

// A number as messages print it: six significant digits ("2.5", "7.37870e+19").
inline std::string format_number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

class Error : public std::runtime_error {
 public:
  // `where` is a file name, optionally with a location ("scene.json: /objects/2/sigma").
  Error(const std::string& where, const std::string& what)
      : std::runtime_error(where.empty() ? what : where + ": " + what), where_(where), what_(what) {}
  const std::string& where() const { return where_; }
  const std::string& problem() const { return what_; }

 private:
  std::string where_;
  std::string what_;
};

// A broken invariant of this library or a call its contract forbids (a bug,
// never bad input, which is a cdsm::Error): std::logic_error naming the
// condition that failed, where, and what was expected.
//   CDSM_CHECK(first == done, "lists_from_gl: a tile out of order");
[[noreturn]] inline void check_failed(const char* condition, const char* file, int line, const std::string& what) {
  throw std::logic_error(what + " (check failed: " + condition + ", " + file + ":" + std::to_string(line) + ")");
}

}  // namespace cdsm

#define CDSM_CHECK(condition, what)                                               \
  do {                                                                            \
    if (!(condition)) ::cdsm::check_failed(#condition, __FILE__, __LINE__, what); \
  } while (0)
