// JSON scene files -> cdsm::Scene. Field reference: README "Scene files".
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "json_reader.h"
#include "memory_budget.h"

namespace cdsm {
namespace {

// Range of voxel_size / raw spacing, world units.
constexpr float kMinVoxelSize = 1e-6f;
constexpr float kMaxVoxelSize = 1e6f;

struct Parser {
  std::string file;
  std::string base_dir;
  Scene scene;
  std::map<std::string, int> volume_by_name;
  std::vector<VolumeProxy> proxy_of;  // per volume: its default boundary mesh

  // A file reference (string node): relative to the scene file, "$SHARED/..."
  // or found in the data directory (cdsm/loaders.h).
  std::string resolve(const JsonNode& n) const {
    return resolve_asset(n.as_string(), base_dir, n.file() + ": " + n.path());
  }

  // The JSON text of a mesh or grid node as read (Object::mesh_source,
  // Volume::grid_source), compact. A "file" found relative to the scene's
  // folder is made absolute, so the description still names that file when
  // the scene is saved elsewhere ("$SHARED/..." and absolute paths are kept).
  std::string source_of(const JsonNode& n) const {
    nlohmann::json j = n.raw();
    if (j.is_object() && j.contains("file") && j["file"].is_string()) {
      const std::string ref = j["file"].get<std::string>();
      if (!ref.empty() && ref[0] != '/' && ref.rfind("$SHARED/", 0) != 0) {
        std::error_code ec;
        std::filesystem::path local = std::filesystem::path(base_dir.empty() ? "." : base_dir) / ref;
        if (std::filesystem::is_regular_file(local, ec))
          j["file"] = std::filesystem::absolute(local, ec).lexically_normal().string();
      }
    }
    return j.dump();
  }

  // Runs a loader; its errors (which name the asset) also get the scene
  // location that referred to it.
  template <class F>
  auto load(const JsonNode& n, F&& f) -> decltype(f()) {
    try {
      return f();
    } catch (const Error& e) {
      n.fail(e.what());
    }
  }

  // {"type":"raw", "file", "dims":[x,y,z], "format":"uint8"|"uint16",
  //  "byte_order":"little"|"big", "header":bytes, "normalize":bool, "spacing":[x,y,z]}
  std::shared_ptr<DenseGrid> raw_grid(const JsonNode& n, bool& has_spacing, Vec3& spacing) {
    n.expect_object({"type", "file", "dims", "format", "byte_order", "header", "normalize", "spacing"});
    RawVolumeDesc d;
    JsonNode dims = n.at("dims");
    Vec3 dv = dims.as_vec3();
    if (!(dv.x >= 1 && dv.y >= 1 && dv.z >= 1 && dv.x <= 65536 && dv.y <= 65536 && dv.z <= 65536) ||
        dv.x != std::floor(dv.x) || dv.y != std::floor(dv.y) || dv.z != std::floor(dv.z))
      dims.fail("dimensions must be integers within [1, 65536]");
    d.nx = int(dv.x);
    d.ny = int(dv.y);
    d.nz = int(dv.z);
    std::string format = n.get("format", "uint8");
    if (format == "uint8")
      d.format = RawFormat::UInt8;
    else if (format == "uint16")
      d.format = RawFormat::UInt16;
    else
      n.at("format").fail("unknown format '" + format + "' (uint8 or uint16)");
    std::string order = n.get("byte_order", "little");
    if (order == "little")
      d.big_endian = false;
    else if (order == "big")
      d.big_endian = true;
    else
      n.at("byte_order").fail("unknown byte order '" + order + "' (little or big)");
    int header = n.get("header", 0);
    if (header < 0) n.at("header").fail("must be >= 0");
    d.header_bytes = uint64_t(header);
    d.normalize = n.get("normalize", true);
    has_spacing = n.has("spacing");
    if (has_spacing) spacing = n.at("spacing").as_vec3();
    std::string path = resolve(n.at("file"));
    return load(n.at("file"), [&] { return load_raw(path, d); });
  }

  Camera camera(const JsonNode& n) {
    Camera c;
    n.read_fields(c);
    n.at("position");  // required
    n.at("target");
    return c;  // ranges: validate_scene
  }

  ShadowSettings shadows(const JsonNode& n) {
    ShadowSettings s;
    n.read_fields(s);  // ranges: validate_scene
    return s;
  }

  // {"matrix": [16 numbers]}: row-major, the last row 0 0 0 1 (affine).
  static Mat4 matrix(const JsonNode& n) {
    n.expect_object({"matrix"});
    JsonNode a = n.at("matrix");
    a.expect_array();
    if (a.size() != 16) a.fail("expected 16 numbers (row-major 4x4), got " + std::to_string(a.size()));
    Mat4 m;
    for (size_t i = 0; i < 16; ++i) m.m[i / 4][i % 4] = a.at(i).as_float();
    if (m.m[3][0] != 0 || m.m[3][1] != 0 || m.m[3][2] != 0 || m.m[3][3] != 1)
      a.fail("the last row must be 0 0 0 1 (an affine transform)");
    return m;
  }

  Mat4 transform(const JsonNode& n) {
    if (n.has("matrix")) return matrix(n);  // ranges (singular, infinite): the compile
    n.expect_object({"translate", "rotate", "scale"});
    Vec3 s = n.get("scale", Vec3{1, 1, 1});
    if (s.x == 0 || s.y == 0 || s.z == 0) n.at("scale").fail("scale must not be 0");
    return make_transform(n.get("translate", Vec3{0, 0, 0}), n.get("rotate", Vec3{0, 0, 0}), s);
  }

  // A grid size: three whole numbers within [lo, hi] whose product (taken
  // in double, so it cannot wrap) is at most max_voxels.
  static std::array<int32_t, 3> grid_size(const JsonNode& n, int lo, int hi, double max_voxels) {
    Vec3 v = n.as_vec3();
    std::array<int32_t, 3> out{};
    double product = 1.0;
    for (int a = 0; a < 3; ++a) {
      double x = v[a];
      if (x != std::floor(x)) n.fail("must be whole numbers of voxels, got " + format_number(x));
      if (!(x >= lo && x <= hi))
        n.fail("each dimension must be within [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
               format_number(x));
      out[size_t(a)] = int32_t(x);
      product *= x;
    }
    if (product > max_voxels)
      n.fail("holds " + format_number(product) + " voxels, at most " + format_number(max_voxels));
    return out;
  }

  // A grid of nx ny nz voxels is made here and compiled later: twice its
  // floats, against the scene's memory limit (before generating it).
  void check_grid_memory(const JsonNode& n, int nx, int ny, int nz) const {
    double voxels = double(nx) * double(ny) * double(nz);
    check_allocation(n.file() + ": " + n.path() + "/size",
                     "a " + std::to_string(nx) + "x" + std::to_string(ny) + "x" + std::to_string(nz) + " grid",
                     voxels * 8.0, scene.shadows);
  }

  std::shared_ptr<DenseGrid> grid(const JsonNode& n) {
    std::string type = n.at("type").as_string();
    if (type == "noise") {
      n.expect_object({"type", "size", "seed", "frequency", "octaves", "plume", "scale"});
      NoiseVolumeParams p;
      if (n.has("size")) {
        std::array<int32_t, 3> d = grid_size(n.at("size"), 2, 1024, 1024.0 * 1024.0 * 1024.0);
        p.nx = d[0];
        p.ny = d[1];
        p.nz = d[2];
      }
      check_grid_memory(n, p.nx, p.ny, p.nz);
      const double seed = n.has("seed") ? double(n.at("seed").as_float()) : 1.0;
      if (!(seed >= 0 && seed <= 4294967295.0 && seed == std::floor(seed)))
        n.at("seed").fail("must be a whole number within [0, 4294967295], got " + format_number(seed));
      p.seed = uint32_t(seed);
      p.frequency = n.get("frequency", p.frequency);
      if (!(p.frequency > 0 && p.frequency <= 1000))
        n.at("frequency").fail("must be within (0, 1000], got " + format_number(p.frequency));
      p.octaves = n.get("octaves", p.octaves);
      if (!(p.octaves >= 1 && p.octaves <= 12 && p.octaves == std::floor(p.octaves)))
        n.at("octaves").fail("must be a whole number within [1, 12], got " + format_number(p.octaves));
      p.plume = n.get("plume", p.plume);
      if (!(p.plume >= 0 && p.plume <= 1)) n.at("plume").fail("must be within [0, 1], got " + format_number(p.plume));
      p.density_scale = n.get("scale", p.density_scale);
      if (!(p.density_scale >= 0 && p.density_scale <= 1e6))
        n.at("scale").fail("must be within [0, 1e+06], got " + format_number(p.density_scale));
      return make_noise_volume(p);
    }
    if (type == "dense") {  // small inline grids: tests and analytic cases
      n.expect_object({"type", "size", "fill", "values", "background"});
      auto g = std::make_shared<DenseGrid>();
      std::array<int32_t, 3> d = grid_size(n.at("size"), 1, 1 << 30, double(1 << 28));
      g->nx = d[0];
      g->ny = d[1];
      g->nz = d[2];
      check_grid_memory(n, g->nx, g->ny, g->nz);
      size_t count = size_t(g->nx) * g->ny * g->nz;
      // Densities are >= 0 (the transfer function maps them to extinction).
      auto density = [](const JsonNode& at, float d) {
        if (!(d >= 0)) at.fail("a density must be >= 0, got " + format_number(d));
        return d;
      };
      g->background = n.has("background") ? density(n.at("background"), n.at("background").as_float()) : 0.0f;
      if (n.has("values")) {
        JsonNode v = n.at("values");
        v.expect_array();
        if (v.size() != count)
          v.fail("has " + std::to_string(v.size()) + " values, size needs " + std::to_string(count));
        g->values.resize(count);
        for (size_t i = 0; i < count; ++i) g->values[i] = density(v.at(i), v.at(i).as_float());
      } else {
        g->values.assign(count, n.has("fill") ? density(n.at("fill"), n.at("fill").as_float()) : 1.0f);
      }
      return g;
    }
    n.at("type").fail("unknown grid type '" + type + "' (noise, dense, raw or vdb)");
  }

  Volume volume(const JsonNode& n) {
    Volume v;
    n.read_fields(v, {"grid", "voxel_size", "origin", "index_to_object", "transfer", "proxy"});
    JsonNode gn = n.at("grid");
    std::string type = gn.at("type").as_string();
    bool has_spacing = false;
    Vec3 spacing{1, 1, 1};
    if (type == "vdb") {  // {"type":"vdb", "file", "grid": name}: the grid's own transform
      gn.expect_object({"type", "file", "grid"});
      if (n.has("voxel_size") || n.has("origin") || n.has("index_to_object"))
        n.fail(
            "a vdb grid is placed by its own transform: give no voxel_size, origin or index_to_object (use the "
            "object's transform)");
      std::string path = resolve(gn.at("file"));
      std::string grid_name = gn.get("grid", "density");
      VdbVolume vdb = load(gn.at("file"), [&] { return load_vdb(path, grid_name); });
      v.sparse = vdb.grid;
      v.index_to_object = vdb.index_to_object;
    } else {
      v.grid = type == "raw" ? raw_grid(gn, has_spacing, spacing) : grid(gn);
      if (has_spacing && n.has("voxel_size"))
        n.fail("give the raw grid's spacing or the volume's voxel_size, not both");
    }
    if (!v.sparse && n.has("index_to_object")) {  // any affine placement (scene_write.cpp writes it when needed)
      if (has_spacing || n.has("voxel_size") || n.has("origin"))
        n.fail("give index_to_object or voxel_size / origin (or a raw grid's spacing), not both");
      v.index_to_object = matrix(n.at("index_to_object"));
    } else if (!v.sparse) {
      Vec3 vs = has_spacing ? spacing : n.get("voxel_size", Vec3{0.05f, 0.05f, 0.05f});
      if (!(vs.x >= kMinVoxelSize && vs.y >= kMinVoxelSize && vs.z >= kMinVoxelSize && vs.x <= kMaxVoxelSize &&
            vs.y <= kMaxVoxelSize && vs.z <= kMaxVoxelSize))
        (has_spacing ? gn.at("spacing") : n.at("voxel_size"))
            .fail("must be within [1e-6, 1e6] world units (a finer voxel cannot be marched at ordinary distances)");
      Vec3 origin = n.get("origin", Vec3{0, 0, 0});
      // Voxel (i,j,k) centre at origin + (i + 0.5) * voxel_size: the grid's
      // box spans [origin, origin + n * voxel_size].
      Mat4 m;
      m.m[0][0] = vs.x;
      m.m[1][1] = vs.y;
      m.m[2][2] = vs.z;
      m.m[0][3] = origin.x + 0.5f * vs.x;
      m.m[1][3] = origin.y + 0.5f * vs.y;
      m.m[2][3] = origin.z + 0.5f * vs.z;
      v.index_to_object = m;
    }
    if (!(type == "dense" && gn.has("values"))) v.grid_source = source_of(gn);  // values are data, not a description
    std::string proxy = n.get("proxy", "box");
    if (proxy == "box")
      proxy_of.push_back(VolumeProxy::Box);
    else if (proxy == "leaves")
      proxy_of.push_back(VolumeProxy::Leaves);
    else
      n.at("proxy").fail("unknown proxy '" + proxy + "' (box or leaves)");
    if (proxy == "leaves" && !v.sparse) n.at("proxy").fail("a leaves proxy needs a sparse (vdb) grid");
    JsonNode tf = n.at("transfer");
    tf.expect_array();
    if (tf.size() < 1 || tf.size() > size_t(kMaxTransferPoints))
      tf.fail("needs 1 to " + std::to_string(kMaxTransferPoints) + " control points");
    for (size_t i = 0; i < tf.size(); ++i) {
      JsonNode p = tf.at(i);
      p.expect_object({"density", "extinction", "color"});
      TransferPoint tp;
      tp.density = p.at("density").as_float();
      tp.extinction = p.at("extinction").as_vec3();  // a number, or [r, g, b] per channel
      tp.color = p.get("color", tp.color);
      v.transfer.push_back(tp);  // ranges and order: validate_scene
    }
    return v;
  }

  // Proxy of a volume's grid (its box, or its active leaves), in object space.
  std::shared_ptr<TriangleMesh> volume_box(int volume_index) {
    return std::make_shared<TriangleMesh>(
        make_volume_proxy(scene.volumes[size_t(volume_index)], proxy_of[size_t(volume_index)]));
  }

  // {"type":"triangles", "positions":[x,y,z, ...], "indices":[i,j,k, ...], "normals":[x,y,z, ...]}:
  // a mesh given by its data (what scene_write.cpp writes for meshes built
  // in code or taken from a whole glTF scene). Normals are optional.
  std::shared_ptr<TriangleMesh> triangles(const JsonNode& n) {
    n.expect_object({"type", "positions", "indices", "normals"});
    auto mesh = std::make_shared<TriangleMesh>();
    JsonNode p = n.at("positions"), ix = n.at("indices");
    p.expect_array();
    ix.expect_array();
    if (p.size() % 3 != 0) p.fail("needs x, y, z per vertex: " + std::to_string(p.size()) + " numbers");
    if (ix.size() % 3 != 0) ix.fail("needs 3 indices per triangle: " + std::to_string(ix.size()) + " indices");
    check_allocation(n.file() + ": " + n.path(), "a mesh of " + std::to_string(ix.size() / 3) + " triangles",
                     double(p.size()) * 8.0 + double(ix.size()) * 80.0, scene.shadows);
    auto vec3s = [](const JsonNode& a, std::vector<Vec3>& out) {
      out.resize(a.size() / 3);
      for (size_t i = 0; i < out.size(); ++i)
        out[i] = {a.at(3 * i).as_float(), a.at(3 * i + 1).as_float(), a.at(3 * i + 2).as_float()};
    };
    vec3s(p, mesh->positions);
    mesh->indices.resize(ix.size());
    for (size_t i = 0; i < ix.size(); ++i) {
      JsonNode e = ix.at(i);
      const double v = e.is_number() ? e.raw().get<double>() : -1.0;
      if (!(v >= 0 && v < double(mesh->positions.size()) && v == std::floor(v)))
        e.fail("must be a vertex index within [0, " + std::to_string(mesh->positions.size()) + ")");
      mesh->indices[i] = uint32_t(v);
    }
    if (n.has("normals")) {
      JsonNode nn = n.at("normals");
      nn.expect_array();
      if (nn.size() != p.size() && nn.size() != 0)
        nn.fail("needs one normal per vertex (" + std::to_string(p.size()) + " numbers), got " +
                std::to_string(nn.size()));
      vec3s(nn, mesh->normals);
    }
    return mesh;
  }

  std::shared_ptr<TriangleMesh> mesh(const JsonNode& n, int volume_index) {
    std::string type = n.at("type").as_string();
    if (type == "box") {
      n.expect_object({"type", "size"});
      Vec3 s = n.get("size", Vec3{1, 1, 1});
      if (!(s.x > 0 && s.y > 0 && s.z > 0)) n.at("size").fail("must be > 0");
      return std::make_shared<TriangleMesh>(make_box(s));
    }
    if (type == "sphere") {
      n.expect_object({"type", "radius", "segments", "rings"});
      float r = n.get("radius", 0.5f);
      int seg = n.get("segments", 48), rings = n.get("rings", 24);
      if (!(r > 0)) n.at("radius").fail("must be > 0");
      if (seg < 3 || rings < 2 || seg > 4096 || rings > 4096) n.fail("needs 3 <= segments, 2 <= rings (<= 4096)");
      // The mesh (two triangles per quad, ~100 bytes each) and its compiled copy.
      check_allocation(n.file() + ": " + n.path(),
                       "a sphere of " + std::to_string(seg) + " x " + std::to_string(rings) + " segments",
                       2.0 * seg * (rings - 1) * 250.0, scene.shadows);
      return std::make_shared<TriangleMesh>(make_sphere(r, seg, rings));
    }
    if (type == "ground") {
      n.expect_object({"type", "size", "thickness"});
      Vec3 s = n.get("size", Vec3{10, 0, 10});
      float th = n.get("thickness", 0.02f);
      if (!(s.x > 0 && s.z > 0 && th > 0)) n.fail("size x, z and thickness must be > 0");
      return std::make_shared<TriangleMesh>(make_ground(s.x, s.z, th));
    }
    if (type == "quad") {
      n.expect_object({"type", "size"});
      Vec3 s = n.get("size", Vec3{1, 0, 1});
      if (!(s.x > 0 && s.z > 0)) n.at("size").fail("x and z must be > 0");
      return std::make_shared<TriangleMesh>(make_quad(s.x, s.z));
    }
    if (type == "teapot" || type == "teacup") {
      n.expect_object({"type", "subdivisions"});
      int sub = n.get("subdivisions", 8);
      if (sub < 1 || sub > 64) n.at("subdivisions").fail("must be within [1, 64]");
      return std::make_shared<TriangleMesh>(make_newell_mesh(content_dir() + "/meshes/newell/" + type, sub));
    }
    if (type == "triangles") return triangles(n);
    if (type == "volume_box") {
      n.expect_object({"type"});
      if (volume_index < 0) n.fail("a volume_box mesh needs an interior of type volume");
      return volume_box(volume_index);
    }
    if (type == "gltf") {  // {"type":"gltf", "file", "node": name or index, "subtree": bool}
      n.expect_object({"type", "file", "node", "subtree"});
      std::string node;
      if (n.has("node")) {
        node = n.at("node").is_number() ? std::to_string(n.at("node").as_int()) : n.at("node").as_string();
        if (node.empty()) n.at("node").fail("names no node (omit \"node\" for the whole file)");
      }
      bool subtree = n.get("subtree", true);
      if (!subtree && node.empty()) n.at("subtree").fail("subtree false needs a node");
      std::string path = resolve(n.at("file"));
      return load(n.at("file"), [&] { return std::make_shared<TriangleMesh>(load_gltf_mesh(path, node, subtree)); });
    }
    n.at("type").fail("unknown mesh type '" + type +
                      "' (box, sphere, ground, quad, teapot, teacup, gltf, triangles, volume_box)");
  }

  Object object(const JsonNode& n) {
    Object o;
    n.read_fields(o, {"mesh", "transform", "material", "interior"});
    if (n.has("transform")) o.transform = transform(n.at("transform"));
    if (n.has("material")) {
      n.at("material").read_fields(o.surface);  // ranges: validate_scene
    }
    if (n.has("interior")) {
      JsonNode in = n.at("interior");
      std::string type = in.at("type").as_string();
      if (type == "none") {
        in.expect_object({"type"});
      } else if (type == "constant") {
        in.expect_object({"type", "sigma"});
        o.interior = InteriorKind::Constant;
        o.sigma = in.at("sigma").as_vec3();  // a number, or [r, g, b] per channel
      } else if (type == "volume") {
        in.expect_object({"type", "volume"});
        o.interior = InteriorKind::Volume;
        JsonNode v = in.at("volume");
        if (v.is_string()) {
          auto it = volume_by_name.find(v.as_string());
          if (it == volume_by_name.end()) v.fail("no volume named '" + v.as_string() + "'");
          o.volume = it->second;
        } else {
          o.volume = v.as_int();
          if (o.volume < 0 || size_t(o.volume) >= scene.volumes.size())
            v.fail("volume index " + std::to_string(o.volume) + " does not exist");
        }
      } else {
        in.at("type").fail("unknown interior type '" + type + "' (none, constant or volume)");
      }
    }
    if (n.has("mesh")) {
      o.mesh = mesh(n.at("mesh"), o.volume);
      if (n.at("mesh").at("type").as_string() != "triangles") o.mesh_source = source_of(n.at("mesh"));  // data: none
    } else if (o.interior == InteriorKind::Volume) {
      o.mesh = volume_box(o.volume);
      o.mesh_source = R"({"type":"volume_box"})";
    } else {
      n.at("mesh").fail("missing required field");
    }
    return o;
  }

  Light light(const JsonNode& n) {
    Light l;
    n.at("type");                                      // required
    l.type = n.get_tag("type", l.type, "light type");  // (named in its error as such)
    n.read_fields(l, {"target"});
    const bool directional = l.type == LightType::Directional;
    // A directional light has no position (one with a target only aims it).
    if (!directional || n.has("target")) n.at("position");
    // A point light keeps a direction and cones when given (unused; they
    // come back when it is made a spot again, and a saved scene keeps them).
    if (l.type != LightType::Point || n.has("target") || n.has("direction")) {
      if (n.has("target"))
        l.direction = n.at("target").as_vec3() - l.position;
      else
        l.direction = n.at("direction").as_vec3();
      const float len = length(l.direction);
      if (l.type != LightType::Point && len <= 0) n.fail(std::string(tag_name(l.type)) + " direction is zero");
      // Unit length already (a saved scene): kept bit for bit.
      if (len > 0 && std::fabs(len - 1.0f) > 1e-6f) l.direction = normalize(l.direction);
    }
    if (!n.has("inner_cone")) l.inner_cone_deg = std::min(Light{}.inner_cone_deg, l.outer_cone_deg);
    return l;  // ranges: validate_scene
  }

  void parse(const nlohmann::json& root) {
    JsonNode r(root, file, "");
    r.expect_object({"camera", "shadows", "background", "volumes", "objects", "lights", "comment"});
    scene.source = file;
    scene.camera = camera(r.at("camera"));
    if (r.has("shadows")) scene.shadows = shadows(r.at("shadows"));
    scene.background = r.get("background", scene.background);
    if (r.has("volumes")) {
      JsonNode vs = r.at("volumes");
      vs.expect_array();
      for (size_t i = 0; i < vs.size(); ++i) {
        scene.volumes.push_back(volume(vs.at(i)));
        const std::string& name = scene.volumes.back().name;
        if (!name.empty() && !volume_by_name.emplace(name, int(i)).second)
          vs.at(i).at("name").fail("duplicate volume name '" + name + "'");
      }
    }
    JsonNode os = r.at("objects");
    os.expect_array();
    for (size_t i = 0; i < os.size(); ++i) scene.objects.push_back(object(os.at(i)));
    JsonNode ls = r.at("lights");
    ls.expect_array();
    if (ls.size() == 0) ls.fail("a scene needs at least one light");
    if (ls.size() > size_t(kMaxLights)) ls.fail("at most " + std::to_string(kMaxLights) + " lights");
    for (size_t i = 0; i < ls.size(); ++i) scene.lights.push_back(light(ls.at(i)));
    std::vector<std::string> notes;
    validate_scene(scene, &notes);
    for (const std::string& w : notes) warn(w);
    // Each volume is placed by exactly one object.
    std::vector<int> users(scene.volumes.size(), 0);
    for (const Object& o : scene.objects)
      if (o.interior == InteriorKind::Volume) ++users[size_t(o.volume)];
    for (size_t i = 0; i < users.size(); ++i)
      if (users[i] != 1)
        r.at("volumes").at(i).fail(users[i] == 0 ? "volume is not used by any object"
                                                 : "volume is used by more than one object");
  }
};

}  // namespace

namespace {

// Finds where a JSON text fails (syntax errors and numbers out of range alike).
struct ErrorLocator : nlohmann::json_sax<nlohmann::json> {
  size_t position = 0;
  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(std::size_t) override { return true; }
  bool key(string_t&) override { return true; }
  bool end_object() override { return true; }
  bool start_array(std::size_t) override { return true; }
  bool end_array() override { return true; }
  bool parse_error(std::size_t pos, const std::string&, const nlohmann::detail::exception&) override {
    position = pos;
    return false;
  }
};

}  // namespace

Scene parse_scene(const std::string& text, const std::string& name, const std::string& base_dir) {
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    ErrorLocator loc;
    nlohmann::json::sax_parse(text, &loc);
    // `position` counts the bytes read, the offending one included (1-based).
    size_t line = 1, col = 1;
    for (size_t i = 0; i + 1 < loc.position && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    bool range = dynamic_cast<const nlohmann::json::out_of_range*>(&e) != nullptr;
    throw Error(name + ":" + std::to_string(line) + ":" + std::to_string(col),
                range ? "number out of range (NaN and infinity are not allowed)" : "invalid JSON");
  }
  Parser p{name, base_dir, {}, {}, {}};
  p.parse(root);
  return std::move(p.scene);
}

Scene load_scene(const std::string& path) {
  // A glTF file is a whole scene by itself.
  auto ends_with = [&](const char* ext) {
    std::string e(ext);
    if (path.size() < e.size()) return false;
    for (size_t i = 0; i < e.size(); ++i)
      if (std::tolower(static_cast<unsigned char>(path[path.size() - e.size() + i])) != e[i]) return false;
    return true;
  };
  require_file(path, ends_with(".gltf") || ends_with(".glb") ? "glTF file" : "scene file");
  if (ends_with(".gltf") || ends_with(".glb")) return load_gltf_scene(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open scene file (missing or unreadable)");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string dir;
  size_t slash = path.find_last_of('/');
  if (slash != std::string::npos) dir = path.substr(0, slash);
  return parse_scene(ss.str(), path, dir);
}

}  // namespace cdsm
