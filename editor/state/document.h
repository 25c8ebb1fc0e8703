// The document `cdsm edit` edits: a scene value and the file it came from.
// Plain data; the panels read it, edits (state/edit.h) change it through the
// history (state/history.h), and it is saved as a JSON scene file.
#pragma once

#include <string>

#include "cdsm/scene.h"

namespace cdsm::editor {

struct Document {
  Scene scene;
  std::string path;        // the file it was opened from ("" for none)
  std::string saved_path;  // the file it was last saved to ("" for none)
  bool dirty = false;      // edited since opened or last saved
};

// Opens a scene file: JSON, or a whole glTF / GLB scene (load_scene reads
// both by their extension). Throws cdsm::Error naming the file and the
// place in it.
Document open_document(const std::string& path);

// Saves the document as a JSON scene file (save_scene: bit for bit, written
// whole or not at all). Never over the file it was opened from unless
// `overwrite_opened` (the UI asks first): the same file by any name — a
// relative path, a link — counts. On success: saved_path = path, dirty =
// false, true. Refused or failed (the opened file, a .gltf/.glb name, a
// scene a file cannot hold, an unwritable path): false and *why says why,
// naming the path; the document is unchanged.
bool save_document(Document& doc, const std::string& path, bool overwrite_opened, std::string* why);

// Whether two paths name the same file (the same inode when both exist,
// else the same absolute, normalized path).
bool same_file(const std::string& a, const std::string& b);

}  // namespace cdsm::editor
