// Mesh and transform utilities of the public scene model.
#include <algorithm>
#include <limits>
#include <string>
#include <utility>
#include <cmath>
#include <map>
#include <tuple>
#include <unordered_map>

#include "cdsm/error.h"
#include "cdsm/scene.h"

namespace cdsm {

bool is_closed(const TriangleMesh& mesh) {
  if (mesh.indices.empty() || mesh.indices.size() % 3 != 0) return false;
  // Weld vertices at identical positions.
  std::map<std::tuple<float, float, float>, uint32_t> weld;
  std::vector<uint32_t> id(mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    auto it = weld.emplace(std::make_tuple(p.x, p.y, p.z), uint32_t(weld.size())).first;
    id[i] = it->second;
  }
  // Every directed edge must appear exactly once and its reverse exactly once.
  std::unordered_map<uint64_t, int> directed;
  directed.reserve(mesh.indices.size());
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    uint32_t v[3];
    for (int k = 0; k < 3; ++k) {
      uint32_t idx = mesh.indices[t + k];
      if (idx >= id.size()) return false;
      v[k] = id[idx];
    }
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue;  // degenerate: ignore
    // Zero area (collinear corners), decided exactly: no surface, no edges.
    const Vec3 &a = mesh.positions[mesh.indices[t]], &b = mesh.positions[mesh.indices[t + 1]],
               &c = mesh.positions[mesh.indices[t + 2]];
    double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
    double wx = double(c.x) - a.x, wy = double(c.y) - a.y, wz = double(c.z) - a.z;
    if (uy * wz - uz * wy == 0.0 && uz * wx - ux * wz == 0.0 && ux * wy - uy * wx == 0.0) continue;
    for (int k = 0; k < 3; ++k) {
      uint64_t key = (uint64_t(v[k]) << 32) | v[(k + 1) % 3];
      if (++directed[key] > 1) return false;
    }
  }
  for (const auto& [key, n] : directed) {
    uint64_t rev = (key << 32) | (key >> 32);
    auto it = directed.find(rev);
    if (it == directed.end() || it->second != 1) return false;
  }
  return !directed.empty();
}

Box3 world_bounds(const TriangleMesh& mesh, const Mat4& transform) {
  Box3 b;
  for (const Vec3& p : mesh.positions) b.grow(transform.point(p));
  return b;
}

Mat4 make_transform(Vec3 t, Vec3 r_deg, Vec3 s) {
  const float k = 3.14159265358979f / 180.0f;
  float cx = std::cos(r_deg.x * k), sx = std::sin(r_deg.x * k);
  float cy = std::cos(r_deg.y * k), sy = std::sin(r_deg.y * k);
  float cz = std::cos(r_deg.z * k), sz = std::sin(r_deg.z * k);
  Mat4 rx, ry, rz, sc, tr;
  rx.m[1][1] = cx;
  rx.m[1][2] = -sx;
  rx.m[2][1] = sx;
  rx.m[2][2] = cx;
  ry.m[0][0] = cy;
  ry.m[0][2] = sy;
  ry.m[2][0] = -sy;
  ry.m[2][2] = cy;
  rz.m[0][0] = cz;
  rz.m[0][1] = -sz;
  rz.m[1][0] = sz;
  rz.m[1][1] = cz;
  sc.m[0][0] = s.x;
  sc.m[1][1] = s.y;
  sc.m[2][2] = s.z;
  tr.m[0][3] = t.x;
  tr.m[1][3] = t.y;
  tr.m[2][3] = t.z;
  // Rotate about X first, then Y, then Z.
  return tr * (rz * (ry * (rx * sc)));
}

// ---- Camera <-> matrices ----------------------------------------------------

Mat4 Camera::view_matrix() const {
  const Vec3 f = normalize(target - position);
  Vec3 r = cross(f, up);
  if (length(r) < 1e-6f) {  // up along the view: any perpendicular roll
    const Vec3 a = std::fabs(f.y) < 0.9f ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
    r = cross(f, normalize(cross(cross(f, a), f)) * -1.0f);
  }
  r = normalize(r);
  const Vec3 u = cross(r, f);
  const Vec3 rows[3] = {r, u, -f};
  Mat4 v;
  for (int i = 0; i < 3; ++i) {
    v.m[i][0] = rows[i].x;
    v.m[i][1] = rows[i].y;
    v.m[i][2] = rows[i].z;
    v.m[i][3] = -dot(rows[i], position);
  }
  return v;
}

Mat4 Camera::projection_matrix(ClipDepth depth) const {
  const float ty = std::tan(fov_y_deg * 0.5f * 3.14159265f / 180.0f);
  const float tx = ty * float(width) / float(height);
  Mat4 p;
  p.m[0][0] = 1.0f / tx;
  p.m[1][1] = 1.0f / ty;
  if (depth == ClipDepth::ZeroToOne) {
    p.m[2][2] = -far / (far - near);
    p.m[2][3] = -far * near / (far - near);
  } else {
    p.m[2][2] = -(far + near) / (far - near);
    p.m[2][3] = -2.0f * far * near / (far - near);
  }
  p.m[3][2] = -1.0f;
  p.m[3][3] = 0.0f;
  return p;
}

namespace {

std::string entry(const char* m, int i, int j, float v) {
  return std::string(m) + "[" + std::to_string(i) + "][" + std::to_string(j) + "] = " + std::to_string(v);
}

}  // namespace

Camera Camera::from_matrices(const float* view, const float* proj, int32_t width, int32_t height, ClipDepth depth) {
  if (!view || !proj)
    throw Error("Camera::from_matrices", std::string(view ? "projection" : "view") + " is a null pointer");
  Mat4 v, p;  // row-major: m[row][col] = a[col * 4 + row]
  for (int row = 0; row < 4; ++row)
    for (int col = 0; col < 4; ++col) {
      v.m[row][col] = view[col * 4 + row];
      p.m[row][col] = proj[col * 4 + row];
    }
  return from_matrices(v, p, width, height, depth);
}

Camera Camera::from_matrices(const Mat4& view, const Mat4& proj, int32_t width, int32_t height, ClipDepth depth) {
  const std::string where = "Camera::from_matrices";
  if (width <= 0 || height <= 0)
    throw Error(where, "an image of " + std::to_string(width) + "x" + std::to_string(height) + " pixels");
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      if (!std::isfinite(view.m[i][j])) throw Error(where, "view matrix entry " + entry("view", i, j, view.m[i][j]));
      if (!std::isfinite(proj.m[i][j]))
        throw Error(where, "projection entry " + entry("projection", i, j, proj.m[i][j]));
    }
  // The view: a rotation (orthonormal rows, determinant +1) and a translation.
  const Vec3 rows[3] = {{view.m[0][0], view.m[0][1], view.m[0][2]},
                        {view.m[1][0], view.m[1][1], view.m[1][2]},
                        {view.m[2][0], view.m[2][1], view.m[2][2]}};
  const float tol = 1e-3f;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const float d = dot(rows[i], rows[j]) - (i == j ? 1.0f : 0.0f);
      if (std::fabs(d) > tol)
        throw Error(where, "the view matrix is not a rigid motion (its rotation rows " + std::to_string(i) + " and " +
                               std::to_string(j) + " have dot product " + std::to_string(dot(rows[i], rows[j])) +
                               "): remove scale and shear from the camera's transform");
    }
  if (dot(cross(rows[0], rows[1]), rows[2]) < 0.0f)
    throw Error(where,
                "the view matrix mirrors (determinant -1): a right-handed eye space looking down -Z is expected");
  if (std::fabs(view.m[3][0]) > 1e-6f || std::fabs(view.m[3][1]) > 1e-6f || std::fabs(view.m[3][2]) > 1e-6f ||
      std::fabs(view.m[3][3] - 1.0f) > 1e-6f)
    throw Error(where, "the view matrix's last row is not (0, 0, 0, 1)");

  // The projection: a symmetric perspective.
  const Mat4& p = proj;
  if (p.m[3][2] == 0.0f && std::fabs(p.m[3][3] - 1.0f) <= 1e-6f)
    throw Error(where, "an orthographic projection: cameras are perspective (a symmetric frustum)");
  if (std::fabs(p.m[3][2] + 1.0f) > 1e-6f || p.m[3][3] != 0.0f || p.m[3][0] != 0.0f || p.m[3][1] != 0.0f)
    throw Error(where, "the projection's last row is not (0, 0, -1, 0) (" + entry("projection", 3, 2, p.m[3][2]) +
                           "): a perspective projection looking down -Z is expected");
  const float scale = std::max(std::fabs(p.m[0][0]), std::fabs(p.m[1][1]));
  for (auto [i, j] : {std::pair{0, 2}, std::pair{1, 2}})
    if (std::fabs(p.m[i][j]) > 1e-6f * scale)
      throw Error(where, "an off-centre (asymmetric) projection, " + entry("projection", i, j, p.m[i][j]) +
                             ": cameras are symmetric frusta");
  for (auto [i, j] :
       {std::pair{0, 1}, std::pair{0, 3}, std::pair{1, 0}, std::pair{1, 3}, std::pair{2, 0}, std::pair{2, 1}})
    if (std::fabs(p.m[i][j]) > 1e-6f * scale)
      throw Error(where, "the projection is not a perspective frustum, " + entry("projection", i, j, p.m[i][j]));
  if (!(p.m[0][0] > 0.0f) || !(p.m[1][1] > 0.0f))
    throw Error(where, "the projection's " + entry("projection", 0, 0, p.m[0][0]) + " and " +
                           entry("projection", 1, 1, p.m[1][1]) + " must be positive");
  const double aspect = double(p.m[1][1]) / double(p.m[0][0]), want = double(width) / double(height);
  if (std::fabs(aspect / want - 1.0) > 1e-3)
    throw Error(where, "the projection's aspect ratio " + std::to_string(aspect) + " is not the image's " +
                           std::to_string(width) + "/" + std::to_string(height) + " = " + std::to_string(want));
  // Depth: ndc(d) = -P22 + P23 / d at distance d along the view; the two
  // ends of the clip range give the planes (either order: reversed depth).
  const double p22 = p.m[2][2], p23 = p.m[2][3];
  if (p23 == 0.0) throw Error(where, "the projection has no depth (" + entry("projection", 2, 3, p.m[2][3]) + ")");
  const double lo = depth == ClipDepth::ZeroToOne ? 0.0 : -1.0, hi = 1.0;
  auto plane = [&](double ndc) {
    const double den = ndc + p22;
    const double d = den == 0.0 ? std::numeric_limits<double>::infinity() : p23 / den;
    return d > 0.0 ? d : std::numeric_limits<double>::infinity();  // behind the eye: no plane there
  };
  const double a = plane(lo), b = plane(hi);
  const double n = std::min(a, b), f = std::max(a, b);
  if (!std::isfinite(n))
    throw Error(where, "the projection's depth maps no positive distance to its clip range (" +
                           entry("projection", 2, 2, p.m[2][2]) + ", " + entry("projection", 2, 3, p.m[2][3]) +
                           "): is the clip depth " + (depth == ClipDepth::ZeroToOne ? "[0, 1]" : "[-1, 1]") + "?");

  Camera c;
  c.width = width;
  c.height = height;
  c.fov_y_deg = float(2.0 * std::atan(1.0 / double(p.m[1][1])) * 180.0 / 3.14159265358979323846);
  c.near = float(n);
  c.far = float(std::min(f, double(kMaxFar)));
  // position = -R^T t; the eye looks down -Z (row 2), +Y up (row 1).
  const Vec3 t{view.m[0][3], view.m[1][3], view.m[2][3]};
  c.position = (rows[0] * t.x + rows[1] * t.y + rows[2] * t.z) * -1.0f;
  const Vec3 forward = normalize(rows[2] * -1.0f);
  c.target = c.position + forward;
  c.up = normalize(rows[1]);
  return c;
}

}  // namespace cdsm
