// Scene files: JSON (see content/scenes/*.json and the README for fields).
#pragma once

#include <string>

#include "cdsm/scene.h"

namespace cdsm {

// Loads a scene file. Errors (missing or mistyped field, NaN or Inf, unknown
// type, a referenced file missing, an impossible value) throw cdsm::Error
// with `where` = "FILE: /json/path".
Scene load_scene(const std::string& path);

// Parses scene JSON text; `name` is used in messages, `base_dir` resolves
// relative file references.
Scene parse_scene(const std::string& json_text, const std::string& name, const std::string& base_dir);

}  // namespace cdsm
