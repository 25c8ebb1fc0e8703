// Scene files: JSON (see content/scenes/*.json and the README for fields).
#pragma once

#include <string>
#include <vector>

#include "cdsm/scene.h"

namespace cdsm {

// Loads a scene file. Errors (missing or mistyped field, NaN or Inf, unknown
// type, a referenced file missing, an impossible value) throw cdsm::Error
// with `where` = "FILE: /json/path".
Scene load_scene(const std::string& path);

// Parses scene JSON text; `name` is used in messages, `base_dir` resolves
// relative file references.
Scene parse_scene(const std::string& json_text, const std::string& name, const std::string& base_dir);

// Checks every numeric field of a scene (from a file or built in code)
// against its documented range (README "Scene files"): a value outside
// throws cdsm::Error("SOURCE: /json/pointer", "must be within [lo, hi], got
// v"). Where a fallback is reasonable (camera.up parallel to the view) a
// line is appended to `warnings` instead. load_scene/parse_scene and
// Renderer::render call it.
void validate_scene(const Scene& scene, std::vector<std::string>* warnings = nullptr);

}  // namespace cdsm
