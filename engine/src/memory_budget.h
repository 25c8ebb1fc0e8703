// Up-front memory estimates (issue "Reliability"): before anything large is
// allocated, what a scene and its settings will need is estimated and
// compared with a limit (default half the physical memory; --max-memory,
// /shadows/max_memory, or set_memory_limit_mib()).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cdsm/renderer.h"
#include "cdsm/scene.h"

namespace cdsm {

uint64_t physical_memory_bytes();

// The limit for a scene: its /shadows/max_memory if set, else the process
// default (set_memory_limit_mib, else half the physical memory).
uint64_t memory_limit_bytes(const ShadowSettings& s);

// Where the limit came from, for messages.
std::string memory_limit_origin(const ShadowSettings& s);

// "1.5 GiB", "340 MiB".
std::string format_bytes(double bytes);

// What one texel of a map is estimated to take (its buffers and the frame's
// copy; upper estimates: node pools start at 4 nodes per texel).
double map_bytes_per_texel(const ShadowSettings& s);

struct MemoryItem {
  std::string what;     // "DSM node pools of 6 maps of 8192^2 texels"
  std::string setting;  // the JSON pointer that drives it: "/shadows/resolution"
  double bytes = 0.0;
  bool per_map_texel = false;  // grows with the maps' texels (what auto resolution budgets)
};

// The bytes the maps' texels may take: the limit less every other item.
double map_texel_budget(const ShadowSettings& s, const std::vector<MemoryItem>& items);

// What a frame of `scene` with `options` will allocate, item by item
// (upper estimates where the true figure is known only later, e.g. the
// node pools, which start at 4 nodes per texel and grow to the exact need).
std::vector<MemoryItem> estimate_frame_memory(const Scene& scene, const RenderOptions& options);

// Throws Error("SOURCE: <setting of the largest item>", "...") when the
// estimate exceeds the limit, naming the estimate, its largest parts and the
// limit; `what` prefixes the message ("this frame").
void check_memory(const Scene& scene, const std::vector<MemoryItem>& items);

// Throws Error(where, ...) when `bytes` for `what` alone exceed the limit
// (the scene reader's check before it generates a grid or a mesh).
void check_allocation(const std::string& where, const std::string& what, double bytes, const ShadowSettings& s);

}  // namespace cdsm
