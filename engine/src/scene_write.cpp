// cdsm::Scene -> JSON scene file, the inverse of scene_json.cpp: what
// load_scene() reads back to an equal scene, bit for bit. Field reference:
// README "Scene files".
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <type_traits>
#include <vector>

#include "cdsm/config.h"
#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "cdsm/fields.h"
#include "cdsm/scene_io.h"

namespace cdsm {
namespace {

namespace fs = std::filesystem;

// A float with the fewest digits that read back to the same float the way
// the reader reads it (decimal -> double -> float); locale-independent.
// Negative zero keeps its sign ("-0" would read as the integer 0).
std::string number_text(float f) {
  if (f == 0.0f) return std::signbit(f) ? "-0.0" : "0";
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof buf, f);
  double back = 0.0;
  std::from_chars(buf, r.ptr, back);
  if (float(back) == f) return std::string(buf, r.ptr);
  r = std::to_chars(buf, buf + sizeof buf, double(f));  // exact through double
  return std::string(buf, r.ptr);
}

bool same_mesh(const TriangleMesh& a, const TriangleMesh& b) {
  auto same_vec3s = [](const std::vector<Vec3>& x, const std::vector<Vec3>& y) {
    return x.size() == y.size() && (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(Vec3)) == 0);
  };
  return same_vec3s(a.positions, b.positions) && a.indices == b.indices && same_vec3s(a.normals, b.normals);
}

// A tag as a JSON string: "packed".
template <class E>
std::string quoted(E e) {
  return std::string("\"") + tag_name(e) + "\"";
}

// One JSON object written field by field: {"a": 1, "b": [2, 3]}.
struct Fields {
  std::string text;
  void add(const char* key, const std::string& value) {
    text += text.empty() ? "{" : ", ";
    text += "\"";
    text += key;
    text += "\": ";
    text += value;
  }
  std::string done() const { return text.empty() ? "{}" : text + "}"; }
};

struct Writer {
  const Scene& s;
  std::string where;               // names the output (or the scene) in messages
  std::string base_dir;            // absolute folder the text will be read from; "" keeps file references
  std::vector<VolumeProxy> proxy;  // per volume: the proxy its object's volume_box mesh needs

  [[noreturn]] void fail(const std::string& pointer, const std::string& what) const {
    throw Error(where + ": " + (pointer.empty() ? "/" : pointer), what);
  }

  std::string num(float v, const std::string& pointer) const {
    if (!std::isfinite(v)) fail(pointer, "has a NaN or infinite value; a scene file cannot hold it");
    if (std::fabs(v) > 3.0e38f) fail(pointer, "is " + format_number(v) + ": a scene file holds numbers up to 3e+38");
    return number_text(v);
  }
  // Per-channel values (extinction, sigma): one number when grey.
  std::string channels(Vec3 v, const std::string& pointer) const {
    const bool grey = std::memcmp(&v.x, &v.y, sizeof(float)) == 0 && std::memcmp(&v.y, &v.z, sizeof(float)) == 0;
    return grey ? num(v.x, pointer) : vec(v, pointer);
  }
  std::string vec(Vec3 v, const std::string& pointer) const {
    return "[" + num(v.x, pointer + "/0") + ", " + num(v.y, pointer + "/1") + ", " + num(v.z, pointer + "/2") + "]";
  }
  std::string str(const std::string& v, const std::string& pointer) const {
    try {
      return nlohmann::json(v).dump();
    } catch (const nlohmann::json::exception&) {
      fail(pointer, "is not valid UTF-8");
    }
  }
  static std::string boolean(bool b) { return b ? "true" : "false"; }
  std::string matrix(const Mat4& m, const std::string& pointer) const {
    if (m.m[3][0] != 0 || m.m[3][1] != 0 || m.m[3][2] != 0 || m.m[3][3] != 1)
      fail(pointer, "the last row must be 0 0 0 1 (an affine transform)");
    std::string t = "{\"matrix\": [";
    for (int i = 0; i < 16; ++i)
      t += (i ? ", " : "") + num(m.m[i / 4][i % 4], pointer + "/matrix/" + std::to_string(i));
    return t + "]}";
  }
  // Flat numbers of a vertex array: [x0, y0, z0, x1, ...].
  std::string flat(const std::vector<Vec3>& v, const std::string& pointer) const {
    std::string t = "[";
    for (size_t i = 0; i < v.size(); ++i)
      for (int a = 0; a < 3; ++a)
        t += (i || a ? "," : "") + num(v[i][a], pointer + "/" + std::to_string(3 * i + size_t(a)));
    return t + "]";
  }

  // A description read from a file, its "file" reference relative to the
  // new folder when the reader made it absolute (it was found beside the
  // scene) and the two folders share more than the root.
  nlohmann::json parse_source(const std::string& text, const std::string& pointer) const {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception&) {
      fail(pointer, "its description (mesh_source / grid_source) is not valid JSON: " + text);
    }
    if (!j.is_object() || !j.contains("type") || !j["type"].is_string())
      fail(pointer, "its description (mesh_source / grid_source) has no \"type\": " + text);
    if (!base_dir.empty() && j.contains("file") && j["file"].is_string()) {
      const fs::path file = fs::path(j["file"].get<std::string>()).lexically_normal(), base(base_dir);
      if (file.is_absolute()) {
        const fs::path rel = file.lexically_relative(base);
        auto f = file.begin(), b = base.begin();
        int common = 0;
        for (; f != file.end() && b != base.end() && *f == *b; ++f, ++b) ++common;
        if (!rel.empty() && common >= 2) j["file"] = rel.string();
      }
    }
    return j;
  }

  std::string triangles(const TriangleMesh& m, const std::string& pointer) const {
    Fields f;
    f.add("type", "\"triangles\"");
    f.add("positions", flat(m.positions, pointer + "/positions"));
    std::string ix = "[";
    for (size_t i = 0; i < m.indices.size(); ++i) {
      if (m.indices[i] >= m.positions.size())
        fail(pointer + "/indices/" + std::to_string(i), "vertex index " + std::to_string(m.indices[i]) + " past the " +
                                                            std::to_string(m.positions.size()) + " vertices");
      ix += (i ? "," : "") + std::to_string(m.indices[i]);
    }
    if (m.indices.size() % 3 != 0) fail(pointer + "/indices", "is not 3 indices per triangle");
    f.add("indices", ix + "]");
    if (!m.normals.empty()) {
      if (m.normals.size() != m.positions.size()) fail(pointer + "/normals", "needs one normal per vertex");
      f.add("normals", flat(m.normals, pointer + "/normals"));
    }
    return f.done();
  }

  // Which proxy of volume `vi` the mesh is (the reader makes it again from
  // {"type":"volume_box"} and the volume's "proxy"); false: neither.
  bool proxy_of(const TriangleMesh& mesh, size_t vi, VolumeProxy& kind) const {
    const Volume& v = s.volumes[vi];
    for (VolumeProxy k : {VolumeProxy::Box, VolumeProxy::Leaves}) {
      if (k == VolumeProxy::Leaves && !v.sparse) continue;
      if ((v.grid || v.sparse) && same_mesh(mesh, make_volume_proxy(v, k))) {
        kind = k;
        return true;
      }
    }
    return false;
  }

  std::string mesh(const Object& o, const std::string& pointer) {
    if (!o.mesh) fail(pointer, "has no mesh");
    if (!o.mesh_source.empty()) {
      nlohmann::json j = parse_source(o.mesh_source, pointer);
      if (j["type"] == "gl_buffers")
        fail(pointer,
             "is a mesh that stays on the GPU (ShadowSystem::add_gpu_object): its triangles are in the "
             "application's GL buffers, not in the scene, and cannot be written");
      if (j["type"] != "volume_box") return j.dump();
      // A proxy is described only while it still is the proxy of the
      // object's volume (else its triangles are written).
      VolumeProxy kind = VolumeProxy::Box;
      if (o.interior == InteriorKind::Volume && proxy_of(*o.mesh, size_t(o.volume), kind)) {
        proxy[size_t(o.volume)] = kind;
        return j.dump();
      }
    }
    return triangles(*o.mesh, pointer);
  }

  std::string material(const SurfaceMaterial& m, const std::string& pointer) const {
    Fields f;
    write_fields(f, m, pointer);
    return f.done();
  }

  std::string object(const Object& o, size_t i) {
    const std::string at = "/objects/" + std::to_string(i);
    Fields f;
    write_fields(f, o, at);
    f.add("mesh", mesh(o, at + "/mesh"));
    f.add("transform", matrix(o.transform, at + "/transform"));
    f.add("material", material(o.surface, at + "/material"));
    Fields in;
    const InteriorKind kind =
        o.interior == InteriorKind::Constant || o.interior == InteriorKind::Volume ? o.interior : InteriorKind::None;
    in.add("type", quoted(kind));
    if (kind == InteriorKind::Constant) in.add("sigma", channels(o.sigma, at + "/interior/sigma"));
    if (kind == InteriorKind::Volume) {
      const Volume& v = s.volumes[size_t(o.volume)];
      in.add("volume", v.name.empty() ? std::to_string(o.volume) : str(v.name, at + "/interior/volume"));
    }
    f.add("interior", in.done());
    return f.done();
  }

  // Finds an origin the reader turns into `t` exactly: it computes
  // origin + 0.5 * voxel_size in float.
  static bool origin_for(float t, float vs, float& origin) {
    const float half = 0.5f * vs;
    float o = t - half;
    for (int step = 0; step < 8; ++step) {
      for (float c : {o, std::nextafter(o, INFINITY), std::nextafter(o, -INFINITY)})
        if (c + half == t && std::isfinite(c)) {
          origin = c;
          return true;
        }
      o = (o + half < t) ? std::nextafter(o, INFINITY) : std::nextafter(o, -INFINITY);
    }
    return false;
  }

  // voxel_size and origin when they give index_to_object exactly (an
  // axis-aligned placement); else index_to_object as a matrix.
  void placement(const Volume& v, nlohmann::json* raw_grid, Fields& f, const std::string& at) const {
    const Mat4& m = v.index_to_object;
    Vec3 vs{m.m[0][0], m.m[1][1], m.m[2][2]}, origin;
    bool axis_aligned = m.m[0][1] == 0 && m.m[0][2] == 0 && m.m[1][0] == 0 && m.m[1][2] == 0 && m.m[2][0] == 0 &&
                        m.m[2][1] == 0 && m.m[3][0] == 0 && m.m[3][1] == 0 && m.m[3][2] == 0 && m.m[3][3] == 1;
    for (int a = 0; a < 3 && axis_aligned; ++a)
      axis_aligned = vs[a] >= 1e-6f && vs[a] <= 1e6f && origin_for(m.m[a][3], vs[a], origin[a]);
    const bool has_spacing = raw_grid && raw_grid->contains("spacing");
    if (axis_aligned) {
      // A raw grid's spacing is its voxel size; kept when it still is.
      bool spacing_holds = false;
      if (has_spacing) {
        const nlohmann::json& sp = (*raw_grid)["spacing"];
        if (sp.is_array() && sp.size() == 3 && sp[0].is_number() && sp[1].is_number() && sp[2].is_number()) {
          spacing_holds = true;
          for (int a = 0; a < 3; ++a) spacing_holds = spacing_holds && float(sp[size_t(a)].get<double>()) == vs[a];
        }
        if (!spacing_holds) raw_grid->erase("spacing");
      }
      if (!spacing_holds) f.add("voxel_size", vec(vs, at + "/voxel_size"));
      f.add("origin", vec(origin, at + "/origin"));
    } else {
      if (has_spacing) raw_grid->erase("spacing");
      f.add("index_to_object", matrix(m, at + "/index_to_object"));
    }
  }

  std::string dense_grid(const DenseGrid& g, const std::string& pointer) const {
    const size_t count = size_t(std::max(g.nx, 0)) * size_t(std::max(g.ny, 0)) * size_t(std::max(g.nz, 0));
    if (g.nx < 1 || g.ny < 1 || g.nz < 1 || g.values.size() != count)
      fail(pointer, "a dense grid of " + std::to_string(g.nx) + "x" + std::to_string(g.ny) + "x" +
                        std::to_string(g.nz) + " voxels holds " + std::to_string(g.values.size()) + " values");
    Fields f;
    f.add("type", "\"dense\"");
    f.add("size", "[" + std::to_string(g.nx) + ", " + std::to_string(g.ny) + ", " + std::to_string(g.nz) + "]");
    auto density = [&](float d, const std::string& p) {
      if (!(d >= 0 && d <= 3.0e38f)) fail(p, "a density must be within [0, 3e+38], got " + format_number(d));
      return number_text(d);
    };
    std::string values = "[";
    for (size_t i = 0; i < count; ++i)
      values += (i ? "," : "") + density(g.values[i], pointer + "/values/" + std::to_string(i));
    f.add("values", values + "]");
    f.add("background", density(g.background, pointer + "/background"));
    return f.done();
  }

  std::string volume(const Volume& v, size_t i) const {
    const std::string at = "/volumes/" + std::to_string(i);
    Fields f;
    write_fields(f, v, at);
    if (bool(v.grid) == bool(v.sparse)) fail(at + "/grid", "a volume needs exactly one grid, dense or sparse");
    nlohmann::json source;
    bool described = false;
    if (!v.grid_source.empty()) {
      source = parse_source(v.grid_source, at + "/grid");
      described = (source["type"] == "vdb") == bool(v.sparse);  // else stale: the data are written
    }
    if (v.sparse && !described)
      fail(at + "/grid", "a sparse grid without a description (grid_source naming its .vdb file) cannot be written");
    if (v.grid) {
      Fields place;  // decided first: it may drop a raw grid's spacing
      placement(v, described && source["type"] == "raw" ? &source : nullptr, place, at);
      f.add("grid", described ? source.dump() : dense_grid(*v.grid, at + "/grid"));
      f.text += ", " + place.text.substr(1);
    } else {
      f.add("grid", source.dump());  // placed by the .vdb's own transform
    }
    f.add("proxy", proxy[i] == VolumeProxy::Leaves ? "\"leaves\"" : "\"box\"");
    std::string tf = "[";
    for (size_t k = 0; k < v.transfer.size(); ++k) {
      const std::string pt = at + "/transfer/" + std::to_string(k);
      Fields p;
      p.add("density", num(v.transfer[k].density, pt + "/density"));
      p.add("extinction", channels(v.transfer[k].extinction, pt + "/extinction"));
      p.add("color", vec(v.transfer[k].color, pt + "/color"));
      tf += (k ? ", " : "") + p.done();
    }
    f.add("transfer", tf + "]");
    return f.done();
  }

  std::string light(const Light& l, size_t i) const {
    Fields f;
    write_fields(f, l, "/lights/" + std::to_string(i));
    return f.done();
  }

  std::string camera() const {
    Fields f;
    write_fields(f, s.camera, "/camera");
    return f.done();
  }

  std::string shadows() const {
    Fields f;
    write_fields(f, s.shadows, "/shadows");
    return f.done();
  }

  // Every field of S's table, by its key, in table order.
  template <class S>
  void write_fields(Fields& f, const S& value, const std::string& at) const {
    for_each_field<S>([&](const auto& field) {
      const auto& v = value.*field.member;
      using T = std::remove_cv_t<std::remove_reference_t<decltype(v)>>;
      const std::string path = at + "/" + field.key;
      if constexpr (std::is_enum_v<T>)
        f.add(field.key, quoted(v));
      else if constexpr (std::is_same_v<T, bool>)
        f.add(field.key, boolean(v));
      else if constexpr (std::is_same_v<T, float>)
        f.add(field.key, num(v, path));
      else if constexpr (std::is_same_v<T, Vec3>)
        f.add(field.key, vec(v, path));
      else if constexpr (std::is_same_v<T, std::string>)
        f.add(field.key, str(v, path));
      else if (zero_is_auto(field) && v == 0)
        f.add(field.key, "\"auto\"");
      else
        f.add(field.key, std::to_string(v));
    });
  }

  // What only the reader checks (validate_scene has checked the ranges).
  void check_structure() const {
    if (s.lights.empty()) fail("/lights", "a scene needs at least one light");
    std::map<std::string, size_t> names;
    for (size_t i = 0; i < s.volumes.size(); ++i) {
      const std::string& n = s.volumes[i].name;
      if (!n.empty() && !names.emplace(n, i).second)
        fail("/volumes/" + std::to_string(i) + "/name",
             "volumes " + std::to_string(names[n]) + " and " + std::to_string(i) + " share the name '" + n + "'");
    }
    std::vector<int> users(s.volumes.size(), 0);
    for (const Object& o : s.objects)
      if (o.interior == InteriorKind::Volume) ++users[size_t(o.volume)];  // index checked by validate_scene
    for (size_t i = 0; i < users.size(); ++i)
      if (users[i] != 1)
        fail("/volumes/" + std::to_string(i),
             users[i] == 0 ? "volume is not used by any object (a scene file places each volume in exactly one object)"
                           : "volume is used by more than one object");
  }

  std::string write() {
    // Ranges first, reported at their field of the output.
    try {
      validate_scene(s);
    } catch (const Error& e) {
      const std::string prefix = s.source + ": ";
      if (e.where().rfind(prefix, 0) == 0) fail(e.where().substr(prefix.size()), e.problem());
      throw Error(where, e.what());
    }
    check_structure();
    proxy.assign(s.volumes.size(), VolumeProxy::Box);
    std::vector<std::string> objects;  // before the volumes: they decide each volume's proxy
    for (size_t i = 0; i < s.objects.size(); ++i) objects.push_back(object(s.objects[i], i));
    std::string t = "{\n";
    t += "  \"camera\": " + camera() + ",\n";
    t += "  \"shadows\": " + shadows() + ",\n";
    t += "  \"background\": " + vec(s.background, "/background") + ",\n";
    auto list = [&](const char* key, const std::vector<std::string>& items, bool last) {
      t += std::string("  \"") + key + "\": [";
      for (size_t i = 0; i < items.size(); ++i) t += (i ? ",\n    " : "\n    ") + items[i];
      t += items.empty() ? "]" : "\n  ]";
      t += last ? "\n" : ",\n";
    };
    std::vector<std::string> volumes, lights;
    for (size_t i = 0; i < s.volumes.size(); ++i) volumes.push_back(volume(s.volumes[i], i));
    for (size_t i = 0; i < s.lights.size(); ++i) lights.push_back(light(s.lights[i], i));
    list("volumes", volumes, false);
    list("objects", objects, false);
    list("lights", lights, true);
    return t + "}\n";
  }
};

std::string absolute_dir(const std::string& dir) {
  std::error_code ec;
  fs::path p = fs::absolute(dir.empty() ? fs::path(".") : fs::path(dir), ec);
  return ec ? dir : p.lexically_normal().string();
}

std::string dir_of(const std::string& path) {
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash == 0 ? 1 : slash);
}

bool ends_with_ci(const std::string& s, const std::string& ext) {
  if (s.size() < ext.size()) return false;
  for (size_t i = 0; i < ext.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - ext.size() + i])) != ext[i]) return false;
  return true;
}

}  // namespace

std::string scene_to_json(const Scene& scene, const std::string& base_dir) {
  Writer w{scene, scene.source.empty() ? "scene" : scene.source, base_dir.empty() ? "" : absolute_dir(base_dir), {}};
  return w.write();
}

void save_scene(const Scene& scene, const std::string& path) {
  if (path.empty()) throw Error("save_scene", "no file name given");
  if (ends_with_ci(path, ".gltf") || ends_with_ci(path, ".glb"))
    throw Error(path, "scene files are written as JSON: give a name that does not end in .gltf or .glb");
  struct stat target {};
  const bool exists = ::stat(path.c_str(), &target) == 0;
  if (exists && S_ISDIR(target.st_mode)) throw Error(path, "is a directory, not a scene file");
  if (exists && !S_ISREG(target.st_mode)) throw Error(path, "is not a regular file: a scene file is not written there");
  const std::string dir = dir_of(path);
  Writer w{scene, path, absolute_dir(dir), {}};
  const std::string text = w.write();

  // Beside the target, renamed over it when complete.
  const std::string name = path.substr(dir.empty() ? 0 : dir.size() + (dir == "/" ? 0 : 1));
  std::string tmp = (dir.empty() ? "" : (dir == "/" ? "/" : dir + "/")) + "." + name + ".XXXXXX";
  std::vector<char> tmpl(tmp.begin(), tmp.end());
  tmpl.push_back('\0');
  const int fd = ::mkstemp(tmpl.data());
  if (fd < 0)
    throw Error(path,
                std::string("cannot create a file in '") + (dir.empty() ? "." : dir) + "': " + std::strerror(errno));
  tmp = tmpl.data();
  auto fail = [&](const std::string& what) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    throw Error(path, what + ": " + std::strerror(err));
  };
  for (size_t done = 0; done < text.size();) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail("cannot write the scene file");
    done += size_t(n);
  }
  // The target's permissions when it exists, else rw-r--r--.
  if (::fchmod(fd, exists ? (target.st_mode & 07777) : 0644) != 0) fail("cannot set the file's permissions");
  if (::fsync(fd) != 0) fail("cannot write the scene file");
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw Error(path, std::string("cannot write the scene file: ") + std::strerror(err));
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw Error(path, std::string("cannot replace the file: ") + std::strerror(err));
  }
}

}  // namespace cdsm
