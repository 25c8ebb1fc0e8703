// The frame driver of ShadowSystem (cdsm/shadow_system.h): update() =
// build() (compile, fragments, maps) + publish() (the GL map buffers), and
// render() / render_reference(), with the FrameStats they fill.
#include "cdsm/fields.h"
#include "cdsm/shadow_system.h"

#include <algorithm>
#include <stdexcept>
#include <chrono>
#include <cstring>

#include "cdsm/error.h"
#include "cdsm/scene_io.h"
#include "backend_select.h"
#include "backend/backend.h"
#include "memory_budget.h"
#include "reference/reference.h"
#include "scene_compile.h"
#include "shadow_system_impl.h"
#include "stopwatch.h"

namespace cdsm {

namespace {

template <class T>
uint64_t capacity_bytes(const std::vector<T>& v) {
  return uint64_t(v.capacity()) * sizeof(T);
}

uint64_t scene_bytes(const SceneBuffers& sb) {
  return capacity_bytes(sb.tri_vertices) + capacity_bytes(sb.tri_normals) + capacity_bytes(sb.tri_object) +
         capacity_bytes(sb.objects) + capacity_bytes(sb.volumes) + capacity_bytes(sb.voxels) +
         capacity_bytes(sb.macro_max) + capacity_bytes(sb.nano_pool) + capacity_bytes(sb.bvh) +
         capacity_bytes(sb.bvh_prims) + capacity_bytes(sb.object_bounds);
}

void add_walk(FrameStats& st, const WalkStats& w) {
  st.unmatched_fragments += w.unmatched;
  st.enclosing_overflow += w.enclosing_overflow;
  st.match_overflow += w.match_overflow;
  st.march_lengthened += w.march_lengthened;
}

}  // namespace

const char* to_string(RebuildReason r) {
  switch (r) {
    case RebuildReason::New: return "new";
    case RebuildReason::Settings: return "settings";
    case RebuildReason::Light: return "light";
    case RebuildReason::Members: return "members";
    case RebuildReason::Frustum: return "frustum";
    case RebuildReason::Content: return "content";
  }
  return "?";
}

std::string cluster_count_text(const LightClusterStats& c) {
  if (c.chosen_clusters == 0) return "";
  std::string s = "auto clusters: " + std::to_string(c.chosen_clusters) + ", " + c.count_reason + " (";
  for (size_t k = 0; k < c.count_trials.size(); ++k) {
    const LightClusterStats::CountTrial& t = c.count_trials[k];
    char text[160];
    if (t.wanted_texels > 0.0)
      std::snprintf(text, sizeof text, "%sm=%d: %u map%s, %.2f Mtexels, the neediest wants %.0f^2%s", k ? "; " : "",
                    t.clusters, t.maps, t.maps == 1 ? "" : "s", t.texels / 1e6, t.wanted_texels,
                    t.reaches ? "" : ", too many");
    else
      std::snprintf(text, sizeof text, "%sm=%d: %u map%s, none seen", k ? "; " : "", t.clusters, t.maps,
                    t.maps == 1 ? "" : "s");
    s += text;
  }
  return s + ")";
}

// The backend's kernel times since the last take (the exec backends: CUDA
// events on the cuda backend), into `t.kernels`; the fragment producer's
// launches ("fragments: ...", and "scan: ...", its offsets: no other pass
// scans) add to `fragments_ms`, the others to `other_ms`.
static void take_kernel_times(ShadowBackend& backend, StageTimes& t, double& fragments_ms, double& other_ms) {
  for (const exec::StageTime& k : backend.take_stage_times()) {
    const bool producer = k.name.rfind("fragments", 0) == 0 || k.name.rfind("scan", 0) == 0;
    (producer ? fragments_ms : other_ms) += k.ms;
    auto it = std::find_if(t.kernels.begin(), t.kernels.end(), [&](const KernelTime& x) { return x.name == k.name; });
    if (it == t.kernels.end()) it = t.kernels.insert(t.kernels.end(), KernelTime{k.name, 0.0, 0});
    it->ms += k.ms;
    it->launches += k.launches;
  }
}

// What the backend's executor did since the last take (bytes each way,
// synchronizations, allocations, launches), into `st`.
static void add_counters(ShadowBackend& backend, FrameStats& st) {
  const exec::ExecCounters c = backend.take_counters();
  st.update.host_to_backend_bytes += c.bytes_up;
  st.update.backend_to_host_bytes += c.bytes_down;
  st.counters.host_syncs += c.syncs;
  st.counters.backend_allocations += c.allocations;
  st.counters.launches += c.launches;
}

// This thread's GL buffer work since `before`, into `st`.
static void add_gl_work(FrameStats& st, const GlWork& before) {
  const GlWork now = thread_gl_work();
  st.counters.gl_allocations += now.allocations - before.allocations;
  st.counters.gl_readbacks += now.readbacks - before.readbacks;
}

void ShadowSystem::Impl::update(FrameStats& st) {
  const auto t0 = Clock::now();
  build(st);
  publish(st);
  st.times.total_ms = ms_since(t0);
}

void ShadowSystem::Impl::publish(FrameStats& st) {
  if (!gl) return;
  const GlWork gl0 = thread_gl_work();
  if (gl_published) {
    // Nothing changed since the last publish: the buffers hold this frame.
    require_gl_current(*gl, &st.warnings);
    st.update.gl_map_bytes = gl_map_bytes;
  } else {
    SystemGlScope gl_scope(gl.get(), &st.warnings);
    sync_gl_maps(*gl, frame.view(scene.shadows, /*with_storage=*/false), *backend, st.update);
    gl_map_bytes = st.update.gl_map_bytes;
    gl_published = true;
  }
  st.update.gl_readback_bytes = gl_readback_bytes;
  gl_readback_bytes = 0;
  st.counters.gl_readbacks += gl_readbacks;  // the meshes read since the last update
  gl_readbacks = 0;
  add_gl_work(st, gl0);
  add_counters(*backend, st);
}

void ShadowSystem::Impl::build(FrameStats& st) {
  const GlWork gl0 = thread_gl_work();
  build_maps(st);
  add_gl_work(st, gl0);
  st.backend = backend_name;
  st.backend_reason = backend_reason;
}

void ShadowSystem::Impl::build_maps(FrameStats& st) {
  // The application's context only where the fragments are rasterized on it
  // (then on that context's thread).
  const bool app_fragments = (options.fragments == FragmentSource::Auto || options.fragments == FragmentSource::Gl) &&
                             !options.private_fragment_context;
  // GL work here only for a frame with edits (fragments rasterized).
  SystemGlScope gl_scope(app_fragments && changed ? gl.get() : nullptr, &st.warnings);
  if (changed) gl_published = false;
  if (scene.objects.empty() && scene.lights.empty()) {
    // An empty system (an engine's empty level) is valid and free: no maps,
    // nothing compiled; the maps of what was removed are dropped.
    if (!frame.maps.empty() || !cache.retired.empty()) {
      st.update.maps_freed = uint32_t(frame.maps.size() + cache.retired.size());
      cache.clear(*backend);
      frame = ShadowFrame{};
    }
    changed = false;
    return;
  }
  if (changed) {
    validate_scene(scene, &st.warnings);
    const std::vector<MemoryItem> memory = estimate_frame_memory(scene, RenderOptions{});
    check_memory(scene, memory);
    compile(st);
    FrameInputs in;
    in.map_texel_budget = map_texel_budget(scene.shadows, memory);
    in.scene = &sb;
    in.lights = scene.lights;
    in.light_ids = lights;
    for (const ObjectRec& r : objects) {
      in.object_ids.push_back(r.id);
      in.object_generations.push_back(r.generation);
    }
    in.camera = scene.camera;
    in.settings = scene.shadows;
    in.keep_previous = keep_previous;
    in.keep_fragments = options.keep_fragment_lists;
    in.geometry_epoch = geometry_epoch;
    in.maps_built = &progress_built;
    in.maps_to_build = &progress_total;
    build_shadow_frame(in, fragments.producer(sb), *backend, cache, frame);
    st.update.frames_planned = 1;
    changed = false;
  } else {
    for (uint8_t& r : frame.map_rebuilt) r = 0;
    frame.rebuilt = frame.freed = 0;
    // Maps kept for the popping probe are not needed by a frame whose maps
    // did not change.
    backend->free_maps(cache.retired);
    frame.freed += uint32_t(cache.retired.size());
    cache.retired.clear();
    if (frame.freed) {
      frame.refresh_headers();
      gl_published = false;  // the store may have moved
    }
    frame.rebuilds.clear();
    frame.reused = uint32_t(frame.maps.size());
    frame.fragments_ms = frame.build_ms = frame.cluster_ms = 0.0;
    frame.fragments = 0;
    frame.fragment_lists_reused = 0;
    frame.fragment_lists_redone = 0;
  }
  st.fragment_source = fragment_name;
  st.fragment_source_reason = fragment_reason;
  st.warnings.insert(st.warnings.end(), sb.warnings.begin(), sb.warnings.end());
  st.warnings.insert(st.warnings.end(), frame.warnings.begin(), frame.warnings.end());
  st.maps_rebuilt = frame.rebuilt;
  st.maps_reused = frame.reused;
  st.update.maps_freed = frame.freed;
  st.update.fragment_lists_reused = frame.fragment_lists_reused;
  st.update.fragment_lists_redone = frame.fragment_lists_redone;
  st.update.fragment_cache_bytes = frame.fragment_cache_bytes;
  st.update.rebuilds = frame.rebuilds;
  for (const MapRebuild& r : frame.rebuilds) ++st.update.rebuilt_by_reason[int(r.reason)];
  st.cluster_ms = frame.cluster_ms;
  st.clusters.clear();
  for (size_t li = 0; li < frame.clusters.size(); ++li) {
    const LightClusters& lc = frame.clusters[li];
    LightClusterStats cs;
    cs.clustered = lc.clustered;
    cs.fallback_reason = lc.fallback_reason;
    cs.reclustered = lc.clustered && lc.clustering.reclustered;
    if (lc.clustered)
      for (const auto& c : lc.clustering.clusters) {
        cs.members.push_back({c.members.begin(), c.members.end()});
        cs.changed.push_back(c.members_changed || c.views_changed ? 1 : 0);
      }
    cs.maps = frame.setup.lights[li].map_count;
    cs.directions = lc.clustering.directions;
    cs.warped_directions = lc.clustering.perspective_directions;
    cs.count_trials = lc.count_trials;
    if (!lc.count_trials.empty()) cs.chosen_clusters = lc.count;
    cs.count_reason = lc.count_reason;
    st.clusters.push_back(std::move(cs));
  }
  st.map_resolutions = frame.resolutions;
  st.times.fragments_ms = frame.fragments_ms;
  st.times.dsm_build_ms = frame.build_ms;
  take_kernel_times(*backend, st.times, st.times.kernel_fragments_ms, st.times.kernel_dsm_build_ms);
  add_counters(*backend, st);
  st.light_fragments = frame.fragments;
  DsmMemory& m = st.memory;
  m = DsmMemory{};
  m.maps = frame.maps.size();
  for (const DsmBuildStats& b : frame.map_stats) {
    m.texels += b.texels;
    m.nodes += b.nodes;
    m.index_bytes += b.index_bytes;
    m.node_bytes += b.node_bytes_used;
    m.slack_bytes += b.slack_bytes;
    m.tag_bytes += b.tag_bytes;
    m.pyramid_bytes += b.pyramid_bytes;
    m.max_nodes_per_texel = std::max(m.max_nodes_per_texel, b.max_nodes);
    m.overflow_texels += b.overflow_texels;
    m.rewalked_texels += b.rewalked_texels;
    m.max_extra_error = std::max(m.max_extra_error, b.max_extra_error);
    const uint64_t bytes = b.index_bytes + b.node_bytes_allocated + b.tag_bytes + b.pyramid_bytes;
    if (b.rgb) {
      ++m.rgb_maps;
      m.rgb_bytes += bytes;
      m.rgb_nodes += b.nodes;
    } else {
      m.grey_bytes += bytes;
    }
    add_walk(st, b.walk);
  }
  m.avg_nodes_per_texel = m.texels ? double(m.nodes) / double(m.texels) : 0.0;
  const MapStoreStats store = backend->map_store();
  st.update.map_store_bytes = store.allocated_bytes;
  st.update.map_live_bytes = store.live_bytes;
  st.update.scene_bytes = scene_bytes(sb);
  st.update.gl_scene_bytes = fragments.gl_scene_bytes();
  st.lights = uint32_t(scene.lights.size());
  update_stats = st;
}

Image ShadowSystem::render(FrameStats* stats) {
  Impl& I = *impl_;
  FrameStats local;
  FrameStats& st = stats ? *stats : local;
  st = FrameStats{};
  const auto t_total = Clock::now();
  I.require_host_meshes("render()");
  SystemGlScope gl_scope(I.gl.get(), &st.warnings);
  I.update(st);
  const GlWork gl0 = thread_gl_work();  // render()'s own GL work: the camera's lists
  CameraPassParams& cam = I.cam;
  cam.view = camera_view(I.scene.camera);
  SceneView sv = I.sb.view();
  I.cam_inside = objects_containing(sv, cam.view.eye, ObjectMask{});
  cam.inside = {I.cam_inside.data(), I.cam_inside.size()};
  cam.ambient = I.scene.shadows.ambient_light;
  cam.background = I.scene.background;
  auto t0 = Clock::now();
  if (I.has_camera_lists) I.backend->free_lists(I.camera_lists);
  I.has_camera_lists = false;
  I.camera_frags_read = false;
  // (made unchecked where the backend can: the camera pass's one read says
  // whether they fit, and lists that did not are made again, counted)
  I.camera_lists =
      produce_lists(I.fragments.producer(I.sb), *I.backend, cam.view, ObjectMask{}, true, kCameraListsSlot);
  I.has_camera_lists = true;
  st.times.camera_fragments_ms = ms_since(t0);
  take_kernel_times(*I.backend, st.times, st.times.kernel_camera_fragments_ms, st.times.kernel_camera_fragments_ms);
  Image img;
  img.width = cam.view.width;
  img.height = cam.view.height;
  t0 = Clock::now();
  WalkStats ws;
  // (the backend reads its own store: no host view of it is fetched)
  const ShadowView shadows = I.frame.view(I.scene.shadows, /*with_storage=*/false);
  try {
    I.backend->camera_pass(shadows, cam, I.camera_lists, img.rgb, ws);
  } catch (const ListsShortError&) {
    I.backend->free_lists(I.camera_lists);
    I.has_camera_lists = false;
    I.camera_lists =
        produce_lists(I.fragments.producer(I.sb), *I.backend, cam.view, ObjectMask{}, false, kCameraListsSlot);
    I.has_camera_lists = true;
    ++st.update.fragment_lists_redone;
    ws = WalkStats{};
    I.backend->camera_pass(shadows, cam, I.camera_lists, img.rgb, ws);
  }
  st.camera_fragments = I.backend->lists_fragments(I.camera_lists);
  st.times.camera_ms = ms_since(t0);
  take_kernel_times(*I.backend, st.times, st.times.kernel_camera_ms, st.times.kernel_camera_ms);
  add_counters(*I.backend, st);
  add_gl_work(st, gl0);
  add_walk(st, ws);
  if (st.march_lengthened > 0)
    st.warnings.push_back(I.scene.source + ": " + std::to_string(st.march_lengthened) +
                          " volume segments lie so far from the eye or light that their march step is below float "
                          "resolution there; they were marched with the finest step float allows (coarser than asked)");
  if (st.enclosing_overflow > 0)
    st.warnings.push_back(I.scene.source + ": " + std::to_string(st.enclosing_overflow) +
                          " entries of light or camera rays into volumes nested inside " +
                          std::to_string(kMaxEnclosing) +
                          " other volumes; those innermost volumes were left out there (their media absorb nothing)");
  st.times.total_ms = ms_since(t_total);
  return img;
}

Image ShadowSystem::render_reference(float step_voxels, RenderProgress* progress) {
  Impl& I = *impl_;
  I.require_host_meshes("render_reference()");
  FrameStats st;
  validate_scene(I.scene, &st.warnings);
  // The frame's estimate with the reference's own buffers (its image and
  // per-pixel state): this render's memory check.
  RenderOptions with_reference;
  with_reference.compare_reference = true;
  check_memory(I.scene, estimate_frame_memory(I.scene, with_reference));
  I.compile(st);
  SceneView sv = I.sb.view();
  LightSetup ls = setup_lights(I.scene.lights, I.sb, 4);
  ReferenceOptions ro;
  ro.step_voxels = step_voxels;
  if (progress) {
    ro.progress = &progress->fraction;
    ro.cancel = &progress->cancel;
  }
  ReferenceRenderer ref(sv, ls.lights, ro);
  CameraPassParams cam;
  cam.view = camera_view(I.scene.camera);
  std::vector<uint32_t> inside = objects_containing(sv, cam.view.eye, ObjectMask{});
  cam.inside = {inside.data(), inside.size()};
  cam.ambient = I.scene.shadows.ambient_light;
  cam.background = I.scene.background;
  Image img;
  img.width = cam.view.width;
  img.height = cam.view.height;
  ref.render(cam, img.rgb);
  if (progress) {
    if (progress->cancel.load()) throw Error(I.scene.source, "reference render cancelled");
    progress->fraction.store(1.0f);
  }
  return img;
}

}  // namespace cdsm
