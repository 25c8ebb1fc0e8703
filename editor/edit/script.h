// Script mode of `cdsm edit SCENE --script FILE`: the editor driven by a
// list of commands, one per line, for tests and for measuring (each line is
// echoed with what it did; `wait` prints the time from the last change to
// the refined frame). The commands: script_commands.h (`cdsm edit
// --script-help`, the README's "Scripts").
#pragma once

#include <string>
#include <vector>

#include "ui.h"

namespace cdsm::editor {

class ScriptRunner {
 public:
  // Throws cdsm::Error naming the file when it cannot be read.
  explicit ScriptRunner(const std::string& path);
  // Runs commands until one has to wait for later frames. Returns false
  // when the script ended (quit or its end). Errors (an unknown command, a
  // bad value) throw cdsm::Error naming the file and line.
  bool step(Session& s, UiState& ui);
  // After the frame was drawn and presented: a screenshot requested by the
  // last command is taken here.
  void after_frame(Session& s, UiState& ui, int width, int height);
  int failures() const { return failures_; }

 private:
  std::string file_;
  std::vector<std::string> lines_;
  size_t next_ = 0;
  double changed_at_ = 0.0;   // of the last change (for `wait`)
  double changed_cpu_ = 0.0;  // the process's CPU seconds then
  bool waiting_ = false;
  std::string waiting_for_;
  std::string screenshot_;  // to take after this frame
  int frames_waited_ = 0;
  int failures_ = 0;
};

// Writes the window's framebuffer (bound: 0) as a PNG (sRGB 8-bit as
// displayed), rows top first.
void write_window_png(const std::string& path, int width, int height);

}  // namespace cdsm::editor
