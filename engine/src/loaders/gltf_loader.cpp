// glTF 2.0 meshes (referenced from JSON scenes) and glTF files as whole
// scenes: materials, KHR_lights_punctual lights, the first camera.
#include <algorithm>
#include <cmath>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "loaders/gltf_read.h"

namespace cdsm {
namespace {

using gltf::File;
using gltf::Unsupported;

constexpr float kPi = 3.14159265358979f;

// A number member of a tinygltf extension object, or `def`.
double number(const tinygltf::Value& obj, const char* key, double def) {
  if (!obj.IsObject() || !obj.Has(key)) return def;
  const tinygltf::Value& v = obj.Get(key);
  return v.IsNumber() ? v.GetNumberAsDouble() : def;
}

// A 3-vector member ([r, g, b]), or `def`.
Vec3 vec3_member(const tinygltf::Value& obj, const char* key, Vec3 def) {
  if (!obj.IsObject() || !obj.Has(key)) return def;
  const tinygltf::Value& v = obj.Get(key);
  if (!v.IsArray() || v.ArrayLen() != 3) return def;
  float c[3];
  for (int i = 0; i < 3; ++i) {
    if (!v.Get(i).IsNumber()) return def;
    c[i] = float(v.Get(i).GetNumberAsDouble());
  }
  return {c[0], c[1], c[2]};
}

bool has_texture(const tinygltf::Value& ext, const char* key) { return ext.IsObject() && ext.Has(key); }

std::string material_label(const tinygltf::Model& m, int i) {
  return "material " + std::to_string(i) +
         (m.materials[size_t(i)].name.empty() ? "" : " '" + m.materials[size_t(i)].name + "'");
}

// glTF metallic-roughness -> this renderer's Phong constants (thesis eq.
// 3.8). Approximate: the highlight narrows as roughness drops (Blinn-Phong
// exponent 2/r^4 - 2, r = roughness^2 as in glTF's GGX), metals are shaded
// like dielectrics of their base colour.
struct MaterialResult {
  SurfaceMaterial surface;
  Vec3 sigma{0, 0, 0};  // KHR_materials_volume: constant interior extinction per channel
};

MaterialResult convert_material(const File& f, int index, const std::string& node, Unsupported& un) {
  MaterialResult r;
  if (index < 0) return r;  // glTF default material: white, opaque
  const tinygltf::Model& m = f.model;
  if (size_t(index) >= m.materials.size())
    throw Error(f.path, "node " + node + " uses material " + std::to_string(index) + ", which does not exist");
  const tinygltf::Material& mat = m.materials[size_t(index)];
  const std::string label = material_label(m, index);
  const auto& pbr = mat.pbrMetallicRoughness;
  if (pbr.baseColorFactor.size() != 4) throw Error(f.path, label + ": baseColorFactor needs 4 numbers");
  float c[4];
  for (int i = 0; i < 4; ++i) {
    c[i] = float(pbr.baseColorFactor[size_t(i)]);
    if (!std::isfinite(c[i])) throw Error(f.path, label + ": baseColorFactor is NaN or infinite");
    c[i] = std::min(std::max(c[i], 0.0f), 1.0f);
  }
  r.surface.color = {c[0], c[1], c[2]};
  if (mat.alphaMode == "BLEND")
    r.surface.opacity = c[3];
  else if (mat.alphaMode == "MASK")
    r.surface.opacity = c[3] >= float(mat.alphaCutoff) ? 1.0f : 0.0f;
  else
    r.surface.opacity = 1.0f;
  const float rough = std::min(std::max(float(pbr.roughnessFactor), 0.0f), 1.0f);
  const float a = std::max(rough * rough, 0.01f);
  r.surface.shininess = std::min(std::max(2.0f / (a * a) - 2.0f, 1.0f), 256.0f);
  r.surface.specular = 0.5f * (1.0f - rough) + 0.05f;

  if (pbr.baseColorTexture.index >= 0 || pbr.metallicRoughnessTexture.index >= 0 || mat.normalTexture.index >= 0 ||
      mat.occlusionTexture.index >= 0 || mat.emissiveTexture.index >= 0)
    un.add("textures", label);
  if (mat.emissiveFactor.size() == 3 &&
      (mat.emissiveFactor[0] > 0 || mat.emissiveFactor[1] > 0 || mat.emissiveFactor[2] > 0))
    un.add("emission", label);
  for (const auto& [name, ext] : mat.extensions) {
    if (name == "KHR_materials_transmission") {
      const double t = number(ext, "transmissionFactor", 0.0);
      if (!std::isfinite(t)) throw Error(f.path, label + ": transmissionFactor is NaN or infinite");
      // A fraction t of the covered part passes, tinted by the base colour
      // (cdsm/scene.h SurfaceMaterial): the light passed per channel is
      // (1 - a) + a t c_k = (1 - opacity) f_k with opacity = a (1 - t).
      const float tt = std::min(std::max(float(t), 0.0f), 1.0f), cover = r.surface.opacity;
      r.surface.opacity = cover * (1.0f - tt);
      if (tt > 0.0f && r.surface.opacity < 1.0f) {
        const float pass = 1.0f - r.surface.opacity;  // > 0
        for (int i = 0; i < 3; ++i)
          r.surface.transmission_color[i] = std::min(((1.0f - cover) + cover * tt * c[i]) / pass, 1.0f);
      }
      if (has_texture(ext, "transmissionTexture")) un.add("textures", label);
    } else if (name == "KHR_materials_volume") {
      const double d = number(ext, "attenuationDistance", INFINITY);
      const Vec3 col = vec3_member(ext, "attenuationColor", {1, 1, 1});
      if (std::isnan(d) || !is_finite(col) || !(d > 0))
        throw Error(f.path, label + ": KHR_materials_volume attenuation is NaN or not positive");
      if (std::isfinite(d)) {
        // Beer-Lambert per channel: T_k = c_k^(x/d), sigma_k = -ln(c_k)/d
        // (a channel of 0 absorbs as if 1e-4: finite).
        for (int i = 0; i < 3; ++i) r.sigma[i] = -std::log(std::min(std::max(col[i], 1e-4f), 1.0f)) / float(d);
      }
      if (has_texture(ext, "thicknessTexture")) un.add("textures", label);
    } else {
      un.add("extension " + name, label);
    }
  }
  (void)node;
  return r;
}

Box3 scene_bounds(const Scene& s) {
  Box3 b;
  for (const Object& o : s.objects) b.grow(world_bounds(*o.mesh, o.transform));
  return b;
}

// A view of the whole scene's box from the front-right, above.
Camera default_camera(const Box3& b) {
  Camera c;
  const Vec3 centre = b.center();
  const float radius = std::max(0.5f * length(b.extent()), 1e-3f);
  const float dist = radius / std::tan(0.5f * c.fov_y_deg * kPi / 180.0f) * 1.15f;
  c.position = centre + normalize(Vec3{0.55f, 0.45f, 1.0f}) * dist;
  c.target = centre;
  c.near = std::max(dist - 2.0f * radius, dist * 1e-3f);
  c.far = dist + 2.0f * radius;
  return c;
}

Light default_light(const Box3& b) {
  Light l;
  l.name = "default spot";
  const Vec3 centre = b.center();
  const float radius = std::max(0.5f * length(b.extent()), 1e-3f);
  l.position = centre + normalize(Vec3{0.4f, 1.0f, 0.6f}) * (3.0f * radius);
  l.direction = normalize(centre - l.position);
  l.outer_cone_deg = std::atan(1.2f / 3.0f) * 180.0f / kPi + 5.0f;
  l.inner_cone_deg = l.outer_cone_deg - 5.0f;
  return l;
}

}  // namespace

TriangleMesh load_gltf_mesh(const std::string& path, const std::string& node, bool subtree) {
  Unsupported un;
  File f = gltf::read_file(path, un);
  std::vector<int> roots;
  Mat4 parent;
  if (node.empty()) {
    roots = gltf::scene_roots(f);
  } else {
    int n = gltf::find_node(f, node);
    roots = {n};
    if (f.parent[size_t(n)] >= 0) parent = gltf::global_transform(f, f.parent[size_t(n)]);
  }
  TriangleMesh out;
  size_t meshes = 0;
  gltf::walk(f, roots, parent, [&](int ni, const Mat4& g) {
    const tinygltf::Node& nd = f.model.nodes[size_t(ni)];
    if (!subtree && !node.empty() && ni != roots[0]) return;
    if (nd.skin >= 0) un.add("skins (the bind pose is used)", gltf::node_label(f, ni));
    if (nd.mesh < 0) return;
    if (size_t(nd.mesh) >= f.model.meshes.size())
      throw Error(
          path, "node " + gltf::node_label(f, ni) + " uses mesh " + std::to_string(nd.mesh) + ", which does not exist");
    for (size_t p = 0; p < f.model.meshes[size_t(nd.mesh)].primitives.size(); ++p) {
      TriangleMesh prim;
      if (!gltf::read_primitive(f, nd.mesh, int(p), gltf::node_label(f, ni), un, prim)) continue;
      gltf::append_transformed(out, prim, g);
      ++meshes;
    }
  });
  if (meshes == 0 || out.indices.empty())
    throw Error(path, node.empty() ? "glTF file has no triangle meshes" : "node '" + node + "' has no triangle meshes");
  un.report(path);
  return out;
}

Scene load_gltf_scene(const std::string& path) {
  Unsupported un;
  File f = gltf::read_file(path, un);
  const tinygltf::Model& m = f.model;
  Scene scene;
  scene.source = path;
  struct PendingLight {
    int index;
    Mat4 g;
    int node;
  };
  std::vector<PendingLight> lights;
  int camera_node = -1;
  Mat4 camera_g;
  gltf::walk(f, gltf::scene_roots(f), Mat4{}, [&](int ni, const Mat4& g) {
    const tinygltf::Node& nd = m.nodes[size_t(ni)];
    const std::string label = gltf::node_label(f, ni);
    if (nd.skin >= 0) un.add("skins (the bind pose is used)", label);
    auto ext = nd.extensions.find("KHR_lights_punctual");
    if (ext != nd.extensions.end()) {
      double li = number(ext->second, "light", -1.0);
      if (!(li >= 0 && li < double(m.lights.size())))
        throw Error(path, "node " + label + " refers to a light that does not exist");
      lights.push_back({int(li), g, ni});
    }
    if (nd.camera >= 0 && camera_node < 0) {
      if (size_t(nd.camera) >= m.cameras.size())
        throw Error(path, "node " + label + " uses camera " + std::to_string(nd.camera) + ", which does not exist");
      camera_node = ni;
      camera_g = g;
    }
    if (nd.mesh < 0) return;
    if (size_t(nd.mesh) >= m.meshes.size())
      throw Error(path, "node " + label + " uses mesh " + std::to_string(nd.mesh) + ", which does not exist");
    const tinygltf::Mesh& me = m.meshes[size_t(nd.mesh)];
    for (size_t p = 0; p < me.primitives.size(); ++p) {
      TriangleMesh prim;
      if (!gltf::read_primitive(f, nd.mesh, int(p), label, un, prim)) continue;
      if (prim.indices.empty()) continue;
      Object o;
      o.name = nd.name.empty() ? "node " + std::to_string(ni) : nd.name;
      if (me.primitives.size() > 1) o.name += "/" + std::to_string(p);
      // The mesh stays in mesh space, counter-clockwise outward as glTF
      // stores it; a mirroring node transform `g` is undone by compile_object
      // (the one place winding follows the object-to-world determinant).
      const bool closed = is_closed(prim);
      o.mesh = std::make_shared<TriangleMesh>(std::move(prim));
      o.transform = g;
      MaterialResult mr = convert_material(f, me.primitives[p].material, label, un);
      o.surface = mr.surface;
      if (max_channel(mr.sigma) > 0.0f) {
        if (closed) {
          o.interior = InteriorKind::Constant;
          o.sigma = mr.sigma;
        } else {
          un.add("KHR_materials_volume on an open mesh (no interior)", label);
        }
      }
      scene.objects.push_back(std::move(o));
    }
  });
  if (scene.objects.empty()) throw Error(path, "glTF file has no triangle meshes");
  const Box3 bounds = scene_bounds(scene);

  // Camera.
  if (camera_node >= 0) {
    const tinygltf::Camera& c = m.cameras[size_t(m.nodes[size_t(camera_node)].camera)];
    if (c.type == "perspective") {
      const auto& p = c.perspective;
      Camera cam;
      cam.position = camera_g.point({0, 0, 0});
      cam.target = cam.position + normalize(camera_g.vector({0, 0, -1}));
      cam.up = normalize(camera_g.vector({0, 1, 0}));
      cam.fov_y_deg = float(p.yfov) * 180.0f / kPi;
      cam.near = float(p.znear);
      const float reach = length(bounds.center() - cam.position) + length(bounds.extent());
      cam.far = p.zfar > 0.0 ? float(p.zfar) : std::max(reach * 2.0f, cam.near * 10.0f);
      if (p.aspectRatio != 0.0) {  // optional; 0 = absent
        if (!(p.aspectRatio >= 0.01 && p.aspectRatio <= 100.0))
          throw Error(path, "camera of node " + gltf::node_label(f, camera_node) + ": aspectRatio " +
                                format_number(p.aspectRatio) + " is outside [0.01, 100]");
        cam.width = std::max(1, int(std::lround(cam.height * p.aspectRatio)));
      }
      if (!is_finite(cam.position) || !is_finite(cam.target) || !is_finite(cam.up) || !(cam.fov_y_deg > 0) ||
          !(cam.fov_y_deg < 179) || !(cam.near > 0) || !(cam.far > cam.near))
        throw Error(path, "camera of node " + gltf::node_label(f, camera_node) +
                              " is invalid (needs 0 < yfov < pi, 0 < znear < zfar, a finite transform)");
      scene.camera = cam;
    } else {
      un.add("orthographic cameras (a default view is used)", gltf::node_label(f, camera_node));
      scene.camera = default_camera(bounds);
    }
  } else {
    scene.camera = default_camera(bounds);
  }

  // Lights: positions and directions from their nodes (lights point down
  // their node's -z), intensities scaled so the brightest is 1 — apart for
  // directional lights (lux) and spot and point lights (candela), whose
  // units do not compare.
  float brightest = 0.0f, brightest_sun = 0.0f;
  for (const PendingLight& pl : lights) {
    const tinygltf::Light& L = m.lights[size_t(pl.index)];
    if (!std::isfinite(L.intensity)) continue;
    if (L.type == "spot" || L.type == "point") brightest = std::max(brightest, float(L.intensity));
    if (L.type == "directional") brightest_sun = std::max(brightest_sun, float(L.intensity));
  }
  for (const PendingLight& pl : lights) {
    const tinygltf::Light& L = m.lights[size_t(pl.index)];
    const std::string label = gltf::node_label(f, pl.node);
    if (L.type != "spot" && L.type != "point" && L.type != "directional") {
      un.add(L.type + " lights", label);
      continue;
    }
    if (scene.lights.size() == size_t(kMaxLights)) {
      un.add("more than " + std::to_string(kMaxLights) + " lights", label);
      continue;
    }
    Light l;
    l.name = L.name.empty() ? m.nodes[size_t(pl.node)].name : L.name;
    if (!parse_tag(L.type, l.type)) continue;  // spot, point, directional: the same names
    l.position = pl.g.point({0, 0, 0});
    l.direction = normalize(pl.g.vector({0, 0, -1}));
    if (L.color.size() == 3) l.color = {float(L.color[0]), float(L.color[1]), float(L.color[2])};
    const float scale = l.type == LightType::Directional ? brightest_sun : brightest;
    l.intensity = scale > 0.0f ? float(L.intensity) / scale : 0.0f;
    if (L.range > 0.0) un.add("light range (no distance falloff is modelled)", label);
    if (l.type == LightType::Spot) {
      float outer = float(L.spot.outerConeAngle) * 180.0f / kPi, inner = float(L.spot.innerConeAngle) * 180.0f / kPi;
      if (outer > 89.5f) {
        un.add("spot cones wider than 89.5 degrees (clamped)", label);
        outer = 89.5f;
      }
      l.outer_cone_deg = outer;
      l.inner_cone_deg = std::min(std::max(inner, 0.0f), outer);
    }
    // KHR_lights_punctual lights are points: a size only from the light's
    // extras ("radius" in world units for spot and point lights,
    // "angular_diameter" in degrees for directional ones).
    const char* size_key = l.type == LightType::Directional ? "angular_diameter" : "radius";
    if (L.extras.IsObject() && L.extras.Has(size_key)) {
      const tinygltf::Value& v = L.extras.Get(size_key);
      const double size = v.IsNumber() ? v.GetNumberAsDouble() : -1.0;
      const double most = l.type == LightType::Directional ? 10.0 : 1e6;
      if (!(size >= 0.0 && size <= most))
        throw Error(path, "light of node " + label + ": extras." + size_key + " must be a number within [0, " +
                              (l.type == LightType::Directional ? "10] degrees" : "1e6] world units"));
      (l.type == LightType::Directional ? l.angular_diameter_deg : l.radius) = float(size);
    }
    if (!is_finite(l.position) || !is_finite(l.direction) || !is_finite(l.color) || !std::isfinite(l.intensity) ||
        l.intensity < 0.0f || !(l.outer_cone_deg > 0.0f))
      throw Error(path, "light of node " + label + " has NaN, negative or zero parameters");
    scene.lights.push_back(l);
  }
  if (scene.lights.empty()) {
    scene.lights.push_back(default_light(bounds));
    warn(path + ": no spot, point or directional light (KHR_lights_punctual); added a default spot light");
  }
  un.report(path);
  return scene;
}

}  // namespace cdsm
