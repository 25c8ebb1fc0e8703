// Mesh and transform utilities of the public scene model.
#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>
#include <unordered_map>

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
  rx.m[1][1] = cx; rx.m[1][2] = -sx; rx.m[2][1] = sx; rx.m[2][2] = cx;
  ry.m[0][0] = cy; ry.m[0][2] = sy; ry.m[2][0] = -sy; ry.m[2][2] = cy;
  rz.m[0][0] = cz; rz.m[0][1] = -sz; rz.m[1][0] = sz; rz.m[1][1] = cz;
  sc.m[0][0] = s.x; sc.m[1][1] = s.y; sc.m[2][2] = s.z;
  tr.m[0][3] = t.x; tr.m[1][3] = t.y; tr.m[2][3] = t.z;
  // Rotate about X first, then Y, then Z.
  return tr * (rz * (ry * (rx * sc)));
}

}  // namespace cdsm
