// Inspection of a shadow system's maps (cdsm/shadow_system.h): what the
// editor's views show — each map's frustum, members and memory, its node
// counts and opacity per texel, and one texel's stored visibility function
// against the same light ray walked with epsilon 0.
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "cdsm/error.h"
#include "cdsm/shadow_system.h"
#include "scene/fragments.h"
#include "hd/light_pass.h"
#include "shadow_system_impl.h"

namespace cdsm {
namespace {

const ShadowSystem::Impl& checked_map(const ShadowSystem::Impl& I, int map) {
  if (map < 0 || size_t(map) >= I.frame.headers.size())
    throw Error(I.scene.source, "map " + std::to_string(map) + " does not exist (the last update built " +
                                    std::to_string(I.frame.headers.size()) + ")");
  return I;
}

// The light whose maps include map k, and k's place among them.
void owner_of(const ShadowFrame& f, size_t k, int& light, int& slot) {
  light = int(f.setup.maps[k].light);
  slot = int(k) - int(f.setup.lights[size_t(light)].first_map);
}

// The one-texel view whose pixel centre is texel (tx, ty)'s centre of v.
PinholeView texel_view(const PinholeView& v, int tx, int ty) {
  PinholeView t = v;
  t.center.x = v.center.x + (2.0f * (float(tx) + 0.5f) / float(v.width) - 1.0f) * v.tan_half_x;
  t.center.y = v.center.y + (1.0f - 2.0f * (float(ty) + 0.5f) / float(v.height)) * v.tan_half_y;
  t.tan_half_x = v.tan_half_x / float(v.width);
  t.tan_half_y = v.tan_half_y / float(v.height);
  t.width = t.height = 1;
  return t;
}

// alpha per channel just before / at z (lookup_alpha) and just after z
// (a grey list: its one value in every channel).
template <int N>
Vec3 alpha_before_in_colour(Span<const DsmNodeN<N>> n, float z) {
  return to_rgb(lookup_alpha(n, z));
}
template <int N>
Vec3 alpha_after_in_colour(Span<const DsmNodeN<N>> n, float z) {
  return to_rgb(alpha_after(n, z));
}

// sup over depths and channels of how far one visibility function lies
// outside the other's range within +-tol(z) of the same depth: |f - g| where
// both have their steps at the same depths, but a step moved by a depth
// difference below tol (the GL and CPU fragment producers differ by up to
// ~1e-5 of the depth) does not count as the step's height. Both functions
// are monotone, so g's range over [z - tol, z + tol] is [g(z - tol), g(z + tol)].
template <class Node>
float deviation(Span<const Node> f, Span<const Node> g, float rel_tol) {
  float worst = 0.0f;
  for (int pass = 0; pass < 2; ++pass) {
    const Span<const Node> a = pass == 0 ? f : g, b = pass == 0 ? g : f;
    for (int list = 0; list < 2; ++list) {
      const Span<const Node> at = list == 0 ? a : b;
      for (uint64_t i = 0; i < at.size(); ++i) {
        const float z = at[i].z, tol = rel_tol * fabsf(z);
        const Vec3 lo = alpha_before_in_colour(b, z - tol), hi = alpha_after_in_colour(b, z + tol);
        for (const Vec3& v : {alpha_before_in_colour(a, z), alpha_after_in_colour(a, z)})
          for (int k = 0; k < 3; ++k) worst = fmaxf(worst, fmaxf(lo[k] - v[k], v[k] - hi[k]));
      }
    }
  }
  return worst;
}

// The samples of a node list; with tags, each step's object (tags hold the
// object index modulo 16383, plus 1: exact below 16383 objects).
template <class Node>
std::vector<ShadowSystem::AlphaSample> samples_of(const Node* n, uint32_t count, const SurfaceTag* tags = nullptr) {
  std::vector<ShadowSystem::AlphaSample> out;
  for (uint32_t i = 0; i < count; ++i) {
    const uint32_t o = tags ? tag_object_of(tags[i]) : 0u;
    out.push_back({n[i].z, to_rgb(n[i].alpha), o ? int(o) - 1 : -1});
  }
  return out;
}

}  // namespace

std::vector<ShadowSystem::MapInfo> ShadowSystem::maps() const {
  const Impl& I = *impl_;
  const ShadowFrame& f = I.frame;
  std::vector<MapInfo> out;
  for (size_t k = 0; k < f.headers.size(); ++k) {
    MapInfo m;
    owner_of(f, k, m.light, m.slot);
    const PinholeView& v = f.setup.maps[k].view;
    m.res = int(f.headers[k].res);
    m.rgb = f.headers[k].rgb != 0u;
    m.rebuilt = k < f.map_rebuilt.size() && f.map_rebuilt[k] != 0;
    for (uint32_t o : f.setup.maps[k].members) m.members.push_back(int(o));
    m.near = v.near;
    m.far = v.far;
    for (int c = 0; c < 8; ++c) {
      const float sx = v.center.x + ((c & 1) ? v.tan_half_x : -v.tan_half_x);
      const float sy = v.center.y + ((c & 2) ? v.tan_half_y : -v.tan_half_y);
      const float d = (c & 4) ? v.far : v.near;
      m.corners[c] = is_orthographic(v) ? v.eye + v.right * sx + v.up * sy + v.forward * d
                                        : v.eye + (v.forward + v.right * sx + v.up * sy) * d;
    }
    if (k < f.map_stats.size()) {
      const DsmBuildStats& b = f.map_stats[k];
      m.nodes = b.nodes;
      m.max_nodes = b.max_nodes;
      m.index_bytes = b.index_bytes;
      m.node_bytes = b.node_bytes_used;
      m.slack_bytes = b.slack_bytes;
    }
    out.push_back(std::move(m));
  }
  return out;
}

std::vector<uint32_t> ShadowSystem::map_node_counts(int map) const {
  const Impl& I = checked_map(*impl_, map);
  const DsmMap& m = I.frame.headers[size_t(map)];
  const DsmStorage st = I.backend->storage();
  std::vector<uint32_t> out(size_t(m.res) * m.res);
  for (int ty = 0; ty < int(m.res); ++ty)
    for (int tx = 0; tx < int(m.res); ++tx) out[size_t(ty) * m.res + tx] = texel_node_count(st, m, tx, ty);
  return out;
}

std::vector<float> ShadowSystem::map_alpha(int map, float depth) const {
  const Impl& I = checked_map(*impl_, map);
  const DsmMap& m = I.frame.headers[size_t(map)];
  const DsmStorage st = I.backend->storage();
  std::vector<float> out(size_t(m.res) * m.res);
  for (int ty = 0; ty < int(m.res); ++ty)
    for (int tx = 0; tx < int(m.res); ++tx) {
      const Vec3 a = texel_alpha_in_colour(st, m, tx, ty, depth);
      out[size_t(ty) * m.res + tx] = (a.x + a.y + a.z) / 3.0f;
    }
  return out;
}

ShadowSystem::TexelInspection ShadowSystem::inspect_texel(int light, Vec3 p, int object, Vec3 plane) const {
  const Impl& I = *impl_;
  const ShadowFrame& f = I.frame;
  TexelInspection r;
  r.light = light;
  if (light < 0 || size_t(light) >= f.setup.lights.size()) {
    r.why = "light " + std::to_string(light) + " does not exist";
    return r;
  }
  const LightData& L = f.setup.lights[size_t(light)];
  const ShadowView sv = I.shadow_view();
  const DsmStorage st = I.backend->storage();
  // The map that serves p: the cube face holding it, else the map whose
  // window holds it with the largest opacity there.
  uint32_t first = L.first_map, count = L.map_count;
  if (L.map_mode == MapMode::CubeFaces && count == 6) {
    first += uint32_t(cube_face_of(p - L.position));
    count = 1;
  }
  float best = -1.0f;
  for (uint32_t k = first; k < first + count; ++k) {
    const DsmMap& m = f.headers[k];
    const ViewProjection pr = project(m.view, p);
    if (pr.axial <= 0.0f || pr.u < 0.0f || pr.v < 0.0f || pr.u >= float(m.res) || pr.v >= float(m.res)) continue;
    const float a = grey_of(map_alpha_in_colour(sv, L, m, pr, Receiver{p, Vec3{0, 0, 0}, kNoObject}));
    if (a > best) {
      best = a;
      r.map = int(k);
    }
  }
  if (r.map < 0) {
    r.why = "the point lies outside every map of light " + std::to_string(light);
    return r;
  }
  const size_t k = size_t(r.map);
  const DsmMap& m = f.headers[k];
  const ViewProjection pr = project(m.view, p);
  owner_of(f, k, r.light, r.slot);
  r.tx = std::min(int(std::floor(pr.u)), int(m.res) - 1);
  r.ty = std::min(int(std::floor(pr.v)), int(m.res) - 1);
  r.depth = pr.depth;
  r.epsilon = I.scene.shadows.epsilon;
  r.rgb = m.rgb != 0u;

  // The stored nodes, compared with the texel walked again at epsilon 0.
  const auto inspect_nodes = [&](auto kind) {
    constexpr int N = decltype(kind)::value;
    const uint32_t n = read_texel<N>(st, m, r.tx, r.ty, nullptr, 0);
    std::vector<DsmNodeN<N>> nodes(n);
    std::vector<SurfaceTag> tags(n);
    read_texel(st, m, r.tx, r.ty, nodes.data(), n, tags.data());

    // What the clicked surface reads from the texel: its plane along the
    // texel's centre ray, its own step (if it casts) left out.
    if (object >= 0 && size_t(object) < I.scene.objects.size() && dot(plane, plane) > 0.0f) {
      const Receiver rc{p, plane, I.scene.objects[size_t(object)].casts_shadows ? uint32_t(object) : kNoObject};
      r.receiver = true;
      r.receiver_depth = tap_depth(sv, m, pr, rc, r.tx, r.ty);
      const TexelRead tr = receiver_read_at(sv, m, pr, rc, r.receiver_depth);
      r.received = to_rgb(texel_receive<N>(st, m, r.tx, r.ty, tr));
      OwnStepSearch own(tr);
      if (tr.own != 0u)
        for (uint32_t i = 0; i < n; ++i)
          if (!own.visit(nodes[i].z, tags[i])) break;
      r.own_node = own.index == 0xffffffffu ? -1 : int(own.index);
    }

    // The same ray, epsilon 0: the texel's one-pixel view, its members' fragments.
    const MapPlan& plan = f.setup.maps[k];
    const SceneView scene = I.sb.view();
    std::vector<uint32_t> words = I.sb.mask_where(
        [&](uint32_t o) { return std::find(plan.members.begin(), plan.members.end(), o) != plan.members.end(); });
    const ObjectMask mask{{words.data(), words.size()}};
    const PinholeView one = texel_view(m.view, r.tx, r.ty);
    FragmentBuffers fb;
    cast_fragments(scene, one, mask, fb);
    std::vector<uint32_t> inside = objects_containing(scene, pixel_origin(one, 0, 0), mask);
    LightPassParams lp{one, 0.0f, {inside.data(), inside.size()}, ShadowMethod::Dsm, 0.0f};
    lp.rgb = r.rgb;
    WalkStats ws;
    constexpr int kCapacity = 1 << 16;  // every sample of a long march
    std::vector<DsmNodeN<N>> exact(kCapacity);
    NodeBufferN<N> buf{exact.data(), kCapacity};
    build_texel(scene, lp, fb.lists().pixel(0, 0), 0, 0, buf, ws);
    r.nodes = samples_of(nodes.data(), n, tags.data());
    r.exact = samples_of(exact.data(), uint32_t(buf.count));
    r.max_deviation = deviation(Span<const DsmNodeN<N>>{nodes.data(), n},
                                Span<const DsmNodeN<N>>{exact.data(), uint64_t(buf.count)}, kRelativeDepthOffset);
  };
  if (r.rgb)
    inspect_nodes(std::integral_constant<int, 3>{});
  else
    inspect_nodes(std::integral_constant<int, 1>{});
  r.found = true;
  return r;
}

}  // namespace cdsm
