// Frame orchestration behind cdsm::Renderer: compile the scene, build the
// lights' deep shadow maps, run the camera pass, and measure the error
// against the reference renderer on request.
#include "cdsm/renderer.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "cdsm/error.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
#include "frame_snapshot.h"
#include "hashing.h"
#include "reference/lookup_recorder.h"
#include "reference/reference.h"
#include "scene_sync.h"
#include "stopwatch.h"

namespace cdsm {
namespace {

// One compared lookup: its map, resolution and total error, weight, class.
struct PointError {
  float map, resolution, total, weight;
  bool edge;
};
// Per colour channel.
struct PointErrorRgb {
  PointError channel[3];
};

// Weighted mean, RMSE, max and 99th percentile of one kind of error.
ErrorSummary summarize(std::vector<std::pair<float, float>> e) {  // (error, weight)
  ErrorSummary s;
  double sw = 0, se = 0, se2 = 0;
  for (const auto& [err, w] : e) {
    sw += w;
    se += double(w) * err;
    se2 += double(w) * err * err;
    s.max = std::max(s.max, double(err));
  }
  if (sw <= 0.0) return s;
  s.mean = se / sw;
  s.rmse = std::sqrt(se2 / sw);
  std::sort(e.begin(), e.end());
  double acc = 0;
  s.p99 = e.back().first;
  for (const auto& [err, w] : e) {
    acc += w;
    if (acc >= 0.99 * sw) {
      s.p99 = err;
      break;
    }
  }
  return s;
}

// The decomposition over all points and per class (edge, interior).
TransmittanceError summarize_errors(const std::vector<PointError>& pts) {
  TransmittanceError e;
  e.points = pts.size();
  if (pts.empty()) return e;
  auto pick = [&](int cls, float PointError::*field) {  // cls: -1 all, 0 interior, 1 edge
    std::vector<std::pair<float, float>> v;
    for (const PointError& p : pts)
      if (cls < 0 || int(p.edge) == cls) v.push_back({p.*field, p.weight});
    return summarize(std::move(v));
  };
  e.map = pick(-1, &PointError::map);
  e.resolution = pick(-1, &PointError::resolution);
  e.total = pick(-1, &PointError::total);
  e.mean = e.total.mean;
  e.p99 = e.total.p99;
  e.max = e.total.max;
  e.rmse = e.total.rmse;
  size_t edges = 0;
  for (const PointError& p : pts) edges += p.edge;
  for (int cls = 0; cls < 2; ++cls) {
    ErrorClass& c = cls ? e.edge : e.interior;
    c.share = double(cls ? edges : pts.size() - edges) / double(pts.size());
    c.map = pick(cls, &PointError::map);
    c.resolution = pick(cls, &PointError::resolution);
    c.total = pick(cls, &PointError::total);
  }
  return e;
}

// Figure by figure, the larger of two channels' errors.
ErrorSummary max_of(const ErrorSummary& a, const ErrorSummary& b) {
  return {std::max(a.mean, b.mean), std::max(a.p99, b.p99), std::max(a.max, b.max), std::max(a.rmse, b.rmse)};
}
ErrorClass max_of(const ErrorClass& a, const ErrorClass& b) {
  ErrorClass c = a;
  c.share = std::max(a.share, b.share);
  c.map = max_of(a.map, b.map);
  c.resolution = max_of(a.resolution, b.resolution);
  c.total = max_of(a.total, b.total);
  return c;
}
TransmittanceError max_of(const TransmittanceError& a, const TransmittanceError& b) {
  TransmittanceError e = a;
  e.mean = std::max(a.mean, b.mean);
  e.p99 = std::max(a.p99, b.p99);
  e.max = std::max(a.max, b.max);
  e.rmse = std::max(a.rmse, b.rmse);
  e.map = max_of(a.map, b.map);
  e.resolution = max_of(a.resolution, b.resolution);
  e.total = max_of(a.total, b.total);
  e.edge = max_of(a.edge, b.edge);
  e.interior = max_of(a.interior, b.interior);
  return e;
}

}  // namespace

struct Renderer::Impl {
  // The persistent state: a Scene value is synced into it by identity
  // (sync_scene), so frames cost what changed.
  std::unique_ptr<ShadowSystem> system = std::make_unique<ShadowSystem>();
  FragmentSource fragments = FragmentSource::Auto;
  Backend backend = Backend::Cpu;  // the system's (Reference renders through a cpu system)
  Image last_reference;
  // Popping probe: the previous frame's maps and its sampled receivers.
  struct Previous {
    bool valid = false;
    LightSetup setup;
    std::vector<MapId> maps;      // alive in the backend until the next update (keep_previous)
    std::vector<DsmMap> headers;  // fetched again at each measurement (compaction moves maps)
    ShadowSettings settings;
    std::vector<Receiver> receivers;
  } previous;

  // The system for `scene` with these options (a new fragment source or
  // backend starts a new system), synced to it by edits. Validation and
  // the memory check are the system's, once per update().
  void sync(const Scene& scene, const RenderOptions& opt) {
    const Backend want = opt.backend == Backend::Reference ? Backend::Cpu : opt.backend;
    if (opt.fragments != fragments || want != backend) {
      SystemOptions so{opt.fragments, scene.source};
      so.backend = want;
      system = std::make_unique<ShadowSystem>(so);
      fragments = opt.fragments;
      backend = want;
      previous = Previous{};
    }
    sync_scene(*system, scene);
    SystemHooks::keep_replaced_maps(*system, opt.measure_popping);
  }

  TransmittanceError probe_error(const RenderOptions& opt, const FrameSnapshot& f) {
    SceneView sv = f.scene_view();
    ShadowView shv = f.shadow_view();
    DsmVisibility vis{shv};
    const CameraPassParams& cam = f.camera();
    const int w = cam.view.width, h = cam.view.height;
    // Stratified pixels: one jittered pixel per cell of a grid with about
    // error_samples / 2 cells (rays yield several lookups each), shaded by
    // the camera pass with its own visibility functor, each lookup recorded
    // (shadows/cpu/lookup_recorder.h): the probe measures what the image uses.
    int cells = std::max(1, opt.error_samples / 2);
    double cell = std::sqrt(double(w) * h / double(cells));
    int gx = std::max(1, int(std::ceil(w / cell))), gy = std::max(1, int(std::ceil(h / cell)));
    std::vector<std::vector<RecordedLookup>> per_row(static_cast<size_t>(gy));
    const FragmentLists camera_lists = f.camera_fragments();
    // Cells finer than pixels (small images) pick the same pixel from
    // different rows: each walk sorts a copy of the pixel's list, never the
    // shared one (found by ThreadSanitizer).
    tbb::parallel_for(0, gy, [&](int cy) {
      WalkStats ws;
      std::vector<Fragment> frags;
      for (int cx = 0; cx < gx; ++cx) {
        uint32_t hsh = mix32(uint32_t(cy * 7919 + cx * 104729 + 17));
        int px = std::min(w - 1, int((cx + (hsh & 0xffff) / 65536.0) * w / gx));
        int py = std::min(h - 1, int((cy + (hsh >> 16) / 65536.0) * h / gy));
        Span<Fragment> shared = camera_lists.pixel(px, py);
        frags.assign(shared.begin(), shared.end());
        record_pixel_lookups(sv, shv.lights, vis, cam, Span<Fragment>{frags.data(), frags.size()}, px, py,
                             per_row[size_t(cy)], ws);
      }
    });
    std::vector<RecordedLookup> lookups;
    for (auto& r : per_row) lookups.insert(lookups.end(), r.begin(), r.end());
    if (lookups.size() > size_t(opt.error_samples)) {  // deterministic thinning
      std::vector<RecordedLookup> kept;
      double stride = double(lookups.size()) / opt.error_samples;
      for (int i = 0; i < opt.error_samples; ++i) kept.push_back(lookups[size_t(i * stride)]);
      lookups.swap(kept);
    }
    const LightSetup& setup = f.frame().setup;
    ReferenceRenderer ref(sv, setup.lights, ReferenceOptions{opt.reference_step_voxels});
    // Each map's members, for the filtered exact reference of its taps.
    std::vector<std::vector<uint32_t>> member_words(setup.maps.size());
    for (size_t k = 0; k < member_words.size(); ++k) {
      member_words[k].assign((sv.objects.size() + 31) / 32, 0u);
      for (uint32_t o : setup.maps[k].members) member_words[k][o >> 5] |= 1u << (o & 31u);
    }
    // T_f's taps read at the receiver's plane along their rays (volume
    // samples: at their depth) whatever the lookup does, so the resolution
    // error is the same for every receiver lookup and the map error holds
    // the lookup's offsets.
    ShadowView exact_taps = shv;
    exact_taps.receiver = ReceiverLookup::Plane;
    std::vector<PointErrorRgb> errors(lookups.size());
    tbb::parallel_for(size_t(0), lookups.size(), [&](size_t i) {
      const RecordedLookup& l = lookups[i];
      const LightData& L = shv.lights[uint32_t(l.light)];
      Vec3 tap_lo{1, 1, 1}, tap_hi{0, 0, 0};
      // T_f: the lookup's own maps, taps, weights and depths (hd/lights.h),
      // each tap's texel exact through its map's members, per channel.
      const Vec3 alpha_f = combine_maps(shv, L, l.at.p, [&](uint32_t k, const DsmMap& m, const ViewProjection& pr) {
        const ObjectMask members{{member_words[k].data(), member_words[k].size()}};
        Vec3 a{0, 0, 0};
        for_each_tap(m, pr.u, pr.v, shv.filtering, [&](int tx, int ty, float w) {
          const Vec3 d = normalize(view_direction(m.view, float(tx) + 0.5f, float(ty) + 0.5f));
          const float depth = tap_depth(exact_taps, m, pr, l.at, tx, ty);
          const Vec3 q = pixel_origin(m.view, tx, ty) + d * depth;
          // The receiver's own surface by identity, searched as the lookup
          // searches its own step (hd/lights.h receiver_read_at).
          ReferenceRenderer::End end;
          end.surface = dot(l.at.plane, l.at.plane) > 0.0f;
          end.own = l.at.object;
          end.own_window = receiver_read_at(exact_taps, m, pr, l.at, depth).window;
          const Vec3 te = ref.transmittance_segment(ref.light_origin(L, q), q, members, end);
          tap_lo = vmin(tap_lo, te);
          tap_hi = vmax(tap_hi, te);
          a = a + one_minus(te) * w;
        });
        return a;
      });
      const Vec3 t_f = one_minus(alpha_f), t_exact = ref.transmittance(l.light, l.at);
      // A light with a size, looked up soft: the maps' own error is the
      // hard lookup's against its exact taps (what the maps store); the
      // rest — penumbra estimate, filter and texel grid together — is not
      // separated: resolution = total = |T_soft - T_area reference|.
      const bool soft = L.size > 0.0f && shv.penumbra != Penumbra::Hard;
      Vec3 t_map = l.transmittance;
      if (soft) {
        ShadowView hard = shv;
        hard.penumbra = Penumbra::Hard;
        t_map = one_minus(shadow_alpha(hard, L, l.at));
      }
      // Edge: the taps' exact transmittances, and the point's own, differ by
      // more than 0.05 in some channel (the point's own: a feature finer
      // than a texel, which all taps miss or all taps see).
      tap_lo = vmin(tap_lo, t_exact);
      tap_hi = vmax(tap_hi, t_exact);
      const bool edge = max_channel(tap_hi - tap_lo) > 0.05f;
      for (int k = 0; k < 3; ++k)
        errors[i].channel[k] = {std::fabs(t_map[k] - t_f[k]),
                                std::fabs((soft ? l.transmittance[k] : t_f[k]) - t_exact[k]),
                                std::fabs(l.transmittance[k] - t_exact[k]), l.weight, edge};
    });
    // CDSM_PROBE_DUMP=FILE: every compared lookup, one line each (README).
    if (const char* dump = std::getenv("CDSM_PROBE_DUMP")) {
      FILE* fo = std::fopen(dump, "w");
      if (!fo) throw Error(dump, "cannot write the probe dump (CDSM_PROBE_DUMP)");
      std::fprintf(fo, "# x y z  plane_x plane_y plane_z object  T_dsm map_error resolution_error total_error edge\n");
      for (size_t i = 0; i < lookups.size(); ++i) {
        const RecordedLookup& l = lookups[i];
        std::fprintf(fo, "%g %g %g  %g %g %g %d  %g %g %g %g %d\n", l.at.p.x, l.at.p.y, l.at.p.z, l.at.plane.x,
                     l.at.plane.y, l.at.plane.z, l.at.object == kNoObject ? -1 : int(l.at.object),
                     grey_of(l.transmittance), errors[i].channel[0].map, errors[i].channel[0].resolution,
                     errors[i].channel[0].total, int(errors[i].channel[0].edge));
      }
      std::fclose(fo);
    }
    // Each figure per channel; reported: the largest over the channels.
    TransmittanceError worst;
    for (int k = 0; k < 3; ++k) {
      std::vector<PointError> one(errors.size());
      for (size_t i = 0; i < errors.size(); ++i) one[i] = errors[i].channel[k];
      const TransmittanceError e = summarize_errors(one);
      worst = k == 0 ? e : max_of(worst, e);
      worst.channel_mean[k] = e.mean;
    }
    return worst;
  }

  // Surface points of the camera view on a coarse grid (receivers for the
  // popping probe: the first surface receiver each pixel's camera pass asks
  // a light about, with its plane and identity).
  std::vector<Receiver> sample_receivers(const FrameSnapshot& f) {
    SceneView sv = f.scene_view();
    struct FirstSurface {
      Receiver* r;
      bool* found;
      Vec3 operator()(int, const Receiver& rc) const {
        if (!*found && dot(rc.plane, rc.plane) > 0.0f) {
          *r = rc;
          *found = true;
        }
        return vec3(1.0f);
      }
    };
    const ShadowView shv = f.shadow_view();
    std::vector<Receiver> out;
    const CameraPassParams& cam = f.camera();
    const int w = cam.view.width, h = cam.view.height;
    const int g = 48;
    FragmentLists lists = f.camera_fragments();
    for (int gy = 0; gy < g; ++gy)
      for (int gx = 0; gx < g; ++gx) {
        int px = std::min(w - 1, (2 * gx + 1) * w / (2 * g)), py = std::min(h - 1, (2 * gy + 1) * h / (2 * g));
        Receiver r{};
        bool found = false;
        FirstSurface vis{&r, &found};
        NoRecorder rec;
        WalkStats ws;
        shade_pixel(sv, shv.lights, vis, cam, lists.pixel(px, py), px, py, rec, ws);
        if (found) out.push_back(r);
      }
    return out;
  }

  // |T_new - T_old| at the previous frame's receivers, when maps changed.
  // The previous frame's replaced maps are alive until the next update
  // (keep_previous), so both lookups read the backend's store.
  void measure_popping(const FrameSnapshot& f, FrameStats& st) {
    const ShadowFrame& now_frame = f.frame();
    if (previous.valid && now_frame.rebuilt > 0 && now_frame.previous_kept &&
        previous.setup.lights.size() == now_frame.setup.lights.size()) {
      ShadowView now = f.shadow_view();
      previous.headers.clear();
      for (MapId id : previous.maps) previous.headers.push_back(f.backend().map_header(id));
      ShadowView before = now;
      before.lights = {previous.setup.lights.data(), previous.setup.lights.size()};
      before.maps = {previous.headers.data(), previous.headers.size()};
      set_lookup(before, previous.settings);
      double sum = 0.0, mx = 0.0;
      uint64_t n = 0;
      std::vector<double> changes;
      for (const Receiver& r : previous.receivers)
        for (uint32_t li = 0; li < now.lights.size(); ++li) {
          if (cone_factor(now.lights[li], r.p) <= 0.0f) continue;
          const Vec3 a = shadow_alpha(now, now.lights[li], r);
          const Vec3 b = shadow_alpha(before, before.lights[li], r);
          const Vec3 diff = a - b;
          double d = double(max_channel(vmax(diff, -diff)));  // the largest channel's change
          sum += d;
          mx = std::max(mx, d);
          changes.push_back(d);
          ++n;
        }
      double p99 = 0.0;
      if (!changes.empty()) {
        const size_t k = std::min(changes.size() - 1, size_t(0.99 * double(changes.size())));
        std::nth_element(changes.begin(), changes.begin() + ptrdiff_t(k), changes.end());
        p99 = changes[k];
      }
      st.popping.measured = true;
      st.popping.points = n;
      st.popping.mean = n ? sum / double(n) : 0.0;
      st.popping.p99 = p99;
      st.popping.max = mx;
    }
    previous.setup = now_frame.setup;
    previous.maps = now_frame.maps;
    previous.settings = f.scene().shadows;
    previous.receivers = sample_receivers(f);
    previous.valid = true;
  }
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {}
Renderer::~Renderer() = default;

const Image& Renderer::last_reference() const { return impl_->last_reference; }

Image Renderer::render(const Scene& scene, const RenderOptions& opt, FrameStats* stats) {
  if (opt.backend == Backend::Reference) return render_reference(scene, opt, stats);
  FrameStats local;
  FrameStats& st = stats ? *stats : local;
  impl_->sync(scene, opt);
  Image img = impl_->system->render(&st);
  const FrameSnapshot f(*impl_->system);
  if (opt.measure_popping) {
    impl_->measure_popping(f, st);
  } else {
    impl_->previous.valid = false;
  }
  if (opt.compare_reference) {
    auto t0 = Clock::now();
    st.transmittance = impl_->probe_error(opt, f);
    impl_->last_reference = impl_->system->render_reference(opt.reference_step_voxels, opt.progress);
    st.image = compare_images(img, impl_->last_reference);
    st.has_reference = true;
    st.times.reference_ms = ms_since(t0);
  }
  return img;
}

Image Renderer::render_reference(const Scene& scene, const RenderOptions& opt, FrameStats* stats) {
  FrameStats local;
  FrameStats& st = stats ? *stats : local;
  st = FrameStats{};
  auto t0 = Clock::now();
  impl_->sync(scene, opt);
  auto t1 = Clock::now();
  Image img = impl_->system->render_reference(opt.reference_step_voxels, opt.progress);
  st.times.reference_ms = ms_since(t1);
  st.times.total_ms = ms_since(t0);
  st.lights = uint32_t(scene.lights.size());
  return img;
}

TransmittanceError Renderer::transmittance_error(const Scene& scene, const RenderOptions& opt) {
  FrameStats st;
  RenderOptions o = opt;
  o.backend = Backend::Cpu;
  impl_->sync(scene, o);
  impl_->system->render(&st);
  return impl_->probe_error(o, FrameSnapshot(*impl_->system));
}

}  // namespace cdsm
