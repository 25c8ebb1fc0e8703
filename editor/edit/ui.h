// The editor's ImGui panels over a Session (STYLE.md 14: flat
// immediate-mode code; the state that matters lives in the Session and the
// document). ImGui stays in editor/.
#pragma once

#include <string>
#include <vector>

#include "session.h"

namespace cdsm::editor {

struct Rect {
  int x = 0, y = 0, w = 0, h = 0;  // window pixels, y down
};

// UI state that is only UI: open windows, text fields, popups.
struct UiState {
  bool show_plot = false;   // the alpha(z) window
  bool show_map = false;    // the map viewer
  bool show_error = false;  // the error view
  bool show_stats = true;
  int error_width = 240;
  std::string path_field;           // open / save as / screenshot
  std::string pending_path_action;  // "open", "save_as", "screenshot"
  bool confirm_overwrite = false;
  std::vector<std::string> recent;  // most recent first
  std::string status;               // one line at the bottom
  std::string screenshot_request;   // written after the frame is drawn
  bool quit = false;
  // Output of draw_ui: where the viewport is, and whether the user is
  // interacting (dragging in it or holding a widget).
  Rect viewport;
  bool interacting = false;
  bool viewport_hovered = false;
};

// The recent-files list, kept in $XDG_CONFIG_HOME/cdsm/recent (or
// ~/.config/cdsm/recent); failures to read or write it are ignored.
std::vector<std::string> load_recent();
void remember_recent(std::vector<std::string>& recent, const std::string& path);

// One frame of the whole UI for a window of `width` x `height` pixels.
void draw_ui(Session& s, UiState& ui, int width, int height);

// The viewport's mouse and keyboard handling (orbit, pan, zoom, fly, F,
// click to select and inspect); call after draw_ui.
void handle_viewport_input(Session& s, UiState& ui);

}  // namespace cdsm::editor
