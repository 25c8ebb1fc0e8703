// Newell's teapot and teacup: parse the Bezier patch file, tessellate, weld,
// orient consistently and cap the open rims into closed shells (procedural.h).
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/procedural.h"

namespace cdsm {
namespace {

using Tri = std::array<uint32_t, 3>;

// ---- patch file -------------------------------------------------------------

struct PatchFile {
  std::vector<std::array<uint32_t, 16>> patches;  // zero-based control-point indices
  std::vector<Vec3> points;                       // control points, as in the file (z up)
};

// Reads a patch file line by line; every error names the file and the line.
class PatchReader {
 public:
  explicit PatchReader(const std::string& file) : file_(file), in_(file) {
    if (!in_) throw Error(file_, "cannot open Bezier patch file");
  }

  PatchFile read() {
    PatchFile f;
    const long patch_count = read_count("patch count");
    std::vector<int> patch_lines;
    for (long p = 0; p < patch_count; ++p) {
      const std::vector<double> v = read_numbers(16, "patch (16 control-point indices)");
      std::array<uint32_t, 16> patch{};
      for (int i = 0; i < 16; ++i) {
        if (v[i] != std::floor(v[i]) || v[i] < 1.0 || v[i] > 1e9)
          fail("control-point index must be a positive integer");
        patch[i] = uint32_t(v[i]) - 1;
      }
      f.patches.push_back(patch);
      patch_lines.push_back(line_);
    }
    const long point_count = read_count("point count");
    for (long i = 0; i < point_count; ++i) {
      const std::vector<double> v = read_numbers(3, "point (x,y,z)");
      f.points.push_back(Vec3{float(v[0]), float(v[1]), float(v[2])});
    }
    std::string rest;
    while (next_line(rest)) fail("unexpected text after the last point");
    for (size_t p = 0; p < f.patches.size(); ++p) {
      for (uint32_t idx : f.patches[p]) {
        if (idx >= f.points.size()) {
          throw Error(where(patch_lines[p]), "control-point index " + std::to_string(idx + 1) + " out of range (" +
                                                 std::to_string(point_count) + " points)");
        }
      }
    }
    return f;
  }

 private:
  std::string where(int line) const { return file_ + ":" + std::to_string(line); }
  [[noreturn]] void fail(const std::string& what) const { throw Error(where(line_), what); }

  // Next non-blank line; false at the end of the file.
  bool next_line(std::string& s) {
    while (std::getline(in_, s)) {
      ++line_;
      if (s.find_first_not_of(" \t\r") != std::string::npos) return true;
    }
    return false;
  }

  // A line of exactly `n` comma-separated numbers.
  std::vector<double> read_numbers(size_t n, const char* what) {
    std::string s;
    if (!next_line(s)) {
      ++line_;
      fail(std::string("unexpected end of file, expected ") + what);
    }
    std::vector<double> v;
    size_t start = 0;
    while (start <= s.size()) {
      const size_t comma = std::min(s.find(',', start), s.size());
      const std::string field = s.substr(start, comma - start);
      const char* b = field.c_str();
      char* end = nullptr;
      errno = 0;
      const double x = std::strtod(b, &end);
      const bool blank_tail = std::string(end).find_first_not_of(" \t\r") == std::string::npos;
      if (end == b || !blank_tail || errno == ERANGE || !std::isfinite(x)) {
        fail("'" + field + "' is not a number (expected " + what + ")");
      }
      v.push_back(x);
      start = comma + 1;
    }
    if (v.size() != n) {
      fail("expected " + std::string(what) + ", found " + std::to_string(v.size()) + " values");
    }
    return v;
  }

  long read_count(const char* what) {
    const double c = read_numbers(1, what)[0];
    if (c != std::floor(c) || c < 1.0 || c > 1e7) fail(std::string(what) + " must be an integer in [1, 10^7]");
    return long(c);
  }

  std::string file_;
  std::ifstream in_;
  int line_ = 0;
};

// Newell's models rest on their origin plane: the teapot's file has z up, the
// teacup's (cup and saucer) y up. The up axis is the one of y and z along which
// the control points reach least below the origin.
bool file_is_z_up(const std::vector<Vec3>& points) {
  Box3 b;
  for (Vec3 p : points) b.grow(p);
  return b.lo.z >= b.lo.y;
}

// ---- tessellation and welding ----------------------------------------------

// Point of the bicubic Bezier patch (control points row-major, u along rows).
Vec3 bezier_point(const std::array<Vec3, 16>& cp, float u, float v) {
  auto basis = [](float t, float b[4]) {
    const float s = 1.0f - t;
    b[0] = s * s * s, b[1] = 3.0f * t * s * s, b[2] = 3.0f * t * t * s, b[3] = t * t * t;
  };
  float bu[4], bv[4];
  basis(u, bu);
  basis(v, bv);
  Vec3 p{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) p += cp[i * 4 + j] * (bu[i] * bv[j]);
  return p;
}

// Merges points closer than a tolerance, hashing them into cells of that size.
class Welder {
 public:
  explicit Welder(float tolerance) : tol_(tolerance) {}

  uint32_t add(Vec3 p) {
    const std::array<int64_t, 3> c = cell(p);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          auto it = cells_.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == cells_.end()) continue;
          for (uint32_t v : it->second) {
            const Vec3 d = points_[v] - p;
            if (dot(d, d) <= tol_ * tol_) return v;
          }
        }
    points_.push_back(p);
    cells_[c].push_back(uint32_t(points_.size() - 1));
    return uint32_t(points_.size() - 1);
  }
  std::vector<Vec3>& points() { return points_; }

 private:
  std::array<int64_t, 3> cell(Vec3 p) const {
    return {int64_t(std::floor(p.x / tol_)), int64_t(std::floor(p.y / tol_)), int64_t(std::floor(p.z / tol_))};
  }
  float tol_;
  std::vector<Vec3> points_;
  std::map<std::array<int64_t, 3>, std::vector<uint32_t>> cells_;
};

// Triangles of all patches on an (n+1)^2 grid each, over welded vertices;
// triangles collapsed by the weld (patch edges shrunk to a pole) are dropped.
std::vector<Tri> tessellate(const PatchFile& f, int n, std::vector<Vec3>& positions) {
  Box3 bounds;
  for (Vec3 p : f.points) bounds.grow(p);  // the convex hull property bounds every patch
  Welder welder(1e-5f * std::max(length(bounds.extent()), 1e-20f));
  std::vector<Tri> tris;
  std::vector<uint32_t> grid(size_t(n + 1) * (n + 1));
  for (const auto& patch : f.patches) {
    std::array<Vec3, 16> cp;
    for (int i = 0; i < 16; ++i) cp[i] = f.points[patch[i]];
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j)
        grid[i * (n + 1) + j] = welder.add(bezier_point(cp, float(i) / float(n), float(j) / float(n)));
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const uint32_t a = grid[i * (n + 1) + j], b = grid[(i + 1) * (n + 1) + j];
        const uint32_t c = grid[(i + 1) * (n + 1) + j + 1], d = grid[i * (n + 1) + j + 1];
        for (Tri t : {Tri{a, b, c}, Tri{a, c, d}})
          if (t[0] != t[1] && t[1] != t[2] && t[2] != t[0]) tris.push_back(t);
      }
  }
  positions = std::move(welder.points());
  return tris;
}

// Removes coincident triangles (same three vertices): a doubled surface or a
// zero-thickness sheet of two back-to-back copies encloses nothing, so every
// copy goes and the surfaces around it are left to meet (or to be capped).
std::vector<Tri> remove_coincident(const std::vector<Tri>& tris) {
  std::map<Tri, int> count;
  auto key = [](Tri t) {
    std::sort(t.begin(), t.end());
    return t;
  };
  for (const Tri& t : tris) ++count[key(t)];
  std::vector<Tri> out;
  for (const Tri& t : tris)
    if (count[key(t)] == 1) out.push_back(t);
  return out;
}

// ---- topology ---------------------------------------------------------------

uint64_t edge_key(uint32_t a, uint32_t b) { return a < b ? (uint64_t(a) << 32) | b : (uint64_t(b) << 32) | a; }

// For every undirected edge, the triangles using it.
std::unordered_map<uint64_t, std::vector<uint32_t>> edge_triangles(const std::vector<Tri>& tris) {
  std::unordered_map<uint64_t, std::vector<uint32_t>> e;
  for (uint32_t t = 0; t < tris.size(); ++t)
    for (int k = 0; k < 3; ++k) e[edge_key(tris[t][k], tris[t][(k + 1) % 3])].push_back(t);
  return e;
}

// Whether triangle t walks the edge from a to b.
bool walks(const Tri& t, uint32_t a, uint32_t b) {
  for (int k = 0; k < 3; ++k)
    if (t[k] == a && t[(k + 1) % 3] == b) return true;
  return false;
}

// Flips triangles so that neighbours across every two-triangle edge walk it in
// opposite directions; returns the connected component of each triangle.
std::vector<uint32_t> orient_consistently(std::vector<Tri>& tris) {
  const auto edges = edge_triangles(tris);
  const uint32_t none = ~0u;
  std::vector<uint32_t> component(tris.size(), none);
  uint32_t count = 0;
  for (uint32_t seed = 0; seed < tris.size(); ++seed) {
    if (component[seed] != none) continue;
    std::vector<uint32_t> stack{seed};
    component[seed] = count;
    while (!stack.empty()) {
      const uint32_t t = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = tris[t][k], b = tris[t][(k + 1) % 3];
        const auto& users = edges.at(edge_key(a, b));
        if (users.size() != 2) continue;  // boundary or non-manifold: no propagation
        const uint32_t u = users[0] == t ? users[1] : users[0];
        if (component[u] != none) continue;
        if (walks(tris[u], a, b)) std::swap(tris[u][1], tris[u][2]);
        component[u] = count;
        stack.push_back(u);
      }
    }
    ++count;
  }
  return component;
}

// Closed loops of boundary edges (edges with one triangle), each listed in the
// direction its triangle walks them.
std::vector<std::vector<uint32_t>> boundary_loops(const std::vector<Tri>& tris) {
  const auto edges = edge_triangles(tris);
  std::multimap<uint32_t, uint32_t> next;  // boundary half-edges a -> b
  for (const auto& [key, users] : edges) {
    if (users.size() != 1) continue;
    const Tri& t = tris[users[0]];
    for (int k = 0; k < 3; ++k)
      if (edge_key(t[k], t[(k + 1) % 3]) == key) next.emplace(t[k], t[(k + 1) % 3]);
  }
  std::vector<std::vector<uint32_t>> loops;
  while (!next.empty()) {
    std::vector<uint32_t> loop{next.begin()->first};
    uint32_t at = next.begin()->second;
    next.erase(next.begin());
    while (at != loop.front()) {
      auto it = next.find(at);
      if (it == next.end()) break;  // an open chain (only in non-manifold input): dropped
      loop.push_back(at);
      at = it->second;
      next.erase(it);
    }
    if (at == loop.front() && loop.size() >= 3) loops.push_back(std::move(loop));
  }
  return loops;
}

// ---- capping ----------------------------------------------------------------

// A cap filling one boundary loop: triangles over the mesh vertices plus
// possibly one new centre vertex.
struct Cap {
  std::vector<Tri> tris;
};

// Sum of edge cross products (Newell's polygon normal, length = 2 * area).
Vec3 polygon_normal(const std::vector<uint32_t>& poly, const std::vector<Vec3>& pos) {
  Vec3 n{};
  for (size_t i = 0; i < poly.size(); ++i) n += cross(pos[poly[i]], pos[poly[(i + 1) % poly.size()]]);
  return n;
}

float cross2(Vec2 o, Vec2 a, Vec2 b) { return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x); }

// Triangulates the polygon `poly` (vertex order kept in every triangle) by ear
// clipping in its best-fit plane; when the projection has no ear left (a
// strongly non-planar loop) the rest is fanned from a new centre vertex.
Cap triangulate(std::vector<uint32_t> poly, std::vector<Vec3>& pos) {
  Cap cap;
  const Vec3 n = normalize(polygon_normal(poly, pos));
  const Vec3 helper = std::fabs(n.x) < 0.6f ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 u = normalize(cross(helper, n)), v = cross(n, u);  // (u, v, n) right-handed
  std::unordered_map<uint32_t, Vec2> p2;
  for (uint32_t i : poly) p2[i] = Vec2{dot(pos[i], u), dot(pos[i], v)};
  while (poly.size() > 3) {
    const size_t m = poly.size();
    size_t ear = m;
    for (size_t i = 0; i < m && ear == m; ++i) {
      const uint32_t a = poly[(i + m - 1) % m], b = poly[i], c = poly[(i + 1) % m];
      if (cross2(p2[a], p2[b], p2[c]) <= 0.0f) continue;  // reflex or flat corner
      bool empty = true;
      for (size_t j = 0; j < m && empty; ++j) {
        const uint32_t q = poly[j];
        if (q == a || q == b || q == c) continue;
        empty = !(cross2(p2[a], p2[b], p2[q]) >= 0.0f && cross2(p2[b], p2[c], p2[q]) >= 0.0f &&
                  cross2(p2[c], p2[a], p2[q]) >= 0.0f);
      }
      if (empty) ear = i;
    }
    if (ear == m) break;
    cap.tris.push_back({poly[(ear + m - 1) % m], poly[ear], poly[(ear + 1) % m]});
    poly.erase(poly.begin() + long(ear));
  }
  if (poly.size() == 3) {
    cap.tris.push_back({poly[0], poly[1], poly[2]});
  } else {
    Vec3 centre{};
    for (uint32_t i : poly) centre += pos[i];
    pos.push_back(centre / float(poly.size()));
    const uint32_t c = uint32_t(pos.size() - 1);
    for (size_t i = 0; i < poly.size(); ++i) cap.tris.push_back({poly[i], poly[(i + 1) % poly.size()], c});
  }
  return cap;
}

// Six times the signed volume enclosed by the triangles (positive: outward).
double signed_volume6(const std::vector<Tri>& tris, const std::vector<Vec3>& pos) {
  double v = 0.0;
  for (const Tri& t : tris) v += dot(pos[t[0]], cross(pos[t[1]], pos[t[2]]));
  return v;
}

}  // namespace

TriangleMesh make_newell_mesh(const std::string& patch_file, int subdivisions) {
  PatchFile file = PatchReader(patch_file).read();
  if (file_is_z_up(file.points)) {
    // z up -> y up by a rotation about x: (x, y, z) -> (x, z, -y).
    for (Vec3& p : file.points) p = Vec3{p.x, p.z, -p.y};
  }

  std::vector<Vec3> pos;
  // Two segments at least: with one, the two-patch tubes (handle, spout) flatten.
  std::vector<Tri> surface = remove_coincident(tessellate(file, std::max(subdivisions, 2), pos));
  orient_consistently(surface);

  // Cap every open rim: a cap walks its loop backwards, matching the surface.
  std::vector<Cap> caps;
  for (std::vector<uint32_t> loop : boundary_loops(surface)) {
    std::reverse(loop.begin(), loop.end());
    caps.push_back(triangulate(loop, pos));
  }

  // Orient each closed shell outwards (positive enclosed volume).
  std::vector<Tri> all = surface;
  for (const Cap& c : caps) all.insert(all.end(), c.tris.begin(), c.tris.end());
  const std::vector<uint32_t> component = orient_consistently(all);
  const uint32_t components = component.empty() ? 0 : *std::max_element(component.begin(), component.end()) + 1;
  std::vector<std::vector<Tri>> shells(components);
  for (size_t t = 0; t < all.size(); ++t) shells[component[t]].push_back(all[t]);
  std::vector<bool> flip(components);
  for (uint32_t s = 0; s < components; ++s) flip[s] = signed_volume6(shells[s], pos) < 0.0;
  for (size_t t = 0; t < all.size(); ++t)
    if (flip[component[t]]) std::swap(all[t][1], all[t][2]);

  // Surface vertices get area-weighted smooth normals; each cap gets its own
  // copies of its vertices with the cap's flat normal (they weld by position).
  std::vector<size_t> group_end{surface.size()};
  for (const Cap& c : caps) group_end.push_back(group_end.back() + c.tris.size());
  TriangleMesh mesh;
  size_t begin = 0;
  for (size_t g = 0; g < group_end.size(); begin = group_end[g++]) {
    auto face_normal = [&](const Tri& f) { return cross(pos[f[1]] - pos[f[0]], pos[f[2]] - pos[f[0]]); };
    Vec3 flat{};
    for (size_t t = begin; t < group_end[g]; ++t) flat += face_normal(all[t]);
    std::unordered_map<uint32_t, uint32_t> copy;  // position index -> mesh vertex
    for (size_t t = begin; t < group_end[g]; ++t) {
      const Vec3 n = g == 0 ? face_normal(all[t]) : flat;
      for (uint32_t i : all[t]) {
        auto [it, added] = copy.emplace(i, uint32_t(mesh.positions.size()));
        if (added) {
          mesh.positions.push_back(pos[i]);
          mesh.normals.push_back(Vec3{});
        }
        mesh.normals[it->second] += n;
        mesh.indices.push_back(it->second);
      }
    }
  }
  for (Vec3& n : mesh.normals) n = normalize(n);

  // Rest on y = 0.
  float min_y = 1e30f;
  for (const Vec3& p : mesh.positions) min_y = std::min(min_y, p.y);
  for (Vec3& p : mesh.positions) p.y -= min_y;
  return mesh;
}

}  // namespace cdsm
