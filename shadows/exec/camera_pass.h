// The camera pass and the ray-cast fragment producer over an executor
// (shadows/exec/exec.h): one pixel per parallel_for index (the producer on
// CPU threads: one block of pixels per index), the CDSM_HD
// functions of hd/camera_pass.h and hd/cast.h — the cpu drivers'
// (cpu/camera_pass.cpp, cpu/fragments_cpu.cpp) per-pixel work, unchanged.
#pragma once

#include <cstring>
#include <stdexcept>
#include <vector>

#include "exec/exec.h"
#include "exec/scan.h"
#include "hd/camera_pass.h"
#include "hd/cast.h"

namespace cdsm::exec {

// Shades every pixel of params.view into rgb (3 floats per pixel). Every
// span (scene, shadows, params.inside, frags) is in executor memory; the
// walk counters are added to walk4[0..4) (executor memory, zeroed by the caller).
template <class Ex>
void shade_pixels(Ex& ex, const SceneView& scene, const ShadowView& shadows, const CameraPassParams& params,
                  FragmentLists frags, float* rgb, uint32_t* walk4) {
  const int w = params.view.width;
  const uint64_t n = uint64_t(w) * uint64_t(params.view.height);
  const SceneView sv = scene;
  const ShadowView shv = shadows;
  const CameraPassParams cp = params;
  ex.parallel_for(
      "camera pass", n, CDSM_LAMBDA(uint64_t i) {
        const int px = int(i % uint64_t(w)), py = int(i / uint64_t(w));
        DsmVisibility vis{shv};
        NoRecorder rec;
        WalkStats st;
        PixelResult r = shade_pixel(sv, shv.lights, vis, cp, frags.pixel(px, py), px, py, rec, st);
        rgb[3 * i + 0] = r.color.x;
        rgb[3 * i + 1] = r.color.y;
        rgb[3 * i + 2] = r.color.z;
        if (st.enclosing_overflow) atomic_add(&walk4[0], st.enclosing_overflow);
        if (st.match_overflow) atomic_add(&walk4[1], st.match_overflow);
        if (st.unmatched) atomic_add(&walk4[2], st.unmatched);
        if (st.march_lengthened) atomic_add(&walk4[3], st.march_lengthened);
      });
}

// Fragment lists of `view` by ray casting (count -> scan -> fill), like
// cpu/fragments_cpu.cpp's cast_fragments: `offsets` gets width*height + 1
// entries, `fragments` the lists (unsorted). `mask` in executor memory;
// `any_media` = mask_has_media(scene, mask), decided by the caller.
// cast_fragments_exec takes the executor's way: a GPU casts each ray twice,
// counting then filling (cast_fragments_twice), rather than hold lists per
// thread; CPU threads cast each ray once: blocks of
// kHostCastBlock pixels keep their fragments (host memory, exactly what
// they cast) until the scan has placed them, then copy them in one piece.
// Both give the same lists, bit for bit (test_exec_backend).
inline constexpr uint64_t kHostCastBlock = 64;

// A cast in two halves, so that several views' totals come back in one
// read: the count (counts, offsets scanned, the total left at *total in
// executor memory), then, with `fragments` sized to the total, the fill.
// CPU threads keep each block's fragments from the count (`held`, host
// memory) and copy them in the fill; a GPU casts each ray again.
struct CastHeld {
  std::vector<std::vector<Fragment>> blocks;
};

template <bool kRecast, class Ex>
void cast_count_way(Ex& ex, const SceneView& scene, const PinholeView& view, ObjectMask mask, bool any_media,
                    ExecArray<uint32_t, Ex>& counts, ExecArray<uint32_t, Ex>& offsets,
                    ExecArray<unsigned long long, Ex>& sums, unsigned long long* total, CastHeld& held) {
  const int w = view.width;
  const uint64_t n = uint64_t(w) * uint64_t(view.height);
  counts.resize_discard(n + 1);
  offsets.resize_discard(n + 1);
  uint32_t* c = counts.data();
  if constexpr (!kRecast) {
    static_assert(Ex::kHostMemory, "casting once holds its blocks' lists in host memory");
    const uint64_t blocks = (n + kHostCastBlock - 1) / kHostCastBlock;
    held.blocks.assign(blocks, {});
    c[n] = 0;  // the scan's last entry becomes the total
    ex.parallel_for("fragments: count", blocks, [&](uint64_t b) {
      std::vector<Fragment>& mine = held.blocks[b];
      for (uint64_t i = b * kHostCastBlock; i < n && i < (b + 1) * kHostCastBlock; ++i) {
        const size_t before = mine.size();
        cast_pixel(scene, view, mask, any_media, int(i % uint64_t(w)), int(i / uint64_t(w)),
                   [&](Fragment f) { mine.push_back(f); });
        c[i] = uint32_t(mine.size() - before);
      }
    });
  } else {
    const SceneView sv = scene;
    const PinholeView v = view;
    ex.parallel_for(
        "fragments: count", n + 1, CDSM_LAMBDA(uint64_t i) {
          if (i == n) {  // the scan's last entry becomes the total
            c[i] = 0;
            return;
          }
          uint32_t k = 0;
          cast_pixel(sv, v, mask, any_media, int(i % uint64_t(w)), int(i / uint64_t(w)), [&](Fragment) { ++k; });
          c[i] = k;
        });
  }
  exclusive_scan_to(ex, c, offsets.data(), n + 1, sums, total);
}

template <bool kRecast, class Ex>
void cast_fill_way(Ex& ex, const SceneView& scene, const PinholeView& view, ObjectMask mask, bool any_media,
                   const ExecArray<uint32_t, Ex>& offsets, ExecArray<Fragment, Ex>& fragments, CastHeld& held) {
  const int w = view.width;
  const uint64_t n = uint64_t(w) * uint64_t(view.height);
  const uint32_t* off = offsets.data();
  Fragment* out = fragments.data();
  if constexpr (!kRecast) {
    ex.parallel_for("fragments: fill", uint64_t(held.blocks.size()), [&](uint64_t b) {
      std::vector<Fragment>& mine = held.blocks[b];
      if (!mine.empty()) std::memcpy(out + off[b * kHostCastBlock], mine.data(), mine.size() * sizeof(Fragment));
      std::vector<Fragment>().swap(mine);
    });
  } else {
    const SceneView sv = scene;
    const PinholeView v = view;
    ex.parallel_for(
        "fragments: fill", n, CDSM_LAMBDA(uint64_t i) {
          uint32_t at = off[i];
          cast_pixel(sv, v, mask, any_media, int(i % uint64_t(w)), int(i / uint64_t(w)),
                     [&](Fragment f) { out[at++] = f; });
        });
  }
}

// The executor's way: CPU threads cast once, a GPU twice.
template <class Ex>
void cast_count_exec(Ex& ex, const SceneView& scene, const PinholeView& view, ObjectMask mask, bool any_media,
                     ExecArray<uint32_t, Ex>& counts, ExecArray<uint32_t, Ex>& offsets,
                     ExecArray<unsigned long long, Ex>& sums, unsigned long long* total, CastHeld& held) {
  cast_count_way<!Ex::kHostMemory>(ex, scene, view, mask, any_media, counts, offsets, sums, total, held);
}
template <class Ex>
void cast_fill_exec(Ex& ex, const SceneView& scene, const PinholeView& view, ObjectMask mask, bool any_media,
                    const ExecArray<uint32_t, Ex>& offsets, ExecArray<Fragment, Ex>& fragments, CastHeld& held) {
  cast_fill_way<!Ex::kHostMemory>(ex, scene, view, mask, any_media, offsets, fragments, held);
}

// One view's cast in the given way: its count, its total read back (one
// synchronization), its fill.
template <bool kRecast, class Ex>
void cast_fragments_way(Ex& ex, const SceneView& scene, const PinholeView& view, ObjectMask mask, bool any_media,
                        ExecArray<uint32_t, Ex>& counts, ExecArray<uint32_t, Ex>& offsets,
                        ExecArray<Fragment, Ex>& fragments, ExecArray<unsigned long long, Ex>& sums) {
  const uint64_t n = uint64_t(view.width) * uint64_t(view.height);
  const uint64_t chunks = (n + 1 + kScanChunk - 1) / kScanChunk;
  sums.resize_discard(chunks + 1);
  CastHeld held;
  cast_count_way<kRecast>(ex, scene, view, mask, any_media, counts, offsets, sums, sums.data() + chunks, held);
  unsigned long long all = 0;
  ex.download(&all, sums.data() + chunks, sizeof all);
  if (all > 0xffffffffull) throw std::length_error("fragment lists exceed 2^32 fragments");
  fragments.resize_discard(all);
  cast_fill_way<kRecast>(ex, scene, view, mask, any_media, offsets, fragments, held);
}
template <class Ex>
void cast_fragments_twice(Ex& ex, const SceneView& scene, const PinholeView& view, ObjectMask mask, bool any_media,
                          ExecArray<uint32_t, Ex>& counts, ExecArray<uint32_t, Ex>& offsets,
                          ExecArray<Fragment, Ex>& fragments, ExecArray<unsigned long long, Ex>& sums) {
  cast_fragments_way<true>(ex, scene, view, mask, any_media, counts, offsets, fragments, sums);
}
template <class Ex>
void cast_fragments_exec(Ex& ex, const SceneView& scene, const PinholeView& view, ObjectMask mask, bool any_media,
                         ExecArray<uint32_t, Ex>& counts, ExecArray<uint32_t, Ex>& offsets,
                         ExecArray<Fragment, Ex>& fragments, ExecArray<unsigned long long, Ex>& sums) {
  cast_fragments_way<!Ex::kHostMemory>(ex, scene, view, mask, any_media, counts, offsets, fragments, sums);
}

}  // namespace cdsm::exec
