// One editing session of `cdsm edit`: the document and its undo history
// (editor/state), the shadow system kept in step with it edit by edit, the
// viewport renderer (engine/forward: an OpenGL forward renderer
// with cdsm.glsl, like an engine's), and the views' data. No ImGui here:
// the panels (ui.cpp) read and write this state; the script runner drives
// it the same way.
//
// Responsiveness: maps build on a worker thread (ShadowSystem::build with
// CPU fragments) while the viewport keeps drawing with the last published
// maps; edits made meanwhile queue and reach the system when it is idle.
// While the user interacts (a drag, a slider) the viewport draws at half
// resolution with a coarser volume march, and refines when still.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "camera_control.h"
#include "cdsm/cdsm.h"
#include "cdsm/gl.h"
#include "forward_renderer.h"
#include "state/document.h"
#include "state/history.h"
#include "state/system_binding.h"

namespace cdsm::editor {

// What the viewport shows.
enum class Tint { None, Clusters };
enum class MapView { NodeCounts, AlphaAtDepth };

struct ErrorView {
  std::atomic<bool> running{false}, ready{false};
  std::string message;  // failure or cancellation
  std::unique_ptr<RenderProgress> progress;
  std::thread worker;
  Image dsm, reference, heatmap;  // at the probe's size
  TransmittanceError error;
  ImageError image;
  double seconds = 0.0;
};

// One worker thread for a shadow system's builds: the system's own fragment
// context (SystemOptions::private_fragment_context) is made and stays
// current there. It ends (joined) before its system is destroyed, so the
// context leaves with the thread.
class Worker {
 public:
  Worker();
  ~Worker();
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;
  void run(std::function<void()> job);  // the worker must be idle
  bool busy() const { return busy_; }
  // Called on the worker's thread after each job (set while idle): wakes
  // a UI loop that sleeps in glfwWaitEvents.
  std::function<void()> on_done;

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::function<void()> job_;
  bool quit_ = false;
  std::atomic<bool> busy_{false};
  std::thread thread_;
};

class Session {
 public:
  // Takes an opened document (open_document: the scene file is read and
  // checked before any window exists); the GL context must be current.
  explicit Session(Document doc);
  // `wake` runs on the build thread when a build ends (before the session's
  // destructor returns at the latest): the window's loop uses it to stop
  // sleeping at once (glfwPostEmptyEvent).
  void set_wake(std::function<void()> wake) { worker_->on_done = std::move(wake); }
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // ---- the document ----
  Document& document() { return doc_; }
  const Scene& scene() const { return doc_.scene; }
  void apply(Edit e, double now_seconds);
  bool undo();
  bool redo();
  const History& history() const { return history_; }
  // Why the last edit was refused ("" when it applied): shown in the status line.
  const std::string& refusal() const { return refusal_; }
  // Save (refuses the opened file unless `overwrite_opened`); false + why.
  bool save(const std::string& path, bool overwrite_opened, std::string* why);
  // Replaces the document (a new system and viewport data).
  void open(const std::string& path);

  // ---- per frame ----
  // Moves queued edits into the system when it is idle, starts and
  // finishes background builds (publish on this thread).
  void tick();
  // Draws the viewport at `width` x `height` (half that while interacting).
  void draw_viewport(int width, int height, bool interacting);
  forward::ForwardRenderer& renderer() { return *renderer_; }
  // Nothing queued, no build running, and the last viewport frame was at
  // full resolution after the last publish: what the user sees is final.
  bool refined() const;
  bool building() const { return building_; }
  ShadowSystem::BuildProgress progress() const { return system_->build_progress(); }

  // ---- camera ----
  OrbitCamera& orbit() { return orbit_; }
  void camera_changed();  // after orbit_ changed: the document's camera follows
  void frame_scene();     // F

  // ---- selection and views ----
  int selected_object = -1;
  int selected_light = -1;
  Tint tint = Tint::None;
  int tint_light = 0;  // whose clusters colour the objects
  bool show_frusta = true;
  int map_view = -1;  // map index shown in the map viewer (-1: none)
  MapView map_view_kind = MapView::NodeCounts;
  float map_view_depth = 0.5f;  // fraction of the map's near..far
  // Click in the viewport (row 0 at the top, in viewport pixels of the last
  // frame): selects the object and inspects its light ray.
  void click(int x, int y);
  bool inspection_pending() const { return inspect_pending_; }
  const ShadowSystem::TexelInspection& inspection() const { return inspection_; }
  int inspect_light = 0;
  // The map viewer's image (res x res, RGBA8, rows top first), rebuilt on demand.
  const std::vector<unsigned char>& map_image(int& res);
  GLuint map_texture();

  // ---- stats (of the last publish) ----
  const FrameStats& build_stats() const { return build_stats_; }
  const std::vector<ShadowSystem::MapInfo>& maps() const { return maps_; }
  const std::deque<float>& frame_ms() const { return frame_ms_; }
  double last_build_ms() const { return last_build_ms_; }
  double last_draw_ms() const { return last_draw_ms_; }
  double last_light_grid_ms() const { return last_light_grid_ms_; }  // of a draw: the volumes' light grids
  uint64_t viewport_draws() const { return draws_; }                 // frames drawn since the session began
  uint32_t last_maps_rebuilt() const { return build_stats_.maps_rebuilt; }
  const std::vector<std::string>& notes() const { return notes_; }

  // ---- error view against the reference (background, cancellable) ----
  void start_error_view(int width);
  void cancel_error_view();
  ErrorView& error_view() { return error_; }
  void finish_error_view();  // joins a finished worker (called by tick)

  // Cluster colours (the paper's Figure 4 palette).
  static Vec3 cluster_color(int slot);

 private:
  void rebuild_system();
  void start_build();
  void after_publish();
  static bool maps_only(const Edit& e);

  Document doc_;
  History history_;
  std::unique_ptr<ShadowSystem> system_;
  std::unique_ptr<SystemBinding> binding_;
  std::unique_ptr<forward::ForwardRenderer> renderer_;
  OrbitCamera orbit_;
  std::vector<Edit> queued_;
  bool camera_dirty_ = false;
  bool system_dirty_ = true;        // edits reached the system since its last build
  std::unique_ptr<Worker> worker_;  // after system_: destroyed (joined) first
  bool building_ = false;
  std::string build_error_;
  FrameStats build_stats_;
  std::vector<ShadowSystem::MapInfo> maps_;
  bool full_res_since_publish_ = false;
  bool published_ = false;
  bool inspect_pending_ = false;
  int inspect_x_ = 0, inspect_y_ = 0;
  forward::Pick last_pick_;
  ShadowSystem::TexelInspection inspection_;
  std::vector<unsigned char> map_image_;
  int map_image_res_ = 0, map_image_for_ = -2;
  MapView map_image_kind_ = MapView::NodeCounts;
  float map_image_depth_ = -1.0f;
  GLuint map_texture_ = 0;
  bool map_texture_stale_ = true;
  // The viewport is drawn only when what it shows changed: the document,
  // the camera, new maps, a view setting, its size or the interaction.
  uint64_t generation_ = 1;  // bumped by every change of what the viewport shows
  uint64_t drawn_generation_ = 0;
  uint64_t maps_version_ = 0;  // bumped by every publish that changed the maps (DrawOptions::maps_version)
  uint64_t draws_ = 0;
  std::string drawn_view_;  // view settings and size of the last frame
  bool drawn_interacting_ = false;
  std::deque<float> frame_ms_;
  double last_build_ms_ = 0.0, last_draw_ms_ = 0.0, last_light_grid_ms_ = 0.0;
  double build_started_ = 0.0;
  std::vector<std::string> notes_;
  std::string refusal_;
  ErrorView error_;
};

double now_seconds();

}  // namespace cdsm::editor
