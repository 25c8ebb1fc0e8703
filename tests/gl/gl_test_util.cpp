#include "gl_test_util.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>

#include "cdsm/procedural.h"
#include "gl/gl_api.h"
#include "hd/fragment.h"
#include "hd/segments.h"

namespace cdsm::test {

bool gl_required() {
  const char* e = std::getenv("CDSM_REQUIRE_GL");
  return e && std::strcmp(e, "1") == 0;
}

std::unique_ptr<gl::Context> GlTest::s_context;
std::string GlTest::s_reason;
bool GlTest::s_tried = false;

void GlTest::SetUpTestSuite() {
  if (s_tried) return;
  s_tried = true;
  s_context = gl::create_headless_context({}, &s_reason);
  if (s_context) std::printf("[   gl     ] %s\n", s_context->description().c_str());
}

void GlTest::TearDownTestSuite() {}

void GlTest::release_context() { s_context.reset(); }

namespace {
// Destroys the shared context after the last test, before exit handlers
// (EGL's own among them) run.
class GlEnvironment : public ::testing::Environment {
 public:
  void TearDown() override { GlTest::release_context(); }
};
[[maybe_unused]] ::testing::Environment* const g_gl_environment =
    ::testing::AddGlobalTestEnvironment(new GlEnvironment);
}  // namespace

void GlTest::SetUp() {
  if (!s_context) {
    if (gl_required()) FAIL() << "CDSM_REQUIRE_GL=1 but " << s_reason;
    GTEST_SKIP() << s_reason;
  }
  s_context->make_current();
}

// ---- scenes -----------------------------------------------------------------

uint32_t TestScene::add(const TriangleMesh& mesh, const Mat4& transform, bool closed) {
  uint32_t object = uint32_t(sb.objects.size());
  ObjectData od{};
  od.opacity = 1.0f;
  od.volume = -1;
  od.flags = (closed ? kObjClosed : 0u) | kObjCastsShadows;
  od.first_tri = uint32_t(sb.tri_object.size());
  od.tri_count = uint32_t(mesh.triangle_count());
  sb.objects.push_back(od);
  Box3 box;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      Vec3 p = transform.point(mesh.positions[mesh.indices[3 * t + size_t(k)]]);
      sb.tri_vertices.push_back(p);
      sb.tri_normals.push_back(Vec3{0, 1, 0});
      box.grow(p);
    }
    sb.tri_object.push_back(object);
  }
  sb.object_bounds.push_back(box);
  sb.bounds.grow(box);
  return object;
}

void TestScene::add_triangle(Vec3 a, Vec3 b, Vec3 c, uint32_t object) {
  while (sb.objects.size() <= object) {
    ObjectData od{};
    od.opacity = 1.0f;
    od.volume = -1;
    od.flags = kObjCastsShadows;
    od.first_tri = uint32_t(sb.tri_object.size());
    sb.objects.push_back(od);
    sb.object_bounds.push_back(Box3{});
  }
  sb.objects[object].tri_count++;
  for (Vec3 p : {a, b, c}) {
    sb.tri_vertices.push_back(p);
    sb.tri_normals.push_back(Vec3{0, 1, 0});
    sb.object_bounds[object].grow(p);
    sb.bounds.grow(p);
  }
  sb.tri_object.push_back(object);
}

void TestScene::finish() { build_bvh(sb); }

void TestScene::upload(gl::FragmentRasterizer& r) const {
  r.upload_scene({sb.tri_vertices.data(), sb.tri_vertices.size()}, {sb.tri_object.data(), sb.tri_object.size()},
                 {sb.objects.data(), sb.objects.size()});
}

void TestScene::cast(const PinholeView& v, ObjectMask mask, FragmentBuffers& out) const {
  cast_fragments(sb.view(), v, mask, out);
}

TestScene closed_meshes_scene() {
  // Objects float 2 cm above the ground: touching coplanar faces would tie
  // in depth and make the (depth, bits) order arbitrary.
  TestScene s;
  s.add(make_ground(12.0f, 12.0f, 0.2f), Mat4{});
  s.add(make_sphere(0.8f, 40, 20), make_transform({0.0f, 0.82f, 0.0f}, {0, 0, 0}, {1, 1, 1}));
  s.add(make_sphere(0.5f, 24, 12), make_transform({1.8f, 0.55f, 0.9f}, {10, 20, 0}, {1, 1, 1}));
  s.add(make_box({1.0f, 1.5f, 1.0f}), make_transform({-1.6f, 0.77f, 0.4f}, {0, 30, 0}, {1, 1, 1}));
  s.add(make_box({0.6f, 0.6f, 0.6f}), make_transform({0.9f, 0.6f, -1.5f}, {35, 45, 0}, {1, 1, 1}));
  // A box with a sphere inside it (nested closed meshes).
  s.add(make_box({1.2f, 1.2f, 1.2f}), make_transform({-0.6f, 0.65f, -2.2f}, {0, -15, 0}, {1, 1, 1}));
  s.add(make_sphere(0.35f, 20, 10), make_transform({-0.6f, 0.65f, -2.2f}, {0, 0, 0}, {1, 1, 1}));
  // Something above, so an omni light's +y face sees geometry too.
  s.add(make_box({2.0f, 0.3f, 1.5f}), make_transform({0.4f, 4.0f, -0.5f}, {5, 10, 0}, {1, 1, 1}));
  s.finish();
  return s;
}

TestScene many_spheres_scene(int count, int segments, int rings) {
  TestScene s;
  s.add(make_ground(14.0f, 14.0f, 0.2f), Mat4{});
  TriangleMesh sphere = make_sphere(0.45f, segments, rings);
  int side = int(std::ceil(std::sqrt(double(count))));
  for (int i = 0; i < count; ++i) {
    float x = (float(i % side) - 0.5f * float(side - 1)) * 1.1f;
    float z = (float(i / side) - 0.5f * float(side - 1)) * 1.1f;
    float y = 0.47f + 0.3f * float((i * 7) % 5) / 5.0f;
    s.add(sphere, make_transform({x, y, z}, {float(i * 13 % 90), float(i * 29 % 180), 0}, {1, 1, 1}));
  }
  s.finish();
  return s;
}

// ---- views ------------------------------------------------------------------

PinholeView look_at(Vec3 eye, Vec3 target, Vec3 up_hint, float fov_y_deg, int width, int height, float near_plane,
                    float far_plane, Vec2 center) {
  PinholeView v;
  v.eye = eye;
  v.forward = normalize(target - eye);
  v.right = normalize(cross(v.forward, up_hint));
  v.up = cross(v.right, v.forward);
  v.tan_half_y = std::tan(fov_y_deg * 3.14159265f / 360.0f);
  v.tan_half_x = v.tan_half_y * float(width) / float(height);
  v.center = center;
  v.width = width;
  v.height = height;
  v.near = near_plane;
  v.far = far_plane;
  return v;
}

std::array<PinholeView, 6> omni_faces(Vec3 eye, int resolution, float near_plane, float far_plane) {
  const Vec3 fwd[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const Vec3 up[6] = {{0, 1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};
  std::array<PinholeView, 6> faces;
  for (int f = 0; f < 6; ++f) {
    PinholeView& v = faces[size_t(f)];
    v.eye = eye;
    v.forward = fwd[f];
    v.up = up[f];
    v.right = cross(fwd[f], up[f]);
    v.tan_half_x = v.tan_half_y = 1.0f;
    v.width = v.height = resolution;
    v.near = near_plane;
    v.far = far_plane;
  }
  return faces;
}

PinholeView row_view(const PinholeView& v, int row) {
  PinholeView r = v;
  // view_direction: sy = center.y + (1 - 2*py_v/H) * tan_half_y. With
  // height 1 and py_v = 0.5 the factor is exactly 0, so sy = center.y.
  float py_v = float(row) + 0.5f;
  r.center.y = v.center.y + (1.0f - 2.0f * py_v / float(v.height)) * v.tan_half_y;
  r.height = 1;
  return r;
}

// ---- edge distances -----------------------------------------------------------

namespace {

struct D3 {
  double x, y, z;  // view space: right, up, forward
};

D3 to_view(const PinholeView& v, Vec3 p) {
  double dx = double(p.x) - v.eye.x, dy = double(p.y) - v.eye.y, dz = double(p.z) - v.eye.z;
  auto d = [&](Vec3 a) { return dx * a.x + dy * a.y + dz * a.z; };
  return {d(v.right), d(v.up), d(v.forward)};
}

// Keeps the part of `poly` with sign * (z - plane) >= 0.
std::vector<D3> clip(const std::vector<D3>& poly, double plane, double sign) {
  std::vector<D3> out;
  for (size_t i = 0; i < poly.size(); ++i) {
    const D3& a = poly[i];
    const D3& b = poly[(i + 1) % poly.size()];
    double da = sign * (a.z - plane), db = sign * (b.z - plane);
    if (da >= 0) out.push_back(a);
    if ((da >= 0) != (db >= 0)) {
      double t = da / (da - db);
      out.push_back({a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z)});
    }
  }
  return out;
}

double segment_distance(double px, double py, double ax, double ay, double bx, double by) {
  double ex = bx - ax, ey = by - ay;
  double len2 = ex * ex + ey * ey;
  double t = len2 > 0 ? ((px - ax) * ex + (py - ay) * ey) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  double qx = ax + t * ex - px, qy = ay + t * ey - py;
  return std::sqrt(qx * qx + qy * qy);
}

}  // namespace

double edge_distance_px(const PinholeView& view, const Vec3 tri[3], double u, double v) {
  std::vector<D3> poly = {to_view(view, tri[0]), to_view(view, tri[1]), to_view(view, tri[2])};
  poly = clip(poly, view.near, 1.0);
  poly = clip(poly, view.far, -1.0);
  if (poly.empty()) return std::numeric_limits<double>::infinity();
  std::vector<std::pair<double, double>> img;
  for (const D3& p : poly) {
    const double w = is_orthographic(view) ? 1.0 : p.z;  // parallel rays: no divide
    double sx = p.x / w - view.center.x, sy = p.y / w - view.center.y;
    img.push_back({(sx / view.tan_half_x + 1.0) * 0.5 * view.width, (1.0 - sy / view.tan_half_y) * 0.5 * view.height});
  }
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < img.size(); ++i) {
    const auto& a = img[i];
    const auto& b = img[(i + 1) % img.size()];
    best = std::min(best, segment_distance(u, v, a.first, a.second, b.first, b.second));
  }
  return best;
}

// ---- comparison -----------------------------------------------------------------

namespace {

constexpr uint32_t kKey = kFragPrimMask | kFragFrontBit;

std::vector<Fragment> pixel_list(const FragmentBuffers& b, int px, int py) {
  size_t i = size_t(py) * size_t(b.width) + size_t(px);
  return std::vector<Fragment>(b.fragments.begin() + b.offsets[i], b.fragments.begin() + b.offsets[i + 1]);
}

bool depth_close(float a, float b) { return std::fabs(a - b) <= 1e-4f * std::max(std::fabs(a), std::fabs(b)); }

std::string describe(const std::vector<Fragment>& l) {
  std::ostringstream s;
  for (const Fragment& f : l) s << " " << frag_prim(f) << (frag_front(f) ? "F" : "B") << "@" << f.depth;
  return s.str();
}

}  // namespace

Comparison compare_fragments(const TestScene& scene, const PinholeView& view, const FragmentBuffers& gl,
                             const FragmentBuffers& cpu, double edge_tol_px, int gl_row) {
  Comparison c;
  int shown = 0;
  for (int py = 0; py < cpu.height; ++py) {
    const int gy = gl_row >= 0 ? gl_row + py : py;
    for (int px = 0; px < cpu.width; ++px) {
      ++c.pixels;
      std::vector<Fragment> a = pixel_list(gl, px, gy), b = pixel_list(cpu, px, py);
      c.gl_fragments += a.size();
      c.cpu_fragments += b.size();
      std::sort(a.begin(), a.end(), frag_less);
      std::sort(b.begin(), b.end(), frag_less);
      bool equal = a.size() == b.size();
      for (size_t i = 0; equal && i < a.size(); ++i)
        equal = (a[i].bits & kKey) == (b[i].bits & kKey) && depth_close(a[i].depth, b[i].depth);
      // Pair by primitive (unique per pixel) to measure depths and find the
      // disputed fragments: in one list only, facing or depth differs.
      auto by_prim = [](Fragment x, Fragment y) { return frag_prim(x) < frag_prim(y); };
      std::sort(a.begin(), a.end(), by_prim);
      std::sort(b.begin(), b.end(), by_prim);
      std::vector<uint32_t> disputed;
      size_t i = 0, j = 0;
      while (i < a.size() || j < b.size()) {
        if (j == b.size() || (i < a.size() && frag_prim(a[i]) < frag_prim(b[j]))) {
          disputed.push_back(frag_prim(a[i++]));
        } else if (i == a.size() || frag_prim(b[j]) < frag_prim(a[i])) {
          disputed.push_back(frag_prim(b[j++]));
        } else {
          double rel = std::fabs(double(a[i].depth) - b[j].depth) / std::max(1e-30, double(b[j].depth));
          c.max_rel_depth = std::max(c.max_rel_depth, rel);
          if (frag_front(a[i]) != frag_front(b[j]) || !depth_close(a[i].depth, b[j].depth))
            disputed.push_back(frag_prim(a[i]));
          ++i;
          ++j;
        }
      }
      if (equal) {
        ++c.equal;
        continue;
      }
      bool ok = true;
      double worst = 0.0;
      for (uint32_t prim : disputed) {
        const Vec3* tri = &scene.sb.tri_vertices[3 * size_t(prim)];
        double d = edge_distance_px(view, tri, px + 0.5, gy + 0.5);
        worst = std::max(worst, d);
        if (!(d <= edge_tol_px)) ok = false;
      }
      // Equal as sets but ordered differently: depths tie within 1e-4.
      if (ok) {
        ++c.explained;
        c.order_ties += disputed.empty();
        if (std::getenv("CDSM_TEST_VERBOSE") && shown++ < 40) {
          std::sort(a.begin(), a.end(), frag_less);
          std::sort(b.begin(), b.end(), frag_less);
          std::printf("  explained (%d, %d) edge %.2e px\n    gl: %s\n    cpu:%s\n", px, gy, worst, describe(a).c_str(),
                      describe(b).c_str());
        }
      } else {
        ++c.unexplained;
        if (shown++ < 8) {
          std::sort(a.begin(), a.end(), frag_less);
          std::sort(b.begin(), b.end(), frag_less);
          c.report += "  pixel (" + std::to_string(px) + ", " + std::to_string(gy) + "), edge distance " +
                      std::to_string(worst) + " px\n    gl: " + describe(a) + "\n    cpu:" + describe(b) + "\n";
        }
      }
    }
  }
  return c;
}

uint64_t count_unpaired_pixels(const TestScene& scene, const FragmentBuffers& lists, std::string* first) {
  uint64_t bad = 0;
  for (int py = 0; py < lists.height; ++py)
    for (int px = 0; px < lists.width; ++px) {
      std::vector<Fragment> l = pixel_list(lists, px, py);
      // Depth order, then the walker's own rule for silhouette crossings
      // (an object's exit just before its own entry is one crossing point:
      // hd/segments.h order_crossings).
      std::sort(l.begin(), l.end(), frag_less);
      SceneView sv = scene.view();
      order_crossings(sv, Span<Fragment>{l.data(), l.size()});
      std::vector<int> inside(scene.object_count(), 0);
      bool ok = true;
      for (const Fragment& f : l) {
        uint32_t o = scene.sb.tri_object[frag_prim(f)];
        int& in = inside[o];
        if (frag_front(f) == (in == 0)) {
          in ^= 1;
        } else {
          ok = false;
        }
      }
      for (int in : inside) ok = ok && in == 0;
      if (!ok) {
        if (bad == 0 && first) *first = "pixel (" + std::to_string(px) + ", " + std::to_string(py) + "):" + describe(l);
        ++bad;
      }
    }
  return bad;
}

std::string gl_maps_differ(const GlMapBuffers& b, const DsmStorage& s) {
  struct Array {
    const char* name;
    uint32_t buffer;
    const void* data;
    uint64_t bytes;
  };
  const Array arrays[] = {
      {"texels", b.texels, s.grey.texels.data(), s.grey.texels.size() * sizeof(TexelRange)},
      {"nodes", b.nodes, s.grey.nodes.data(), s.grey.nodes.size() * sizeof(DsmNode)},
      {"chunks", b.chunks, s.grey.chunks.data(), s.grey.chunks.size() * sizeof(ChunkNode)},
      {"rgb_texels", b.rgb_texels, s.rgb.texels.data(), s.rgb.texels.size() * sizeof(TexelRange)},
      {"rgb_nodes", b.rgb_nodes, s.rgb.nodes.data(), s.rgb.nodes.size() * sizeof(DsmNodeRgb)},
      {"rgb_chunks", b.rgb_chunks, s.rgb.chunks.data(), s.rgb.chunks.size() * sizeof(ChunkNodeRgb)},
      {"tags", b.tags, s.grey.tags.data(), s.grey.tags.size() * sizeof(SurfaceTag)},
      {"rgb_tags", b.rgb_tags, s.rgb.tags.data(), s.rgb.tags.size() * sizeof(SurfaceTag)},
  };
  std::string out;
  for (const Array& a : arrays) {
    if (a.bytes == 0) continue;
    GLint64 size = 0;
    glGetNamedBufferParameteri64v(a.buffer, GL_BUFFER_SIZE, &size);
    if (uint64_t(size) < a.bytes) {
      out += std::string(out.empty() ? "" : "; ") + a.name + ": GL buffer of " + std::to_string(size) + " bytes < " +
             std::to_string(a.bytes);
      continue;
    }
    std::vector<unsigned char> gl(a.bytes);
    glGetNamedBufferSubData(a.buffer, 0, GLsizeiptr(a.bytes), gl.data());
    const unsigned char* want = static_cast<const unsigned char*>(a.data);
    for (uint64_t i = 0; i < a.bytes; ++i)
      if (gl[i] != want[i]) {
        out += std::string(out.empty() ? "" : "; ") + a.name + ": first difference at byte " + std::to_string(i) +
               " of " + std::to_string(a.bytes);
        break;
      }
  }
  return out;
}

std::string lists_differ(const FragmentBuffers& a, const FragmentBuffers& b) {
  if (a.width != b.width || a.height != b.height)
    return "sizes " + std::to_string(a.width) + "x" + std::to_string(a.height) + " and " + std::to_string(b.width) +
           "x" + std::to_string(b.height);
  if (a.offsets != b.offsets) return "the offsets differ";
  if (a.fragments.size() != b.fragments.size()) return "the fragment counts differ";
  std::vector<Fragment> x, y;
  for (size_t i = 0; i + 1 < a.offsets.size(); ++i) {
    x.assign(a.fragments.begin() + a.offsets[i], a.fragments.begin() + a.offsets[i + 1]);
    y.assign(b.fragments.begin() + b.offsets[i], b.fragments.begin() + b.offsets[i + 1]);
    std::sort(x.begin(), x.end(), frag_less);
    std::sort(y.begin(), y.end(), frag_less);
    for (size_t k = 0; k < x.size(); ++k)
      if (x[k].bits != y[k].bits || x[k].depth != y[k].depth)
        return "pixel " + std::to_string(i) + " (" + std::to_string(i % uint64_t(a.width)) + ", " +
               std::to_string(i / uint64_t(a.width)) + "), fragment " + std::to_string(k);
  }
  return "";
}

SystemOptions app_options(FragmentSource fragments) {
  SystemOptions o;
  o.gl_context = GlContextUse::Application;
  o.fragments = fragments;
  o.source = "test system";
  return o;
}

}  // namespace cdsm::test
