// The editor's UI for one frame (ui.h): the panels, windows and menu around
// the viewport (ui_parts.h), and the viewport's mouse and keyboard input.
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

void draw_ui(Session& s, UiState& ui, int width, int height) {
  menu_bar(s, ui);
  const float top = ImGui::GetFrameHeight();
  const float h = float(height) - top - kStatusHeight;
  // Left: the editing panels.
  ImGui::SetNextWindowPos(ImVec2(0, top));
  ImGui::SetNextWindowSize(ImVec2(kLeftWidth, h));
  ImGui::Begin("Scene", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  if (ImGui::CollapsingHeader("Shadows", ImGuiTreeNodeFlags_DefaultOpen)) shadows_panel(s);
  if (ImGui::CollapsingHeader("Lights", ImGuiTreeNodeFlags_DefaultOpen)) lights_panel(s);
  if (ImGui::CollapsingHeader("Objects", ImGuiTreeNodeFlags_DefaultOpen)) objects_panel(s);
  if (ImGui::CollapsingHeader("Views", ImGuiTreeNodeFlags_DefaultOpen)) views_panel(s, ui);
  ImGui::End();
  // Right: stats.
  const float right = ui.show_stats ? kRightWidth : 0.0f;
  if (ui.show_stats) stats_window(s, ui, float(width) - kRightWidth, top, h);
  // Middle: the viewport (the renderer's colour texture, GL rows bottom first).
  ui.viewport = {int(kLeftWidth), int(top), std::max(int(float(width) - kLeftWidth - right), 16), std::max(int(h), 16)};
  ImGui::SetNextWindowPos(ImVec2(float(ui.viewport.x), float(ui.viewport.y)));
  ImGui::SetNextWindowSize(ImVec2(float(ui.viewport.w), float(ui.viewport.h)));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(0, 0));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowBorderSize, 0.0f);
  ImGui::Begin("Viewport", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoBringToFrontOnFocus |
                   ImGuiWindowFlags_NoScrollWithMouse);
  ImGui::Image(texture_id(s.renderer().display_texture()), ImVec2(float(ui.viewport.w), float(ui.viewport.h)),
               ImVec2(0, 1), ImVec2(1, 0));
  ui.viewport_hovered = ImGui::IsItemHovered();
  ImGui::End();
  ImGui::PopStyleVar(2);
  if (ui.show_plot) plot_window(s, ui);
  if (ui.show_map) map_window(s, ui);
  if (ui.show_error) error_window(s, ui);
  // Status line.
  ImGui::SetNextWindowPos(ImVec2(0, float(height) - kStatusHeight));
  ImGui::SetNextWindowSize(ImVec2(float(width), kStatusHeight));
  ImGui::Begin("status", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove);
  const ShadowSystem::BuildProgress p = s.progress();
  if (!s.refusal().empty()) ui.status = s.refusal();
  ImGui::Text("%s%s | %s | undo %zu | %s", s.document().path.c_str(), s.document().dirty ? " *" : "",
              s.building() ? ("building " + std::to_string(p.built) + "/" + std::to_string(p.to_build)).c_str()
                           : (s.refined() ? "refined" : "refining"),
              s.history().size(), ui.status.c_str());
  ImGui::End();
  ui.interacting = ImGui::IsAnyItemActive();
}

void handle_viewport_input(Session& s, UiState& ui) {
  ImGuiIO& io = ImGui::GetIO();
  static bool dragging = false;
  static ImVec2 press;
  const bool in_view = ui.viewport_hovered;
  bool moved = false;
  if (in_view && !io.WantTextInput) {
    if (io.MouseWheel != 0.0f) {
      s.orbit().zoom(io.MouseWheel);
      moved = true;
    }
    if (ImGui::IsMouseClicked(ImGuiMouseButton_Left) || ImGui::IsMouseClicked(ImGuiMouseButton_Middle) ||
        ImGui::IsMouseClicked(ImGuiMouseButton_Right)) {
      dragging = true;
      press = io.MousePos;
    }
    if (ImGui::IsKeyPressed(GLFW_KEY_F)) s.frame_scene();
  }
  if (!io.WantTextInput && io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_Z)) s.undo();
  if (!io.WantTextInput && io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_Y)) s.redo();
  if (dragging) {
    const ImVec2 d = io.MouseDelta;
    if (ImGui::IsMouseDown(ImGuiMouseButton_Left) && io.KeyShift && s.selected_light >= 0 &&
        size_t(s.selected_light) < s.scene().lights.size()) {
      // Move the selected light in the view plane.
      Light l = s.scene().lights[size_t(s.selected_light)];
      const Camera& c = s.scene().camera;
      const Vec3 f = normalize(c.target - c.position), r = normalize(cross(f, Vec3{0, 1, 0})), u = cross(r, f);
      const float per_px = 2.0f * length(l.position - c.position) *
                           std::tan(0.5f * c.fov_y_deg * 3.14159265f / 180.0f) / float(std::max(ui.viewport.h, 1));
      l.position = l.position + r * (d.x * per_px) - u * (d.y * per_px);
      if (d.x != 0.0f || d.y != 0.0f) s.apply(set_light(s.document(), size_t(s.selected_light), l), now_seconds());
    } else if (ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
      if (d.x != 0.0f || d.y != 0.0f) s.orbit().orbit(d.x, d.y), moved = true;
    } else if (ImGui::IsMouseDown(ImGuiMouseButton_Middle)) {
      if (d.x != 0.0f || d.y != 0.0f) s.orbit().pan(d.x, d.y, s.scene().camera.fov_y_deg, ui.viewport.h), moved = true;
    } else if (ImGui::IsMouseDown(ImGuiMouseButton_Right)) {
      // Fly: right button held, W/A/S/D/Q/E, speed by the distance.
      const float step = 0.02f * s.orbit().distance;
      Vec3 f{0, 0, 0};
      if (ImGui::IsKeyDown(GLFW_KEY_W)) f.z += step;
      if (ImGui::IsKeyDown(GLFW_KEY_S)) f.z -= step;
      if (ImGui::IsKeyDown(GLFW_KEY_D)) f.x += step;
      if (ImGui::IsKeyDown(GLFW_KEY_A)) f.x -= step;
      if (ImGui::IsKeyDown(GLFW_KEY_E)) f.y += step;
      if (ImGui::IsKeyDown(GLFW_KEY_Q)) f.y -= step;
      if (f.x != 0.0f || f.y != 0.0f || f.z != 0.0f) s.orbit().fly(f), moved = true;
      if (d.x != 0.0f || d.y != 0.0f) s.orbit().orbit(d.x, d.y), moved = true;
    } else {
      dragging = false;
      // A click (press and release in place): select and inspect.
      const float dx = io.MousePos.x - press.x, dy = io.MousePos.y - press.y;
      if (ImGui::IsMouseReleased(ImGuiMouseButton_Left) && dx * dx + dy * dy < 9.0f) {
        const forward::ForwardRenderer& r = s.renderer();
        const int x = int((io.MousePos.x - float(ui.viewport.x)) * float(r.width()) / float(ui.viewport.w));
        const int y = int((io.MousePos.y - float(ui.viewport.y)) * float(r.height()) / float(ui.viewport.h));
        s.click(x, y);
        ui.show_plot = true;
      }
    }
    ui.interacting = true;
  }
  if (moved) s.camera_changed();
}

}  // namespace cdsm::editor
