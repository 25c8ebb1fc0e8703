// What a map's casters are like (frame_steps.h): their depth extent along
// its rays, and a warning where they are all smaller than a texel.
#include <algorithm>
#include <cstdio>
#include <string>

#include "frame_steps.h"

namespace cdsm {
namespace {

// A map whose casters all project to less than a texel across holds
// (almost) no shadow, and nothing else would say so (issue 25 c: a 10 km
// scene with 1 m casters, one map). Per map, from the casters' boxes: the
// casters in its window, the largest one's extent in texels and the texel's
// world size at the nearest one.
struct CasterTexels {
  int casters = 0;       // members whose box lies (partly) in the map's window
  float largest = 0.0f;  // the largest projected extent among them, texels
  float texel = 0.0f;    // world size of a texel at the nearest of them
};

CasterTexels caster_texels(const MapPlan& plan, const SceneBuffers& sb) {
  const PinholeView& v = plan.view;
  CasterTexels r;
  float nearest = 0.0f;
  for (uint32_t o : plan.members) {
    const Box3& b = sb.object_bounds[o];
    if (b.empty()) continue;
    float u0 = 1e30f, u1 = -1e30f, v0 = 1e30f, v1 = -1e30f, axial = 1e30f;
    int behind = 0;
    for (int c = 0; c < 8; ++c) {
      const ViewProjection p = project(v, b.corner(c));
      if (p.axial <= 0.0f) {
        ++behind;
        continue;
      }
      u0 = std::min(u0, p.u);
      u1 = std::max(u1, p.u);
      v0 = std::min(v0, p.v);
      v1 = std::max(v1, p.v);
      axial = std::min(axial, p.axial);
    }
    if (behind == 8) continue;  // behind the light's plane: not in this map
    if (behind > 0) {           // around the light: as wide as the map
      ++r.casters;
      r.largest = 1e30f;
      continue;
    }
    if (u1 < 0.0f || v1 < 0.0f || u0 > float(v.width) || v0 > float(v.height)) continue;  // outside the window
    if (r.casters == 0 || axial < nearest) nearest = axial;
    ++r.casters;
    r.largest = std::max(r.largest, std::max(u1 - u0, v1 - v0));
  }
  r.texel = 2.0f * v.tan_half_x * nearest / float(v.width);
  return r;
}

}  // namespace

// The depth extent of a map's casters along its rays (radial from a point
// light, axial for parallel rays): from the nearest point of their boxes to
// the farthest corner. The deep opacity maps' default layers span it.
float caster_depth_extent(const MapPlan& plan, const SceneBuffers& sb) {
  const PinholeView& v = plan.view;
  float lo = 1e30f, hi = 0.0f;
  for (uint32_t o : plan.members) {
    const Box3& b = sb.object_bounds[o];
    if (b.empty()) continue;
    if (is_orthographic(v)) {
      for (int c = 0; c < 8; ++c) {
        const float t = dot(b.corner(c) - v.eye, v.forward);
        lo = std::min(lo, t);
        hi = std::max(hi, t);
      }
    } else {
      lo = std::min(lo, length(vmax(vmax(b.lo - v.eye, v.eye - b.hi), Vec3{0, 0, 0})));
      for (int c = 0; c < 8; ++c) hi = std::max(hi, length(b.corner(c) - v.eye));
    }
  }
  return hi > std::max(lo, 0.0f) ? hi - std::max(lo, 0.0f) : 0.0f;
}

// One warning per light with a map whose every caster is below a texel.
// The whole cone after parallel splits only serves points outside every
// split: it is not counted.
void warn_subtexel_casters(const FrameInputs& in, ShadowFrame& frame) {
  for (size_t li = 0; li < frame.setup.lights.size(); ++li) {
    const LightData& ld = frame.setup.lights[li];
    const bool splits = ld.map_mode == MapMode::FirstContaining && ld.map_count > 1;
    const uint32_t counted = splits ? ld.map_count - 1 : ld.map_count;
    uint32_t small = 0;
    float largest = 0.0f, texel = 1e30f;
    int res = 0;
    for (uint32_t k = 0; k < counted; ++k) {
      const MapPlan& plan = frame.setup.maps[ld.first_map + k];
      const CasterTexels c = caster_texels(plan, *in.scene);
      if (c.casters == 0 || !(c.largest < 1.0f)) continue;
      ++small;
      largest = std::max(largest, c.largest);
      texel = std::min(texel, c.texel);
      res = plan.view.width;
    }
    if (small == 0) continue;
    const Light& l = in.lights[li];
    const std::string light = l.name.empty() ? "light " + std::to_string(li) : "light '" + l.name + "'";
    const std::string maps =
        ld.map_count == 1 ? "its map" : std::to_string(small) + " of its " + std::to_string(ld.map_count) + " maps";
    char text[512];
    std::snprintf(
        text, sizeof text,
        "%s: every shadow caster in %s is smaller than a texel (%dx%d texels; a texel is %.3g world units wide at "
        "the casters, the largest caster covers %.2g of one), so they cast almost no shadow; use more clusters "
        "(/shadows/clusters, now %s) or a higher resolution (/shadows/resolution)",
        light.c_str(), maps.c_str(), res, res, double(texel), double(largest),
        in.settings.auto_clusters() ? "auto" : std::to_string(in.settings.max_clusters).c_str());
    frame.warnings.push_back(text);
  }
}

}  // namespace cdsm
