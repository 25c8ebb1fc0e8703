// The map cache (frame.h, steps 2 and 3 of a frame): the planned maps
// matched against the cache by key, the missing ones built, replaced ones
// freed or kept a frame; and the lookup over a frame's maps.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <unordered_map>

#include "cdsm/fields.h"
#include "cdsm/method_params.h"
#include "frame_steps.h"
#include "stopwatch.h"

namespace cdsm {

void ShadowFrame::refresh_headers() {
  headers.clear();
  for (MapId id : maps) headers.push_back(backend->map_header(id));
}

ShadowView ShadowFrame::view(const ShadowSettings& s, bool with_storage) const {
  ShadowView v;
  v.lights = {setup.lights.data(), setup.lights.size()};
  v.maps = {headers.data(), headers.size()};
  v.storage = backend && with_storage ? backend->storage() : DsmStorage{};
  set_lookup(v, s);
  return v;
}

void set_lookup(ShadowView& v, const ShadowSettings& s) {
  v.filtering = s.filtering;
  v.penumbra = s.penumbra;
  v.penumbra_taps = s.penumbra_taps;
  v.bias_constant = s.bias_constant;
  v.bias_slope = s.bias_slope;
  v.receiver = s.receiver;
}

namespace {

using Hasher = Fnv1a;

// Whether light l's maps carry blocker pyramids (hd/blocker_pyramid.h):
// its estimated penumbrae search them; a light without a size pays nothing.
bool wants_pyramid(const LightData& l, const ShadowSettings& s) {
  return l.size > 0.0f && s.penumbra == Penumbra::Estimated;
}

uint64_t hash_light(const LightData& l, const ShadowSettings& s) {
  Hasher h;
  h.pod(l.position);
  h.pod(l.type);
  h.pod(l.direction);
  h.pod(l.cos_outer);
  h.pod(wants_pyramid(l, s));
  return h.h;
}

std::vector<uint32_t> mask_words(const std::vector<uint32_t>& members, size_t object_count) {
  std::vector<uint32_t> w((object_count + 31) / 32, 0u);
  for (uint32_t o : members) w[o >> 5] |= 1u << (o & 31u);
  return w;
}

uint64_t settings_hash(const ShadowSettings& s) {
  Hasher h;
  hash_fields(h, s, kAffectsMaps);
  return h.h;
}

// What a map is built from: its view, its members' identities and content
// generations, the map settings, whether it has a blocker pyramid.
uint64_t map_key(const MapPlan& plan, const FrameInputs& in, uint64_t settings, bool pyramid) {
  Hasher h;
  h.pod(plan.view);
  h.pod(pyramid);
  for (uint32_t o : plan.members) {
    h.pod(in.object_ids[o]);
    h.pod(in.object_generations[o]);
  }
  h.pod(settings);
  return h.h;
}

// What a map's fragment lists are produced from: its view, its members'
// identities and generations, everything else the producer reads.
uint64_t fragment_key(const MapPlan& plan, const FrameInputs& in) {
  Hasher h;
  h.pod(plan.view);
  for (uint32_t o : plan.members) {
    h.pod(in.object_ids[o]);
    h.pod(in.object_generations[o]);
  }
  h.pod(in.geometry_epoch);
  return h.h;
}

RebuildReason rebuild_reason(const MapCache::Entry* before, const MapCache::Entry& now) {
  if (!before) return RebuildReason::New;
  if (before->settings_hash != now.settings_hash) return RebuildReason::Settings;
  if (before->light_hash != now.light_hash) return RebuildReason::Light;
  if (before->member_ids != now.member_ids) return RebuildReason::Members;
  if (std::memcmp(&before->view, &now.view, sizeof(PinholeView)) != 0) return RebuildReason::Frustum;
  return RebuildReason::Content;
}

}  // namespace

void MapCache::clear(ShadowBackend& backend) {
  for (const Entry& e : entries) backend.free_map(e.id);
  for (MapId id : retired) backend.free_map(id);
  for (const KeptFragments& k : fragments) backend.free_lists(k.lists);
  entries.clear();
  retired.clear();
  lights.clear();
  fragments.clear();
}

namespace {

// A frame's missing maps are built together, their lists made first: up to
// this many bytes of lists at once, then the group is built (one read of
// its counters) and its lists freed.
constexpr uint64_t kBuildGroupListBytes = uint64_t(256) << 20;
// Views whose lists are made together: up to this many pixels (the GL
// rasterizer's counters and offsets of 4 cube faces at 2048^2).
constexpr uint64_t kProduceBatchPixels = uint64_t(1) << 24;

// The planned maps against the cache: per plan its entry (reused by key, or
// described for building), and per cache entry whether a plan took it.
struct CacheMatch {
  std::vector<MapCache::Entry> next;  // per planned map
  std::vector<uint8_t> found;         // per planned map: its key was in the cache
  std::vector<uint8_t> taken;         // per cache entry: a planned map reuses it
  size_t missing() const { return found.size() - size_t(std::count(found.begin(), found.end(), 1)); }
};

// Step 2: reuse by key (each cache entry once, the first of equal keys
// first), and the reason each unmatched map is built — against the map its
// light had in that place. O(maps + entries).
CacheMatch match_cache(const FrameInputs& in, const MapCache& cache, ShadowFrame& frame) {
  const uint64_t settings = settings_hash(in.settings);
  const size_t n = frame.setup.maps.size();
  CacheMatch m;
  m.next.resize(n);
  m.found.assign(n, 0);
  m.taken.assign(cache.entries.size(), 0);
  std::unordered_map<uint64_t, std::vector<size_t>> by_key;  // cache indices, in cache order
  for (size_t c = cache.entries.size(); c-- > 0;) by_key[cache.entries[c].key].push_back(c);
  for (size_t k = 0; k < n; ++k) {
    const MapPlan& plan = frame.setup.maps[k];
    const LightData& ld = frame.setup.lights[plan.light];
    MapCache::Entry& e = m.next[k];
    e.key = map_key(plan, in, settings, wants_pyramid(ld, in.settings));
    e.light_id = in.light_ids[plan.light];
    e.slot = uint32_t(k - ld.first_map);
    e.light_hash = hash_light(ld, in.settings);
    e.settings_hash = settings;
    e.view = plan.view;
    for (uint32_t o : plan.members) e.member_ids.push_back(in.object_ids[o]);
    auto it = by_key.find(e.key);
    if (it == by_key.end() || it->second.empty()) continue;
    const size_t c = it->second.back();  // the earliest untaken entry
    it->second.pop_back();
    m.taken[c] = 1;
    m.found[k] = 1;
    e.id = cache.entries[c].id;
    e.stats = cache.entries[c].stats;
  }
  std::map<std::pair<uint64_t, uint32_t>, const MapCache::Entry*> by_place;  // (light, slot) -> its last entry
  for (const MapCache::Entry& old : cache.entries) by_place[{old.light_id, old.slot}] = &old;
  for (size_t k = 0; k < n; ++k) {
    if (m.found[k]) continue;
    auto it = by_place.find({m.next[k].light_id, m.next[k].slot});
    const MapCache::Entry* before = it == by_place.end() ? nullptr : it->second;
    frame.rebuilds.push_back({frame.setup.maps[k].light, m.next[k].slot, rebuild_reason(before, m.next[k])});
  }
  return m;
}

// Step 3: releases the maps no plan took (or retires them for the popping
// probe), builds the missing ones (from kept fragment lists where their key
// matches), and updates the cache. A failure (a build refused by the memory
// budget, an allocation) leaves nothing of this frame: the maps it built
// are freed, and so is the cache (its maps and lists), so the backend's
// store holds no map nothing refers to and the next frame builds afresh.
void build_missing(const FrameInputs& in, const FragmentProducer& produce, ShadowBackend& backend, MapCache& cache,
                   CacheMatch& m, ShadowFrame& frame) {
  const SceneBuffers& sb = *in.scene;
  SceneView sv = sb.view();
  const ShadowSettings& s = in.settings;
  const size_t n = frame.setup.maps.size();
  std::vector<MapCache::Entry>& next = m.next;
  // Replaced maps are released before new ones are built (a layout change
  // needs an empty store), or kept one frame for the popping probe.
  const DsmLayoutParams layout = dsm_layout_params(s);
  const bool layout_changed = layout.layout != cache.layout.layout ||
                              layout.fixed_layers != cache.layout.fixed_layers ||
                              layout.chunk_nodes != cache.layout.chunk_nodes;
  frame.previous_kept = in.keep_previous && !layout_changed;
  std::vector<uint8_t> released(cache.entries.size(), 0);  // freed or retired below
  std::vector<uint8_t> built(n, 0);
  std::vector<MapCache::KeptFragments> kept;  // the next frame's MapCache::fragments
  std::vector<ListsId> reading;               // lists a build is reading
  auto abandon = [&] {
    auto quietly = [](auto f) {
      try {
        f();
      } catch (...) {  // freeing a map may compact the store, whose failure leaves holes only
      }
    };
    for (size_t k = 0; k < n; ++k)
      if (built[k]) quietly([&] { backend.free_map(next[k].id); });
    for (size_t c = 0; c < cache.entries.size(); ++c)
      if (!released[c]) quietly([&] { backend.free_map(cache.entries[c].id); });
    for (MapId id : cache.retired) quietly([&] { backend.free_map(id); });
    for (const MapCache::KeptFragments& c : kept) quietly([&] { backend.free_lists(c.lists); });
    for (const MapCache::KeptFragments& c : cache.fragments)
      if (!c.taken) quietly([&] { backend.free_lists(c.lists); });
    for (ListsId id : reading) quietly([&] { backend.free_lists(id); });
    cache.entries.clear();
    cache.retired.clear();
    cache.lights.clear();
    cache.fragments.clear();
    frame = ShadowFrame{};
  };
  try {
    std::vector<MapId> replaced;
    for (size_t c = 0; c < cache.entries.size(); ++c) {
      if (m.taken[c]) continue;
      released[c] = 1;
      if (frame.previous_kept)
        cache.retired.push_back(cache.entries[c].id);
      else
        replaced.push_back(cache.entries[c].id);
    }
    backend.free_maps(replaced);  // one decision about the store for all of them
    frame.freed += uint32_t(replaced.size());
    if (in.maps_built) in.maps_built->store(0);
    if (in.maps_to_build) in.maps_to_build->store(uint32_t(m.missing()));
    // The missing maps' lists are made first, then built together (one read
    // of the light pass's counters for all of them: exec/light_pass.h), in
    // groups whose lists stay under kBuildGroupListBytes.
    std::vector<ShadowBackend::MapBuild> group;
    std::vector<size_t> group_maps;              // their k
    std::vector<ObjectMask> group_masks;         // their objects
    std::vector<size_t> group_kept;              // their lists' copy in `kept`, or none (SIZE_MAX)
    std::vector<std::vector<uint32_t>> insides;  // each build's objects containing its light
    uint64_t group_bytes = 0;
    const auto flush = [&] {
      if (group.empty()) return;
      const auto t0 = Clock::now();
      std::vector<MapId> ids(group.size());
      std::vector<DsmBuildStats> stats(group.size());
      try {
        backend.build_maps(group.data(), group.size(), layout, ids.data(), stats.data());
      } catch (const ListsShortError& e) {
        // Lists made into guessed capacities (ShadowBackend::
        // lists_from_gl_unchecked) that did not fit: made again, counted
        // on the host (and their kept copies with them), then built again.
        for (const ListsId bad : e.lists) {
          const size_t g = size_t(std::find_if(group.begin(), group.end(),
                                               [&](const ShadowBackend::MapBuild& b) { return b.lists == bad; }) -
                                  group.begin());
          CDSM_CHECK(g < group.size(), "build_maps: short lists that are not the group's");
          const ListsRequest again{frame.setup.maps[group_maps[g]].view, group_masks[g], false,
                                   uint64_t(group_maps[g]) + 1};
          ListsId fresh = 0;
          produce(backend, &again, 1, &fresh);
          reading.push_back(fresh);
          reading.erase(std::find(reading.begin(), reading.end(), bad));
          backend.free_lists(bad);
          group[g].lists = fresh;
          if (group_kept[g] != SIZE_MAX) {
            backend.free_lists(kept[group_kept[g]].lists);
            kept[group_kept[g]].lists = backend.copy_lists(fresh);
          }
          ++frame.fragment_lists_redone;
        }
        backend.build_maps(group.data(), group.size(), layout, ids.data(), stats.data());
      }
      // (the counts of lists made unchecked came with the build's read)
      for (const ShadowBackend::MapBuild& g : group) frame.fragments += backend.lists_fragments(g.lists);
      for (size_t i = 0; i < group.size(); ++i) {
        next[group_maps[i]].id = ids[i];
        next[group_maps[i]].stats = stats[i];
        built[group_maps[i]] = 1;
      }
      for (const ShadowBackend::MapBuild& g : group) {
        reading.erase(std::find(reading.begin(), reading.end(), g.lists));
        backend.free_lists(g.lists);
      }
      frame.build_ms += ms_since(t0);
      if (in.maps_built) in.maps_built->fetch_add(uint32_t(group.size()));
      group.clear();
      group_maps.clear();
      group_masks.clear();
      group_kept.clear();
      insides.clear();
      group_bytes = 0;
    };
    // The maps to build, and the kept lists each planned map can take (kept
    // again for the next frame below, where they are free again).
    std::vector<size_t> todo;                          // k of the maps to build
    std::vector<MapCache::KeptFragments*> from_cache;  // per todo: its kept lists, or null
    for (size_t k = 0; k < n; ++k) {
      MapCache::KeptFragments* cached = nullptr;
      const uint64_t fkey = in.keep_fragments ? fragment_key(frame.setup.maps[k], in) : 0;
      if (in.keep_fragments)
        for (MapCache::KeptFragments& c : cache.fragments)
          if (!c.taken && c.key == fkey) cached = &c;
      if (cached) {
        cached->taken = true;
        kept.push_back(*cached);
      }
      if (m.found[k]) continue;
      todo.push_back(k);
      from_cache.push_back(cached);
    }
    // Lists made together (one wait of the producer for all of them) in
    // batches of up to kProduceBatchPixels, then built in groups.
    std::vector<std::vector<uint32_t>> words(todo.size());  // each build's object mask
    std::vector<ListsRequest> requests;
    std::vector<ListsId> produced;
    for (size_t t0 = 0; t0 < todo.size();) {
      size_t t1 = t0;
      uint64_t pixels = 0;
      requests.clear();
      for (; t1 < todo.size(); ++t1) {
        const MapPlan& plan = frame.setup.maps[todo[t1]];
        words[t1] = mask_words(plan.members, sb.objects.size());
        if (from_cache[t1]) continue;
        const uint64_t p = uint64_t(plan.view.width) * uint64_t(plan.view.height);
        if (!requests.empty() && pixels + p > kProduceBatchPixels) break;
        pixels += p;
        requests.push_back({plan.view, ObjectMask{{words[t1].data(), words[t1].size()}}, true, uint64_t(todo[t1]) + 1});
      }
      auto t_start = Clock::now();
      produced.assign(requests.size(), 0);
      if (!requests.empty()) produce(backend, requests.data(), requests.size(), produced.data());
      reading.insert(reading.end(), produced.begin(), produced.end());
      frame.fragments_ms += ms_since(t_start);
      size_t next_produced = 0;
      for (size_t t = t0; t < t1; ++t) {
        const size_t k = todo[t];
        const MapPlan& plan = frame.setup.maps[k];
        ObjectMask mask{{words[t].data(), words[t].size()}};
        // The lists the build reads (and sorts in place): a copy of kept
        // lists, or new ones of which a copy is kept — on the backend.
        ListsId lists;
        size_t kept_at = SIZE_MAX;
        if (from_cache[t]) {
          reading.push_back(backend.copy_lists(from_cache[t]->lists));
          lists = reading.back();
          ++frame.fragment_lists_reused;
        } else {
          lists = produced[next_produced++];
          if (in.keep_fragments) {
            kept_at = kept.size();
            kept.push_back({fragment_key(plan, in), backend.copy_lists(lists), false});
          }
        }
        insides.push_back(objects_containing(sv, plan.view.eye, mask));
        LightPassParams lp{
            plan.view, s.epsilon, {insides.back().data(), insides.back().size()}, s.method, s.method_param};
        if (s.method == ShadowMethod::DeepOpacity)
          lp.layer_thickness = s.layer_thickness > 0.0f
                                   ? s.layer_thickness
                                   : caster_depth_extent(plan, sb) / method_param_or_default(s.method, s.method_param);
        // RGB nodes only where a member is coloured (deep shadow maps; the
        // baselines are grey).
        lp.rgb = s.rgb_maps && s.method == ShadowMethod::Dsm &&
                 std::any_of(plan.members.begin(), plan.members.end(),
                             [&](uint32_t o) { return is_coloured(sv, sv.objects[o]); });
        lp.blocker_pyramid = wants_pyramid(frame.setup.lights[plan.light], s);
        group.push_back({lp, lists});
        group_maps.push_back(k);
        group_masks.push_back(mask);
        group_kept.push_back(kept_at);
        group_bytes += backend.lists_bytes(lists);
        if (group_bytes >= kBuildGroupListBytes) flush();
      }
      t0 = t1;
    }
    flush();
    for (size_t k = 0; k < n; ++k) {
      const MapCache::Entry& e = next[k];
      frame.map_rebuilt.push_back(m.found[k] ? 0 : 1);
      if (m.found[k])
        ++frame.reused;
      else
        ++frame.rebuilt;
      frame.maps.push_back(e.id);
      frame.map_stats.push_back(e.stats);
    }
  } catch (...) {
    abandon();
    throw;
  }
  frame.refresh_headers();
  for (const MapCache::KeptFragments& c : cache.fragments)
    if (!c.taken) backend.free_lists(c.lists);  // lists of maps no longer planned
  for (MapCache::KeptFragments& c : kept) c.taken = false;
  cache.fragments = std::move(kept);
  for (const MapCache::KeptFragments& c : cache.fragments) frame.fragment_cache_bytes += backend.lists_bytes(c.lists);
  cache.entries = std::move(next);
  cache.layout = layout;
}

}  // namespace

void build_shadow_frame(const FrameInputs& in, const FragmentProducer& produce, ShadowBackend& backend, MapCache& cache,
                        ShadowFrame& frame) {
  frame = ShadowFrame{};
  frame.backend = &backend;
  std::unordered_map<uint64_t, MapCache::LightState> lights = plan_maps(in, backend, cache, frame);
  CacheMatch matched = match_cache(in, cache, frame);
  build_missing(in, produce, backend, cache, matched, frame);
  cache.lights = std::move(lights);
}

}  // namespace cdsm
