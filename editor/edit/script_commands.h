// The commands of `cdsm edit SCENE --script FILE`, one table: the parser
// (script.cpp) refuses what is not in it, `cdsm edit --script-help` prints
// it, and the README's list is checked against that print (tests/cli).
#pragma once

#include <string>
#include <string_view>

namespace cdsm::editor {

struct ScriptCommand {
  const char* name;
  const char* args;  // what follows the name ("" for none)
  const char* help;
};

inline constexpr ScriptCommand kScriptCommands[] = {
    {"set", "KEY VALUE",
     "any shadow setting by its scene-file key (cdsm/fields.h): epsilon, resolution, clusters, d0, layout, "
     "filtering, receiver, penumbra, ambient R G B, ..."},
    {"light", "INDEX KEY VALUE | INDEX select",
     "any light field by its key: position X Y Z, direction X Y Z, intensity, radius, angular_diameter, "
     "color R G B, ...; select: its fields in the Lights panel"},
    {"orbit", "DYAW DPITCH", "camera orbit, degrees"},
    {"zoom", "STEPS", "camera zoom, mouse-wheel steps"},
    {"frame", "", "the camera frames the whole scene"},
    {"select", "OBJECT", "select an object by name or index"},
    {"click", "X Y", "viewport pixel (full resolution, row 0 at the top): select and inspect"},
    {"view", "clusters on|off [LIGHT] | map INDEX nodes|alpha [DEPTH] | plot on|off | error WIDTH",
     "what the viewport shows; error computes the error against the reference (waits until done)"},
    {"noop", "", "an edit that changes nothing"},
    {"undo", "", "undo the last edit"},
    {"redo", "", "redo the last undone edit"},
    {"wait", "", "until the frame is refined (maps built and published, full resolution)"},
    {"screenshot", "FILE.png", "the window (FILE.png.rect: the viewport's x y w h)"},
    {"viewport", "FILE.pfm", "the viewport frame, linear float (Portable Float Map)"},
    {"save", "FILE [overwrite]", "save the scene (never over an existing file unless overwrite)"},
    {"quit", "", "end the script"},
};

inline const ScriptCommand* find_script_command(std::string_view name) {
  for (const ScriptCommand& c : kScriptCommands)
    if (name == c.name) return &c;
  return nullptr;
}

// The table as `cdsm edit --script-help` prints it (and the README shows).
inline std::string script_help() {
  std::string out = "Script commands (cdsm edit SCENE --script FILE), one per line; # starts a comment:\n";
  for (const ScriptCommand& c : kScriptCommands) {
    std::string head = std::string("  ") + c.name + (*c.args ? std::string(" ") + c.args : std::string());
    out += head + "\n      " + c.help + "\n";
  }
  return out;
}

// The names, for an error message.
inline std::string script_command_names() {
  std::string out;
  for (const ScriptCommand& c : kScriptCommands) out += (out.empty() ? "" : ", ") + std::string(c.name);
  return out;
}

}  // namespace cdsm::editor
