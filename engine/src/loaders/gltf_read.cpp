// glTF 2.0 reading with every reference checked (no out-of-range read
// whatever the file says), node transforms and primitives.
#include "loaders/gltf_read.h"

#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "cdsm/error.h"
#include "cdsm/loaders.h"

namespace cdsm::gltf {
namespace {

constexpr uint64_t kMaxFileBytes = uint64_t(1) << 31;  // tinygltf takes 32-bit lengths

// Extensions this loader reads.
const std::set<std::string> kHandled = {"KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_volume"};
// Extensions that change only the look of surfaces; without them the
// geometry is still right (reported as unsupported when used).
bool appearance_only(const std::string& ext) {
  return ext.rfind("KHR_materials_", 0) == 0 || ext.rfind("KHR_texture_", 0) == 0 ||
         ext.rfind("EXT_texture_", 0) == 0 || ext == "MSFT_texture_dds";
}

// tinygltf's messages quote what the JSON parser last read: in a truncated
// .gltf that is the rest of a base64 buffer (hundreds of kB). One line, the
// quote cut to 100 characters, at most 300 in all.
std::string shorten_context(std::string m) {
  for (char& c : m)
    if (c == '\n' || c == '\r') c = ' ';
  const std::string mark = "last read: '";
  size_t at = m.find(mark);
  if (at != std::string::npos) {
    size_t from = at + mark.size(), end = m.find('\'', from);
    size_t len = (end == std::string::npos ? m.size() : end) - from;
    if (len > 100)
      m = m.substr(0, from + 100) + "...' (" + std::to_string(len) + " characters)" +
          (end == std::string::npos ? "" : m.substr(end + 1));
  }
  if (m.size() > 300) m = m.substr(0, 300) + "... (" + std::to_string(m.size()) + " characters)";
  return m;
}

bool regular_file(const std::string& p, uint64_t* size = nullptr) {
  struct stat st {};
  if (::stat(p.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  if (size) *size = uint64_t(st.st_size);
  return true;
}

bool read_bytes(const std::string& p, std::vector<unsigned char>& out, std::string* err) {
  uint64_t size = 0;
  if (!regular_file(p, &size)) {
    if (err) *err += "file not found: " + p + "\n";
    return false;
  }
  if (size > kMaxFileBytes) {
    if (err) *err += "file larger than 2 GiB: " + p + "\n";
    return false;
  }
  std::ifstream in(p, std::ios::binary);
  out.resize(size);
  if (size > 0) in.read(reinterpret_cast<char*>(out.data()), std::streamsize(size));
  if (!in || uint64_t(in.gcount()) != size) {
    if (err) *err += "cannot read " + p + "\n";
    return false;
  }
  return true;
}

// Filesystem callbacks: plain reads, no path expansion (tinygltf's default
// expands shell words), no writes.
bool fs_exists(const std::string& p, void*) { return regular_file(p); }
std::string fs_expand(const std::string& p, void*) { return p; }
bool fs_read(std::vector<unsigned char>* out, std::string* err, const std::string& p, void*) {
  return read_bytes(p, *out, err);
}
bool fs_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "writing is disabled\n";
  return false;
}
// Loading from memory: the file system stays shut (an external buffer or
// image URI is not found).
bool mem_exists(const std::string&, void*) { return false; }
bool mem_read(std::vector<unsigned char>*, std::string* err, const std::string& p, void*) {
  if (err) *err += "cannot read the external file '" + p + "' when loading from memory\n";
  return false;
}

// load_gltf_scene_from_memory() runs load_gltf_scene() with this set: a
// read_file() of `name` on this thread parses `bytes` instead of a file.
struct MemoryFile {
  const std::string* name;
  const std::vector<unsigned char>* bytes;
};
thread_local const MemoryFile* t_memory_file = nullptr;

// Images are never decoded: textures are not supported.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char& c : s)
    if (c == '\n') c = ';';
  return s;
}

size_t component_size(int type) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_INT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: return 8;
    default: return 0;
  }
}

// A checked view of an accessor's elements: element i starts at
// base + i * stride and has `elem` bytes, all inside the buffer.
struct AccessorView {
  const unsigned char* base = nullptr;
  size_t stride = 0, elem = 0, count = 0;
  int component = 0, type = 0;
};

AccessorView view_accessor(const File& f, int index, const std::string& what) {
  const tinygltf::Model& m = f.model;
  auto fail = [&](const std::string& why) -> AccessorView { throw Error(f.path, what + ": " + why); };
  if (index < 0 || size_t(index) >= m.accessors.size())
    return fail("accessor " + std::to_string(index) + " does not exist (the file has " +
                std::to_string(m.accessors.size()) + ")");
  const tinygltf::Accessor& a = m.accessors[size_t(index)];
  const std::string acc = "accessor " + std::to_string(index);
  if (a.sparse.isSparse) return fail(acc + " is sparse; sparse accessors are not supported");
  AccessorView v;
  v.component = a.componentType;
  v.type = a.type;
  v.count = a.count;
  const size_t cs = component_size(a.componentType);
  const int n = tinygltf::GetNumComponentsInType(uint32_t(a.type));
  if (cs == 0 || n <= 0) return fail(acc + " has an invalid component type or type");
  v.elem = cs * size_t(n);
  if (a.count == 0) return v;
  if (a.bufferView < 0 || size_t(a.bufferView) >= m.bufferViews.size())
    return fail(acc + " refers to buffer view " + std::to_string(a.bufferView) + ", which does not exist");
  const tinygltf::BufferView& bv = m.bufferViews[size_t(a.bufferView)];
  const std::string view = "buffer view " + std::to_string(a.bufferView);
  if (bv.buffer < 0 || size_t(bv.buffer) >= m.buffers.size())
    return fail(view + " refers to buffer " + std::to_string(bv.buffer) + ", which does not exist");
  const tinygltf::Buffer& b = m.buffers[size_t(bv.buffer)];
  if (bv.byteOffset > b.data.size() || bv.byteLength > b.data.size() - bv.byteOffset)
    return fail(view + " (bytes " + std::to_string(bv.byteOffset) + " + " + std::to_string(bv.byteLength) +
                ") lies outside buffer " + std::to_string(bv.buffer) + " (" + std::to_string(b.data.size()) +
                " bytes)");
  v.stride = bv.byteStride ? bv.byteStride : v.elem;
  if (v.stride < v.elem) return fail(view + " has a byte stride smaller than an element of " + acc);
  // Last byte read: byteOffset + stride * (count - 1) + elem, without overflow.
  const size_t limit = bv.byteLength;
  if (a.byteOffset > limit || a.count - 1 > (limit - a.byteOffset) / v.stride ||
      a.byteOffset + v.stride * (a.count - 1) + v.elem > limit)
    return fail(acc + " (" + std::to_string(a.count) + " elements from byte " + std::to_string(a.byteOffset) +
                ") reads past the end of " + view + " (" + std::to_string(limit) + " bytes)");
  v.base = b.data.data() + bv.byteOffset + a.byteOffset;
  return v;
}

template <class T>
T load(const unsigned char* p) {
  T x;
  std::memcpy(&x, p, sizeof(T));
  return x;
}

// VEC3 of FLOAT; NaN or infinite elements are an error unless `lenient`
// (then they are read as they are and the caller repairs them).
std::vector<Vec3> read_vec3(const File& f, int index, const std::string& what, bool lenient = false) {
  AccessorView v = view_accessor(f, index, what);
  if (v.type != TINYGLTF_TYPE_VEC3 || v.component != TINYGLTF_COMPONENT_TYPE_FLOAT)
    throw Error(f.path, what + ": accessor " + std::to_string(index) + " is not VEC3 of FLOAT");
  std::vector<Vec3> out(v.count);
  for (size_t i = 0; i < v.count; ++i) {
    const unsigned char* p = v.base + i * v.stride;
    out[i] = {load<float>(p), load<float>(p + 4), load<float>(p + 8)};
    if (!lenient && !is_finite(out[i]))
      throw Error(f.path, what + ": element " + std::to_string(i) + " is NaN or infinite");
  }
  return out;
}

// A normal the shading can use: finite and of non-zero length.
bool usable_normal(Vec3 n) { return is_finite(n) && dot(n, n) > 1e-24f; }

// Replaces unusable normals of `m` by the area-weighted normal of the
// triangles around their vertex (outward for counter-clockwise triangles);
// returns how many were replaced.
size_t repair_normals(TriangleMesh& m) {
  std::vector<uint8_t> bad(m.normals.size(), 0);
  size_t count = 0;
  for (size_t i = 0; i < m.normals.size(); ++i)
    if (!usable_normal(m.normals[i])) {
      bad[i] = 1;
      ++count;
      m.normals[i] = Vec3{0, 0, 0};
    }
  if (count == 0) return 0;
  for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    const uint32_t a = m.indices[t], b = m.indices[t + 1], c = m.indices[t + 2];
    Vec3 area = cross(m.positions[b] - m.positions[a], m.positions[c] - m.positions[a]);  // twice the area
    for (uint32_t v : {a, b, c})
      if (bad[v]) m.normals[v] += area;
  }
  for (size_t i = 0; i < m.normals.size(); ++i)
    if (bad[i]) m.normals[i] = usable_normal(m.normals[i]) ? normalize(m.normals[i]) : Vec3{0, 1, 0};
  return count;
}

std::vector<uint32_t> read_indices(const File& f, int index, size_t vertices, const std::string& what) {
  AccessorView v = view_accessor(f, index, what);
  if (v.type != TINYGLTF_TYPE_SCALAR ||
      (v.component != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && v.component != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
       v.component != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT))
    throw Error(f.path, what + ": accessor " + std::to_string(index) + " is not SCALAR of unsigned integers");
  std::vector<uint32_t> out(v.count);
  for (size_t i = 0; i < v.count; ++i) {
    const unsigned char* p = v.base + i * v.stride;
    uint32_t x = v.component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE    ? uint32_t(*p)
                 : v.component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? uint32_t(load<uint16_t>(p))
                                                                         : load<uint32_t>(p);
    if (x >= vertices)
      throw Error(f.path, what + ": index " + std::to_string(i) + " is " + std::to_string(x) + ", but there are " +
                              std::to_string(vertices) + " vertices");
    out[i] = x;
  }
  return out;
}

bool finite_mat(const Mat4& m) {
  for (const auto& r : m.m)
    for (float x : r)
      if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace

std::string Unsupported::message(const std::string& path) const {
  std::string s = path + ": unsupported glTF features ignored:";
  bool first = true;
  for (const auto& [feature, where] : found_) {
    s += first ? " " : "; ";
    first = false;
    s += feature + " (";
    size_t k = 0;
    for (const std::string& w : where) {
      if (k == 8) {
        s += ", ... " + std::to_string(where.size() - 8) + " more";
        break;
      }
      s += (k++ ? ", " : "") + w;
    }
    s += ")";
  }
  return s;
}

void Unsupported::report(const std::string& path) const {
  if (!empty()) warn(message(path));
}

namespace {

// Parses the bytes of a .gltf or .glb named `path` in messages; `dir`
// resolves external URIs, `from_memory` shuts the file system.
File parse_bytes(const std::string& path, const std::vector<unsigned char>& bytes, const std::string& dir,
                 bool from_memory, Unsupported& unsupported) {
  File f;
  f.path = path;
  std::string err;
  tinygltf::TinyGLTF loader;
  tinygltf::FsCallbacks fs{};
  fs.FileExists = from_memory ? mem_exists : fs_exists;
  fs.ExpandFilePath = fs_expand;
  fs.ReadWholeFile = from_memory ? mem_read : fs_read;
  fs.WriteWholeFile = fs_write;
  fs.user_data = nullptr;
  loader.SetFsCallbacks(fs);
  loader.SetImageLoader(skip_image, nullptr);
  std::string warn_text;
  bool ok = false;
  const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  if (bytes.size() > std::numeric_limits<unsigned>::max())
    throw Error(path, "glTF file of " + std::to_string(bytes.size()) + " bytes is larger than 4 GiB");
  if (binary) {  // the 12-byte header: magic, version, total length (little-endian)
    if (bytes.size() < 12) throw Error(path, "invalid or truncated .glb file: the 12-byte header is cut off");
    const uint32_t version =
        uint32_t(bytes[4]) | uint32_t(bytes[5]) << 8 | uint32_t(bytes[6]) << 16 | uint32_t(bytes[7]) << 24;
    if (version != 2)
      throw Error(path,
                  "the .glb header says version " + std::to_string(version) + "; only binary glTF 2 is supported");
  }
  try {
    if (binary)
      ok = loader.LoadBinaryFromMemory(&f.model, &err, &warn_text, bytes.data(), unsigned(bytes.size()), dir);
    else
      ok = loader.LoadASCIIFromString(&f.model, &err, &warn_text, reinterpret_cast<const char*>(bytes.data()),
                                      unsigned(bytes.size()), dir);
  } catch (const std::bad_alloc&) {
    throw Error(path, "corrupt glTF file (a size field asks for an impossible allocation)");
  } catch (const std::exception& e) {
    throw Error(path, std::string("invalid glTF file: ") + e.what());
  }
  if (!ok) {
    std::string why = shorten_context(trim(err.empty() ? warn_text : err));
    throw Error(path, std::string(binary ? "invalid or truncated .glb file" : "invalid glTF file") +
                          (why.empty() ? "" : ": " + why));
  }
  const tinygltf::Model& m = f.model;
  if (m.asset.version.compare(0, 2, "2.") != 0)
    throw Error(path, "asset.version is '" + m.asset.version + "'; only glTF 2.x is supported");
  for (const std::string& ext : m.extensionsRequired)
    if (!kHandled.count(ext) && !appearance_only(ext))
      throw Error(path, "requires the glTF extension " + ext + ", which this loader does not support");
  for (const std::string& ext : m.extensionsUsed)
    if (!kHandled.count(ext)) unsupported.add("extension " + ext, "file");
  if (!m.animations.empty())
    unsupported.add("animations (the static pose is used)", std::to_string(m.animations.size()) + " animations");

  // The node hierarchy must be a forest.
  f.parent.assign(m.nodes.size(), -1);
  for (size_t i = 0; i < m.nodes.size(); ++i)
    for (int c : m.nodes[i].children) {
      if (c < 0 || size_t(c) >= m.nodes.size())
        throw Error(path, "node " + std::to_string(i) + " has child " + std::to_string(c) + ", which does not exist");
      if (f.parent[size_t(c)] != -1 || size_t(c) == i)
        throw Error(path, "node " + std::to_string(c) + " has more than one parent (the hierarchy must be a tree)");
      f.parent[size_t(c)] = int(i);
    }
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    size_t steps = 0;
    for (int p = f.parent[i]; p >= 0; p = f.parent[size_t(p)])
      if (++steps > m.nodes.size()) throw Error(path, "node " + std::to_string(i) + " is part of a cycle");
  }
  for (const tinygltf::Scene& s : m.scenes)
    for (int n : s.nodes)
      if (n < 0 || size_t(n) >= m.nodes.size())
        throw Error(path, "scene '" + s.name + "' lists node " + std::to_string(n) + ", which does not exist");
  if (m.defaultScene >= 0 && size_t(m.defaultScene) >= m.scenes.size())
    throw Error(path, "default scene " + std::to_string(m.defaultScene) + " does not exist");
  return f;
}

}  // namespace

File read_file(const std::string& path, Unsupported& unsupported) {
  if (t_memory_file && *t_memory_file->name == path)
    return parse_bytes(path, *t_memory_file->bytes, "", /*from_memory=*/true, unsupported);
  std::vector<unsigned char> bytes;
  std::string err;
  require_file(path, "glTF file");
  if (!read_bytes(path, bytes, &err)) throw Error(path, "cannot read glTF file (" + trim(err) + ")");
  std::string dir;
  size_t slash = path.find_last_of('/');
  if (slash != std::string::npos) dir = path.substr(0, slash);
  return parse_bytes(path, bytes, dir, /*from_memory=*/false, unsupported);
}

std::string node_label(const File& f, int node) {
  const std::string& n = f.model.nodes[size_t(node)].name;
  return (n.empty() ? std::string() : "'" + n + "' ") + "(node " + std::to_string(node) + ")";
}

Mat4 local_transform(const File& f, int node) {
  const tinygltf::Node& n = f.model.nodes[size_t(node)];
  auto fail = [&](const std::string& why) -> Mat4 { throw Error(f.path, "node " + node_label(f, node) + ": " + why); };
  Mat4 m;
  if (!n.matrix.empty()) {
    if (n.matrix.size() != 16) return fail("matrix needs 16 numbers");
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m.m[r][c] = float(n.matrix[size_t(c * 4 + r)]);  // column-major
  } else {
    Vec3 t{0, 0, 0}, s{1, 1, 1};
    double q[4] = {0, 0, 0, 1};
    if (!n.translation.empty()) {
      if (n.translation.size() != 3) return fail("translation needs 3 numbers");
      t = {float(n.translation[0]), float(n.translation[1]), float(n.translation[2])};
    }
    if (!n.scale.empty()) {
      if (n.scale.size() != 3) return fail("scale needs 3 numbers");
      s = {float(n.scale[0]), float(n.scale[1]), float(n.scale[2])};
    }
    if (!n.rotation.empty()) {
      if (n.rotation.size() != 4) return fail("rotation needs 4 numbers");
      for (int i = 0; i < 4; ++i) q[i] = n.rotation[size_t(i)];
    }
    double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!std::isfinite(len)) return fail("transform has NaN or infinite values");
    if (!(len > 1e-12)) return fail("rotation quaternion is zero");
    const double x = q[0] / len, y = q[1] / len, z = q[2] / len, w = q[3] / len;
    const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                            {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                            {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    const float sc[3] = {s.x, s.y, s.z};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m.m[i][j] = float(r[i][j] * sc[j]);
    m.m[0][3] = t.x;
    m.m[1][3] = t.y;
    m.m[2][3] = t.z;
  }
  if (!finite_mat(m)) return fail("transform has NaN or infinite values");
  return m;
}

Mat4 global_transform(const File& f, int node) {
  Mat4 m = local_transform(f, node);
  for (int p = f.parent[size_t(node)]; p >= 0; p = f.parent[size_t(p)]) m = local_transform(f, p) * m;
  if (!finite_mat(m)) throw Error(f.path, "node " + node_label(f, node) + ": global transform overflows");
  return m;
}

std::vector<int> scene_roots(const File& f) {
  const tinygltf::Model& m = f.model;
  if (!m.scenes.empty()) return m.scenes[size_t(std::max(m.defaultScene, 0))].nodes;
  std::vector<int> roots;
  for (size_t i = 0; i < m.nodes.size(); ++i)
    if (f.parent[i] < 0) roots.push_back(int(i));
  return roots;
}

void walk(const File& f, const std::vector<int>& roots, const Mat4& root_parent,
          const std::function<void(int, const Mat4&)>& visit) {
  std::vector<std::pair<int, Mat4>> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, root_parent});
  while (!stack.empty()) {
    auto [node, parent] = stack.back();
    stack.pop_back();
    Mat4 g = parent * local_transform(f, node);
    if (!finite_mat(g)) throw Error(f.path, "node " + node_label(f, node) + ": global transform overflows");
    visit(node, g);
    const auto& ch = f.model.nodes[size_t(node)].children;
    for (auto it = ch.rbegin(); it != ch.rend(); ++it) stack.push_back({*it, g});
  }
}

int find_node(const File& f, const std::string& key) {
  const auto& nodes = f.model.nodes;
  std::vector<int> hits;
  for (size_t i = 0; i < nodes.size(); ++i)
    if (nodes[i].name == key) hits.push_back(int(i));
  if (hits.size() == 1) return hits[0];
  if (hits.size() > 1) {
    std::string list;
    for (int h : hits) list += (list.empty() ? "" : ", ") + std::to_string(h);
    throw Error(f.path, "several nodes are named '" + key + "' (nodes " + list + "); give the node's index");
  }
  bool digits = !key.empty() && key.size() < 10 && key.find_first_not_of("0123456789") == std::string::npos;
  if (digits && size_t(std::stoul(key)) < nodes.size()) return int(std::stoul(key));
  std::string list;
  for (size_t i = 0; i < nodes.size() && i < 40; ++i)
    list += (list.empty() ? "" : ", ") + std::to_string(i) + (nodes[i].name.empty() ? "" : " '" + nodes[i].name + "'");
  throw Error(f.path, "no node '" + key + "'; the nodes are " + (list.empty() ? "(none)" : list));
}

bool read_primitive(const File& f, int mesh, int prim, const std::string& where, Unsupported& unsupported,
                    TriangleMesh& out) {
  const tinygltf::Mesh& me = f.model.meshes[size_t(mesh)];
  const tinygltf::Primitive& p = me.primitives[size_t(prim)];
  const std::string what = "mesh " + std::to_string(mesh) + (me.name.empty() ? "" : " '" + me.name + "'") +
                           " primitive " + std::to_string(prim);
  if (p.mode != TINYGLTF_MODE_TRIANGLES && p.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
      p.mode != TINYGLTF_MODE_TRIANGLE_FAN && p.mode != -1) {
    unsupported.add("points and lines", where);
    return false;
  }
  if (!p.targets.empty()) unsupported.add("morph targets (the base shape is used)", where);
  auto pos = p.attributes.find("POSITION");
  if (pos == p.attributes.end()) throw Error(f.path, what + " has no POSITION attribute");
  out = TriangleMesh{};
  out.positions = read_vec3(f, pos->second, what + " POSITION");
  auto nrm = p.attributes.find("NORMAL");
  if (nrm != p.attributes.end()) {
    out.normals = read_vec3(f, nrm->second, what + " NORMAL", /*lenient=*/true);
    if (out.normals.size() != out.positions.size())
      throw Error(f.path, what + " has " + std::to_string(out.normals.size()) + " normals for " +
                              std::to_string(out.positions.size()) + " positions");
  }
  std::vector<uint32_t> idx;
  if (p.indices >= 0) {
    idx = read_indices(f, p.indices, out.positions.size(), what + " indices");
  } else {
    idx.resize(out.positions.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = uint32_t(i);
  }
  if (p.mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (size_t i = 0; i + 2 < idx.size(); ++i) {  // glTF 2.0 spec 3.7.2.1
      uint32_t t[3] = {idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]};
      out.indices.insert(out.indices.end(), t, t + 3);
    }
  } else if (p.mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    for (size_t i = 0; i + 2 < idx.size(); ++i) {
      uint32_t t[3] = {idx[i + 1], idx[i + 2], idx[0]};
      out.indices.insert(out.indices.end(), t, t + 3);
    }
  } else {
    if (idx.size() % 3 != 0)
      throw Error(f.path, what + " has " + std::to_string(idx.size()) + " indices, not a multiple of 3");
    out.indices = std::move(idx);
  }
  if (size_t bad = repair_normals(out))
    warn(f.path + ": " + what + ": " + std::to_string(bad) +
         " normals are NaN, infinite or zero; recomputed from the geometry");
  return true;
}

void append_transformed(TriangleMesh& dst, const TriangleMesh& src, const Mat4& m) {
  const bool had_vertices = !dst.positions.empty();
  const bool normals = (!had_vertices || dst.normals.size() == dst.positions.size()) &&
                       src.normals.size() == src.positions.size() && !src.positions.empty();
  if (!normals) dst.normals.clear();
  const uint32_t base = uint32_t(dst.positions.size());
  Mat4 inv, nm;
  invert(m, inv);
  nm = transpose(inv);
  for (size_t i = 0; i < src.positions.size(); ++i) {
    dst.positions.push_back(m.point(src.positions[i]));
    if (normals) {
      Vec3 n = nm.vector(src.normals[i]);
      float l = length(n);
      dst.normals.push_back(l > 0.0f ? n * (1.0f / l) : Vec3{0, 1, 0});
    }
  }
  const bool flip = mirrors(m);
  for (size_t t = 0; t + 2 < src.indices.size(); t += 3) {
    dst.indices.push_back(base + src.indices[t]);
    dst.indices.push_back(base + src.indices[t + (flip ? 2 : 1)]);
    dst.indices.push_back(base + src.indices[t + (flip ? 1 : 2)]);
  }
}

}  // namespace cdsm::gltf

namespace cdsm {

// load_gltf_scene() (gltf_loader.cpp) builds the scene; its read_file() of
// `name` parses `bytes` while this call lasts.
Scene load_gltf_scene_from_memory(const std::vector<unsigned char>& bytes, const std::string& name) {
  const gltf::MemoryFile source{&name, &bytes};
  struct Restore {
    const gltf::MemoryFile* previous;
    ~Restore() { gltf::t_memory_file = previous; }
  } restore{gltf::t_memory_file};
  gltf::t_memory_file = &source;
  return load_gltf_scene(name);
}

}  // namespace cdsm
