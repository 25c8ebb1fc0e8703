// `cdsm edit SCENE [--script FILE]`: the interactive editor (GLFW window,
// Dear ImGui panels, an OpenGL viewport with cdsm.glsl shadows).
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/gl.h"
#include "cdsm/gl_window.h"
#include "commands.h"
#include "script.h"
#include "script_commands.h"
#include "session.h"
#include "ui.h"

namespace cdsm::cli {

namespace {

const char* const kEditFooter =
    "Viewport: left drag orbits, middle drag pans, wheel zooms, right drag + W/A/S/D/Q/E flies, F frames the scene,\n"
    "a click selects an object and plots its light ray's alpha(z); shift + left drag moves the selected light.\n"
    "Ctrl+Z / Ctrl+Y undo and redo. Needs a display (X11, or xvfb-run).";

// What `cdsm edit` was given.
struct EditArgs {
  std::string scene_path, script_path;
  int width = 1600, height = 900;  // the window
  bool hidden = false;
};

int run_edit(const EditArgs& a) {
  // Bad input fails before any window: a missing or broken scene file (the
  // error names it and the place in it), then a missing script.
  editor::Document document = editor::open_document(a.scene_path);
  std::unique_ptr<editor::ScriptRunner> script;
  if (!a.script_path.empty()) script = std::make_unique<editor::ScriptRunner>(a.script_path);

  std::string why;
  auto context = GlWindow::create(a.width, a.height, "cdsm edit - " + a.scene_path, !a.hidden, &why);
  if (!context)
    throw Error("cdsm edit", "no window with OpenGL 4.5 (needs a display: X11, or run under xvfb-run): " + why);
  GLFWwindow* window = static_cast<GLFWwindow*>(context->native_window());
  glfwSwapInterval(script ? 0 : 1);

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini next to the user's files
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window, true);
  ImGui_ImplOpenGL3_Init("#version 450");
  int rc = 0;
  {
    editor::Session session(std::move(document));
    session.set_wake([] { glfwPostEmptyEvent(); });  // a finished build ends the wait below at once
    editor::UiState ui;
    ui.recent = editor::load_recent();
    editor::remember_recent(ui.recent, a.scene_path);
    std::fprintf(stderr, "cdsm edit: %s\n", context->description().c_str());
    bool running = true;
    while (running) {
      // While maps build, the UI runs at ~10 frames a second at most (input still
      // wakes it at once): each frame (ImGui, the window's copy to the display)
      // would take the worker's cores.
      if (session.building())
        glfwWaitEventsTimeout(0.1);
      else
        glfwPollEvents();
      if (context->should_close() || ui.quit) break;
      session.tick();
      if (script && !script->step(session, ui)) running = false;
      int fbw = 0, fbh = 0;
      glfwGetFramebufferSize(window, &fbw, &fbh);
      if (ui.viewport.w == 0) ui.viewport = {340, 20, std::max(fbw - 660, 16), std::max(fbh - 44, 16)};
      session.draw_viewport(ui.viewport.w, ui.viewport.h, ui.interacting);
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      editor::draw_ui(session, ui, fbw, fbh);
      editor::handle_viewport_input(session, ui);
      ImGui::Render();
      glViewport(0, 0, fbw, fbh);
      glClearColor(0.1f, 0.1f, 0.12f, 1.0f);
      glClear(GL_COLOR_BUFFER_BIT);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      if (script) script->after_frame(session, ui, fbw, fbh);
      if (!ui.screenshot_request.empty()) {
        editor::write_window_png(ui.screenshot_request, fbw, fbh);
        ui.status = "wrote " + ui.screenshot_request;
        ui.screenshot_request.clear();
      }
      context->swap_buffers();
    }
    if (script && script->failures() > 0) rc = 1;
  }
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  return rc;
}

}  // namespace

Command add_edit(CLI::App& cdsm) {
  auto a = std::make_shared<EditArgs>();
  CLI::App* app = cdsm.add_subcommand("edit",
                                      "the interactive editor: tune epsilon, d0 and clusters live, see what\n"
                                      "each does");
  app->footer(kEditFooter);
  app->add_option("SCENE", a->scene_path, "a JSON scene, or a glTF / GLB file")->required();
  app->add_option("--script", a->script_path,
                  "run the commands of FILE (--script-help lists them) instead of waiting for a person")
      ->type_name("FILE");
  app->add_flag_callback(
         "--script-help",
         [] {
           std::fputs(editor::script_help().c_str(), stdout);
           throw CLI::Success();
         },
         "print the script commands and exit")
      ->trigger_on_parse();
  app->add_option("--width", a->width, "window width")->check(within(640, 8192, true))->capture_default_str();
  app->add_option("--height", a->height, "window height")->check(within(400, 8192, true))->capture_default_str();
  app->add_flag("--hidden", a->hidden, "no visible window (scripts)");
  return {app, [a] { return run_edit(*a); }};
}

}  // namespace cdsm::cli
