// Analytic built-in meshes: box, UV sphere, ground slab, quad (procedural.h).
#include <cmath>
#include <cstdint>

#include "cdsm/procedural.h"

namespace cdsm {
namespace {

constexpr float kPi = 3.14159265358979323846f;

// Appends a flat quad a-b-c-d (counter-clockwise seen from where `n` points)
// with its own four vertices, so each face keeps a flat normal; the copies
// weld by position into a closed surface.
void add_flat_quad(TriangleMesh& m, Vec3 a, Vec3 b, Vec3 c, Vec3 d, Vec3 n) {
  const uint32_t base = uint32_t(m.positions.size());
  for (Vec3 p : {a, b, c, d}) {
    m.positions.push_back(p);
    m.normals.push_back(n);
  }
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
}

// Unit vector along axis 0, 1 or 2.
Vec3 axis(int a) { return {a == 0 ? 1.0f : 0.0f, a == 1 ? 1.0f : 0.0f, a == 2 ? 1.0f : 0.0f}; }

// Axis-aligned box of half extent `h` around `c`, six flat-shaded faces.
TriangleMesh box_around(Vec3 c, Vec3 h) {
  TriangleMesh m;
  for (int a = 0; a < 3; ++a) {
    for (float s : {1.0f, -1.0f}) {
      // (u, v, n) right-handed, so corners -u-v, u-v, u+v, -u+v run CCW around n.
      const Vec3 n = axis(a) * s;
      Vec3 u = axis((a + 1) % 3), v = axis((a + 2) % 3);
      if (s < 0.0f) std::swap(u, v);
      u = u * h, v = v * h;
      const Vec3 f = c + n * h;
      add_flat_quad(m, f - u - v, f + u - v, f + u + v, f - u + v, n);
    }
  }
  return m;
}

}  // namespace

TriangleMesh make_box(Vec3 size) { return box_around(Vec3{}, size * 0.5f); }

TriangleMesh make_ground(float size_x, float size_z, float thickness) {
  const Vec3 h{size_x * 0.5f, thickness * 0.5f, size_z * 0.5f};
  return box_around(Vec3{0.0f, -h.y, 0.0f}, h);
}

TriangleMesh make_quad(float size_x, float size_z) {
  TriangleMesh m;
  const float x = size_x * 0.5f, z = size_z * 0.5f;
  add_flat_quad(m, {-x, 0, -z}, {-x, 0, z}, {x, 0, z}, {x, 0, -z}, {0, 1, 0});
  return m;
}

TriangleMesh make_sphere(float radius, int segments, int rings) {
  segments = segments < 3 ? 3 : segments;
  rings = rings < 2 ? 2 : rings;
  TriangleMesh m;
  // Vertex 0 is the north pole (+y), then rings-1 latitude circles, then the south pole.
  auto add_vertex = [&](Vec3 n) {
    m.positions.push_back(n * radius);
    m.normals.push_back(n);
  };
  add_vertex({0, 1, 0});
  for (int r = 1; r < rings; ++r) {
    const float theta = kPi * float(r) / float(rings);
    for (int s = 0; s < segments; ++s) {
      const float phi = 2.0f * kPi * float(s) / float(segments);
      add_vertex({std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi)});
    }
  }
  add_vertex({0, -1, 0});
  const uint32_t south = uint32_t(m.positions.size() - 1);
  // Index of segment s on latitude circle r (1-based circles, s wraps around).
  auto ring = [&](int r, int s) { return uint32_t(1 + (r - 1) * segments + (s % segments)); };
  auto tri = [&](uint32_t a, uint32_t b, uint32_t c) { m.indices.insert(m.indices.end(), {a, b, c}); };
  // phi grows counter-clockwise seen from +y, so (pole, s, s+1) faces outwards at the top.
  for (int s = 0; s < segments; ++s) tri(0, ring(1, s), ring(1, s + 1));
  for (int r = 1; r + 1 < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      tri(ring(r, s), ring(r + 1, s), ring(r + 1, s + 1));
      tri(ring(r, s), ring(r + 1, s + 1), ring(r, s + 1));
    }
  }
  for (int s = 0; s < segments; ++s) tri(south, ring(rings - 1, s + 1), ring(rings - 1, s));
  return m;
}

}  // namespace cdsm
