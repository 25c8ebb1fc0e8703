// Mirrored transforms (negative determinant; issue "No silent wrong
// answers", item 2): the compile (compile_object) flips the triangle winding of an object
// whose object-to-world transform mirrors, exactly once, so entries stay
// entries. Media, volumes and translucent surfaces under a mirror render as
// the reference renders them and as the same scene unmirrored does.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "cdsm/loaders.h"
#include "cdsm/renderer.h"
#include "unit_util.h"

using namespace cdsm;
using namespace cdsm_test;

namespace {

// Signed volume of an object's compiled world-space triangles (> 0: outward).
double world_signed_volume(const SceneBuffers& sb, uint32_t object) {
  const ObjectData& od = sb.objects[object];
  double v = 0.0;
  for (uint32_t t = od.first_tri; t < od.first_tri + od.tri_count; ++t) {
    Vec3 a = sb.tri_vertices[3 * t], b = sb.tri_vertices[3 * t + 1], c = sb.tri_vertices[3 * t + 2];
    v += double(dot(a, cross(b, c))) / 6.0;
  }
  return v;
}

// A dense grid symmetric under i -> nx - 1 - i, so the volume looks the same
// mirrored in x.
std::shared_ptr<DenseGrid> symmetric_grid() {
  auto g = std::make_shared<DenseGrid>();
  g->nx = g->ny = g->nz = 16;
  g->values.resize(16 * 16 * 16);
  for (int k = 0; k < 16; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i) {
        float x = std::fabs(float(i) - 7.5f) / 8.0f, y = float(j) / 15.0f, z = float(k) / 15.0f;
        g->values[(size_t(k) * 16 + j) * 16 + i] = std::max(0.0f, 1.0f - x * x - 0.6f * y * z);
      }
  return g;
}

enum class Kind { ConstantSphere, VolumeBox, TranslucentBox };
const char* name_of(Kind k) {
  return k == Kind::ConstantSphere ? "constant sphere" : k == Kind::VolumeBox ? "volume box" : "translucent box";
}

// One medium of `kind` at the origin under rotation 30 deg about y and
// scale (sx, 1, 1), on a ground, lit from above; the camera outside
// (or, with eye_inside, at the medium's centre looking at the ground).
Scene mirror_scene(Kind kind, float sx, bool eye_inside = false) {
  Scene s = empty_scene(std::string("mirror/") + name_of(kind));
  s.camera.position = eye_inside ? Vec3{0.05f, 1.0f, 0.1f} : Vec3{0.3f, 2.2f, 4.5f};
  s.camera.target = eye_inside ? Vec3{0.3f, 0.0f, -2.0f} : Vec3{0.0f, 0.8f, 0.0f};
  s.camera.width = 64;
  s.camera.height = 48;
  s.objects.push_back(surface_object("ground", make_ground(12, 12, 0.1f)));
  const Mat4 xf = make_transform({0, 1.0f, 0}, {0, 30, 0}, {sx, 1, 1});
  if (kind == Kind::VolumeBox) {
    Volume v;
    v.name = "vol";
    v.grid = symmetric_grid();
    v.index_to_object = make_transform({-0.75f, -0.75f, -0.75f}, {0, 0, 0}, {0.1f, 0.1f, 0.1f});  // [-0.8, 0.8]^3
    v.transfer = {TransferPoint{0.0f, vec3(0.0f), {1, 1, 1}}, TransferPoint{1.0f, vec3(3.0f), {0.9f, 0.8f, 0.7f}}};
    s.volumes.push_back(v);
    Object o;
    o.name = "vol";
    o.mesh = share(make_volume_proxy(s.volumes[0]));
    o.transform = xf;
    o.surface.opacity = 0.0f;
    o.interior = InteriorKind::Volume;
    o.volume = 0;
    s.objects.push_back(o);
  } else {
    bool sphere = kind == Kind::ConstantSphere;
    Object o = surface_object(name_of(kind), sphere ? make_sphere(0.8f, 48, 24) : make_box({1.4f, 1.2f, 1.0f}), xf,
                              sphere ? 0.0f : 0.4f);
    o.interior = InteriorKind::Constant;
    o.sigma = vec3(sphere ? 1.5f : 0.8f);
    s.objects.push_back(o);
  }
  s.lights.push_back(spot_light({0.5f, 5.0f, 1.0f}, normalize(Vec3{-0.5f, -4.0f, -1.0f}), 35.0f, 30.0f));
  s.shadows.resolution = 256;
  return s;
}

using Result = ComparedFrame;
Result render(const Scene& s) { return compared_render(s); }

}  // namespace

TEST(Mirror, CompiledTrianglesFaceOutwards) {
  for (Kind k : {Kind::ConstantSphere, Kind::VolumeBox, Kind::TranslucentBox})
    for (float sx : {1.0f, -1.0f}) {
      SceneBuffers sb = compiled_scene(mirror_scene(k, sx));
      EXPECT_GT(world_signed_volume(sb, 1), 0.0) << name_of(k) << " scale x " << sx;
    }
  // Mirrored in all three axes (determinant -1) and in two (+1, no flip).
  for (Vec3 sc : {Vec3{-1, -1, -1}, Vec3{-1, -1, 1}, Vec3{1, -2, 0.5f}}) {
    Scene s = empty_scene("mirror/axes");
    s.objects.push_back(surface_object("box", make_box({1, 2, 3}), make_transform({1, 2, 3}, {10, 20, 30}, sc)));
    SceneBuffers sb = compiled_scene(s);
    EXPECT_GT(world_signed_volume(sb, 0), 0.0) << sc.x << " " << sc.y << " " << sc.z;
  }
}

// Each mirrored medium against the reference renderer and against the same
// scene unmirrored (the shapes are symmetric, so the pictures agree).
TEST(Mirror, MediaMatchReferenceAndUnmirrored) {
  for (bool eye_inside : {false, true})
    for (Kind k : {Kind::ConstantSphere, Kind::VolumeBox, Kind::TranslucentBox}) {
      Result mirrored = render(mirror_scene(k, -1.0f, eye_inside));
      Result plain = render(mirror_scene(k, 1.0f, eye_inside));
      ImageError vs_plain = compare_images(mirrored.image, plain.image);
      std::printf("[ mirror ] %-16s %-10s vs reference %6.2f dB (T mean %.4f), vs unmirrored %6.2f dB\n", name_of(k),
                  eye_inside ? "eye inside" : "outside", mirrored.stats.image.psnr, mirrored.stats.transmittance.mean,
                  vs_plain.psnr);
      const std::string what = std::string(name_of(k)) + (eye_inside ? ", eye inside" : "");
      EXPECT_GE(mirrored.stats.image.psnr, plain.stats.image.psnr - 1.0) << what;
      EXPECT_GE(mirrored.stats.image.psnr, 38.0) << what;
      EXPECT_LE(mirrored.stats.transmittance.mean, 0.02) << what;
      EXPECT_GE(vs_plain.psnr, 50.0) << what;
      EXPECT_EQ(mirrored.stats.unmatched_fragments, 0u) << what;
    }
}
