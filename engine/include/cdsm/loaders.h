// Asset loaders: OpenVDB volumes (converted to NanoVDB), raw scalar
// volumes, glTF 2.0 meshes and whole glTF scenes, the closed proxy mesh
// that bounds a volume, and the lookup of files a scene refers to.
//
// Every problem with an input is a cdsm::Error whose message names the file
// and what is wrong with it (truncated, corrupt, out-of-range references,
// NaN, the wrong grid type, ...); no input makes a loader crash. Features a
// loader reads but cannot represent are reported once per file through the
// warning sink (set_warning_sink), naming the features and where they are.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/scene.h"

namespace cdsm {

// ---- warnings --------------------------------------------------------------

// Receives loader warnings (one line each). The default prints
// "cdsm: warning: <text>" to stderr. Pass nullptr to restore the default.
using WarningSink = std::function<void(const std::string&)>;
void set_warning_sink(WarningSink sink);
void warn(const std::string& text);

// ---- files a scene refers to -----------------------------------------------

// The data directory (the public meshes and volumes the shipped scenes
// read; MANIFEST.tsv there names each file's source and licence):
// $CDSM_DATA_DIR if set, else content_dir() + "/data" (the installed
// share/cdsm/data, or the source tree's while the library runs from it).
std::string data_dir();

// Resolves a file reference of a scene file:
//  - "$SHARED/rest" -> data_dir()/rest,
//  - an absolute path -> itself,
//  - a relative path -> base_dir/path, else data_dir()/path.
// A file found nowhere throws Error(where, "file 'ref' not found; looked
// in: <every path tried>"); a directory where the file should be says so.
std::string resolve_asset(const std::string& ref, const std::string& base_dir, const std::string& where);

// Throws Error(path, ...) unless `path` is a readable regular file: "is a
// directory, not a <what>", "<what> not found", or "is not a regular file".
void require_file(const std::string& path, const std::string& what);

// ---- OpenVDB -----------------------------------------------------------------

// Whether this build reads .vdb files (CMake option CDSM_VDB).
bool vdb_supported();

struct VdbVolume {
  std::shared_ptr<const SparseGrid> grid;
  Mat4 index_to_object;  // the grid's own transform (rotation, non-uniform scale included)
};

// Reads the grid named `grid_name` from a .vdb file and converts it to
// NanoVDB. Float grids (also those stored as half floats) and double grids
// (converted) are accepted; the grid's transform must be affine. A name
// matching no grid or several grids (VDB files may repeat a name) is an
// error listing every grid in the file; "name[n]" picks the n-th of
// repeated names. The grid keeps its background value; every value must be
// finite. Active tiles are made voxels and every leaf holding data gets its
// 26 neighbour leaves (values unchanged, inactive), which is what
// empty-space skipping at leaf granularity needs (hd/scene_data.h).
VdbVolume load_vdb(const std::string& path, const std::string& grid_name = "density");

// load_vdb() on the bytes of a .vdb file held in memory (fuzzing, archives);
// `name` stands for the file in messages.
VdbVolume load_vdb_from_memory(const std::vector<unsigned char>& bytes, const std::string& name,
                               const std::string& grid_name = "density");

// ---- raw volumes -------------------------------------------------------------

enum class RawFormat { UInt8, UInt16 };

struct RawVolumeDesc {
  int32_t nx = 0, ny = 0, nz = 0;  // voxels; x fastest, then y, then z
  RawFormat format = RawFormat::UInt8;
  bool big_endian = false;    // byte order of 16-bit values
  uint64_t header_bytes = 0;  // skipped at the start of the file
  bool normalize = true;      // values / 255 (or / 65535) into [0, 1]; else the integers
};

// Reads a raw scalar volume into a dense grid (background 0). The file size
// must be exactly header_bytes + nx*ny*nz*bytes-per-voxel.
std::shared_ptr<DenseGrid> load_raw(const std::string& path, const RawVolumeDesc& desc);

// load_raw() on the bytes of a raw file held in memory; `name` stands for
// the file in messages.
std::shared_ptr<DenseGrid> load_raw_from_memory(const std::vector<unsigned char>& bytes, const std::string& name,
                                                const RawVolumeDesc& desc);

// ---- glTF 2.0 ----------------------------------------------------------------

// The triangles of a glTF file (.gltf with external or embedded buffers, or
// .glb) merged into one mesh in the file's scene space: every mesh under
// the default scene's node hierarchy with its node's global transform. With
// `node` (a node name or index), only that node and, with `subtree`, its
// descendants, still with their global transforms (ancestors included).
// Per-vertex normals when all primitives have them.
TriangleMesh load_gltf_mesh(const std::string& path, const std::string& node = "", bool subtree = true);

// A glTF file as a whole scene:
//  - one object per mesh primitive (triangles), with the node's global transform;
//  - material: baseColorFactor rgb -> colour; its alpha -> surface opacity
//    when alphaMode is BLEND (OPAQUE and MASK: opaque);
//    KHR_materials_transmission: opacity *= 1 - transmissionFactor;
//    metallic/roughness -> Phong specular and shininess (approximate);
//    KHR_materials_volume: a constant absorbing interior with
//    sigma = mean over rgb of -ln(attenuationColor) / attenuationDistance
//    (shadows are scalar; closed meshes only);
//  - KHR_lights_punctual spot and point lights at their nodes (intensities
//    scaled so the brightest light has intensity 1: the renderer has no
//    distance falloff); no light: a default spot light over the scene;
//  - the first camera met in the node hierarchy (perspective); none: a
//    default view of the scene's bounds.
// Everything else that would change the picture (textures, emission,
// skins, morph targets, directional lights, orthographic cameras, ...) is
// listed in one warning. A file with no triangle meshes is an error.
Scene load_gltf_scene(const std::string& path);

// load_gltf_scene() on the bytes of a .gltf or .glb file held in memory;
// `name` stands for the file in messages (and Scene::source). Buffers must
// be embedded (data: URIs, or the .glb's own chunk): an external URI is
// an error, nothing is read from the file system.
Scene load_gltf_scene_from_memory(const std::vector<unsigned char>& bytes, const std::string& name);

// ---- volume proxies ------------------------------------------------------------

enum class VolumeProxy {
  Box,     // the grid's box: dense: all voxels; sparse: the active voxels' bounding box
  Leaves,  // sparse: the union of the 8^3 leaf blocks holding active voxels (dense: Box)
};

// The closed boundary mesh of a volume in object space (CCW outwards, also
// under a mirroring index_to_object), half a voxel beyond the outermost
// voxel centres it encloses. The Leaves hull has no edge shared by more than
// two faces (diagonal contacts are filled), so is_closed() holds.
TriangleMesh make_volume_proxy(const Volume& volume, VolumeProxy kind = VolumeProxy::Box);

}  // namespace cdsm
