// Scene files: JSON (examples in share/cdsm/scenes/*.json; the README lists the fields).
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

// Writes a scene file that load_scene() reads back to an equal scene (bit
// for bit: every float is printed with enough digits). Meshes and grids
// with a description (Object::mesh_source, Volume::grid_source) are written
// as that description, the others as data ({"type":"triangles"} meshes,
// {"type":"dense"} grids with their values); transforms as {"matrix": [16
// numbers]}; every field of the README's "Scene files" tables is written,
// defaults included. A file referred to by a description is written
// relative to the new file's folder when it was found beside the old one.
// The scene is checked first (validate_scene, then what only the reader
// checks: finite transforms and mesh data, each volume inside exactly one
// object, distinct volume names, non-negative grid values); a scene the
// reader would refuse is refused. The text goes to a temporary file in the
// same folder, renamed over `path` when complete, so an error never leaves
// a half-written file. Errors throw cdsm::Error naming `path` (and the
// field, as a JSON pointer). `path` must not end in .gltf or .glb.
void save_scene(const Scene& scene, const std::string& path);

// The text save_scene() writes (file references relative to `base_dir`,
// the folder the text will be read from; "" keeps them as they are).
// Throws cdsm::Error naming `scene.source` and the field.
std::string scene_to_json(const Scene& scene, const std::string& base_dir = "");

// The scene file's fields as Markdown (README "Scene files"; `cdsm info
// --fields` prints it): what a scene must have, then per object of the
// file a table of its plain fields from the field tables (cdsm/fields.h):
// JSON key, the C++ member it sets, default, range or values, meaning.
std::string scene_field_reference();

// Checks every numeric field of a scene (from a file or built in code)
// against its documented range (README "Scene files"): a value outside
// throws cdsm::Error("SOURCE: /json/pointer", "must be within [lo, hi], got
// v"). Where a fallback is reasonable (camera.up parallel to the view) a
// line is appended to `warnings` instead. load_scene/parse_scene and
// Renderer::render call it.
void validate_scene(const Scene& scene, std::vector<std::string>* warnings = nullptr);

}  // namespace cdsm
