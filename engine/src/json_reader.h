// Strict reading of JSON scene fields: every error names the file and the
// JSON path (RFC 6901 pointer) of the offending value.
#pragma once

#include <nlohmann/json.hpp>

#include <initializer_list>
#include <string>
#include <type_traits>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/fields.h"
#include "cdsm/math.h"
#include "cdsm/tags.h"

namespace cdsm {

class JsonNode {
 public:
  JsonNode(const nlohmann::json& j, std::string file, std::string path)
      : j_(j), file_(std::move(file)), path_(std::move(path)) {}

  [[noreturn]] void fail(const std::string& what) const;
  const nlohmann::json& raw() const { return j_; }
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }

  bool is_object() const { return j_.is_object(); }
  bool is_array() const { return j_.is_array(); }
  bool is_string() const { return j_.is_string(); }
  bool is_number() const { return j_.is_number(); }
  bool has(const char* key) const { return j_.is_object() && j_.contains(key); }

  JsonNode at(const char* key) const;  // required member
  JsonNode at(size_t i) const;         // array element
  size_t size() const { return j_.size(); }

  // Object whose keys must all be in `allowed` (a typo is an error).
  void expect_object(std::initializer_list<const char*> allowed) const;
  void expect_object(const std::vector<const char*>& allowed) const;
  void expect_array() const;

  float as_float() const;
  int as_int() const;
  bool as_bool() const;
  std::string as_string() const;
  Vec3 as_vec3() const;  // [x, y, z]; a single number s means [s, s, s]

  float get(const char* key, float def) const { return has(key) ? at(key).as_float() : def; }
  int get(const char* key, int def) const { return has(key) ? at(key).as_int() : def; }
  bool get(const char* key, bool def) const { return has(key) ? at(key).as_bool() : def; }
  std::string get(const char* key, const char* def) const { return has(key) ? at(key).as_string() : def; }
  std::string get(const char* key, const std::string& def) const { return has(key) ? at(key).as_string() : def; }
  Vec3 get(const char* key, Vec3 def) const { return has(key) ? at(key).as_vec3() : def; }
  int64_t get(const char* key, int64_t def) const { return has(key) ? at(key).as_int() : def; }
  // A tag by its name (cdsm/tags.h); `what` names it in the error.
  template <class E>
  E get_tag(const char* key, E def, const char* what) const {
    if (!has(key)) return def;
    const JsonNode n = at(key);
    const std::string s = n.as_string();
    E e = def;
    if (!parse_tag(s, e)) n.fail("unknown " + std::string(what) + " '" + s + "' (" + tag_choices<E>() + ")");
    return e;
  }

  // The fields of S's table present here into s (others keep their value);
  // a key not in the table is an error. Ranges: validate_scene.
  template <class S>
  void read_fields(S& s, std::vector<const char*> more_keys = {}) const {
    for_each_field<S>([&](const auto& f) { more_keys.push_back(f.key); });
    expect_object(more_keys);
    for_each_field<S>([&](const auto& f) {
      auto& v = s.*f.member;
      using T = std::remove_reference_t<decltype(v)>;
      if constexpr (std::is_enum_v<T>) {
        v = get_tag(f.key, v, f.key);
      } else if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
        if (zero_is_auto(f) && has(f.key) && at(f.key).is_string()) {
          if (at(f.key).as_string() != "auto")
            at(f.key).fail("expected an integer or \"auto\", got \"" + at(f.key).as_string() + "\"");
          v = T(0);
        } else {
          v = get(f.key, v);
          if (zero_is_auto(f) && has(f.key) && v == T(0))  // 0 is how "auto" is held, not a value to write
            at(f.key).fail("must be within [" + std::to_string(int64_t(f.lo)) + ", " + std::to_string(int64_t(f.hi)) +
                           "] or \"auto\", got 0");
        }
      } else {
        v = get(f.key, v);
      }
    });
  }

 private:
  const nlohmann::json& j_;
  std::string file_;
  std::string path_;
};

}  // namespace cdsm
