// A camera path for the rebuild and popping tests: `frames` frames that
// move the camera 10 m sideways and turn it 30 degrees about the vertical,
// each rendered (CPU fragments, popping measured), with what the maps did.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "cdsm/renderer.h"

namespace cdsm_test {

struct PathFigures {
  uint32_t frames_with_rebuilds = 0, maps_rebuilt = 0;
  double worst_p99 = 0.0, worst_max = 0.0;
  // Auto resolution: frames where a map's resolution moved a rung, and
  // frames with rebuilds that neither that nor a new clustering explains.
  uint32_t frames_with_new_rungs = 0, unexplained_rebuild_frames = 0;
  // Auto clusters: frames where a light's cluster count changed.
  uint32_t frames_with_new_counts = 0;
};

// CDSM_PATH_FULL=1: the camera-path tests walk the 200 frames at
// the scenes' own image sizes (minutes), else short paths on small images.
inline bool full_paths() { return std::getenv("CDSM_PATH_FULL") != nullptr; }

inline PathFigures walk_camera_path(cdsm::Scene s, int frames) {
  using namespace cdsm;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  opt.measure_popping = true;
  Renderer r;
  FrameStats st;
  r.render(s, opt, &st);
  EXPECT_EQ(st.maps_rebuilt, uint32_t(st.map_resolutions.size()));  // every map is new
  std::vector<int32_t> counts;
  for (const LightClusterStats& c : st.clusters) counts.push_back(c.chosen_clusters);
  const Vec3 p0 = s.camera.position, t0 = s.camera.target;
  PathFigures fig;
  std::vector<MapResolutionStats> rungs = st.map_resolutions;
  for (int f = 1; f <= frames; ++f) {
    const float a = float(f) / float(frames);
    s.camera.position = p0 + Vec3{10.0f * a, 0, 0};             // 10 m sideways
    const float turn = 30.0f * a * 3.14159265358979f / 180.0f;  // and 30 degrees about the vertical
    const Vec3 d = t0 - p0;
    s.camera.target = s.camera.position + Vec3{d.x * std::cos(turn) - d.z * std::sin(turn), d.y,
                                               d.x * std::sin(turn) + d.z * std::cos(turn)};
    r.render(s, opt, &st);
    fig.maps_rebuilt += st.maps_rebuilt;
    fig.frames_with_rebuilds += st.maps_rebuilt > 0;
    bool new_rung = st.map_resolutions.size() != rungs.size(), reclustered = false;
    for (size_t k = 0; !new_rung && k < rungs.size(); ++k)
      new_rung = st.map_resolutions[k].resolution != rungs[k].resolution;
    for (const LightClusterStats& c : st.clusters)
      for (uint8_t changed : c.changed) reclustered = reclustered || changed != 0;
    rungs = st.map_resolutions;
    bool new_count = false;
    for (size_t li = 0; li < st.clusters.size() && li < counts.size(); ++li) {
      new_count = new_count || st.clusters[li].chosen_clusters != counts[li];
      counts[li] = st.clusters[li].chosen_clusters;
    }
    fig.frames_with_new_counts += new_count;
    fig.frames_with_new_rungs += new_rung;
    fig.unexplained_rebuild_frames += st.maps_rebuilt > 0 && !new_rung && !reclustered;
    if (st.popping.measured) {
      fig.worst_p99 = std::max(fig.worst_p99, st.popping.p99);
      fig.worst_max = std::max(fig.worst_max, st.popping.max);
    }
  }
  return fig;
}

// Auto resolution along a path: prints the figures (`what` names it),
// expects every rebuild frame explained by a map on a new rung or a new
// clustering, at most `new_rung_share` of the frames with a new rung, and
// the popping probe's p99 within 0.01.
inline void expect_auto_path(const char* what, const PathFigures& c, int frames, double new_rung_share) {
  std::printf(
      "[ auto path] %s, %d frames: %u with rebuilds (%u maps), %u with a map on a new rung, %u with a new cluster "
      "count, %u unexplained; popping p99 %.4f max %.4f\n",
      what, frames, c.frames_with_rebuilds, c.maps_rebuilt, c.frames_with_new_rungs, c.frames_with_new_counts,
      c.unexplained_rebuild_frames, c.worst_p99, c.worst_max);
  EXPECT_EQ(c.unexplained_rebuild_frames, 0u) << what;
  EXPECT_LT(double(c.frames_with_new_rungs), new_rung_share * frames) << what;
  EXPECT_LE(c.worst_p99, 0.01) << what;
}

}  // namespace cdsm_test
