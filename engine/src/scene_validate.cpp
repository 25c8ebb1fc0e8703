// Every numeric field of a scene against its documented range (README
// "Scene files"), for scenes from files and scenes built in code alike.
// Errors name the scene, the field as a JSON pointer, the value and the
// range; where a fallback is reasonable, a warning says what is used.
#include <cmath>
#include <string>
#include <type_traits>

#include "cdsm/config.h"
#include "cdsm/error.h"
#include "cdsm/fields.h"
#include "cdsm/method_params.h"
#include "cdsm/scene_io.h"

namespace cdsm {
namespace {

struct Checker {
  const Scene& s;
  std::vector<std::string>* warnings;

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw Error(s.source + ": " + path, what);
  }

  static std::string range(double lo, double hi, bool open_lo = false, bool open_hi = false) {
    return std::string(open_lo ? "(" : "[") + format_number(lo) + ", " + format_number(hi) + (open_hi ? ")" : "]");
  }

  void number(const std::string& path, double v, double lo, double hi, bool open_lo = false,
              bool open_hi = false) const {
    bool ok = std::isfinite(v) && (open_lo ? v > lo : v >= lo) && (open_hi ? v < hi : v <= hi);
    if (!ok) fail(path, "must be within " + range(lo, hi, open_lo, open_hi) + ", got " + format_number(v));
  }

  void integer(const std::string& path, int64_t v, int64_t lo, int64_t hi) const {
    if (v < lo || v > hi)
      fail(path, "must be within [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(v));
  }

  void finite(const std::string& path, Vec3 v) const {
    if (!is_finite(v)) fail(path, "has a NaN or infinite value");
  }

  // A colour: each channel within [0, 100] (linear RGB; > 1 is a light's or
  // an emitter's intensity, negative light does not exist).
  void color(const std::string& path, Vec3 c) const {
    for (int a = 0; a < 3; ++a) number(path + "/" + std::to_string(a), c[a], 0.0, 100.0);
  }

  // Three channels, each within [lo, hi].
  void channels(const std::string& path, Vec3 c, double lo, double hi) const {
    if (is_grey(c)) return number(path, c.x, lo, hi);  // given as one number (or three equal)
    for (int a = 0; a < 3; ++a) number(path + "/" + std::to_string(a), c[a], lo, hi);
  }

  void camera() const {
    const Camera& c = s.camera;
    fields(c, "/camera");
    // What a range cannot say.
    if (!(c.near > 0.0f) || !(c.far > c.near))
      fail("/camera",
           "needs 0 < near < far (finite), got near " + format_number(c.near) + ", far " + format_number(c.far));
    number("/camera/fov_y", c.fov_y_deg, 0.0, 179.0, true, true);
    Vec3 d = c.target - c.position;
    if (!(length(d) > 0.0f)) fail("/camera/target", "equals the camera position");
    Vec3 side = cross(normalize(d), c.up);
    if (warnings && !(length(side) >= 1e-6f * std::max(length(c.up), 1e-30f)))
      warnings->push_back(s.source + ": /camera/up is " +
                          (length(c.up) > 0.0f ? "parallel to the view direction" : "zero") +
                          "; a perpendicular up is used instead");
  }

  // Every field of S's table within its range (cdsm/fields.h).
  template <class S>
  void fields(const S& value, const std::string& at) const {
    for_each_field<S>([&](const auto& f) {
      const auto& v = value.*f.member;
      using T = std::remove_cv_t<std::remove_reference_t<decltype(v)>>;
      const std::string path = at + "/" + f.key;
      if constexpr (std::is_enum_v<T>) {
        if (uint32_t(v) >= tag_count<T>())
          fail(path, "unknown value " + std::to_string(uint32_t(v)) + " (" + tag_choices<T>() + ")");
      } else if constexpr (std::is_same_v<T, float>) {
        number(path, v, f.lo, f.hi);
      } else if constexpr (std::is_same_v<T, Vec3>) {
        finite(path, v);
        for (int a = 0; a < 3; ++a) number(path + "/" + std::to_string(a), v[a], f.lo, f.hi);
      } else if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
        if (!(zero_is_auto(f) && v == 0)) integer(path, int64_t(v), int64_t(f.lo), int64_t(f.hi));
      }
    });
  }

  void shadows() const {
    const ShadowSettings& sh = s.shadows;
    // Rules a range cannot say, before the ranges (their messages are the more precise).
    if (sh.parallel_splits != 0 && (sh.parallel_splits < 2 || sh.parallel_splits > kMaxMapsPerLight - 1))
      fail("/shadows/parallel_splits", "must be 0 (off) or within [2, " + std::to_string(kMaxMapsPerLight - 1) +
                                           "], got " + std::to_string(sh.parallel_splits));
    // The method's parameter (cdsm/tags.h kMethodParams); 0 is its default.
    const float p = sh.method_param;
    const MethodParam& mp =
        uint32_t(sh.method) < tag_count<ShadowMethod>() ? method_param(sh.method) : kMethodParams[0];
    if (mp.what && !(p == 0 || (p >= mp.lo && p <= mp.hi && (!mp.integer || p == std::floor(p)))))
      fail("/shadows/method_param", std::string(tag_name(sh.method)) + ": " + mp.what + " must be " +
                                        (mp.integer ? "an integer " : "") + "within [" + format_number(mp.lo) + ", " +
                                        format_number(mp.hi) + "] (0: default " + format_number(mp.fallback) +
                                        "), got " + format_number(p));
    if (!mp.what && !std::isfinite(p)) fail("/shadows/method_param", "has a NaN or infinite value");
    if (sh.method == ShadowMethod::Moments && !moment_count_allowed(p))
      fail("/shadows/method_param",
           "moments: the power moment count must be 4 or 8 (the published biases), got " + format_number(p));
    fields(sh, "/shadows");
  }

  void volumes() const {
    for (size_t i = 0; i < s.volumes.size(); ++i) {
      const Volume& v = s.volumes[i];
      const std::string at = "/volumes/" + std::to_string(i);
      fields(v, at);
      if (v.transfer.empty() || v.transfer.size() > size_t(kMaxTransferPoints))
        fail(at + "/transfer", "needs 1 to " + std::to_string(kMaxTransferPoints) + " control points, got " +
                                   std::to_string(v.transfer.size()));
      for (size_t k = 0; k < v.transfer.size(); ++k) {
        const TransferPoint& tp = v.transfer[k];
        const std::string pt = at + "/transfer/" + std::to_string(k);
        if (!std::isfinite(tp.density)) fail(pt + "/density", "has a NaN or infinite value");
        if (k > 0 && tp.density < v.transfer[k - 1].density)
          fail(pt + "/density", "control points must be sorted by density");
        channels(pt + "/extinction", tp.extinction, 0.0, 1e38);
        color(pt + "/color", tp.color);
      }
    }
  }

  void objects() const {
    for (size_t i = 0; i < s.objects.size(); ++i) {
      const Object& o = s.objects[i];
      const std::string at = "/objects/" + std::to_string(i);
      fields(o, at);
      fields(o.surface, at + "/material");
      if (o.interior == InteriorKind::Constant) channels(at + "/interior/sigma", o.sigma, 0.0, 1e38);
      if (o.interior == InteriorKind::Volume && (o.volume < 0 || size_t(o.volume) >= s.volumes.size()))
        fail(at + "/interior/volume", "volume " + std::to_string(o.volume) + " does not exist");
    }
  }

  void lights() const {
    if (s.lights.size() > size_t(kMaxLights))
      fail("/lights", "at most " + std::to_string(kMaxLights) + " lights, got " + std::to_string(s.lights.size()));
    for (size_t i = 0; i < s.lights.size(); ++i) {
      const Light& l = s.lights[i];
      const std::string at = "/lights/" + std::to_string(i);
      fields(l, at);
      // What a range cannot say.
      if (l.type == LightType::Directional && !(length(l.direction) > 0.0f))
        fail(at + "/direction", "directional direction is zero");
      if (l.type == LightType::Spot) {
        if (!(length(l.direction) > 0.0f)) fail(at + "/direction", "spot direction is zero");
        number(at + "/outer_cone", l.outer_cone_deg, 0.0, 89.5, true);
        number(at + "/inner_cone", l.inner_cone_deg, 0.0, l.outer_cone_deg);
      }
    }
  }
};

}  // namespace

void validate_scene(const Scene& scene, std::vector<std::string>* warnings) {
  Checker c{scene, warnings};
  c.camera();
  c.shadows();
  c.color("/background", scene.background);
  c.volumes();
  c.objects();
  c.lights();
}

}  // namespace cdsm
