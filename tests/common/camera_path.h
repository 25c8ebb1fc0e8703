// A camera path for the rebuild and popping tests: `frames` frames that
// move the camera 10 m sideways and turn it 30 degrees about the vertical,
// each rendered (CPU fragments, popping measured), with what the maps did.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "cdsm/renderer.h"

namespace cdsm_test {

struct PathFigures {
  uint32_t frames_with_rebuilds = 0, maps_rebuilt = 0;
  double worst_p99 = 0.0, worst_max = 0.0;
  // Auto resolution: frames where a map's resolution moved a rung, and
  // frames with rebuilds that neither that nor a new clustering explains.
  uint32_t frames_with_new_rungs = 0, unexplained_rebuild_frames = 0;
};

inline PathFigures walk_camera_path(cdsm::Scene s, int frames) {
  using namespace cdsm;
  RenderOptions opt;
  opt.fragments = FragmentSource::Cpu;
  opt.measure_popping = true;
  Renderer r;
  FrameStats st;
  r.render(s, opt, &st);
  EXPECT_EQ(st.maps_rebuilt, uint32_t(s.shadows.max_clusters > 1 ? s.shadows.max_clusters : 1));
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
    fig.frames_with_new_rungs += new_rung;
    fig.unexplained_rebuild_frames += st.maps_rebuilt > 0 && !new_rung && !reclustered;
    if (st.popping.measured) {
      fig.worst_p99 = std::max(fig.worst_p99, st.popping.p99);
      fig.worst_max = std::max(fig.worst_max, st.popping.max);
    }
  }
  return fig;
}

}  // namespace cdsm_test
