// JSON scene files -> cdsm::Scene. Field reference: README "Scene files".
#include <fstream>
#include <map>
#include <sstream>

#include "cdsm/error.h"
#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "json_reader.h"

namespace cdsm {
namespace {

struct Parser {
  std::string file;
  std::string base_dir;
  Scene scene;
  std::map<std::string, int> volume_by_name;

  std::string resolve(const std::string& p) const {
    if (p.empty() || p[0] == '/') return p;
    return base_dir.empty() ? p : base_dir + "/" + p;
  }

  Camera camera(const JsonNode& n) {
    n.expect_object({"position", "target", "up", "fov_y", "near", "far", "width", "height"});
    Camera c;
    c.position = n.at("position").as_vec3();
    c.target = n.at("target").as_vec3();
    c.up = n.get("up", c.up);
    c.fov_y_deg = n.get("fov_y", c.fov_y_deg);
    c.near = n.get("near", c.near);
    c.far = n.get("far", c.far);
    c.width = n.get("width", c.width);
    c.height = n.get("height", c.height);
    if (c.width < 1 || c.height < 1) n.fail("width and height must be >= 1");
    if (!(c.near > 0) || !(c.far > c.near)) n.fail("needs 0 < near < far");
    if (!(c.fov_y_deg > 0 && c.fov_y_deg < 179)) n.at("fov_y").fail("must be within (0, 179) degrees");
    if (length(c.target - c.position) <= 0) n.at("target").fail("equals the camera position");
    return c;
  }

  ShadowSettings shadows(const JsonNode& n) {
    n.expect_object({"epsilon", "resolution", "filtering", "bias_constant", "bias_slope", "clusters", "d0",
                     "layout", "ambient"});
    ShadowSettings s;
    s.epsilon = n.get("epsilon", s.epsilon);
    if (s.epsilon < 0) n.at("epsilon").fail("must be >= 0 (got " + std::to_string(s.epsilon) + ")");
    s.resolution = n.get("resolution", s.resolution);
    if (s.resolution < 4 || s.resolution > 8192) n.at("resolution").fail("must be within [4, 8192]");
    s.filtering = n.get("filtering", s.filtering);
    s.bias_constant = n.get("bias_constant", s.bias_constant);
    s.bias_slope = n.get("bias_slope", s.bias_slope);
    if (s.bias_constant < 0 || s.bias_slope < 0) n.fail("biases must be >= 0");
    s.max_clusters = n.get("clusters", s.max_clusters);
    if (s.max_clusters < 1 || s.max_clusters > kMaxMapsPerLight) n.at("clusters").fail("must be within [1, 8]");
    s.d0 = n.get("d0", s.d0);
    if (!(s.d0 >= 0)) n.at("d0").fail("must be >= 0");
    std::string layout = n.get("layout", "packed");
    if (layout == "packed") s.layout = DsmLayout::Packed;
    else if (layout == "fixed") s.layout = DsmLayout::Fixed;
    else if (layout == "chunked") s.layout = DsmLayout::Chunked;
    else n.at("layout").fail("unknown layout '" + layout + "' (packed, fixed or chunked)");
    s.ambient_light = n.get("ambient", s.ambient_light);
    return s;
  }

  Mat4 transform(const JsonNode& n) {
    n.expect_object({"translate", "rotate", "scale"});
    Vec3 s = n.get("scale", Vec3{1, 1, 1});
    if (s.x == 0 || s.y == 0 || s.z == 0) n.at("scale").fail("scale must not be 0");
    return make_transform(n.get("translate", Vec3{0, 0, 0}), n.get("rotate", Vec3{0, 0, 0}), s);
  }

  std::shared_ptr<DenseGrid> grid(const JsonNode& n) {
    std::string type = n.at("type").as_string();
    if (type == "noise") {
      n.expect_object({"type", "size", "seed", "frequency", "octaves", "plume", "scale"});
      NoiseVolumeParams p;
      Vec3 size = n.get("size", Vec3{float(p.nx), float(p.ny), float(p.nz)});
      p.nx = int(size.x);
      p.ny = int(size.y);
      p.nz = int(size.z);
      if (p.nx < 2 || p.ny < 2 || p.nz < 2 || p.nx > 1024 || p.ny > 1024 || p.nz > 1024)
        n.at("size").fail("each dimension must be within [2, 1024]");
      p.seed = uint32_t(n.get("seed", 1));
      p.frequency = n.get("frequency", p.frequency);
      p.octaves = n.get("octaves", p.octaves);
      p.plume = n.get("plume", p.plume);
      p.density_scale = n.get("scale", p.density_scale);
      return make_noise_volume(p);
    }
    if (type == "dense") {  // small inline grids: tests and analytic cases
      n.expect_object({"type", "size", "fill", "values", "background"});
      auto g = std::make_shared<DenseGrid>();
      Vec3 size = n.at("size").as_vec3();
      g->nx = int(size.x);
      g->ny = int(size.y);
      g->nz = int(size.z);
      if (g->nx < 1 || g->ny < 1 || g->nz < 1 || size_t(g->nx) * g->ny * g->nz > (size_t(1) << 28))
        n.at("size").fail("dimensions must be >= 1 and hold at most 2^28 voxels");
      size_t count = size_t(g->nx) * g->ny * g->nz;
      g->background = n.get("background", 0.0f);
      if (n.has("values")) {
        JsonNode v = n.at("values");
        v.expect_array();
        if (v.size() != count)
          v.fail("has " + std::to_string(v.size()) + " values, size needs " + std::to_string(count));
        g->values.resize(count);
        for (size_t i = 0; i < count; ++i) g->values[i] = v.at(i).as_float();
      } else {
        g->values.assign(count, n.get("fill", 1.0f));
      }
      return g;
    }
    n.at("type").fail("unknown grid type '" + type + "' (noise or dense)");
  }

  Volume volume(const JsonNode& n) {
    n.expect_object({"name", "grid", "voxel_size", "origin", "transfer", "shading", "step_voxels", "gradient_scale"});
    Volume v;
    v.name = n.get("name", "");
    v.grid = grid(n.at("grid"));
    Vec3 vs = n.get("voxel_size", Vec3{0.05f, 0.05f, 0.05f});
    if (!(vs.x > 0 && vs.y > 0 && vs.z > 0)) n.at("voxel_size").fail("must be > 0");
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
    JsonNode tf = n.at("transfer");
    tf.expect_array();
    if (tf.size() < 1 || tf.size() > size_t(kMaxTransferPoints))
      tf.fail("needs 1 to " + std::to_string(kMaxTransferPoints) + " control points");
    for (size_t i = 0; i < tf.size(); ++i) {
      JsonNode p = tf.at(i);
      p.expect_object({"density", "extinction", "color"});
      TransferPoint tp;
      tp.density = p.at("density").as_float();
      tp.extinction = p.at("extinction").as_float();
      if (tp.extinction < 0) p.at("extinction").fail("must be >= 0");
      tp.color = p.get("color", tp.color);
      if (i > 0 && tp.density < v.transfer.back().density) p.at("density").fail("control points must be sorted by density");
      v.transfer.push_back(tp);
    }
    std::string shading = n.get("shading", "scatter");
    if (shading == "scatter") v.shading = VolumeShading::Scatter;
    else if (shading == "phong") v.shading = VolumeShading::Phong;
    else n.at("shading").fail("unknown shading '" + shading + "' (scatter or phong)");
    v.step_voxels = n.get("step_voxels", v.step_voxels);
    if (!(v.step_voxels >= 0.05f && v.step_voxels <= 8.0f)) n.at("step_voxels").fail("must be within [0.05, 8]");
    v.gradient_scale = n.get("gradient_scale", v.gradient_scale);
    return v;
  }

  // Box proxy of a volume's grid, in object space.
  std::shared_ptr<TriangleMesh> volume_box(const Volume& v) {
    const DenseGrid& g = *v.grid;
    Vec3 lo = v.index_to_object.point({-0.5f, -0.5f, -0.5f});
    Vec3 hi = v.index_to_object.point({g.nx - 0.5f, g.ny - 0.5f, g.nz - 0.5f});
    auto m = std::make_shared<TriangleMesh>(make_box(hi - lo));
    Vec3 c = (lo + hi) * 0.5f;
    for (Vec3& p : m->positions) p = p + c;
    return m;
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
    if (type == "volume_box") {
      n.expect_object({"type"});
      if (volume_index < 0) n.fail("a volume_box mesh needs an interior of type volume");
      return volume_box(scene.volumes[size_t(volume_index)]);
    }
    n.at("type").fail("unknown mesh type '" + type + "' (box, sphere, ground, quad, teapot, teacup, volume_box)");
  }

  Object object(const JsonNode& n) {
    n.expect_object({"name", "mesh", "transform", "casts_shadows", "material", "interior"});
    Object o;
    o.name = n.get("name", "");
    if (n.has("transform")) o.transform = transform(n.at("transform"));
    o.casts_shadows = n.get("casts_shadows", true);
    if (n.has("material")) {
      JsonNode m = n.at("material");
      m.expect_object({"color", "opacity", "ambient", "diffuse", "specular", "shininess"});
      SurfaceMaterial& s = o.surface;
      s.color = m.get("color", s.color);
      s.opacity = m.get("opacity", s.opacity);
      if (!(s.opacity >= 0 && s.opacity <= 1)) m.at("opacity").fail("must be within [0, 1]");
      s.ambient = m.get("ambient", s.ambient);
      s.diffuse = m.get("diffuse", s.diffuse);
      s.specular = m.get("specular", s.specular);
      s.shininess = m.get("shininess", s.shininess);
      if (!(s.shininess >= 0)) m.at("shininess").fail("must be >= 0");
    }
    if (n.has("interior")) {
      JsonNode in = n.at("interior");
      std::string type = in.at("type").as_string();
      if (type == "none") {
        in.expect_object({"type"});
      } else if (type == "constant") {
        in.expect_object({"type", "sigma"});
        o.interior = InteriorKind::Constant;
        o.sigma = in.at("sigma").as_float();
        if (!(o.sigma >= 0)) in.at("sigma").fail("must be >= 0");
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
    if (n.has("mesh")) o.mesh = mesh(n.at("mesh"), o.volume);
    else if (o.interior == InteriorKind::Volume) o.mesh = volume_box(scene.volumes[size_t(o.volume)]);
    else n.at("mesh").fail("missing required field");
    return o;
  }

  Light light(const JsonNode& n) {
    n.expect_object({"name", "type", "position", "direction", "target", "outer_cone", "inner_cone", "color",
                     "intensity"});
    Light l;
    l.name = n.get("name", "");
    std::string type = n.at("type").as_string();
    if (type == "spot") l.type = LightType::Spot;
    else if (type == "point") l.type = LightType::Point;
    else n.at("type").fail("unknown light type '" + type + "' (spot or point)");
    l.position = n.at("position").as_vec3();
    if (l.type == LightType::Spot) {
      if (n.has("target")) l.direction = n.at("target").as_vec3() - l.position;
      else l.direction = n.at("direction").as_vec3();
      if (length(l.direction) <= 0) n.fail("spot direction is zero");
      l.direction = normalize(l.direction);
      l.outer_cone_deg = n.get("outer_cone", l.outer_cone_deg);
      l.inner_cone_deg = n.get("inner_cone", std::min(l.inner_cone_deg, l.outer_cone_deg));
      if (!(l.outer_cone_deg > 0 && l.outer_cone_deg <= 89.5f))
        n.at("outer_cone").fail("half-angle must be within (0, 89.5] degrees");
      if (!(l.inner_cone_deg >= 0 && l.inner_cone_deg <= l.outer_cone_deg))
        n.at("inner_cone").fail("must be within [0, outer_cone]");
    }
    l.color = n.get("color", l.color);
    l.intensity = n.get("intensity", l.intensity);
    if (!(l.intensity >= 0)) n.at("intensity").fail("must be >= 0");
    return l;
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

Scene parse_scene(const std::string& text, const std::string& name, const std::string& base_dir) {
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // Byte offset -> line and column.
    size_t line = 1, col = 1;
    for (size_t i = 0; i < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    throw Error(name + ":" + std::to_string(line) + ":" + std::to_string(col), "invalid JSON");
  }
  Parser p{name, base_dir, {}, {}};
  p.parse(root);
  return std::move(p.scene);
}

Scene load_scene(const std::string& path) {
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
