// The engine's compile of its scene model (cdsm/scene.h) into the
// algorithm's plain input (SceneBuffers, shadows/cpu/scene_buffers.h),
// volume by volume and object by object, so the shadow system recompiles
// only what an edit touched (engine/src/shadow_system.cpp).
#pragma once

#include <string>
#include <vector>

#include "cdsm/scene.h"
#include "cluster/light_views.h"
#include "scene/scene_buffers.h"

namespace cdsm {

// One volume's content on its own arrays: the voxels (dense) or the NanoVDB
// grid's blocks (sparse) and the macro-cell maxima, the offsets in `data`
// relative to these arrays. Placement (index_to_world, step) comes from the
// object whose interior it is: place_volume(). O(voxels).
struct CompiledVolume {
  VolumeData data{};
  std::vector<float> voxels;
  std::vector<float> macro_max;
  std::vector<GridBlock> nano_pool;
};
CompiledVolume compile_volume(const Volume& v, const std::string& where);

// Places a volume inside its object (object -> world `transform`): its
// index <-> world matrices, voxel size and march step. Throws cdsm::Error
// when the placement is singular or the step is below float resolution
// where the volume lies.
void place_volume(VolumeData& vd, const Volume& v, const Mat4& transform, const std::string& where);

// One object: its kernel data (first_tri and volume left for the caller)
// and world-space triangles, 3 vertices and 3 shading normals each, with
// their box. `closed` is is_closed(*o.mesh), computed once per mesh by the
// caller. Throws cdsm::Error on invalid content (NaN, bad indices, a
// singular transform). O(triangles).
struct CompiledObject {
  ObjectData data{};
  std::vector<Vec3> vertices;
  std::vector<Vec3> normals;
  Box3 bounds;
  std::vector<std::string> warnings;
};
void compile_object(const Object& o, bool closed, const std::string& where, CompiledObject& out);

// The surface part of an object's kernel data (colour, coverage, per-channel
// crossing opacity, Phong constants, the cast and coloured flags), checked:
// material edits apply it alone. Throws cdsm::Error naming `where`.
void apply_surface(const Object& o, const std::string& where, ObjectData& od);

// Appends a compiled volume's arrays to the scene's, its offsets re-based;
// returns its index in sb.volumes.
uint32_t append_volume(SceneBuffers& sb, const CompiledVolume& cv);

// Appends a compiled object as the next object of `sb` (its triangle range
// and index set here). Throws when the scene would exceed kMaxPrimitives.
void append_object(SceneBuffers& sb, CompiledObject& co, const std::string& source);

// The BVH over every triangle of `sb` (build_bvh); running out of memory is
// an Error naming `source` and the size.
void build_scene_bvh(SceneBuffers& sb, const std::string& source);

// The light as clustering sees it.
cluster::LightShape light_shape(const Light& light);

// "scene.json: object 3 'name'" for messages.
std::string object_location(const std::string& source, size_t index, const std::string& name);

}  // namespace cdsm
