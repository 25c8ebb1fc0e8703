#include "state/document.h"

#include <sys/stat.h>

#include <filesystem>

#include "cdsm/error.h"
#include "cdsm/scene_io.h"

namespace cdsm::editor {

Document open_document(const std::string& path) {
  Document d;
  d.scene = load_scene(path);
  d.path = path;
  return d;
}

bool same_file(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty()) return false;
  struct stat sa {
  }, sb{};
  if (::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0)
    return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  std::error_code ec;
  const std::filesystem::path pa = std::filesystem::absolute(a, ec).lexically_normal();
  const std::filesystem::path pb = std::filesystem::absolute(b, ec).lexically_normal();
  return pa == pb;
}

bool save_document(Document& doc, const std::string& path, bool overwrite_opened, std::string* why) {
  auto refuse = [&](const std::string& what) {
    if (why) *why = what;
    return false;
  };
  if (!overwrite_opened && same_file(path, doc.path))
    return refuse(path + ": is the file the scene was opened from; save under another name, or confirm overwriting it");
  try {
    save_scene(doc.scene, path);
  } catch (const Error& e) {
    return refuse(e.what());
  }
  doc.saved_path = path;
  doc.dirty = false;
  if (why) why->clear();
  return true;
}

}  // namespace cdsm::editor
