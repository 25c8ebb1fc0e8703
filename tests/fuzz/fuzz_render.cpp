// Structure-aware: the input bytes choose a small valid scene (procedural
// meshes and noise volumes, transforms, materials, interiors, lights,
// shadow settings), which cdsm::Renderer renders on the CPU (CPU fragment
// lists, cpu backend) at 32x24; every pixel must be finite. Sometimes a
// second frame follows with a light moved and the settings changed (map
// reuse and rebuilds). A cdsm::Error (a scene the generator made invalid)
// is tolerated; any other exception, a crash or a non-finite pixel is a
// finding.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "cdsm/procedural.h"
#include "cdsm/renderer.h"
#include "fuzz_util.h"

namespace {

using cdsm::Vec3;
using cdsm_fuzz::ByteReader;

Vec3 colour(ByteReader& in) { return {in.unit(0.05f, 1.0f), in.unit(0.05f, 1.0f), in.unit(0.05f, 1.0f)}; }

// Translation within 1.5 of the origin (y >= 0), any rotation, modest
// scales, occasionally mirrored along one axis.
cdsm::Mat4 transform(ByteReader& in) {
  const Vec3 t{in.unit(-1.5f, 1.5f), in.unit(0.0f, 1.5f), in.unit(-1.5f, 1.5f)};
  const Vec3 r{in.unit(0.0f, 360.0f), in.unit(0.0f, 360.0f), in.unit(0.0f, 360.0f)};
  const float s = in.unit(0.3f, 1.5f);
  Vec3 sc{s * in.unit(0.7f, 1.3f), s * in.unit(0.7f, 1.3f), s * in.unit(0.7f, 1.3f)};
  const uint8_t mirror = in.byte();
  if (mirror % 8 == 0) sc[mirror / 8 % 3] = -sc[mirror / 8 % 3];
  return cdsm::make_transform(t, r, sc);
}

// A noise volume of at most 24^3 voxels with 1 to 4 transfer points.
int add_volume(cdsm::Scene& scene, ByteReader& in) {
  cdsm::NoiseVolumeParams p;
  p.nx = in.range(2, 24);
  p.ny = in.range(2, 24);
  p.nz = in.range(2, 24);
  p.seed = in.u32();
  p.frequency = in.unit(0.5f, 6.0f);
  p.octaves = float(in.range(1, 4));
  p.plume = in.unit(0.0f, 1.0f);
  p.density_scale = in.unit(0.1f, 2.0f);
  cdsm::Volume v;
  v.name = "noise " + std::to_string(scene.volumes.size());
  v.grid = cdsm::make_noise_volume(p);
  // Voxel (i,j,k) centre at -extent/2 + (i + 0.5) * voxel (as scene files place grids).
  const float voxel = in.unit(0.02f, 0.1f);
  cdsm::Mat4 m;
  m.m[0][0] = m.m[1][1] = m.m[2][2] = voxel;
  m.m[0][3] = (0.5f - 0.5f * float(p.nx)) * voxel;
  m.m[1][3] = 0.5f * voxel;
  m.m[2][3] = (0.5f - 0.5f * float(p.nz)) * voxel;
  v.index_to_object = m;
  const int points = in.range(1, 4);
  float density = 0.0f;
  for (int i = 0; i < points; ++i) {
    cdsm::TransferPoint tp;
    density += in.unit(0.0f, 0.5f);  // sorted by density
    tp.density = density;
    tp.extinction = cdsm::vec3(in.flag() ? 0.0f : in.unit(0.0f, 30.0f));
    tp.color = colour(in);
    v.transfer.push_back(tp);
  }
  v.shading = in.flag() ? cdsm::VolumeShading::Phong : cdsm::VolumeShading::Scatter;
  v.step_voxels = in.unit(0.25f, 2.0f);
  scene.volumes.push_back(std::move(v));
  return int(scene.volumes.size()) - 1;
}

void add_object(cdsm::Scene& scene, ByteReader& in) {
  cdsm::Object o;
  o.name = "object " + std::to_string(scene.objects.size());
  const int kind = in.range(0, 4);
  bool closed = true;
  switch (kind) {
    case 0:
      o.mesh = std::make_shared<cdsm::TriangleMesh>(
          cdsm::make_box({in.unit(0.1f, 1.0f), in.unit(0.1f, 1.0f), in.unit(0.1f, 1.0f)}));
      break;
    case 1:
      o.mesh =
          std::make_shared<cdsm::TriangleMesh>(cdsm::make_sphere(in.unit(0.1f, 0.8f), in.range(3, 12), in.range(2, 8)));
      break;
    case 2:
      o.mesh = std::make_shared<cdsm::TriangleMesh>(
          cdsm::make_ground(in.unit(2.0f, 8.0f), in.unit(2.0f, 8.0f), in.unit(0.01f, 0.1f)));
      break;
    case 3:
      o.mesh = std::make_shared<cdsm::TriangleMesh>(cdsm::make_quad(in.unit(0.2f, 2.0f), in.unit(0.2f, 2.0f)));
      closed = false;
      break;
    default: {  // a volume bounded by its grid's box, with an invisible or faint boundary
      o.interior = cdsm::InteriorKind::Volume;
      o.volume = add_volume(scene, in);
      o.mesh = std::make_shared<cdsm::TriangleMesh>(cdsm::make_volume_proxy(scene.volumes[size_t(o.volume)]));
      break;
    }
  }
  o.transform = transform(in);
  o.casts_shadows = in.byte() % 8 != 0;
  o.surface.color = colour(in);
  o.surface.opacity = o.interior == cdsm::InteriorKind::Volume ? (in.flag() ? 0.0f : in.unit(0.0f, 0.3f))
                                                               : (in.flag() ? 1.0f : in.unit(0.0f, 1.0f));
  o.surface.specular = in.unit(0.0f, 1.0f);
  o.surface.shininess = in.unit(1.0f, 96.0f);
  if (closed && o.interior == cdsm::InteriorKind::None) {
    const int interior = in.range(0, 3);
    if (interior == 1) {
      o.interior = cdsm::InteriorKind::Constant;
      o.sigma = cdsm::vec3(in.unit(0.0f, 10.0f));
    } else if (interior == 2 && kind != 2) {  // a volume inside a box or sphere
      o.interior = cdsm::InteriorKind::Volume;
      o.volume = add_volume(scene, in);
    }
  }
  scene.objects.push_back(std::move(o));
}

void add_light(cdsm::Scene& scene, ByteReader& in) {
  cdsm::Light l;
  l.name = "light " + std::to_string(scene.lights.size());
  l.type = in.flag() ? cdsm::LightType::Point : cdsm::LightType::Spot;
  const float az = in.unit(0.0f, 6.2831853f), el = in.unit(0.15f, 1.5f), r = in.unit(2.0f, 6.0f);
  l.position = {r * std::cos(el) * std::cos(az), r * std::sin(el), r * std::cos(el) * std::sin(az)};
  const Vec3 aim{in.unit(-0.5f, 0.5f), in.unit(0.0f, 0.6f), in.unit(-0.5f, 0.5f)};
  l.direction = cdsm::normalize(aim - l.position);
  l.outer_cone_deg = in.unit(10.0f, 80.0f);
  l.inner_cone_deg = in.unit(0.0f, l.outer_cone_deg);
  l.color = colour(in);
  l.intensity = in.unit(0.2f, 1.5f);
  scene.lights.push_back(l);
}

void check_image(const cdsm::Image& image, const cdsm::Scene& scene) {
  if (image.width != scene.camera.width || image.height != scene.camera.height ||
      image.rgb.size() != size_t(image.width) * size_t(image.height) * 3)
    std::abort();
  for (float c : image.rgb)
    if (!std::isfinite(c)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ByteReader in(data, size);
  cdsm::Scene scene;
  scene.source = "fuzz";
  const int objects = in.range(1, 6);
  for (int i = 0; i < objects; ++i) add_object(scene, in);
  const int lights = in.range(1, 2);
  for (int i = 0; i < lights; ++i) add_light(scene, in);

  cdsm::ShadowSettings& sh = scene.shadows;
  sh.epsilon = in.unit(0.0f, 0.5f);
  sh.resolution = 32;
  sh.filtering = in.flag();
  sh.max_clusters = in.range(1, 4);
  sh.d0 = in.unit(0.05f, 1.0f);
  sh.layout = cdsm::DsmLayout(in.range(0, 2));

  cdsm::Camera& cam = scene.camera;
  cam.width = 32;
  cam.height = 24;
  const float az = in.unit(0.0f, 6.2831853f), r = in.unit(3.0f, 8.0f);
  cam.position = {r * std::cos(az), in.unit(0.5f, 4.0f), r * std::sin(az)};
  cam.target = {0.0f, 0.3f, 0.0f};
  cam.fov_y_deg = in.unit(25.0f, 70.0f);
  cam.near = 0.05f;
  cam.far = 100.0f;
  const bool second_frame = in.flag();

  cdsm::RenderOptions options;
  options.backend = cdsm::Backend::Cpu;
  options.fragments = cdsm::FragmentSource::Cpu;
  try {
    cdsm::Renderer renderer;
    check_image(renderer.render(scene, options), scene);
    if (second_frame) {  // the next frame: one light moved, other settings
      add_light(scene, in);
      scene.lights.front().position = scene.lights.back().position;
      scene.lights.pop_back();
      sh.epsilon = in.unit(0.0f, 0.5f);
      sh.max_clusters = in.range(1, 4);
      sh.filtering = in.flag();
      check_image(renderer.render(scene, options), scene);
    }
  } catch (const cdsm::Error& e) {
    // Should be rare: CDSM_FUZZ_SHOW_ERRORS=1 prints them, to check the generator.
    if (std::getenv("CDSM_FUZZ_SHOW_ERRORS")) std::fprintf(stderr, "fuzz_render: %s\n", e.what());
  }
  return 0;
}
