// Reference renderer: parity-based interiors, exact Beer-Lambert for
// constant media, fine Simpson marching for volumes, shadow rays.
#include "reference/reference.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "hd/bvh.h"
#include "hd/volume.h"
#if CDSM_HAVE_NANOVDB
#include "scene/nano_blocks.h"
#endif

namespace cdsm {

namespace {

// The index-space box outside which a sample of volume v reads only the
// background: a trilinear sample at q reads voxels floor(q) .. floor(q) + 1,
// so one voxel of reach around the stored values. Dense: the grid. Sparse:
// every leaf and every tile holding a non-background value, from the tree.
void value_box(const SceneView& s, const VolumeData& v, Vec3& lo, Vec3& hi) {
  lo = Vec3{3e38f, 3e38f, 3e38f};
  hi = Vec3{-3e38f, -3e38f, -3e38f};
  auto grow = [&](float x0, float y0, float z0, float x1, float y1, float z1) {
    lo = vmin(lo, Vec3{x0 - 1.0f, y0 - 1.0f, z0 - 1.0f});
    hi = vmax(hi, Vec3{x1 + 1.0f, y1 + 1.0f, z1 + 1.0f});
  };
  if (v.grid_kind == GridKind::Dense) {
    grow(0, 0, 0, float(v.nx - 1), float(v.ny - 1), float(v.nz - 1));
    return;
  }
#if CDSM_HAVE_NANOVDB
  for_each_value_block(nano_grid(s, v)->tree(), [&](const nanovdb::Coord& o, int dim) {
    grow(float(o[0]), float(o[1]), float(o[2]), float(o[0] + dim - 1), float(o[1] + dim - 1), float(o[2] + dim - 1));
  });
#endif
}

}  // namespace

ReferenceRenderer::ReferenceRenderer(const SceneView& scene, std::vector<LightData> lights, ReferenceOptions opt)
    : scene_(scene), lights_(std::move(lights)), opt_(opt) {
  caster_words_.assign((scene.objects.size() + 31) / 32, 0u);
  for (uint32_t o = 0; o < scene.objects.size(); ++o)
    if (scene.objects[o].flags & kObjCastsShadows) caster_words_[o >> 5] |= 1u << (o & 31u);
  for (uint32_t vi = 0; vi < scene.volumes.size(); ++vi) {
    ValueBox b;
    value_box(scene, scene.volumes[vi], b.lo, b.hi);
    value_boxes_.push_back(b);
  }
  if (!scene.bvh.empty()) {
    scene_lo_ = scene.bvh[0].lo;
    scene_hi_ = scene.bvh[0].hi;
  }
}

Vec3 ReferenceRenderer::light_origin(const LightData& L, Vec3 p) const {
  if (L.type != LightType::Directional) return L.position;
  return outside_along(p, L.direction * -1.0f);
}

// Where the ray from p along unit u has left the scene's box (its nearest
// slab exit), then a margin of a thousandth of the box. The far exit
// instead put the origin of a point among 1 cm pebbles on a 3 km ground
// 8 km away, where 2e-5 of the distance (surfaces that touch,
// kRelativeDepthOffset) is 16 cm: the pebbles' own tops and the ground
// under them touched their undersides; and a margin of 1 m put it 1 m away
// in a scene 0.3 m across. Each ray of a sun with a size leaves along its
// own direction: the central ray's length along a ray 1 degree below it
// can end under a caster.
Vec3 ReferenceRenderer::outside_along(Vec3 p, Vec3 u) const {
  float t_exit = 3.0e38f;
  for (int k = 0; k < 3; ++k) {
    if (u[k] > 0.0f) t_exit = std::min(t_exit, (scene_hi_[k] - p[k]) / u[k]);
    if (u[k] < 0.0f) t_exit = std::min(t_exit, (scene_lo_[k] - p[k]) / u[k]);
  }
  if (!(t_exit < 3.0e38f)) t_exit = 0.0f;  // u = 0 (no direction)
  t_exit = std::max(t_exit, 0.0f);
  const float margin = 1e-3f * length(scene_hi_ - scene_lo_);  // relative: the same origin at every scale
  return p + u * (t_exit + margin);
}

void ReferenceRenderer::hits_along(Vec3 org, Vec3 dir, float tmax, ObjectMask mask, std::vector<Hit>& out) const {
  out.clear();
  for_each_hit(scene_, mask, org, dir, 0.0f, tmax, [&](uint32_t tri, const TriHit& h) {
    const uint32_t o = scene_.tri_object[tri];
    const bool front = dot(geometric_normal(scene_, tri), dir) < 0.0f;
    out.push_back({h.t, o, surface_rank((scene_.objects[o].flags & kObjClosed) != 0u, front)});
  });
  std::sort(out.begin(), out.end(),
            [](const Hit& a, const Hit& b) { return a.t != b.t ? a.t < b.t : a.object < b.object; });
}

// The ray's interval inside volume vi's value box (slabs in index space),
// intersected with [ta, tb]; empty when tb <= ta on return.
void ReferenceRenderer::clip_to_value_box(uint32_t vi, Vec3 qo, Vec3 qd, float& ta, float& tb) const {
  const ValueBox& box = value_boxes_[vi];
  for (int a = 0; a < 3; ++a) {
    if (qd[a] == 0.0f) {
      if (qo[a] < box.lo[a] || qo[a] > box.hi[a]) tb = ta - 1.0f;  // parallel and outside
      continue;
    }
    float u = (box.lo[a] - qo[a]) / qd[a], w = (box.hi[a] - qo[a]) / qd[a];
    ta = std::max(ta, std::min(u, w));
    tb = std::min(tb, std::max(u, w));
  }
}

// Simpson at <= step_voxels inside the volume's value box (every sample
// read from the grid: no skipping), the background's extinction exactly
// outside it.
ReferenceRenderer::Depth ReferenceRenderer::optical_depth_volume(uint32_t vi, Vec3 org, Vec3 dir, float t0,
                                                                 float t1) const {
  const VolumeData& v = scene_.volumes[vi];
  const float h = opt_.step_voxels * v.voxel_world;
  const Vec3 qo = v.world_to_index.point(org), qd = v.world_to_index.vector(dir);
  const Vec3 bg_ext = apply_transfer(v.tf, v.background).extinction;
  float ta = t0, tb = t1;
  clip_to_value_box(vi, qo, qd, ta, tb);
  Depth tau;
  if (!(tb > ta)) {
    tau = {double(bg_ext.x) * double(t1 - t0), double(bg_ext.y) * double(t1 - t0), double(bg_ext.z) * double(t1 - t0)};
    return tau;
  }
  const double outside = double((ta - t0) + (t1 - tb));
  tau = {double(bg_ext.x) * outside, double(bg_ext.y) * outside, double(bg_ext.z) * outside};
  // Simpson's rule, two panels per step of at most h (fourth order where the
  // integrand is smooth; second order at the transfer function's kinks).
  const int n = 2 * std::max(1, int(std::ceil((tb - ta) / h)));
  const double dt = (double(tb) - ta) / double(n);
  auto sigma_at = [&](double t) {
    return apply_transfer(v.tf, density_at_index(scene_, v, qo + qd * float(t))).extinction;
  };
  Vec3 f0 = sigma_at(ta);
  for (int i = 0; i < n; ++i) {
    double a = ta + double(i) * dt;
    const Vec3 fm = sigma_at(a + 0.5 * dt), f1 = sigma_at(a + dt);
    tau.r += (double(f0.x) + 4.0 * fm.x + f1.x) * (dt / 6.0);
    tau.g += (double(f0.y) + 4.0 * fm.y + f1.y) * (dt / 6.0);
    tau.b += (double(f0.z) + 4.0 * fm.z + f1.z) * (dt / 6.0);
    f0 = f1;
  }
  return tau;
}

namespace {

// Parity intervals of one closed object along a ray starting at t = 0: the
// ray is inside where an odd number of that object's hits lie beyond.
template <class F>
void for_each_inside_interval(const std::vector<float>& ts, float t_end, F&& f) {
  size_t n = ts.size();
  bool inside = (n & 1u) != 0u;
  float start = 0.0f;
  for (size_t i = 0; i < n; ++i) {
    if (inside)
      f(start, std::min(ts[i], t_end));
    else
      start = ts[i];
    inside = !inside;
    if (ts[i] >= t_end) return;
  }
  if (inside) f(start, t_end);
}

}  // namespace

Vec3 ReferenceRenderer::transmittance_segment(Vec3 a, Vec3 b) const {
  return transmittance_segment(a, b, ObjectMask{}, End{});
}

ReferenceRenderer::End ReferenceRenderer::end_of(const Receiver& r, float dist) {
  End e;
  e.surface = dot(r.plane, r.plane) > 0.0f;
  e.own = r.object;
  e.own_window = 1e-3f * dist;
  return e;
}

Vec3 ReferenceRenderer::transmittance_segment(Vec3 a, Vec3 b, ObjectMask members, const End& end) const {
  Vec3 d = b - a;
  float dist = length(d);
  if (dist <= 0.0f) return vec3(1.0f);
  Vec3 dir = d * (1.0f / dist);
  thread_local std::vector<Hit> hits;
  hits_along(a, dir, 3.0e38f, ObjectMask{{caster_words_.data(), caster_words_.size()}}, hits);
  // The receiver's own surface: the hit of its object nearest to b.
  const Hit* own = nullptr;
  if (end.surface && end.own != kNoObject)
    for (const Hit& h : hits)
      if (h.object == end.own && std::fabs(h.t - dist) <= end.own_window &&
          (!own || std::fabs(h.t - dist) < std::fabs(own->t - dist)))
        own = &h;
  const uint32_t rank = own ? own->rank : kRankEntry;
  const float touch = end.surface ? kRelativeDepthOffset * dist : 0.0f;
  double T[3] = {1.0, 1.0, 1.0};
  // Surfaces crossed in front of the point, each passing 1 - absorb_k per
  // channel; of those touching it, another object's of lower rank.
  for (const Hit& h : hits) {
    if (end.surface ? h.t > dist + touch : h.t >= dist) break;
    if (&h == own || !members.contains(h.object)) continue;
    if (end.surface && h.t >= dist - touch && (h.object == end.own || h.rank >= rank)) continue;
    const Vec3 ab = scene_.objects[h.object].absorb;
    for (int k = 0; k < 3; ++k) T[k] *= 1.0 - double(ab[k]);
  }
  // Interiors, object by object, by parity over the whole ray.
  Depth tau;
  thread_local std::vector<float> ts;
  for (uint32_t o = 0; o < scene_.objects.size(); ++o) {
    const ObjectData& od = scene_.objects[o];
    if (od.interior == InteriorKind::None || !(od.flags & kObjClosed) || !(od.flags & kObjCastsShadows) ||
        !members.contains(o))
      continue;
    ts.clear();
    for (const Hit& h : hits)
      if (h.object == o) ts.push_back(h.t);
    if (ts.empty()) continue;
    for_each_inside_interval(ts, dist, [&](float t0, float t1) {
      if (t1 <= t0) return;
      if (od.interior == InteriorKind::Constant) {
        tau.r += double(od.sigma.x) * (t1 - t0);
        tau.g += double(od.sigma.y) * (t1 - t0);
        tau.b += double(od.sigma.z) * (t1 - t0);
      } else if (od.volume >= 0) {
        const Depth v = optical_depth_volume(uint32_t(od.volume), a, dir, t0, t1);
        tau.r += v.r;
        tau.g += v.g;
        tau.b += v.b;
      }
    });
  }
  return {float(T[0] * std::exp(-tau.r)), float(T[1] * std::exp(-tau.g)), float(T[2] * std::exp(-tau.b))};
}

Vec3 ReferenceRenderer::transmittance(int light, Vec3 p) const {
  const LightData& L = lights_[size_t(light)];
  const int n = area_sample_count(L);
  Vec3 sum{0, 0, 0};
  for (int k = 0; k < n; ++k) sum += transmittance_segment(area_origin(L, p, k, n), p);
  return sum * (1.0f / float(n));
}

int ReferenceRenderer::area_sample_count(const LightData& L) const {
  if (!(L.size > 0.0f)) return 1;
  const int side = std::max(1, int(std::sqrt(double(std::max(opt_.area_samples, 1)))));
  return side * side;
}

Vec3 ReferenceRenderer::area_origin(const LightData& L, Vec3 p, int k, int n) const {
  const Vec3 center = light_origin(L, p);
  if (!(L.size > 0.0f) || n <= 1) return center;
  // Stratum (i, j) with a jitter hashed from p and k: the same rays for the
  // same point (a deterministic image), decorrelated between points.
  const int side = int(std::lround(std::sqrt(double(n))));
  uint32_t h = 2166136261u;
  for (float c : {p.x, p.y, p.z}) {
    uint32_t b;
    std::memcpy(&b, &c, 4);
    h = (h ^ b) * 16777619u;
  }
  auto next = [&h]() {
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    h *= 0x297a2d39u;
    h ^= h >> 15;
    return float(h >> 8) * (1.0f / 16777216.0f);
  };
  h ^= uint32_t(k) * 0x9e3779b9u;
  const float u = (float(k % side) + next()) / float(side) * 2.0f - 1.0f;
  const float v = (float(k / side) + next()) / float(side) * 2.0f - 1.0f;
  // Concentric map of the square [-1, 1]^2 onto the unit disk (equal area).
  float r = 0.0f, phi = 0.0f;
  if (u != 0.0f || v != 0.0f) {
    if (std::fabs(u) > std::fabs(v)) {
      r = u;
      phi = 0.78539816f * (v / u);
    } else {
      r = v;
      phi = 1.57079633f - 0.78539816f * (u / v);
    }
  }
  const Vec3 axis = normalize(center - p);  // toward the light
  Vec3 e1 = normalize(cross(axis, std::fabs(axis.y) < 0.9f ? Vec3{0, 1, 0} : Vec3{1, 0, 0}));
  Vec3 e2 = cross(axis, e1);
  const Vec3 offset = e1 * (r * std::cos(phi)) + e2 * (r * std::sin(phi));
  if (L.type == LightType::Directional)  // a direction within the cone: tan(angle) = size at unit distance
    return outside_along(p, normalize(axis + offset * L.size));
  return center + offset * L.size;  // the sphere's disk facing p
}

Vec3 ReferenceRenderer::transmittance(int light, const Receiver& r) const {
  const LightData& L = lights_[size_t(light)];
  const int n = area_sample_count(L);
  Vec3 sum{0, 0, 0};
  for (int k = 0; k < n; ++k) {
    const Vec3 a = area_origin(L, r.p, k, n);
    sum += transmittance_segment(a, r.p, ObjectMask{}, end_of(r, length(r.p - a)));
  }
  return sum * (1.0f / float(n));
}

void ReferenceRenderer::render(const CameraPassParams& params, std::vector<float>& rgb) const {
  const PinholeView& view = params.view;
  const int w = view.width, h = view.height;
  rgb.assign(size_t(w) * h * 3, 0.0f);
  Span<const LightData> lights{lights_.data(), lights_.size()};
  auto visibility = [&](int light, const Receiver& r) { return transmittance(light, r); };
  std::atomic<uint32_t> rows_started{0};
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    std::vector<Hit> hits;
    std::vector<float> ts;
    for (int py = rows.begin(); py < rows.end(); ++py) {
      if (opt_.cancel && opt_.cancel->load(std::memory_order_relaxed)) return;
      const uint32_t started = rows_started.fetch_add(1, std::memory_order_relaxed) + 1;
      if (opt_.progress) opt_.progress->store(float(started) / float(h), std::memory_order_relaxed);
      for (int px = 0; px < w; ++px) {
        Vec3 dir = pixel_ray(view, px, py);
        float c = dot(dir, view.forward);
        float t_far = view.far / c;
        hits_along(view.eye, dir, 3.0e38f, ObjectMask{}, hits);
        Vec3 color{0, 0, 0};
        double T[3] = {1.0, 1.0, 1.0};  // per channel
        // Every channel past the camera pass's stop.
        auto done = [&] { return std::max({T[0], T[1], T[2]}) < 1.0 - kCompositeStop; };
        // Media absorb from the eye to far; only surfaces are clipped to
        // [near, far] (view axis). Every hit up to far splits the ray, so
        // each interval's media follow from parity at its midpoint.
        float t_prev = 0.0f;
        auto interval_media = [&](float ta, float tb, auto&& on_medium) {
          // Which interiors enclose (ta, tb)? Parity of each object's hits beyond the midpoint.
          float tm = 0.5f * (ta + tb);
          for (uint32_t o = 0; o < scene_.objects.size(); ++o) {
            const ObjectData& od = scene_.objects[o];
            if (od.interior == InteriorKind::None || !(od.flags & kObjClosed)) continue;
            uint32_t beyond = 0, any = 0;
            for (const Hit& hh : hits)
              if (hh.object == o) {
                ++any;
                if (hh.t > tm) ++beyond;
              }
            if (any && (beyond & 1u)) on_medium(o);
          }
        };
        auto shade_interval = [&](float ta, float tb) {
          if (tb <= ta || done()) return;
          Vec3 sigma{0, 0, 0};
          uint32_t vols[kMaxEnclosing];
          int nv = 0;
          float step = 3e38f;
          interval_media(ta, tb, [&](uint32_t o) {
            const ObjectData& od = scene_.objects[o];
            if (od.interior == InteriorKind::Constant)
              sigma = sigma + od.sigma;
            else if (od.volume >= 0 && nv < kMaxEnclosing) {
              vols[nv++] = uint32_t(od.volume);
              step = std::min(step, opt_.step_voxels * scene_.volumes[uint32_t(od.volume)].voxel_world);
            }
          });
          // Volumes read only their background outside their value boxes:
          // where every background is clear, march only the boxes' hull and
          // let the constant media absorb the rest exactly.
          float ma = tb, mb = ta;
          for (int k = 0; k < nv; ++k) {
            const VolumeData& v = scene_.volumes[vols[k]];
            float ca = ta, cb = tb;
            if (max_channel(apply_transfer(v.tf, v.background).extinction) <= 0.0f)
              clip_to_value_box(vols[k], v.world_to_index.point(view.eye), v.world_to_index.vector(dir), ca, cb);
            if (cb > ca) {
              ma = std::min(ma, ca);
              mb = std::max(mb, cb);
            }
          }
          if (!(mb > ma)) nv = 0;
          if (nv == 0) {
            for (int k = 0; k < 3; ++k) T[k] *= std::exp(-double(sigma[k]) * (tb - ta));
            return;
          }
          for (int k = 0; k < 3; ++k) T[k] *= std::exp(-double(sigma[k]) * (ma - ta));
          const float end = tb;
          ta = ma;
          tb = mb;
          int n = std::max(1, int(std::ceil((tb - ta) / step)));
          float dt = (tb - ta) / float(n);
          for (int i = 0; i < n && !done(); ++i) {
            Vec3 p = view.eye + dir * (ta + (float(i) + 0.5f) * dt);
            Vec3 ext = sigma, vol_ext{0, 0, 0};
            float best = 0.0f;
            Vec3 col{0, 0, 0};
            int dom = -1;
            for (int k = 0; k < nv; ++k) {
              const VolumeData& v = scene_.volumes[vols[k]];
              TransferSample ts2 = apply_transfer(v.tf, density_at(scene_, v, p));
              ext += ts2.extinction;
              vol_ext += ts2.extinction;
              col += ts2.color * ts2.extinction;
              if (max_channel(ts2.extinction) > best) {
                best = max_channel(ts2.extinction);
                dom = k;
              }
            }
            double a[3];
            for (int k = 0; k < 3; ++k) a[k] = 1.0 - std::exp(-double(ext[k]) * dt);
            if (std::max({a[0], a[1], a[2]}) <= 0.0) continue;
            if (max_channel(vol_ext) > 0.0f && dom >= 0) {
              const VolumeData& v = scene_.volumes[vols[dom]];
              Vec3 base{0, 0, 0};
              for (int k = 0; k < 3; ++k) base[k] = vol_ext[k] > 0.0f ? col[k] / vol_ext[k] : 0.0f;
              const ShadeInput in = volume_sample_shading(scene_, v, p, dir, base);
              Vec3 c = shade_point(in, lights, params.ambient, visibility);
              for (int k = 0; k < 3; ++k)
                if (ext[k] > 0.0f) color[k] += c[k] * float(T[k] * a[k] * (vol_ext[k] / ext[k]));
            }
            for (int k = 0; k < 3; ++k) T[k] *= 1.0 - a[k];
          }
          for (int k = 0; k < 3; ++k) T[k] *= std::exp(-double(sigma[k]) * (end - tb));
        };
        for (const Hit& hh : hits) {
          if (hh.t > t_far) break;
          shade_interval(t_prev, hh.t);
          t_prev = std::max(t_prev, hh.t);
          if (done()) break;
          float ax = hh.t * c;
          if (ax < view.near || ax > view.far) continue;  // a clipped surface
          const ObjectData& od = scene_.objects[hh.object];
          if (passes_all(od)) continue;
          if (od.opacity <= 0.0f) {  // a pure filter
            for (int k = 0; k < 3; ++k) T[k] *= 1.0 - double(od.absorb[k]);
            continue;
          }
          // Find the triangle again for the normal: nearest hit of this object at hh.t.
          Vec3 p = view.eye + dir * hh.t;
          uint32_t tri_found = od.first_tri;
          float best = 3e38f;
          for_each_hit(scene_, ObjectMask{}, view.eye, dir, hh.t * (1 - 1e-6f) - 1e-7f, hh.t * (1 + 1e-6f) + 1e-7f,
                       [&](uint32_t tri, const TriHit& th) {
                         if (scene_.tri_object[tri] == hh.object && std::fabs(th.t - hh.t) < best) {
                           best = std::fabs(th.t - hh.t);
                           tri_found = tri;
                         }
                       });
          ShadeInput in;
          in.p = p;
          in.n = surface_normal(scene_, tri_found, p, dir);
          in.v = -dir;
          in.color = od.color;
          in.ka = od.ka;
          in.kd = od.kd;
          in.ks = od.ks;
          in.shininess = od.shininess;
          in.has_normal = true;
          in.plane = geometric_normal(scene_, tri_found);  // a surface: its own hit is left out by identity
          in.object = hh.object;
          Vec3 col = shade_point(in, lights, params.ambient, visibility);
          for (int k = 0; k < 3; ++k) {
            color[k] += col[k] * float(T[k] * od.opacity);
            T[k] *= 1.0 - double(od.absorb[k]);
          }
        }
        if (!done()) shade_interval(t_prev, t_far);
        color += params.background * Vec3{float(T[0]), float(T[1]), float(T[2])};
        float* o = rgb.data() + (size_t(py) * w + px) * 3;
        o[0] = color.x;
        o[1] = color.y;
        o[2] = color.z;
      }
    }
  });
}

}  // namespace cdsm
