// The editor's menu bar (files, views, help) and its recent-files list.
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "ui_parts.h"

namespace cdsm::editor {

std::string config_dir() {
  if (const char* x = std::getenv("XDG_CONFIG_HOME"); x && *x) return std::string(x) + "/cdsm";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.config/cdsm";
  return "";
}

void menu_bar(Session& s, UiState& ui) {
  if (!ImGui::BeginMainMenuBar()) return;
  if (ImGui::BeginMenu("File")) {
    if (ImGui::MenuItem("Open...")) ui.pending_path_action = "open", ui.path_field = s.document().path;
    if (ImGui::MenuItem("Save", nullptr, false, !s.document().path.empty())) {
      std::string why;
      if (!s.save(s.document().path, false, &why))
        ui.confirm_overwrite = true;
      else
        ui.status = "saved " + s.document().path;
    }
    if (ImGui::MenuItem("Save as..."))
      ui.pending_path_action = "save_as", ui.path_field = s.document().path + ".edited.json";
    if (ImGui::MenuItem("Screenshot...")) ui.pending_path_action = "screenshot", ui.path_field = "cdsm-edit.png";
    if (ImGui::BeginMenu("Recent", !ui.recent.empty())) {
      for (const std::string& r : ui.recent)
        if (ImGui::MenuItem(r.c_str())) {
          try {
            s.open(r);
            remember_recent(ui.recent, r);
            ui.status = "opened " + r;
          } catch (const std::exception& e) {
            ui.status = e.what();
          }
        }
      ImGui::EndMenu();
    }
    if (ImGui::MenuItem("Quit")) ui.quit = true;
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Edit")) {
    if (ImGui::MenuItem("Undo", "Ctrl+Z", false, s.history().can_undo())) s.undo();
    if (ImGui::MenuItem("Redo", "Ctrl+Y", false, s.history().can_redo())) s.redo();
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("View")) {
    if (ImGui::MenuItem("Frame scene", "F")) s.frame_scene();
    ImGui::EndMenu();
  }
  ImGui::EndMainMenuBar();

  if (!ui.pending_path_action.empty()) ImGui::OpenPopup("path");
  if (ImGui::BeginPopupModal("path", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::Text("%s", ui.pending_path_action == "open"      ? "Open scene (JSON, glTF, GLB):"
                      : ui.pending_path_action == "save_as" ? "Save as JSON:"
                                                            : "Screenshot PNG:");
    char buf[1024];
    std::snprintf(buf, sizeof buf, "%s", ui.path_field.c_str());
    if (ImGui::InputText("##path", buf, sizeof buf)) ui.path_field = buf;
    if (ImGui::Button("OK")) {
      try {
        if (ui.pending_path_action == "open") {
          s.open(ui.path_field);
          remember_recent(ui.recent, ui.path_field);
          ui.status = "opened " + ui.path_field;
        } else if (ui.pending_path_action == "save_as") {
          std::string why;
          if (s.save(ui.path_field, false, &why))
            ui.status = "saved " + ui.path_field;
          else
            ui.status = why;
        } else {
          ui.screenshot_request = ui.path_field;
        }
      } catch (const std::exception& e) {
        ui.status = e.what();
      }
      ui.pending_path_action.clear();
      ImGui::CloseCurrentPopup();
    }
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) {
      ui.pending_path_action.clear();
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }
  if (ui.confirm_overwrite) ImGui::OpenPopup("overwrite");
  if (ImGui::BeginPopupModal("overwrite", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::Text("Overwrite the opened file\n%s ?", s.document().path.c_str());
    if (ImGui::Button("Overwrite")) {
      std::string why;
      ui.status = s.save(s.document().path, true, &why) ? "saved " + s.document().path : why;
      ui.confirm_overwrite = false;
      ImGui::CloseCurrentPopup();
    }
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) {
      ui.confirm_overwrite = false;
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }
}

std::vector<std::string> load_recent() {
  std::vector<std::string> r;
  const std::string dir = config_dir();
  if (dir.empty()) return r;
  std::ifstream f(dir + "/recent");
  for (std::string line; std::getline(f, line) && r.size() < 10;)
    if (!line.empty()) r.push_back(line);
  return r;
}

void remember_recent(std::vector<std::string>& recent, const std::string& path) {
  recent.erase(std::remove(recent.begin(), recent.end(), path), recent.end());
  recent.insert(recent.begin(), path);
  if (recent.size() > 10) recent.resize(10);
  const std::string dir = config_dir();
  if (dir.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return;  // no place for the list: it stays this session's
  std::ofstream f(dir + "/recent");
  for (const std::string& r : recent) f << r << "\n";
}

}  // namespace cdsm::editor
