#include "memory_budget.h"

#include "auto_resolution.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>

#include "cdsm/error.h"

namespace cdsm {
namespace {

constexpr double kFragmentBytesPerTexel = 24.0;  // a light view's fragment lists per texel (estimate)

std::atomic<int64_t> g_limit_mib{0};  // 0: half the physical memory

}  // namespace

void set_memory_limit_mib(int64_t mib) { g_limit_mib = mib < 0 ? 0 : mib; }

uint64_t physical_memory_bytes() {
  long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? uint64_t(pages) * uint64_t(size) : (uint64_t(8) << 30);
}

uint64_t memory_limit_bytes(const ShadowSettings& s) {
  if (s.max_memory_mib > 0) return uint64_t(s.max_memory_mib) << 20;
  if (g_limit_mib > 0) return uint64_t(g_limit_mib.load()) << 20;
  return physical_memory_bytes() / 2;
}

std::string format_bytes(double bytes) {
  if (bytes >= double(uint64_t(1) << 40))
    return format_number(std::round(bytes / double(uint64_t(1) << 40) * 10) / 10) + " TiB";
  if (bytes >= double(1 << 30)) return format_number(std::round(bytes / double(1 << 30) * 10) / 10) + " GiB";
  return format_number(std::ceil(bytes / double(1 << 20))) + " MiB";
}

std::string memory_limit_origin(const ShadowSettings& s) {
  if (s.max_memory_mib > 0) return "/shadows/max_memory";
  if (g_limit_mib > 0) return "--max-memory";
  return "half of the " + format_bytes(double(physical_memory_bytes())) +
         " of physical memory; raise it with --max-memory or /shadows/max_memory";
}

double map_texel_budget(const ShadowSettings& s, const std::vector<MemoryItem>& items) {
  double others = 0.0;
  for (const MemoryItem& i : items)
    if (!i.per_map_texel) others += i.bytes;
  return double(memory_limit_bytes(s)) - others;
}

double map_bytes_per_texel(const ShadowSettings& sh) {
  // The map's own buffers and the frame's copy of them (nodes with their
  // 2-byte tags; the node pools start at 4 nodes per texel).
  switch (sh.layout) {
    case DsmLayout::Fixed: return 2.0 * double(sh.fixed_layers) * 10.0;
    case DsmLayout::Chunked: return 2.0 * (8.0 + 4.0 * 14.0);
    default: return 2.0 * (8.0 + 4.0 * 10.0);
  }
}

std::vector<MemoryItem> estimate_frame_memory(const Scene& scene, const RenderOptions& options) {
  std::vector<MemoryItem> items;
  const ShadowSettings& sh = scene.shadows;
  // Volumes: the compiled copy of every grid (voxels and macro-cells).
  for (size_t i = 0; i < scene.volumes.size(); ++i) {
    const Volume& v = scene.volumes[i];
    double bytes = 0.0;
    if (v.grid) bytes = double(v.grid->values.size()) * 4.0 * (1.0 + 1.0 / 256.0);
    if (v.sparse) bytes = double(v.sparse->nanovdb_bytes) * 1.1;
    items.push_back({"the compiled grid of volume " + std::to_string(i), "/volumes/" + std::to_string(i), bytes});
  }
  // Triangles: world-space vertices, normals, BVH, and their GL upload.
  double tris = 0.0;
  size_t biggest = 0;
  double biggest_tris = -1.0;
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    double t = scene.objects[i].mesh ? double(scene.objects[i].mesh->triangle_count()) : 0.0;
    tris += t;
    if (t > biggest_tris) {
      biggest_tris = t;
      biggest = i;
    }
  }
  items.push_back({format_number(tris) + " triangles (compiled, BVH, GL upload)",
                   "/objects/" + std::to_string(biggest) + "/mesh", tris * 150.0});
  // Maps: per light, the maps its settings ask for.
  double maps = 0.0;
  for (const Light& l : scene.lights) {
    if (l.type == LightType::Point || l.outer_cone_deg > 60.0f)
      maps += 6.0;
    else if (sh.parallel_splits > 1)
      maps += double(sh.parallel_splits + 1);
    else
      maps += double(sh.auto_clusters() ? sh.cluster_limit : std::max(1, sh.max_clusters));
  }
  // Auto resolution: the maps at the ladder's bottom; the chooser gives
  // them what the limit leaves (map_texel_budget, auto_resolution.h).
  const int res = sh.auto_resolution() ? kSmallestAutoResolution : sh.resolution;
  const double texels = double(res) * double(res) * maps;
  const double per_texel = map_bytes_per_texel(sh);
  const std::string map_setting = sh.layout == DsmLayout::Fixed ? "/shadows/fixed_layers" : "/shadows/resolution";
  items.push_back({format_number(maps) + " shadow maps of " + (sh.auto_resolution() ? "at least " : "") +
                       std::to_string(res) + "^2 texels" +
                       (sh.layout == DsmLayout::Fixed ? " x " + std::to_string(sh.fixed_layers) + " layers" : ""),
                   map_setting, texels * per_texel, true});
  const double list_res = sh.auto_resolution() ? sh.max_resolution : sh.resolution;  // one map's at a time
  items.push_back({"light-view fragment lists", "/shadows/resolution", list_res * list_res * kFragmentBytesPerTexel});
  // Per-thread node buffers of the light pass (K = 1024 nodes per texel of a tile).
  const double threads = std::max(1u, std::thread::hardware_concurrency());
  items.push_back({"per-thread texel buffers", "/shadows/resolution", threads * 64.0 * 1024.0 * 30.0});
  // The camera: fragment lists, image, the reference when compared.
  const double pixels = double(scene.camera.width) * double(scene.camera.height);
  items.push_back(
      {"the camera view (" + std::to_string(scene.camera.width) + "x" + std::to_string(scene.camera.height) + ")",
       "/camera", pixels * (36.0 + (options.compare_reference ? 24.0 : 0.0))});
  return items;
}

void check_memory(const Scene& scene, const std::vector<MemoryItem>& items) {
  double total = 0.0;
  for (const MemoryItem& it : items) total += it.bytes;
  const uint64_t limit = memory_limit_bytes(scene.shadows);
  if (total <= double(limit)) return;
  std::vector<MemoryItem> sorted = items;
  std::sort(sorted.begin(), sorted.end(), [](const MemoryItem& a, const MemoryItem& b) { return a.bytes > b.bytes; });
  std::string parts;
  for (size_t i = 0; i < sorted.size() && i < 3 && sorted[i].bytes > 0.0; ++i)
    parts += (i ? ", " : "") + sorted[i].what + " " + format_bytes(sorted[i].bytes);
  throw Error(scene.source + ": " + sorted[0].setting, "needs an estimated " + format_bytes(total) + " (" + parts +
                                                           "), more than the limit of " + format_bytes(double(limit)) +
                                                           " (" + memory_limit_origin(scene.shadows) + ")");
}

void check_allocation(const std::string& where, const std::string& what, double bytes, const ShadowSettings& s) {
  const uint64_t limit = memory_limit_bytes(s);
  if (bytes > double(limit))
    throw Error(where, what + " needs " + format_bytes(bytes) + ", more than the limit of " +
                           format_bytes(double(limit)) + " (" + memory_limit_origin(s) + ")");
}

}  // namespace cdsm
