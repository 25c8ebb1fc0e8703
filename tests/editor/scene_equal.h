// equal_scenes(): two scenes hold the same content, field by field — floats
// bit for bit, meshes by their vertex and index data, grids by their values
// (sparse: their NanoVDB bytes) — and the same descriptions (mesh_source,
// grid_source). Scene::source (where a scene came from) is not content and
// is not compared. Used by the scene-file round trip and the editor's undo
// tests.
#pragma once

#include <type_traits>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "cdsm/fields.h"
#include "cdsm/scene.h"

namespace cdsm_test {

struct SceneComparer {
  std::string why;  // the first difference, as a JSON pointer and both values

  bool differ(const std::string& at, const std::string& a, const std::string& b) {
    if (why.empty()) why = at + ": " + a + " != " + b;
    return false;
  }
  static std::string text(float v) {
    std::ostringstream s;
    s.precision(9);
    s << v;
    if (v == 0 && std::signbit(v)) s << " (negative zero)";
    return s.str();
  }
  bool f(const std::string& at, float a, float b) {
    return std::memcmp(&a, &b, sizeof a) == 0 || differ(at, text(a), text(b));
  }
  bool v(const std::string& at, cdsm::Vec3 a, cdsm::Vec3 b) {
    return f(at + "/0", a.x, b.x) && f(at + "/1", a.y, b.y) && f(at + "/2", a.z, b.z);
  }
  bool m(const std::string& at, const cdsm::Mat4& a, const cdsm::Mat4& b) {
    bool ok = true;
    for (int i = 0; i < 16 && ok; ++i) ok = f(at + "/" + std::to_string(i), a.m[i / 4][i % 4], b.m[i / 4][i % 4]);
    return ok;
  }
  template <class I>
  bool i(const std::string& at, I a, I b) {
    return a == b || differ(at, std::to_string(int64_t(a)), std::to_string(int64_t(b)));
  }
  bool s(const std::string& at, const std::string& a, const std::string& b) {
    return a == b || differ(at, "'" + a + "'", "'" + b + "'");
  }
  bool vs(const std::string& at, const std::vector<cdsm::Vec3>& a, const std::vector<cdsm::Vec3>& b) {
    if (!i(at + " (count)", a.size(), b.size())) return false;
    for (size_t k = 0; k < a.size(); ++k)
      if (!v(at + "/" + std::to_string(k), a[k], b[k])) return false;
    return true;
  }

  bool mesh(const std::string& at, const cdsm::TriangleMesh* a, const cdsm::TriangleMesh* b) {
    if (!a || !b) return i(at + " (present)", a != nullptr, b != nullptr);
    if (!vs(at + "/positions", a->positions, b->positions) || !vs(at + "/normals", a->normals, b->normals) ||
        !i(at + "/indices (count)", a->indices.size(), b->indices.size()))
      return false;
    for (size_t k = 0; k < a->indices.size(); ++k)
      if (!i(at + "/indices/" + std::to_string(k), a->indices[k], b->indices[k])) return false;
    return true;
  }

  bool dense(const std::string& at, const cdsm::DenseGrid* a, const cdsm::DenseGrid* b) {
    if (!a || !b) return i(at + " (dense grid present)", a != nullptr, b != nullptr);
    if (!i(at + "/nx", a->nx, b->nx) || !i(at + "/ny", a->ny, b->ny) || !i(at + "/nz", a->nz, b->nz) ||
        !f(at + "/background", a->background, b->background) ||
        !i(at + "/values (count)", a->values.size(), b->values.size()))
      return false;
    for (size_t k = 0; k < a->values.size(); ++k)
      if (!f(at + "/values/" + std::to_string(k), a->values[k], b->values[k])) return false;
    return true;
  }

  bool sparse(const std::string& at, const cdsm::SparseGrid* a, const cdsm::SparseGrid* b) {
    if (!a || !b) return i(at + " (sparse grid present)", a != nullptr, b != nullptr);
    bool ok = s(at + "/name", a->name, b->name) && i(at + "/nanovdb_bytes", a->nanovdb_bytes, b->nanovdb_bytes) &&
              i(at + "/active_voxels", a->active_voxels, b->active_voxels) &&
              f(at + "/background", a->background, b->background) && f(at + "/min_value", a->min_value, b->min_value) &&
              f(at + "/max_value", a->max_value, b->max_value);
    for (int k = 0; k < 3 && ok; ++k)
      ok = i(at + "/active_min", a->active_min[k], b->active_min[k]) &&
           i(at + "/active_max", a->active_max[k], b->active_max[k]);
    if (ok && a->nanovdb_bytes <= 32 * a->nanovdb.size() && a->nanovdb_bytes <= 32 * b->nanovdb.size() &&
        std::memcmp(a->data(), b->data(), a->nanovdb_bytes) != 0)
      return differ(at + "/nanovdb", "bytes", "other bytes");
    return ok;
  }

  bool surface(const std::string& at, const cdsm::SurfaceMaterial& a, const cdsm::SurfaceMaterial& b) {
    return fields(at, a, b);
  }

  bool object(const std::string& at, const cdsm::Object& a, const cdsm::Object& b) {
    return fields(at, a, b) && mesh(at + "/mesh", a.mesh.get(), b.mesh.get()) &&
           s(at + "/mesh_source", a.mesh_source, b.mesh_source) && m(at + "/transform", a.transform, b.transform) &&
           surface(at + "/material", a.surface, b.surface) &&
           i(at + "/interior", uint32_t(a.interior), uint32_t(b.interior)) && v(at + "/sigma", a.sigma, b.sigma) &&
           i(at + "/volume", a.volume, b.volume);
  }

  bool volume(const std::string& at, const cdsm::Volume& a, const cdsm::Volume& b) {
    if (!fields(at, a, b) || !dense(at + "/grid", a.grid.get(), b.grid.get()) ||
        !sparse(at + "/grid", a.sparse.get(), b.sparse.get()) ||
        !s(at + "/grid_source", a.grid_source, b.grid_source) ||
        !m(at + "/index_to_object", a.index_to_object, b.index_to_object) ||
        !i(at + "/transfer (count)", a.transfer.size(), b.transfer.size()))
      return false;
    for (size_t k = 0; k < a.transfer.size(); ++k) {
      const std::string p = at + "/transfer/" + std::to_string(k);
      if (!f(p + "/density", a.transfer[k].density, b.transfer[k].density) ||
          !v(p + "/extinction", a.transfer[k].extinction, b.transfer[k].extinction) ||
          !v(p + "/color", a.transfer[k].color, b.transfer[k].color))
        return false;
    }
    return true;
  }

  bool light(const std::string& at, const cdsm::Light& a, const cdsm::Light& b) { return fields(at, a, b); }
  bool camera(const cdsm::Camera& a, const cdsm::Camera& b) { return fields("/camera", a, b); }

  // Every field of S's table (cdsm/fields.h).
  template <class S>
  bool fields(const std::string& at, const S& a, const S& b) {
    bool same = true;
    cdsm::for_each_field<S>([&](const auto& fd) {
      const auto &x = a.*fd.member, &y = b.*fd.member;
      using T = std::remove_cv_t<std::remove_reference_t<decltype(x)>>;
      const std::string path = at + "/" + fd.key;
      if (!same) return;
      if constexpr (std::is_same_v<T, float>)
        same = f(path, x, y);
      else if constexpr (std::is_same_v<T, cdsm::Vec3>)
        same = v(path, x, y);
      else if constexpr (std::is_enum_v<T>)
        same = i(path, uint32_t(x), uint32_t(y));
      else if constexpr (std::is_same_v<T, std::string>)
        same = s(path, x, y);
      else
        same = i(path, x, y);
    });
    return same;
  }

  bool shadows(const cdsm::ShadowSettings& a, const cdsm::ShadowSettings& b) { return fields("/shadows", a, b); }

  bool scene(const cdsm::Scene& a, const cdsm::Scene& b) {
    if (!camera(a.camera, b.camera) || !shadows(a.shadows, b.shadows) ||
        !v("/background", a.background, b.background) || !i("/objects (count)", a.objects.size(), b.objects.size()) ||
        !i("/volumes (count)", a.volumes.size(), b.volumes.size()) ||
        !i("/lights (count)", a.lights.size(), b.lights.size()))
      return false;
    for (size_t k = 0; k < a.objects.size(); ++k)
      if (!object("/objects/" + std::to_string(k), a.objects[k], b.objects[k])) return false;
    for (size_t k = 0; k < a.volumes.size(); ++k)
      if (!volume("/volumes/" + std::to_string(k), a.volumes[k], b.volumes[k])) return false;
    for (size_t k = 0; k < a.lights.size(); ++k)
      if (!light("/lights/" + std::to_string(k), a.lights[k], b.lights[k])) return false;
    return true;
  }
};

// Whether a and b hold the same content; otherwise *why names the first
// difference (a JSON pointer into the scene and both values).
inline bool equal_scenes(const cdsm::Scene& a, const cdsm::Scene& b, std::string* why = nullptr) {
  SceneComparer c;
  const bool same = c.scene(a, b);
  if (why) *why = c.why;
  return same;
}

}  // namespace cdsm_test
