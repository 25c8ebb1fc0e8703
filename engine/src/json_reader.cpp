#include "json_reader.h"

#include <cmath>

namespace cdsm {
namespace {

const char* type_name(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null: return "null";
    case nlohmann::json::value_t::object: return "an object";
    case nlohmann::json::value_t::array: return "an array";
    case nlohmann::json::value_t::string: return "a string";
    case nlohmann::json::value_t::boolean: return "a boolean";
    default: return "a number";
  }
}

}  // namespace

void JsonNode::fail(const std::string& what) const { throw Error(file_ + ": " + (path_.empty() ? "/" : path_), what); }

JsonNode JsonNode::at(const char* key) const {
  if (!j_.is_object()) fail(std::string("expected an object, found ") + type_name(j_));
  auto it = j_.find(key);
  if (it == j_.end()) JsonNode(j_, file_, path_ + "/" + key).fail("missing required field");
  return JsonNode(*it, file_, path_ + "/" + key);
}

JsonNode JsonNode::at(size_t i) const {
  if (!j_.is_array()) fail(std::string("expected an array, found ") + type_name(j_));
  if (i >= j_.size()) fail("index " + std::to_string(i) + " out of range");
  return JsonNode(j_[i], file_, path_ + "/" + std::to_string(i));
}

void JsonNode::expect_object(std::initializer_list<const char*> allowed) const {
  expect_object(std::vector<const char*>(allowed));
}

void JsonNode::expect_object(const std::vector<const char*>& allowed) const {
  if (!j_.is_object()) fail(std::string("expected an object, found ") + type_name(j_));
  for (auto it = j_.begin(); it != j_.end(); ++it) {
    bool ok = false;
    for (const char* a : allowed) ok = ok || it.key() == a;
    if (!ok) {
      std::string list;
      for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
      JsonNode(it.value(), file_, path_ + "/" + it.key()).fail("unknown field (expected one of: " + list + ")");
    }
  }
}

void JsonNode::expect_array() const {
  if (!j_.is_array()) fail(std::string("expected an array, found ") + type_name(j_));
}

float JsonNode::as_float() const {
  if (!j_.is_number()) fail(std::string("expected a number, found ") + type_name(j_));
  double v = j_.get<double>();
  if (!std::isfinite(v) || std::fabs(v) > 3.0e38) fail("number is NaN, infinite or out of float range");
  return float(v);
}

int JsonNode::as_int() const {
  if (!j_.is_number()) fail(std::string("expected an integer, found ") + type_name(j_));
  double v = j_.get<double>();
  if (!std::isfinite(v) || v != std::floor(v) || std::fabs(v) > 2147483647.0) fail("expected an integer");
  return int(v);
}

bool JsonNode::as_bool() const {
  if (!j_.is_boolean()) fail(std::string("expected true or false, found ") + type_name(j_));
  return j_.get<bool>();
}

std::string JsonNode::as_string() const {
  if (!j_.is_string()) fail(std::string("expected a string, found ") + type_name(j_));
  return j_.get<std::string>();
}

Vec3 JsonNode::as_vec3() const {
  if (j_.is_number()) return vec3(as_float());
  if (!j_.is_array() || j_.size() != 3) fail("expected [x, y, z]");
  return {at(size_t(0)).as_float(), at(size_t(1)).as_float(), at(size_t(2)).as_float()};
}

}  // namespace cdsm
