// The pieces of the editor's UI (ui.h is its interface): panels, the menu
// bar, the windows around the viewport, and the widgets they share. Flat
// immediate-mode code over a Session (STYLE.md 14).
#pragma once

#include <GL/glcorearb.h>
#include <imgui.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>

#include "cdsm/fields.h"
#include "ui.h"

namespace cdsm::editor {

inline constexpr float kLeftWidth = 340.0f;
inline constexpr float kRightWidth = 320.0f;
inline constexpr float kStatusHeight = 24.0f;

inline ImTextureID texture_id(GLuint t) { return reinterpret_cast<ImTextureID>(static_cast<uintptr_t>(t)); }

// ---- widgets (ui_panels.cpp) ----------------------------------------------------
// The range of field `member` of S in its field table (cdsm/fields.h).
template <class S, class T>
std::pair<double, double> table_range(T S::*member) {
  std::pair<double, double> r{0.0, 0.0};
  for_each_field<S>([&](const auto& f) {
    if constexpr (std::is_same_v<std::decay_t<decltype(f.member)>, T S::*>)
      if (f.member == member) r = {f.lo, f.hi};
  });
  return r;
}
// A slider over a field: the panel's range [lo, hi] within the table's (a
// narrower range is the panel's choice; a wider one is cut to the table).
template <class S>
bool field_slider(const char* label, S& s, float S::*member, float lo, float hi, const char* format,
                  ImGuiSliderFlags flags = 0) {
  const std::pair<double, double> r = table_range(member);
  return ImGui::SliderFloat(label, &(s.*member), float(std::max(double(lo), r.first)),
                            float(std::min(double(hi), r.second)), format, flags);
}
template <class S>
bool field_slider(const char* label, S& s, int S::*member, int lo, int hi) {
  const std::pair<double, double> r = table_range(member);
  return ImGui::SliderInt(label, &(s.*member), int(std::max(double(lo), r.first)), int(std::min(double(hi), r.second)));
}
bool color_edit(const char* label, Vec3& c);
bool drag3(const char* label, Vec3& v, float speed, float lo = 0.0f, float hi = 0.0f);

// ---- the left column's panels (ui_panels.cpp) ------------------------------------
void shadows_panel(Session& s);
void lights_panel(Session& s);
void objects_panel(Session& s);
void views_panel(Session& s, UiState& ui);

// ---- the menu bar and the recent files (ui_menu.cpp) -----------------------------
void menu_bar(Session& s, UiState& ui);
// $XDG_CONFIG_HOME/cdsm (or ~/.config/cdsm); empty when neither is set.
std::string config_dir();

// ---- windows (ui_windows.cpp) ------------------------------------------------------
void stats_window(Session& s, UiState& ui, float x, float y, float h);
void plot_window(Session& s, UiState& ui);
void map_window(Session& s, UiState& ui);
void error_window(Session& s, UiState& ui);

}  // namespace cdsm::editor
