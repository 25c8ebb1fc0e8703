// Procedural noise densities (smoke plume, steam ball) and the content directory.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include "cdsm/procedural.h"
#include "hashing.h"

namespace cdsm {
namespace {

uint32_t mix(uint32_t h) { return mix32(h); }

// Value in [-1, 1] attached to the lattice point (x, y, z) for `seed`.
float lattice(int32_t x, int32_t y, int32_t z, uint32_t seed) {
  uint32_t h = mix(seed ^ 0x9e3779b9u);
  h = mix(h ^ uint32_t(x));
  h = mix(h ^ uint32_t(y) * 0x85ebca6bu);
  h = mix(h ^ uint32_t(z) * 0xc2b2ae35u);
  return float(h >> 8) * (2.0f / 16777215.0f) - 1.0f;
}

// Quintic fade, C2 continuous at lattice points.
float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }

// Value noise in [-1, 1]: lattice values blended with the quintic fade.
float value_noise(float x, float y, float z, uint32_t seed) {
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int32_t ix = int32_t(fx), iy = int32_t(fy), iz = int32_t(fz);
  const float tx = fade(x - fx), ty = fade(y - fy), tz = fade(z - fz);
  float c[2][2];
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      c[dz][dy] = lerpf(lattice(ix, iy + dy, iz + dz, seed), lattice(ix + 1, iy + dy, iz + dz, seed), tx);
  return lerpf(lerpf(c[0][0], c[0][1], ty), lerpf(c[1][0], c[1][1], ty), tz);
}

// Fractal sum of `octaves` noise layers (a fractional last octave fades in),
// each at twice the frequency and half the amplitude; result roughly in [-1, 1].
float fbm(Vec3 p, float octaves, uint32_t seed) {
  float sum = 0.0f, norm = 0.0f, amplitude = 1.0f;
  for (int o = 0; float(o) < octaves && o < 16; ++o) {
    const float w = amplitude * std::min(1.0f, octaves - float(o));
    sum += w * value_noise(p.x, p.y, p.z, seed + uint32_t(o) * 0x632be5abu);
    norm += w;
    amplitude *= 0.5f;
    p = p * 2.0f + Vec3{17.3f, 5.1f, 9.7f};  // offset so octaves do not share lattice origins
  }
  return norm > 0.0f ? sum / norm : 0.0f;
}

// Smooth step from 0 at e0 to 1 at e1.
float smooth(float e0, float e1, float x) {
  const float t = clampf((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

// Unscaled density of a rising plume at normalized grid position u in [0,1]^3:
// a column dense at the bottom centre that widens, sways and thins upward.
float plume_shape(Vec3 u, Vec3 q, float octaves, uint32_t seed) {
  const float h = u.y;
  // The column's centre drifts with low-frequency noise, more so higher up.
  const float sway = 0.18f * h * h;
  const float cx = 0.5f + sway * fbm(Vec3{0.0f, h * 2.0f, 0.0f}, 2.0f, seed + 11u);
  const float cz = 0.5f + sway * fbm(Vec3{3.0f, h * 2.0f, 7.0f}, 2.0f, seed + 23u);
  const float radius = 0.07f + 0.33f * h;
  const float r = std::sqrt((u.x - cx) * (u.x - cx) + (u.z - cz) * (u.z - cz));
  // Domain-warped fBm, stretched upward, gives wispy detail; fbm() is mostly
  // within +-0.4, so n is rescaled to about +-1.
  const Vec3 warp{fbm(q + Vec3{1.7f, 0.0f, 4.2f}, 2.0f, seed + 37u), fbm(q + Vec3{8.3f, 2.8f, 0.0f}, 2.0f, seed + 41u),
                  fbm(q + Vec3{0.0f, 5.9f, 3.1f}, 2.0f, seed + 43u)};
  const Vec3 stretched{q.x, q.y * 0.6f - h * 1.5f, q.z};
  const float n = 2.5f * fbm(stretched + warp * 1.2f, octaves, seed);
  const float edge = r / radius + 0.3f * n;  // noisy radial coordinate, 1 at the column edge
  const float column = 1.0f - smooth(0.3f, 1.0f, edge);
  // Solid at the source, breaking up into wisps higher up.
  const float body = clampf(1.1f + 0.8f * n - 0.9f * h, 0.0f, 1.5f);
  const float rise = smooth(0.0f, 0.05f, h) * (1.0f - smooth(0.8f, 0.98f, h));
  return column * body * rise;
}

// Unscaled density of a soft ball with a noisy surface and interior.
float ball_shape(Vec3 u, Vec3 q, float octaves, uint32_t seed) {
  const Vec3 d = u - Vec3{0.5f, 0.5f, 0.5f};
  const float n = fbm(q, octaves, seed);
  const float edge = length(d) / 0.42f + 0.35f * n;
  return (1.0f - smooth(0.3f, 1.0f, edge)) * (0.8f + 0.5f * n);
}

}  // namespace

std::shared_ptr<DenseGrid> make_noise_volume(const NoiseVolumeParams& p) {
  auto grid = std::make_shared<DenseGrid>();
  grid->nx = std::max(p.nx, 1);
  grid->ny = std::max(p.ny, 1);
  grid->nz = std::max(p.nz, 1);
  grid->background = 0.0f;
  grid->values.assign(size_t(grid->nx) * grid->ny * grid->nz, 0.0f);
  const float plume = clampf(p.plume, 0.0f, 1.0f);
  // Noise features are isotropic in voxels: `frequency` cells across the widest axis.
  const float cells_per_voxel = p.frequency / float(std::max({grid->nx, grid->ny, grid->nz}));
  for (int k = 1; k + 1 < grid->nz; ++k) {
    for (int j = 1; j + 1 < grid->ny; ++j) {
      for (int i = 1; i + 1 < grid->nx; ++i) {
        const Vec3 u{(float(i) + 0.5f) / float(grid->nx), (float(j) + 0.5f) / float(grid->ny),
                     (float(k) + 0.5f) / float(grid->nz)};
        const Vec3 q = Vec3{float(i), float(j), float(k)} * cells_per_voxel;
        // Fade to zero over the outer few percent so the grid border stays empty.
        const float window = smooth(0.0f, 0.06f, std::min(u.x, 1.0f - u.x)) *
                             smooth(0.0f, 0.06f, std::min(u.z, 1.0f - u.z)) *
                             smooth(0.0f, 0.03f, std::min(u.y, 1.0f - u.y));
        float d = 0.0f;
        if (plume > 0.0f) d += plume * plume_shape(u, q, p.octaves, p.seed);
        if (plume < 1.0f) d += (1.0f - plume) * ball_shape(u, q, p.octaves, p.seed);
        grid->values[(size_t(k) * grid->ny + j) * grid->nx + i] =
            clampf(d * window * p.density_scale, 0.0f, std::max(p.density_scale, 0.0f));
      }
    }
  }
  return grid;
}

std::string content_dir() {
  const char* env = std::getenv("CDSM_CONTENT_DIR");
  if (env != nullptr && env[0] != '\0') return env;
  // The tree this library was built from while it is there (the build
  // tree's programs and tests), else where the package installs content.
  std::error_code ec;
  if (std::filesystem::is_directory(std::string(CDSM_CONTENT_DIR_DEFAULT) + "/scenes", ec))
    return CDSM_CONTENT_DIR_DEFAULT;
  return CDSM_INSTALLED_CONTENT_DIR;
}

}  // namespace cdsm
