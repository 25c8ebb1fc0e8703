// The ShadowBackend (shadows/backend/backend.h): every kernel runs through
// an executor (shadows/exec/exec.h), scene buffers, maps and the camera
// pass live in the executor's memory. Over HostExec it is the cpu backend
// (backend.h: make_cpu_backend), over CudaExec the cuda
// backend (cuda/cuda_backend.h): one class, so the CPU tests run the
// GPU's code minus the CUDA glue.
//
// Fragment lists are held where the kernels read them (ListsId): cast by
// the executor's ray caster, or handed over once from the host (moved in
// over host memory); kept copies are made on the executor.
//
// Maps are appended to one store per node kind (a frame's maps walked
// together, their counters read once: exec/light_pass.h), freed maps leave
// holes that are closed on the executor, inside the arrays, once they
// exceed a quarter of the store; the arrays keep their capacity, given
// back after a frame's builds only past three times what they hold.
// storage() is the host's view: over device
// memory, a host mirror downloaded when the maps changed since the last
// call (the probes read it, and the GL map buffers where the executor
// cannot write them itself); the camera pass reads the executor's copy, and
// over CudaExec the GL map buffers are written from it (write_gl_maps).
//
// Its parts: the scene's arrays (backend/scene_store.h), the held fragment
// lists (backend/list_store.h), the maps' slots and compaction
// (exec/map_store.h); this class is the facade that ties them to the
// executor's passes.
#pragma once

#include <algorithm>
#include <cstring>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "backend/backend.h"
#include "backend/exec_shadow_backend.h"
#include "backend/host_storage.h"
#include "exec/scan.h"
#include "backend/list_store.h"
#include "backend/scene_store.h"
#include "exec/camera_pass.h"
#include "exec/light_pass.h"
#include "exec/map_store.h"

namespace cdsm::exec {

template <class Ex>
class ExecBackend final : public ExecShadowBackend {
 public:
  template <class... Args>
  explicit ExecBackend(const char* name, Args&&... args)
      : name_(name),
        ex_(std::forward<Args>(args)...),
        scene_(ex_),
        lists_(ex_),
        grey_(ex_),
        rgb_(ex_),
        scratch_(ex_),
        cam_inside_(ex_),
        cam_lights_(ex_),
        cam_maps_(ex_),
        cam_rgb_(ex_),
        cam_walk_(ex_),
        frag_counts_(ex_),
        frag_total_(ex_),
        frag_totals_(ex_),
        frag_mask_(ex_),
        bounce_(ex_) {}
  ExecBackend(const ExecBackend&) = delete;
  ExecBackend& operator=(const ExecBackend&) = delete;

  const char* name() const override { return name_; }
  Ex& executor() { return ex_; }
  // Per slot, the count lists_from_gl_unchecked guesses from (tests shrink
  // them to see a frame's lists made again).
  std::map<uint64_t, uint64_t>& gl_guesses() { return gl_guess_; }

  // The scene's arrays into executor memory (on CPU threads too: the same
  // code, counted as copies): ExecSceneStore::update.
  void update_scene(const SceneBuffers& sb, const SceneChange& change) override { scene_.update(sb, change); }

  ExecCounters take_counters() override {
    const ExecCounters d = ex_.counters.since(taken_);
    taken_ = ex_.counters;
    return d;
  }

  MapId build_map(const LightPassParams& params, ListsId lists, const DsmLayoutParams& layout,
                  DsmBuildStats& stats) override {
    const MapBuild b{params, lists};
    MapId id = 0;
    build_maps(&b, 1, layout, &id, &stats);
    return id;
  }

  // Every map walked, their counters read once, then placed
  // (exec/light_pass.h build_maps_exec).
  void build_maps(const MapBuild* builds, size_t n, const DsmLayoutParams& layout, MapId* ids,
                  DsmBuildStats* stats) override {
    if (n == 0) return;
    check_layout(layout);
    if (slots_.live() == 0) reset_store();
    CDSM_CHECK(!stored_any_ || same_layout(layout_, layout),
               "exec backend: maps of different layouts cannot share the store");
    std::vector<MapBuildInput> in(n);
    std::vector<uint32_t> inside;  // every map's objects containing its light, one after another
    for (size_t i = 0; i < n; ++i) {
      const LightPassParams& p = builds[i].params;
      if (p.rgb && p.method != ShadowMethod::Dsm)
        throw std::invalid_argument("build_map: the baselines are grey (no RGB maps)");
      in[i].params = p;
      auto& held = lists_.held(builds[i].lists, "build_map");
      in[i].frags = held.lists();
      if (!held.checked) in[i].lists_status = held.status.data();
      inside.insert(inside.end(), p.inside.begin(), p.inside.end());
    }
    // The few ids of objects containing each light, over device memory,
    // copied (one upload for the frame).
    if constexpr (!Ex::kHostMemory) {
      scratch_.inside.assign(inside.data(), inside.size());
      uint64_t at = 0;
      for (MapBuildInput& b : in) {
        b.params.inside = {scratch_.inside.data() + at, b.params.inside.size()};
        at += b.params.inside.size();
      }
    }
    std::vector<DsmMap> maps(n);
    std::vector<uint64_t> counts(n, 0);
    std::vector<uint8_t> short_lists(n, 0);
    const StoreMark grey = mark(grey_), rgb = mark(rgb_);
    bool fit = true;
    try {
      fit = build_maps_exec(ex_, scene_view(), in.data(), n, layout, options_, grey_, rgb_, scratch_, maps.data(),
                            stats, counts.data(), short_lists.data());
    } catch (...) {
      cut_back(grey_, grey);
      cut_back(rgb_, rgb);
      throw;
    }
    // Unchecked lists' counts came with the build's read: each is checked
    // now, its count the next guess of its slot; lists that did not fit
    // leave nothing built.
    std::vector<ListsId> short_ids;
    std::vector<uint64_t> short_counts;
    for (size_t i = 0; i < n; ++i) {
      if (!in[i].lists_status) continue;
      auto& held = lists_.held(builds[i].lists, "build_map");
      gl_guess_[held.guess_key] = counts[i];
      if (short_lists[i] != 0) {  // more than its capacity, or past a GL pool that earlier views filled
        short_ids.push_back(builds[i].lists);
        short_counts.push_back(counts[i]);
      } else if (fit) {
        held.fragments.resize(counts[i]);
        held.checked = true;
      }
    }
    if (!fit) {
      cut_back(grey_, grey);
      cut_back(rgb_, rgb);
      throw ListsShortError(std::move(short_ids), std::move(short_counts));
    }
    give_back(grey_);
    give_back(rgb_);
    layout_ = layout;
    stored_any_ = true;
    mirror_dirty_ = true;
    // Each map's ranges in its kind's arrays: placed one after another.
    StoreMark at[2] = {grey, rgb};
    for (size_t i = 0; i < n; ++i) {
      const int k = maps[i].rgb ? 1 : 0;
      const StoreMark end = mark_after(at[k], maps[i], stats[i], layout);
      ExecStoredMap m;
      m.live = true;
      m.map = maps[i];
      m.texel_begin = at[k].texels;
      m.node_begin = at[k].nodes;
      m.chunk_begin = at[k].chunks;
      m.texel_end = end.texels;
      m.node_end = end.nodes;
      m.chunk_end = end.chunks;
      ids[i] = slots_.add(m);
      at[k] = end;
    }
  }

  void free_map(MapId id) override {
    slots_.free(id);
    settle_store();
  }
  void free_maps(const std::vector<MapId>& ids) override {
    for (MapId id : ids) slots_.at(id, "free_maps");
    for (MapId id : ids) slots_.free(id);
    if (!ids.empty()) settle_store();
  }

  DsmMap map_header(MapId id) const override { return slots_.at(id, "map_header").map; }

  DsmStorage storage() const override {
    if constexpr (Ex::kHostMemory) {
      return exec_storage();
    } else {
      if (mirror_dirty_) {
        read_kind(grey_, mirror_.grey);
        read_kind(rgb_, mirror_.rgb);
        mirror_dirty_ = false;
      }
      return mirror_.view(exec_storage());
    }
  }
  uint64_t storage_epoch() const override { return epoch_; }
  // The bytes each compaction of the last kKeptEpochs left in place, the
  // least of those since `since`.
  void storage_kept_bytes(uint64_t since, uint64_t* kept) const override {
    for (int a = 0; a < kStorageArrays; ++a) kept[a] = ~uint64_t(0);
    if (since > epoch_ || epoch_ - since > kKeptEpochs) {
      for (int a = 0; a < kStorageArrays; ++a) kept[a] = 0;
      return;
    }
    for (uint64_t e = since + 1; e <= epoch_; ++e) {
      const EpochKept& k = kept_log_[e % kKeptEpochs];
      for (int a = 0; a < kStorageArrays; ++a) kept[a] = std::min(kept[a], k.epoch == e ? k.bytes[a] : 0);
    }
  }

  // Sizes without the mirror: over device memory the spans' data is null.
  DsmStorage storage_extent() const override {
    if constexpr (!Ex::kHostMemory) return storage_sizes(exec_storage());
    return exec_storage();
  }

  // In place only where the executor shares memory with the current GL
  // context (Ex::kGlInterop: CudaExec, with the context on its device).
  bool can_write_gl_maps() const override {
    if constexpr (Ex::kGlInterop)
      return ex_.gl_context_on_device();
    else
      return false;
  }

  void write_gl_maps(const GlMapWrite* writes, int count) override {
    if constexpr (Ex::kGlInterop) {
      const DsmStorage s = exec_storage();
      const void* src[kStorageArrays];
      uint64_t have[kStorageArrays];
      for (int a = 0; a < kStorageArrays; ++a) {
        const StorageBytes b = storage_bytes(s, StorageArray(a));
        src[a] = b.data;
        have[a] = b.bytes;
      }
      bool seen[kStorageArrays] = {};
      for (int i = 0; i < count; ++i) {
        const int a = int(writes[i].array);
        if (a < 0 || a >= kStorageArrays || seen[a])
          throw std::invalid_argument("write_gl_maps: unknown or repeated storage array");
        seen[a] = true;
        if (writes[i].offset + writes[i].bytes > have[a] ||
            writes[i].offset + writes[i].bytes > writes[i].gl_buffer_bytes)
          throw std::out_of_range("write_gl_maps: range past the end of storage array " + std::to_string(a) +
                                  " or of its GL buffer");
      }
      ex_.write_gl_buffers(writes, count, src);
    } else {
      ShadowBackend::write_gl_maps(writes, count);
    }
  }
  // The executor lets go of its registration of that buffer, if it has one.
  void gl_buffer_released(uint32_t name) override {
    if constexpr (Ex::kGlInterop)
      ex_.gl_buffer_released(name);
    else
      (void)name;
  }

  void camera_pass(const ShadowView& shadows, const CameraPassParams& params, ListsId lists, std::vector<float>& rgb,
                   WalkStats& walk) override {
    const FragmentLists frags = camera_lists(lists, params);
    const uint64_t n = uint64_t(params.view.width) * uint64_t(params.view.height);
    cam_rgb_.resize_discard(n * 3);
    shade(shadows, params, lists, frags, cam_rgb_.data(), walk);
    cam_rgb_.read(rgb);
  }

  // The same pass shading straight into the mapped GL buffer (CUDA-GL
  // interop): no image in executor memory, no read-back.
  void camera_pass_to_gl(const ShadowView& shadows, const CameraPassParams& params, ListsId lists, uint32_t gl_buffer,
                         uint64_t gl_buffer_bytes, uint64_t gl_buffer_generation, WalkStats& walk) override {
    if constexpr (Ex::kGlInterop) {
      const FragmentLists frags = camera_lists(lists, params);
      CDSM_CHECK(ex_.gl_context_on_device(),
                 std::string(name_) + " backend: camera_pass_to_gl needs the current GL context on its device");
      const uint64_t bytes = uint64_t(params.view.width) * uint64_t(params.view.height) * 3 * sizeof(float);
      if (gl_buffer_bytes < bytes)
        throw std::invalid_argument("camera_pass_to_gl: GL buffer of " + std::to_string(gl_buffer_bytes) +
                                    " bytes, the image needs " + std::to_string(bytes));
      ex_.with_gl_buffer(gl_buffer, gl_buffer_bytes, gl_buffer_generation,
                         [&](void* p) { shade(shadows, params, lists, frags, static_cast<float*>(p), walk); });
    } else {
      ShadowBackend::camera_pass_to_gl(shadows, params, lists, gl_buffer, gl_buffer_bytes, gl_buffer_generation, walk);
    }
  }

  MapStoreStats map_store() const override {
    MapStoreStats s;
    s.live_bytes = slots_.live_bytes;
    s.allocated_bytes = allocated_bytes();
    s.compactions = compactions_;
    s.compacted_bytes = compacted_bytes_;
    s.maps = slots_.live();
    lists_.add_stats(s);
    return s;
  }

  LightPassOptions& light_pass() override { return options_; }
  std::vector<StageTime> take_stage_times() override { return ex_.take_stage_times(); }

  ListsId cast_lists(const PinholeView& view, ObjectMask mask) override {
    CDSM_CHECK(scene_.host(), "cast_lists: no scene (update_scene first)");
    const bool any_media = mask_has_media(scene_.host()->view(), mask);
    frag_mask_.assign(mask.words.data(), mask.words.size());
    auto h = lists_.make(uint64_t(view.width) * uint64_t(view.height) + 1);
    cast_fragments_exec(ex_, scene_.view(), view, ObjectMask{frag_mask_.cspan()}, any_media, frag_counts_, h->offsets,
                        h->fragments, frag_total_);
    h->width = view.width;
    h->height = view.height;
    return lists_.hold(std::move(h));
  }

  // Every view counted and scanned, each total left in executor memory,
  // all totals read at once (one synchronization), then every view filled.
  void cast_views(const PinholeView* views, const ObjectMask* masks, size_t n, ListsId* ids) override {
    CDSM_CHECK(scene_.host(), "cast_lists: no scene (update_scene first)");
    if (n == 0) return;
    std::vector<uint32_t> words;  // the masks one after another, in one upload
    std::vector<size_t> at(n);
    for (size_t i = 0; i < n; ++i) {
      at[i] = words.size();
      words.insert(words.end(), masks[i].words.begin(), masks[i].words.end());
    }
    frag_mask_.assign(words.data(), words.size());
    frag_totals_.resize_discard(n);
    std::vector<std::unique_ptr<typename ExecListStore<Ex>::Held>> h(n);
    std::vector<exec::CastHeld> held(n);
    std::vector<uint8_t> media(n);
    const auto mask_of = [&](size_t i) { return ObjectMask{{frag_mask_.data() + at[i], masks[i].words.size()}}; };
    for (size_t i = 0; i < n; ++i) {
      media[i] = mask_has_media(scene_.host()->view(), masks[i]) ? 1 : 0;
      h[i] = lists_.make(uint64_t(views[i].width) * uint64_t(views[i].height) + 1);
      exec::cast_count_exec(ex_, scene_.view(), views[i], mask_of(i), media[i] != 0, frag_counts_, h[i]->offsets,
                            frag_total_, frag_totals_.data() + i, held[i]);
    }
    std::vector<unsigned long long> totals(n);
    ex_.download(totals.data(), frag_totals_.data(), n * sizeof(unsigned long long));  // the one read
    for (size_t i = 0; i < n; ++i) {
      if (totals[i] > 0xffffffffull) throw std::length_error("fragment lists exceed 2^32 fragments");
      h[i]->fragments.resize_discard(totals[i]);
      exec::cast_fill_exec(ex_, scene_.view(), views[i], mask_of(i), media[i] != 0, h[i]->offsets, h[i]->fragments,
                           held[i]);
      h[i]->width = views[i].width;
      h[i]->height = views[i].height;
    }
    lists_.hold_all(h, ids);
  }

  ListsId adopt_lists(FragmentBuffers&& lists) override { return lists_.adopt(std::move(lists)); }
  ListsId copy_lists(ListsId id) override { return lists_.copy(id); }
  void free_lists(ListsId id) override { lists_.free(id); }
  uint64_t lists_fragments(ListsId id) const override { return checked_lists(id, "lists_fragments").count(); }
  uint64_t lists_bytes(ListsId id) const override { return lists_.bytes(lists_.held(id, "lists_bytes").lists()); }

  // Each batch's offsets buffer and each filled pool mapped (read-only) once:
  // the bands of offsets re-based on the executor into the views' offsets,
  // the pieces copied into their fragments, which grow as pieces come.
  // Nothing crosses the host but the counts.
  void lists_from_gl(size_t views, const uint64_t* slots, const GlRasterize& rasterize, ListsId* ids) override {
    if constexpr (Ex::kGlInterop) {
      CDSM_CHECK(ex_.gl_context_on_device(),
                 std::string(name_) + " backend: lists_from_gl needs the current GL context on its device");
      std::vector<std::unique_ptr<typename ExecListStore<Ex>::Held>> h(views);
      for (auto& l : h) l = lists_.make();
      std::vector<FragmentBuffers> outs(views);
      std::vector<uint8_t> sized(views, 0);
      rasterize(
          [&](const GlPiece* pieces, size_t n, uint32_t gl_buffer, uint64_t gl_buffer_bytes, uint64_t generation) {
            for (size_t p = 0; p < n; ++p) {
              const GlPiece& q = pieces[p];
              CDSM_CHECK(q.view < views && q.first == h[q.view]->fragments.size(),
                         "lists_from_gl: a piece out of order");
              if ((q.at + q.count) * sizeof(Fragment) > gl_buffer_bytes)
                throw std::out_of_range("lists_from_gl: " + std::to_string(q.count) + " fragments at " +
                                        std::to_string(q.at) + " of a GL buffer of " + std::to_string(gl_buffer_bytes) +
                                        " bytes");
              h[q.view]->fragments.resize(q.first + q.count);
            }
            ex_.with_gl_source(0, gl_buffer, gl_buffer_bytes, generation, [&](const void* src) {
              for (size_t p = 0; p < n; ++p)
                ex_.copy(h[pieces[p].view]->fragments.data() + pieces[p].first,
                         static_cast<const Fragment*>(src) + pieces[p].at, pieces[p].count * sizeof(Fragment));
            });
          },
          [&](const GlOffsets* bands, size_t n, uint32_t gl_buffer, uint64_t gl_buffer_bytes, uint64_t generation) {
            for (size_t b = 0; b < n; ++b) {
              const GlOffsets& o = bands[b];
              CDSM_CHECK(o.view < views, "lists_from_gl: offsets of an unknown view");
              const uint64_t pixels = uint64_t(outs[o.view].width) * uint64_t(outs[o.view].height);
              if (!sized[o.view]) {
                h[o.view]->offsets.resize_discard(pixels + 1);
                sized[o.view] = 1;
              }
              if (o.first + o.count > pixels || (o.at + o.count + 1) * sizeof(uint32_t) > gl_buffer_bytes)
                throw std::out_of_range("lists_from_gl: offsets [" + std::to_string(o.first) + ", " +
                                        std::to_string(o.first + o.count) + "] of a view of " + std::to_string(pixels) +
                                        " pixels");
            }
            ex_.with_gl_source(1, gl_buffer, gl_buffer_bytes, generation, [&](const void* src) {
              for (size_t b = 0; b < n; ++b)
                exec::shifted_copy(ex_, static_cast<const uint32_t*>(src) + bands[b].at,
                                   h[bands[b].view]->offsets.data() + bands[b].first, bands[b].count + 1,
                                   bands[b].shift);
            });
          },
          outs.data());
      for (size_t v = 0; v < views; ++v) {
        const FragmentBuffers& out = outs[v];
        CDSM_CHECK(sized[v] && out.offsets.size() == 1 && out.offsets[0] == h[v]->fragments.size(),
                   "lists_from_gl: view " + std::to_string(v) + "'s offsets or fragments did not all come");
        ExecListStore<Ex>::check(out.width, out.height, h[v]->offsets.size(), h[v]->fragments.size(), "lists_from_gl");
        h[v]->width = out.width;
        h[v]->height = out.height;
        if (slots && slots[v] != 0) gl_guess_[slots[v]] = h[v]->fragments.size();  // the slot's next guess
      }
      lists_.hold_all(h, ids);
    } else {
      ShadowBackend::lists_from_gl(views, slots, rasterize, ids);
    }
  }

  void read_lists(ListsId id, FragmentBuffers& out) override {
    checked_lists(id, "read_lists");
    lists_.read(id, out);
  }

  // Each batch's offsets buffer and pool mapped (read-only) once, each
  // view's part re-based and copied on the executor (exec/scan.h
  // take_gl_part) into lists of its slot's last count and a quarter more:
  // nothing read, nothing sent.
  bool lists_from_gl_unchecked(size_t views, const uint64_t* slots, const GlRasterizeUnchecked& rasterize,
                               ListsId* ids) override {
    if constexpr (Ex::kGlInterop) {
      CDSM_CHECK(ex_.gl_context_on_device(),
                 std::string(name_) + " backend: lists_from_gl_unchecked needs the current GL context on its device");
      std::vector<uint64_t> capacity(views);
      uint64_t pool = 0;
      for (size_t v = 0; v < views; ++v) {
        const auto g = slots[v] != 0 ? gl_guess_.find(slots[v]) : gl_guess_.end();
        if (g == gl_guess_.end()) return false;  // no count of this slot yet: made checked once
        capacity[v] = g->second + g->second / 4 + 256;
        pool += capacity[v];
      }
      std::vector<std::unique_ptr<typename ExecListStore<Ex>::Held>> h(views);
      for (size_t v = 0; v < views; ++v) {
        h[v] = lists_.make(0, capacity[v]);
        h[v]->fragments.resize_discard(capacity[v]);
        h[v]->status.resize_discard(2);
        ex_.fill_zero(h[v]->status.data(), 2 * sizeof(unsigned long long));
        h[v]->checked = false;
        h[v]->guess_key = slots[v];
      }
      std::vector<FragmentBuffers> outs(views);
      const bool made = rasterize(
          pool,
          [&](const GlBatch& b) {
            for (size_t p = 0; p < b.n; ++p) {
              const GlPart& q = b.parts[p];
              CDSM_CHECK(q.view < views, "lists_from_gl_unchecked: a part of an unknown view");
              const uint64_t pixels = uint64_t(outs[q.view].width) * uint64_t(outs[q.view].height);
              if (h[q.view]->offsets.size() != pixels + 1) h[q.view]->offsets.resize_discard(pixels + 1);
              if (q.first + q.count > pixels || (q.at + q.count + 1) * sizeof(uint32_t) > b.offsets_bytes ||
                  (b.total_at + 2) * sizeof(uint32_t) > b.offsets_bytes ||
                  b.pool_fragments * sizeof(Fragment) > b.pool_bytes)
                throw std::out_of_range("lists_from_gl_unchecked: part [" + std::to_string(q.first) + ", " +
                                        std::to_string(q.first + q.count) + ") of a view of " + std::to_string(pixels) +
                                        " pixels, or past its GL buffers");
            }
            ex_.with_gl_source(1, b.offsets_buffer, b.offsets_bytes, b.offsets_generation, [&](const void* offs) {
              ex_.with_gl_source(0, b.pool_buffer, b.pool_bytes, b.pool_generation, [&](const void* frags) {
                for (size_t p = 0; p < b.n; ++p) {
                  const GlPart& q = b.parts[p];
                  auto& l = *h[q.view];
                  exec::take_gl_part(ex_, static_cast<const uint32_t*>(offs), q.at, q.count, b.total_at,
                                     static_cast<const Fragment*>(frags), b.pool_fragments, l.offsets.data(), q.first,
                                     l.fragments.data(), l.fragments.size(), l.status.data());
                }
              });
            });
          },
          outs.data());
      if (!made) {
        for (auto& l : h) lists_.give_back(std::move(l));
        return false;
      }
      for (size_t v = 0; v < views; ++v) {
        const uint64_t pixels = uint64_t(outs[v].width) * uint64_t(outs[v].height);
        CDSM_CHECK(h[v]->offsets.size() == pixels + 1,
                   "lists_from_gl_unchecked: view " + std::to_string(v) + "'s offsets did not all come");
        h[v]->width = outs[v].width;
        h[v]->height = outs[v].height;
      }
      lists_.hold_all(h, ids);
      return true;
    } else {
      (void)views, (void)slots, (void)rasterize, (void)ids;
      return false;
    }
  }

  void read_map(MapId id, uint32_t cap, std::vector<uint32_t>& counts, std::vector<DsmNode>& nodes) override {
    const DsmMap m = map_header(id);
    if (m.rgb) throw std::invalid_argument("read_map: grey maps only");
    read_map_exec(ex_, exec_storage(), m, cap, counts, nodes);
  }

 private:
  // Lists `id`, their count read from the executor (a synchronization) if
  // still unchecked; throws ListsShortError when they did not fit.
  typename ExecListStore<Ex>::Held& checked_lists(ListsId id, const char* what) const {
    auto& held = lists_.held(id, what);
    if (held.checked) return held;
    std::vector<unsigned long long> st;
    held.status.read(st);
    gl_guess_[held.guess_key] = st[0];
    if (st[1] != 0 || st[0] > held.fragments.size()) throw ListsShortError({id}, {st[0]});
    held.fragments.resize(st[0]);
    held.checked = true;
    return held;
  }

  // Lists `id`, which must cover the camera view (unchecked ones are
  // checked by the pass's read: shade).
  FragmentLists camera_lists(ListsId id, const CameraPassParams& params) const {
    const FragmentLists l = lists_.held(id, "camera_pass").lists();
    if (l.width != params.view.width || l.height != params.view.height)
      throw std::invalid_argument("camera_pass: fragment lists of " + std::to_string(l.width) + "x" +
                                  std::to_string(l.height) + " pixels for a view of " +
                                  std::to_string(params.view.width) + "x" + std::to_string(params.view.height));
    return l;
  }

  // The camera pass into `out` (executor memory: 3 floats per pixel) over
  // lists `id` (frags): its walk counters read once, with the lists' status
  // when they are unchecked (ListsShortError when they did not fit: the
  // image is then not the lists', and they are to be made again).
  void shade(const ShadowView& shadows, const CameraPassParams& params, ListsId id, FragmentLists frags, float* out,
             WalkStats& walk) {
    auto& held = lists_.held(id, "camera_pass");
    cam_walk_.resize_discard(8);  // 4 walk counters, then the lists' 2 status words
    static_assert(sizeof(unsigned long long) == 2 * sizeof(uint32_t), "status words after the walk counters");
    ex_.fill_zero(cam_walk_.data(), cam_walk_.bytes());
    // The pass's small inputs in executor memory: over host memory, as they
    // are (the lists are the executor's already).
    ShadowView sv = shadows;
    sv.storage = exec_storage();
    CameraPassParams cp = params;
    if constexpr (!Ex::kHostMemory) {
      cam_inside_.assign(params.inside.data(), params.inside.size());
      cam_lights_.assign(shadows.lights.data(), shadows.lights.size());
      cam_maps_.assign(shadows.maps.data(), shadows.maps.size());
      sv.lights = cam_lights_.cspan();
      sv.maps = cam_maps_.cspan();
      cp.inside = cam_inside_.cspan();
    }
    shade_pixels(ex_, scene_view(), sv, cp, frags, out, cam_walk_.data());
    if (!held.checked) ex_.copy(cam_walk_.data() + 4, held.status.data(), 2 * sizeof(unsigned long long));
    uint32_t w[8];
    ex_.download(w, cam_walk_.data(), held.checked ? 4 * sizeof(uint32_t) : sizeof w);
    walk.enclosing_overflow += w[0];
    walk.match_overflow += w[1];
    walk.unmatched += w[2];
    walk.march_lengthened += w[3];
    if (!held.checked) {
      unsigned long long st[2];
      std::memcpy(st, w + 4, sizeof st);
      gl_guess_[held.guess_key] = st[0];
      if (st[1] != 0) throw ListsShortError({id}, {st[0]});
      held.fragments.resize(st[0]);
      held.checked = true;
    }
  }

  static bool same_layout(const DsmLayoutParams& a, const DsmLayoutParams& b) {
    if (a.layout != b.layout) return false;
    if (a.layout == DsmLayout::Fixed) return a.fixed_layers == b.fixed_layers;
    if (a.layout == DsmLayout::Chunked) return a.chunk_nodes == b.chunk_nodes;
    return true;
  }
  static void check_layout(const DsmLayoutParams& p) {
    if (uint32_t(p.layout) > uint32_t(DsmLayout::Chunked))
      throw std::invalid_argument("build_map: unknown DSM layout " + std::to_string(uint32_t(p.layout)));
    if (p.layout == DsmLayout::Fixed && (p.fixed_layers < 2 || p.fixed_layers > 4096))
      throw std::invalid_argument("build_map: fixed_layers must be within [2, 4096]");
    if (p.layout == DsmLayout::Chunked && (p.chunk_nodes < 1 || p.chunk_nodes > 4096))
      throw std::invalid_argument("build_map: chunk_nodes must be within [1, 4096]");
  }

  // Where a kind's arrays end: what a failed build cuts them back to (their
  // contents before kept: a grown array copied them, and every earlier map
  // reads as before), and where a placed map's ranges begin.
  struct StoreMark {
    uint64_t texels = 0, nodes = 0, chunks = 0, tags = 0, pyramid = 0, texel_count = 0;
  };
  template <class Node>
  static StoreMark mark(const KindStore<Node, Ex>& k) {
    return {k.texels.size(), k.nodes.size(), k.chunks.size(), k.tags.size(), k.pyramid.size(), k.texel_count};
  }
  template <class Node>
  static void cut_back(KindStore<Node, Ex>& k, const StoreMark& m) {
    k.texels.resize(m.texels);
    k.nodes.resize(m.nodes);
    k.chunks.resize(m.chunks);
    k.tags.resize(m.tags);
    k.pyramid.resize(m.pyramid);
    k.texel_count = m.texel_count;
  }
  // The end of a map placed at `at` in `k` (its header and stats): packed
  // and chunked keep a header per texel and their nodes or chunk slots,
  // fixed L slots per texel.
  static StoreMark mark_after(StoreMark at, const DsmMap& map, const DsmBuildStats& st, const DsmLayoutParams& layout) {
    const uint64_t texels = uint64_t(map.res) * uint64_t(map.view.height);
    switch (layout.layout) {
      case DsmLayout::Fixed: at.nodes += texels * uint64_t(layout.fixed_layers); break;
      case DsmLayout::Chunked:
        at.texels += texels;
        at.chunks += st.chunks * uint64_t(layout.chunk_nodes);
        break;
      default: at.texels += texels; at.nodes += st.nodes;
    }
    at.texel_count += texels;
    return at;
  }

  SceneView scene_view() const { return scene_.view(); }

  DsmStorage exec_storage() const {
    DsmStorage s;
    s.grey = grey_.arrays();
    s.rgb = rgb_.arrays();
    s.layout = layout_.layout;
    s.layers = layout_.layout == DsmLayout::Fixed ? uint32_t(layout_.fixed_layers) : 0u;
    return s;
  }

  uint64_t allocated_bytes() const { return allocated_bytes(grey_) + allocated_bytes(rgb_); }
  template <class Node>
  static uint64_t allocated_bytes(const KindStore<Node, Ex>& k) {
    return k.texels.capacity() * sizeof(TexelRange) + k.nodes.capacity() * sizeof(Node) +
           k.chunks.capacity() * sizeof(typename KindStore<Node, Ex>::Chunk) + k.tags.capacity() * sizeof(SurfaceTag) +
           k.pyramid.capacity() * sizeof(float);
  }

  // The host mirror of one kind's arrays (a download each).
  template <class Node>
  static void read_kind(const KindStore<Node, Ex>& k, HostArrays<Node::kChannels>& out) {
    k.texels.read(out.texels);
    k.nodes.read(out.nodes);
    k.chunks.read(out.chunks);
    k.tags.read(out.tags);
    k.pyramid.read(out.pyramid);
  }

  // Emptied, capacity kept: when every map was replaced (the usual rebuild
  // of a one-map light) the next builds reuse the memory instead of
  // allocating it again (give_back trims what the next builds leave unused).
  template <class Node>
  static void empty(KindStore<Node, Ex>& k) {
    k.texels.resize_discard(0);
    k.nodes.resize_discard(0);
    k.chunks.resize_discard(0);
    k.tags.resize_discard(0);
    k.pyramid.resize_discard(0);
    k.texel_count = 0;
  }

  // After maps were freed: empty when none is left, else compacted when
  // holes pass a quarter of it.
  void settle_store() {
    if (slots_.live() == 0)
      reset_store();
    else if (slots_.needs_compaction())
      compact();
  }

  void reset_store() {
    empty(grey_);
    empty(rgb_);
    slots_.clear();
    stored_any_ = false;
    mirror_dirty_ = true;
    ++epoch_;
    kept_log_[epoch_ % kKeptEpochs] = {epoch_, {}};  // nothing kept
  }

  // The live maps moved down over the holes inside their arrays, in the
  // order they lie there, each range through a bounce buffer (kept with its
  // capacity), offsets and links re-based: the arrays keep their capacity
  // (a steady frame that compacts allocates nothing; give_back trims them
  // after the frame's builds). The bounce is allocated
  // before anything moves (a failed allocation leaves the store as it
  // was); a failed copy or launch part-way empties the store (its maps are
  // lost, the error goes on).
  void compact() {
    std::vector<ExecStoredMap> maps = slots_.maps;
    uint64_t bounce = 0;
    for (const ExecStoredMap& m : maps)
      if (m.live)
        bounce = std::max(bounce, m.map.rgb ? move_bounce_bytes<DsmNodeRgb>(m, rgb_.pyramid.size() > 0)
                                            : move_bounce_bytes<DsmNode>(m, grey_.pyramid.size() > 0));
    if (bounce_.capacity() < bounce) bounce_.resize_discard(bounce);
    uint64_t bytes = 0;
    EpochKept kept{epoch_ + 1, {}};
    try {
      compact_kind(grey_, false, maps, bytes, kept.bytes);
      compact_kind(rgb_, true, maps, bytes, kept.bytes);
    } catch (...) {
      reset_store();
      throw;
    }
    slots_.maps = std::move(maps);
    compacted_bytes_ += bytes;
    slots_.compacted();
    ++compactions_;
    ++epoch_;
    kept_log_[epoch_ % kKeptEpochs] = kept;
    mirror_dirty_ = true;
  }

  // Moves kind `k`'s maps down; kept[] (per storage array) gets the bytes
  // before the first that moved, or before the arrays' new ends when none did.
  template <class Node>
  void compact_kind(KindStore<Node, Ex>& k, bool rgb, std::vector<ExecStoredMap>& maps, uint64_t& bytes,
                    uint64_t* kept) {
    std::vector<size_t> order;
    for (size_t i = 0; i < maps.size(); ++i)
      if (maps[i].live && (maps[i].map.rgb != 0u) == rgb) order.push_back(i);
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      const ExecStoredMap &x = maps[a], &y = maps[b];
      return std::tie(x.texel_begin, x.node_begin, x.chunk_begin) <
             std::tie(y.texel_begin, y.node_begin, y.chunk_begin);
    });
    const bool chunked = layout_.layout == DsmLayout::Chunked;
    using Chunk = typename NodeKind<Node>::Chunk;
    const int base = rgb ? int(StorageArray::RgbTexels) : int(StorageArray::Texels);
    const int tags = rgb ? int(StorageArray::RgbTags) : int(StorageArray::Tags);
    // Bytes [0, kept) of each of the kind's arrays untouched: up to where
    // the first moved map now starts, and never past the arrays' new ends
    // (maps built next are appended there).
    const auto keep_below = [&](uint64_t texels, uint64_t nodes, uint64_t chunks) {
      kept[base] = std::min<uint64_t>(kept[base], texels * sizeof(TexelRange));
      kept[base + 1] = std::min<uint64_t>(kept[base + 1], nodes * sizeof(Node));
      kept[base + 2] = std::min<uint64_t>(kept[base + 2], chunks * sizeof(Chunk));
      kept[tags] = std::min<uint64_t>(kept[tags], (chunked ? chunks : nodes) * sizeof(SurfaceTag));
    };
    for (int a : {base, base + 1, base + 2, tags}) kept[a] = ~uint64_t(0);
    StoreCursor at;
    for (size_t i : order) {
      const ExecStoredMap before = maps[i];
      maps[i] = move_map_down_exec(ex_, before, layout_.layout, k, at, bounce_);
      if (maps[i].node_begin != before.node_begin || maps[i].texel_begin != before.texel_begin ||
          maps[i].chunk_begin != before.chunk_begin) {
        bytes += maps[i].bytes();
        keep_below(maps[i].texel_begin, maps[i].node_begin, maps[i].chunk_begin);
      }
    }
    keep_below(at.texels, at.nodes, at.chunks);
    k.texels.resize(at.texels);
    k.nodes.resize(at.nodes);
    k.chunks.resize(at.chunks);
    k.tags.resize(chunked ? at.chunks : at.nodes);
    k.texel_count = at.texel_count;
    if (k.pyramid.size() > 0) k.pyramid.resize(at.texel_count > 0 ? pyramid_array_size(at.texel_count) : 0);
  }

  // Capacity past three times what a kind's arrays hold is given back,
  // once a frame's maps are built (not when compaction empties them in the
  // middle of a frame that builds them again); an emptied kind keeps its
  // arrays, as an emptied store does.
  template <class Node>
  static void give_back(KindStore<Node, Ex>& k) {
    const auto trim = [](auto& a) {
      if (a.size() == 0 || a.capacity() <= 3 * a.size()) return;
      try {
        a.shrink_to_fit();
      } catch (...) {  // (the capacity stays: nothing is lost)
      }
    };
    trim(k.texels);
    trim(k.nodes);
    trim(k.chunks);
    trim(k.tags);
    trim(k.pyramid);
  }

  const char* name_;
  Ex ex_;  // first: every array below holds a pointer to it
  ExecSceneStore<Ex> scene_;
  ExecListStore<Ex> lists_;
  // Per slot (ShadowBackend::lists_from_gl), the count of its last lists:
  // the capacity lists_from_gl_unchecked guesses (updated by every count
  // read).
  mutable std::map<uint64_t, uint64_t> gl_guess_;
  KindStore<DsmNode, Ex> grey_;
  KindStore<DsmNodeRgb, Ex> rgb_;
  LightPassScratch<Ex> scratch_;
  ExecArray<uint32_t, Ex> cam_inside_;
  ExecArray<LightData, Ex> cam_lights_;
  ExecArray<DsmMap, Ex> cam_maps_;
  ExecArray<float, Ex> cam_rgb_;
  ExecArray<uint32_t, Ex> cam_walk_;
  ExecArray<uint32_t, Ex> frag_counts_;
  ExecArray<unsigned long long, Ex> frag_total_;
  ExecArray<unsigned long long, Ex> frag_totals_;  // cast_views: each view's total, read together
  ExecArray<uint32_t, Ex> frag_mask_;
  ExecArray<unsigned char, Ex> bounce_;  // compaction's moves (compact)

  ExecCounters taken_;  // the executor's counters at the last take_counters
  LightPassOptions options_;
  DsmLayoutParams layout_;
  bool stored_any_ = false;
  MapSlots<ExecStoredMap> slots_;
  uint64_t compactions_ = 0, compacted_bytes_ = 0;
  uint64_t epoch_ = 1;
  // What each of the last kKeptEpochs epochs kept of the storage arrays
  // (storage_kept_bytes): slot e % kKeptEpochs holds epoch e's.
  static constexpr uint64_t kKeptEpochs = 8;
  struct EpochKept {
    uint64_t epoch = 0;
    uint64_t bytes[kStorageArrays] = {};
  };
  EpochKept kept_log_[kKeptEpochs];
  // storage() over device memory: a host copy of the store's arrays.
  mutable HostStorage mirror_;
  mutable bool mirror_dirty_ = true;
};

}  // namespace cdsm::exec
