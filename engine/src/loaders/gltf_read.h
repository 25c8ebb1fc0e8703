// glTF 2.0 through tinygltf: reading a file with every reference checked
// (buffers, views, accessors, nodes), node transforms and the hierarchy,
// and primitives as triangle lists. Private to the loaders.
#pragma once

#include <tiny_gltf.h>

#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "cdsm/scene.h"

namespace cdsm::gltf {

// Features that are read but not represented, with where they occur;
// reported once per file as one warning.
class Unsupported {
 public:
  void add(const std::string& feature, const std::string& where) { found_[feature].insert(where); }
  bool empty() const { return found_.empty(); }
  // "FILE: unsupported glTF features ignored: textures (nodes: a, b); ..."
  std::string message(const std::string& path) const;
  void report(const std::string& path) const;  // through cdsm::warn, if any

 private:
  std::map<std::string, std::set<std::string>> found_;
};

// A parsed file. Errors (unreadable, truncated, invalid JSON, a required
// extension this loader lacks) throw cdsm::Error naming the file.
struct File {
  std::string path;
  tinygltf::Model model;
  std::vector<int> parent;  // per node, -1 for roots; validated: a forest
};
// During load_gltf_scene_from_memory(bytes, name), read_file(name) on that
// thread parses `bytes` instead, with the file system shut.
File read_file(const std::string& path, Unsupported& unsupported);

// "'name' (node 3)" for messages.
std::string node_label(const File& f, int node);

// The node's local transform (matrix, or translation * rotation * scale);
// NaN, infinity or a zero quaternion throw.
Mat4 local_transform(const File& f, int node);
// Product of the local transforms from the root down to the node.
Mat4 global_transform(const File& f, int node);

// The root nodes of the default scene (or scene 0; with no scenes, every
// node without a parent).
std::vector<int> scene_roots(const File& f);

// Depth-first over the subtrees of `roots`: visit(node, global transform).
void walk(const File& f, const std::vector<int>& roots, const Mat4& root_parent,
          const std::function<void(int, const Mat4&)>& visit);

// Node by name or by decimal index; a missing or ambiguous name throws.
int find_node(const File& f, const std::string& name_or_index);

// One triangle primitive of a mesh in the mesh's space; skipped (false,
// with a note in `unsupported`) if it is not made of triangles. Normals
// are empty when the primitive has none. Out-of-range references and
// NaN values throw.
bool read_primitive(const File& f, int mesh, int prim, const std::string& where, Unsupported& unsupported,
                    TriangleMesh& out);

// Appends `src` transformed by `m` to `dst` (normals by the inverse
// transpose). `m` is baked into the positions, so a mirroring `m` flips the
// winding here (the result is counter-clockwise outward in dst's space;
// the scene compile (compile_object) flips again only for the object's own transform). Drops
// dst's normals when the two disagree about having them.
void append_transformed(TriangleMesh& dst, const TriangleMesh& src, const Mat4& m);

}  // namespace cdsm::gltf
