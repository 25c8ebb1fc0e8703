#define GL_GLEXT_PROTOTYPES 1
#include "session.h"

#include <GL/glcorearb.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

namespace cdsm::editor {

double now_seconds() {
  using Clock = std::chrono::steady_clock;
  static const Clock::time_point t0 = Clock::now();
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

Worker::Worker() {
  thread_ = std::thread([this] {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      cv_.wait(lock, [this] { return quit_ || job_; });
      if (quit_) return;
      std::function<void()> job = std::move(job_);
      job_ = nullptr;
      lock.unlock();
      job();
      busy_ = false;
      if (on_done) on_done();
      lock.lock();
    }
  });
}

Worker::~Worker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
  }
  cv_.notify_one();
  thread_.join();  // waits for a running job
}

void Worker::run(std::function<void()> job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    busy_ = true;
    job_ = std::move(job);
  }
  cv_.notify_one();
}

Vec3 Session::cluster_color(int slot) {
  static const Vec3 palette[8] = {{0.90f, 0.25f, 0.20f}, {0.20f, 0.55f, 0.95f}, {0.25f, 0.80f, 0.30f},
                                  {0.95f, 0.80f, 0.15f}, {0.70f, 0.30f, 0.85f}, {0.10f, 0.80f, 0.80f},
                                  {0.95f, 0.50f, 0.10f}, {0.60f, 0.60f, 0.60f}};
  return palette[size_t(std::max(slot, 0)) % 8];
}

Session::Session(Document doc) : doc_(std::move(doc)) {
  renderer_ = std::make_unique<forward::ForwardRenderer>();
  orbit_ = OrbitCamera::from(doc_.scene.camera);
  rebuild_system();
}

Session::~Session() {
  worker_.reset();  // the running build ends, the thread (and the system's fragment context) with it
  cancel_error_view();
  if (error_.worker.joinable()) error_.worker.join();
  if (map_texture_) glDeleteTextures(1, &map_texture_);
}

void Session::rebuild_system() {
  ++generation_;
  worker_.reset();
  building_ = false;
  binding_.reset();
  system_.reset();
  SystemOptions o;
  o.gl_context = GlContextUse::Application;  // the window's context: maps in its GL buffers
  o.private_fragment_context = true;         // GL fragments on the worker's own context: builds off this thread
  o.keep_fragment_lists = true;              // an epsilon or layout edit rebuilds without rasterizing
  o.source = doc_.scene.source;
  system_ = std::make_unique<ShadowSystem>(o);
  worker_ = std::make_unique<Worker>();
  binding_ = std::make_unique<SystemBinding>(*system_, doc_.scene);
  notes_.clear();
  renderer_->upload(doc_.scene, &notes_);
  queued_.clear();
  system_dirty_ = true;
  published_ = false;
  maps_.clear();
  map_image_for_ = -2;
  inspection_ = {};
}

void Session::open(const std::string& path) {
  Document next = open_document(path);  // throws before anything changes
  worker_.reset();
  doc_ = std::move(next);
  history_ = History();
  orbit_ = OrbitCamera::from(doc_.scene.camera);
  selected_object = selected_light = map_view = -1;
  rebuild_system();
}

bool Session::save(const std::string& path, bool overwrite_opened, std::string* why) {
  return save_document(doc_, path, overwrite_opened, why);
}

void Session::apply(Edit e, double now) {
  const bool refused = !e.refused.empty();
  const bool through_maps = maps_only(e);  // then the publish decides whether the viewport redraws
  const bool changed = history_.apply(doc_, std::move(e), now);  // false: refused, or nothing changes
  for (Edit& p : history_.take_pending()) queued_.push_back(std::move(p));
  refusal_ = refused ? history_.last_refusal() : std::string();
  if (changed && !through_maps) ++generation_;
}

bool Session::undo() {
  const bool ok = history_.undo(doc_);
  for (Edit& p : history_.take_pending()) queued_.push_back(std::move(p));
  ++generation_;
  return ok;
}

bool Session::redo() {
  const bool ok = history_.redo(doc_);
  for (Edit& p : history_.take_pending()) queued_.push_back(std::move(p));
  ++generation_;
  return ok;
}

void Session::camera_changed() {
  doc_.scene.camera = orbit_.apply(doc_.scene.camera);
  camera_dirty_ = true;
  ++generation_;
}

void Session::frame_scene() {
  Box3 box;
  for (const Object& o : doc_.scene.objects)
    if (o.mesh && o.casts_shadows) box.grow(world_bounds(*o.mesh, o.transform));
  if (box.empty())
    for (const Object& o : doc_.scene.objects)
      if (o.mesh) box.grow(world_bounds(*o.mesh, o.transform));
  orbit_.frame(box, doc_.scene.camera.fov_y_deg);
  camera_changed();
}

void Session::start_build() {
  building_ = true;
  build_error_.clear();
  build_started_ = now_seconds();
  worker_->run([this] {
    try {
      system_->build(&build_stats_);
    } catch (const std::exception& e) {
      build_error_ = e.what();
    }
  });
}

// Shadow settings reach the viewport only through the maps and the frame
// block the system publishes; the ambient light is the renderer's own.
bool Session::maps_only(const Edit& e) {
  const auto* st = std::get_if<change::Settings>(&e.what);
  if (!st) return false;
  const Vec3 a = st->before.ambient_light, b = st->after.ambient_light;
  return a.x == b.x && a.y == b.y && a.z == b.z;
}

void Session::after_publish() {
  maps_ = system_->maps();
  published_ = true;
  full_res_since_publish_ = false;
  map_image_for_ = -2;  // the map viewer reads the new maps
  if (map_view >= int(maps_.size())) map_view = maps_.empty() ? -1 : 0;
  if (inspect_pending_) {
    inspection_ = system_->inspect_texel(inspect_light, last_pick_.position, last_pick_.object, last_pick_.plane);
    inspect_pending_ = false;
  }
}

void Session::tick() {
  finish_error_view();
  if (building_) {
    if (worker_->busy()) return;
    building_ = false;
    last_build_ms_ = (now_seconds() - build_started_) * 1000.0;
    if (!build_error_.empty()) {
      notes_.push_back("build failed: " + build_error_);
    } else {
      system_->publish(&build_stats_);
      // What the viewport reads changed only if a map was built or freed or
      // bytes reached the GL buffers (the frame block included): a d0 that
      // leaves the clusters as they were redraws nothing.
      const UpdateStats& u = build_stats_.update;
      if (build_stats_.maps_rebuilt > 0 || u.maps_freed > 0 || u.gl_map_upload_bytes > 0 || u.gl_map_device_bytes > 0 ||
          u.gl_map_copy_bytes > 0 || u.gl_map_full_upload) {
        ++maps_version_;  // the viewport's volume light grids follow the maps
        ++generation_;
      }
      after_publish();
    }
  }
  // Idle: queued edits reach the system, then the next build starts.
  if (!queued_.empty()) {
    for (const Edit& e : queued_) binding_->apply(e, doc_.scene);
    queued_.clear();
    renderer_->upload(doc_.scene, &notes_);
    system_dirty_ = true;
  }
  if (camera_dirty_) {
    system_->set_camera(doc_.scene.camera);  // rebuilds maps only if clusters follow the camera
    camera_dirty_ = false;
    system_dirty_ = true;
  }
  if (system_dirty_) {
    system_dirty_ = false;
    if (doc_.scene.objects.empty() && doc_.scene.lights.empty()) return;
    start_build();
    return;
  }
  if (inspect_pending_ && published_) after_publish();
}

bool Session::refined() const {
  return !building_ && queued_.empty() && !camera_dirty_ && !system_dirty_ && published_ && full_res_since_publish_ &&
         !inspect_pending_;
}

void Session::draw_viewport(int width, int height, bool interacting) {
  if (!published_) return;  // the first maps are still building (the viewport stays empty meanwhile)
  // Camera moves show at once in quick frames; edits wait for their maps
  // (a frame of the old maps would only delay the new ones).
  if (!interacting && !camera_dirty_ && (building_ || !queued_.empty() || system_dirty_)) return;
  interacting = interacting || camera_dirty_;
  const std::string view = std::to_string(width) + "x" + std::to_string(height) + " " + std::to_string(int(tint)) +
                           " " + std::to_string(tint_light) + " " + std::to_string(show_frusta) + " " +
                           std::to_string(map_view) + " " + std::to_string(selected_object) + " " +
                           std::to_string(selected_light);
  // Nothing it shows changed: the last frame stands (a full-resolution one
  // once the interaction ended).
  if (generation_ == drawn_generation_ && view == drawn_view_ && (interacting || !drawn_interacting_)) {
    if (!interacting && published_ && !building_ && queued_.empty() && !camera_dirty_ && !system_dirty_)
      full_res_since_publish_ = true;
    return;
  }
  drawn_generation_ = generation_;
  drawn_view_ = view;
  drawn_interacting_ = interacting;
  forward::DrawOptions opt;
  const int div = interacting ? 2 : 1;
  opt.width = std::max(width / div, 1);
  opt.height = std::max(height / div, 1);
  // Volumes march at a voxel a step (two while interacting) and read the
  // lights' transmittance from a grid per volume and light (a texel per 2^3
  // voxels) computed once per publish: with 4 clusters 1.4x faster than a
  // lookup every 4th half-voxel sample, and closer to a lookup at every one
  // (61 dB against 51 dB, README).
  opt.volume_step_scale = interacting ? 4.0f : 2.0f;
  opt.volume_shadows = forward::VolumeShadows::LightGrid;
  opt.light_grid_voxels = 2;
  opt.maps_version = maps_version_;
  opt.selected = selected_object;
  const size_t n = doc_.scene.objects.size();
  if (tint == Tint::Clusters) {
    opt.tint.assign(n, Vec3{0.5f, 0.5f, 0.5f});
    opt.tint_weight.assign(n, 0.85f);  // objects in no map of the light: grey
    for (const ShadowSystem::MapInfo& m : maps_)
      if (m.light == tint_light)
        for (int o : m.members)
          if (size_t(o) < n) opt.tint[size_t(o)] = cluster_color(m.slot);
  }
  // Overlays: lights, the shown map's frustum (or every map of the tinted light).
  for (size_t li = 0; li < doc_.scene.lights.size(); ++li) {
    const Light& l = doc_.scene.lights[li];
    const Vec3 c = int(li) == selected_light ? Vec3{1.0f, 0.6f, 0.1f} : Vec3{1.0f, 0.95f, 0.4f};
    const float s = 0.08f;
    if (l.type == LightType::Directional) {  // a ray toward the orbit's centre, along the light
      const Vec3 d = normalize(l.direction);
      opt.lines.push_back({orbit_.target - d * 2.0f, orbit_.target, c});
      continue;
    }
    opt.lines.push_back({l.position - Vec3{s, 0, 0}, l.position + Vec3{s, 0, 0}, c});
    opt.lines.push_back({l.position - Vec3{0, s, 0}, l.position + Vec3{0, s, 0}, c});
    opt.lines.push_back({l.position - Vec3{0, 0, s}, l.position + Vec3{0, 0, s}, c});
    if (l.type == LightType::Spot) opt.lines.push_back({l.position, l.position + normalize(l.direction) * 0.6f, c});
  }
  if (show_frusta)
    for (size_t k = 0; k < maps_.size(); ++k) {
      const ShadowSystem::MapInfo& m = maps_[k];
      const bool shown = int(k) == map_view || (tint == Tint::Clusters && m.light == tint_light);
      if (!shown) continue;
      const Vec3 c = cluster_color(m.slot);
      static const int edges[12][2] = {{0, 1}, {2, 3}, {0, 2}, {1, 3}, {4, 5}, {6, 7},
                                       {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
      for (const auto& e : edges) opt.lines.push_back({m.corners[e[0]], m.corners[e[1]], c});
    }
  const forward::FrameTimes t = renderer_->draw(*system_, doc_.scene, doc_.scene.camera, opt);
  last_draw_ms_ = t.draw_ms;
  ++draws_;
  if (t.light_grids > 0) last_light_grid_ms_ = t.light_grid_ms;
  frame_ms_.push_back(float(t.draw_ms));
  while (frame_ms_.size() > 120) frame_ms_.pop_front();
  if (!interacting && published_ && !building_ && queued_.empty() && !camera_dirty_ && !system_dirty_)
    full_res_since_publish_ = true;
}

void Session::click(int x, int y) {
  const forward::Pick p = renderer_->pick(doc_.scene, doc_.scene.camera, x, y);
  selected_object = p.object;
  ++generation_;
  if (p.object < 0) return;
  last_pick_ = p;
  inspect_pending_ = true;  // on the maps the system has when it is idle
  if (!building_ && published_) after_publish();
}

const std::vector<unsigned char>& Session::map_image(int& res) {
  res = 0;
  if (map_view < 0 || size_t(map_view) >= maps_.size() || building_) {
    res = map_image_res_;
    return map_image_;
  }
  const float depth_frac = map_view_depth;
  if (map_image_for_ != map_view || map_image_kind_ != map_view_kind ||
      (map_view_kind == MapView::AlphaAtDepth && map_image_depth_ != depth_frac)) {
    const ShadowSystem::MapInfo& m = maps_[size_t(map_view)];
    const int r = m.res;
    map_image_.assign(size_t(r) * r * 4, 255);
    if (map_view_kind == MapView::NodeCounts) {
      const std::vector<uint32_t> counts = system_->map_node_counts(map_view);
      const float top = float(std::max<uint32_t>(m.max_nodes, 1));
      for (size_t i = 0; i < counts.size(); ++i) {  // heat: black -> red -> yellow -> white
        const float t = std::sqrt(float(counts[i]) / top);
        map_image_[4 * i] = uint8_t(255.0f * std::clamp(3.0f * t, 0.0f, 1.0f));
        map_image_[4 * i + 1] = uint8_t(255.0f * std::clamp(3.0f * t - 1.0f, 0.0f, 1.0f));
        map_image_[4 * i + 2] = uint8_t(255.0f * std::clamp(3.0f * t - 2.0f, 0.0f, 1.0f));
      }
    } else {
      // Radial depth at the chosen fraction of the map's range (axial near..far
      // scaled by the corner ray's length: close enough for a view).
      const float depth = m.near + (m.far - m.near) * depth_frac;
      const std::vector<float> alpha = system_->map_alpha(map_view, depth);
      for (size_t i = 0; i < alpha.size(); ++i) {
        const uint8_t v = uint8_t(255.0f * std::clamp(1.0f - alpha[i], 0.0f, 1.0f));  // transmittance: white lit
        map_image_[4 * i] = map_image_[4 * i + 1] = map_image_[4 * i + 2] = v;
      }
    }
    map_image_res_ = r;
    map_image_for_ = map_view;
    map_image_kind_ = map_view_kind;
    map_image_depth_ = depth_frac;
    map_texture_stale_ = true;
  }
  res = map_image_res_;
  return map_image_;
}

GLuint Session::map_texture() {
  int res = 0;
  const std::vector<unsigned char>& img = map_image(res);
  if (res == 0) return 0;
  if (map_texture_stale_) {
    if (map_texture_) glDeleteTextures(1, &map_texture_);
    glCreateTextures(GL_TEXTURE_2D, 1, &map_texture_);
    glTextureStorage2D(map_texture_, 1, GL_RGBA8, res, res);
    glTextureSubImage2D(map_texture_, 0, 0, 0, res, res, GL_RGBA, GL_UNSIGNED_BYTE, img.data());
    glTextureParameteri(map_texture_, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(map_texture_, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    map_texture_stale_ = false;
  }
  return map_texture_;
}

void Session::start_error_view(int width) {
  if (error_.running) return;
  if (error_.worker.joinable()) error_.worker.join();
  error_.running = true;
  error_.ready = false;
  error_.message.clear();
  error_.progress = std::make_unique<RenderProgress>();
  Scene scene = doc_.scene;  // a copy: the document may change meanwhile
  const float aspect = float(scene.camera.height) / float(std::max(scene.camera.width, 1));
  scene.camera.width = std::max(width, 16);
  scene.camera.height = std::max(int(float(scene.camera.width) * aspect), 16);
  RenderProgress* progress = error_.progress.get();
  error_.worker = std::thread([this, scene, progress] {
    const double t0 = now_seconds();
    try {
      Renderer r;
      RenderOptions o;
      o.fragments = FragmentSource::Cpu;  // no GL context on this thread
      o.compare_reference = true;
      o.progress = progress;
      FrameStats st;
      error_.dsm = r.render(scene, o, &st);
      error_.reference = r.last_reference();
      error_.heatmap = error_heatmap(error_.dsm, error_.reference, 0.1f);
      error_.error = st.transmittance;
      error_.image = st.image;
      error_.ready = true;
    } catch (const std::exception& e) {
      error_.message = e.what();
    }
    error_.seconds = now_seconds() - t0;
    error_.running = false;
  });
}

void Session::cancel_error_view() {
  if (error_.running && error_.progress) error_.progress->cancel = true;
}

void Session::finish_error_view() {
  if (!error_.running && error_.worker.joinable()) error_.worker.join();
}

}  // namespace cdsm::editor
