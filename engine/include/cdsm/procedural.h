// Built-in content, so the default scene needs no files.
// Every mesh generator returns a closed, consistently wound (CCW outward)
// mesh with per-vertex normals, unless stated otherwise.
#pragma once

#include <memory>
#include <string>

#include "cdsm/scene.h"

namespace cdsm {

// Axis-aligned box centred at the origin with the given full size.
TriangleMesh make_box(Vec3 size);

// UV sphere of the given radius centred at the origin: `segments` around the
// axis (>= 3), `rings` from pole to pole (>= 2). Poles are single vertices.
TriangleMesh make_sphere(float radius, int segments = 48, int rings = 24);

// A thin closed slab standing for a ground plane: size_x by size_z at y = 0
// (top face at y = 0, bottom at y = -thickness).
TriangleMesh make_ground(float size_x, float size_z, float thickness = 0.02f);

// A single open quad (two triangles) in the XZ plane facing +y, centred at the origin.
TriangleMesh make_quad(float size_x, float size_z);

// Newell's teapot or teacup, tessellated from a Bezier patch file (format:
// patch count, 16 one-based control-point indices per patch, point count,
// "x,y,z" per line; share/cdsm/meshes/newell/ holds both), with `subdivisions`
// segments per patch edge, welded and closed (degenerate pole triangles
// dropped, open rims capped) so is_closed() holds. The up axis is detected
// (the teapot file has z up, the teacup y up); the
// returned mesh has y up, rests on y = 0 and keeps the file's units.
// Throws cdsm::Error naming the file (and line) when it is missing or malformed.
TriangleMesh make_newell_mesh(const std::string& patch_file, int subdivisions = 8);

// Parameters of the procedural noise volumes (smoke plume, steam).
struct NoiseVolumeParams {
  int32_t nx = 48, ny = 96, nz = 48;  // grid resolution
  uint32_t seed = 1;
  float frequency = 3.0f;  // noise features across the grid
  float octaves = 4;       // fractal octaves
  float plume = 1.0f;      // 1: density shaped as a rising plume; 0: a soft ball
  float density_scale = 1.0f;
};

// A deterministic fractal-noise density grid in [0, density_scale], zero at
// the grid border (so the proxy box bounds it), background 0.
std::shared_ptr<DenseGrid> make_noise_volume(const NoiseVolumeParams& params);

// The directory of cdsm's content (scenes/, meshes/, shaders/):
// $CDSM_CONTENT_DIR if set, else the source tree this library was built
// from while it exists, else the installed share/cdsm.
std::string content_dir();

}  // namespace cdsm
