// Writes the generated seed inputs of tests/fuzz/corpus/ (no third-party
// assets): small .gltf/.glb scenes made from cdsm::make_box, .vdb files
// written with OpenVDB, raw descriptors and render byte strings.
// Usage: fuzz_make_seeds CORPUS_DIR (its fuzz_<target>/ folders must exist).
#include <openvdb/openvdb.h>
#include <openvdb/tools/Prune.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "cdsm/procedural.h"

namespace {

using Bytes = std::vector<unsigned char>;

void write(const std::string& path, const Bytes& b) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
  if (!out) {
    std::fprintf(stderr, "cannot write %s\n", path.c_str());
    std::exit(1);
  }
}
void write(const std::string& path, const std::string& s) { write(path, Bytes(s.begin(), s.end())); }

std::string base64(const Bytes& b) {
  static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < b.size(); i += 3) {
    uint32_t v = uint32_t(b[i]) << 16;
    if (i + 1 < b.size()) v |= uint32_t(b[i + 1]) << 8;
    if (i + 2 < b.size()) v |= b[i + 2];
    out += abc[(v >> 18) & 63];
    out += abc[(v >> 12) & 63];
    out += i + 1 < b.size() ? abc[(v >> 6) & 63] : '=';
    out += i + 2 < b.size() ? abc[v & 63] : '=';
  }
  return out;
}

template <class T>
void append(Bytes& b, const T& v) {
  const auto* p = reinterpret_cast<const unsigned char*>(&v);
  b.insert(b.end(), p, p + sizeof(T));
}

// ---- glTF ------------------------------------------------------------------

// A box's buffer: u16 indices, then float positions, then float normals.
struct BoxBuffer {
  Bytes bytes;
  size_t index_bytes = 0, vertex_bytes = 0, indices = 0, vertices = 0;
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
};

BoxBuffer box_buffer() {
  cdsm::TriangleMesh m = cdsm::make_box({1.0f, 0.6f, 0.8f});
  BoxBuffer b;
  for (uint32_t i : m.indices) append(b.bytes, uint16_t(i));
  while (b.bytes.size() % 4) b.bytes.push_back(0);
  b.index_bytes = b.bytes.size();
  for (const cdsm::Vec3& p : m.positions) {
    append(b.bytes, p.x), append(b.bytes, p.y), append(b.bytes, p.z);
    for (int a = 0; a < 3; ++a) b.lo[a] = std::min(b.lo[a], p[a]), b.hi[a] = std::max(b.hi[a], p[a]);
  }
  b.vertex_bytes = m.positions.size() * 12;
  for (const cdsm::Vec3& n : m.normals) append(b.bytes, n.x), append(b.bytes, n.y), append(b.bytes, n.z);
  b.indices = m.indices.size();
  b.vertices = m.positions.size();
  return b;
}

// The glTF JSON of a small scene around the box: a node hierarchy, two
// primitives (one a triangle strip without normals), BLEND and volume
// materials, a camera and KHR_lights_punctual spot and point lights.
// `buffer_uri` empty: no uri (the .glb's BIN chunk).
std::string gltf_json(const BoxBuffer& b, const std::string& buffer_uri) {
  const std::string n = std::to_string(b.indices), v = std::to_string(b.vertices);
  const std::string ib = std::to_string(b.index_bytes), vb = std::to_string(b.vertex_bytes);
  char minmax[256];
  std::snprintf(minmax, sizeof minmax, "\"min\":[%g,%g,%g],\"max\":[%g,%g,%g]", b.lo[0], b.lo[1], b.lo[2], b.hi[0],
                b.hi[1], b.hi[2]);
  std::string j = R"({"asset":{"version":"2.0","generator":"cdsm fuzz_make_seeds"},)";
  j += R"("extensionsUsed":["KHR_lights_punctual","KHR_materials_volume","KHR_materials_transmission"],)";
  j += R"("scene":0,"scenes":[{"nodes":[0,4]}],)";
  j += R"("nodes":[{"name":"root","children":[1,2,3],"rotation":[0,0.3826834,0,0.9238795]},)";
  j += R"({"name":"box","mesh":0,"translation":[0,0.3,0]},)";
  j += R"({"name":"glass","mesh":1,"translation":[1.2,0.3,0],"scale":[0.5,-0.5,0.5]},)";
  j +=
      R"({"name":"lamp","translation":[0,3,0],"rotation":[-0.7071068,0,0,0.7071068],"extensions":{"KHR_lights_punctual":{"light":0}}},)";
  j += R"({"name":"eye","camera":0,"matrix":[1,0,0,0, 0,0.9701425,0.2425356,0, 0,-0.2425356,0.9701425,0, 0,1.5,5,1],)";
  j += R"("extensions":{"KHR_lights_punctual":{"light":1}}}],)";
  j += R"("cameras":[{"type":"perspective","perspective":{"yfov":0.7,"znear":0.05,"zfar":50,"aspectRatio":1.5}}],)";
  j += R"("extensions":{"KHR_lights_punctual":{"lights":[{"type":"spot","intensity":20,"color":[1,0.9,0.8],)";
  j += R"("spot":{"innerConeAngle":0.3,"outerConeAngle":0.6}},{"type":"point","intensity":5}]}},)";
  j +=
      R"("materials":[{"name":"red","pbrMetallicRoughness":{"baseColorFactor":[0.8,0.1,0.1,0.5],"metallicFactor":0.2,"roughnessFactor":0.5},"alphaMode":"BLEND"},)";
  j += R"({"name":"gel","extensions":{"KHR_materials_transmission":{"transmissionFactor":0.7},)";
  j += R"("KHR_materials_volume":{"attenuationColor":[0.5,0.8,0.5],"attenuationDistance":0.4}}}],)";
  j += R"("meshes":[{"name":"box","primitives":[{"attributes":{"POSITION":1,"NORMAL":2},"indices":0,"material":0}]},)";
  j += R"({"name":"gel box","primitives":[{"attributes":{"POSITION":1,"NORMAL":2},"indices":0,"material":1},)";
  j += R"({"attributes":{"POSITION":1},"mode":5,"indices":3}]}],)";
  j += R"("accessors":[{"bufferView":0,"componentType":5123,"count":)" + n + R"(,"type":"SCALAR"},)";
  j += R"({"bufferView":1,"componentType":5126,"count":)" + v + R"(,"type":"VEC3",)" + minmax + "},";
  j += R"({"bufferView":1,"byteOffset":)" + vb + R"(,"componentType":5126,"count":)" + v + R"(,"type":"VEC3"},)";
  j += R"({"bufferView":0,"byteOffset":0,"componentType":5123,"count":6,"type":"SCALAR"}],)";
  j += R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":)" + ib + R"(,"target":34963},)";
  j += R"({"buffer":0,"byteOffset":)" + ib + R"(,"byteLength":)" + std::to_string(2 * b.vertex_bytes) +
       R"(,"byteStride":12,"target":34962}],)";
  j += R"("buffers":[{"byteLength":)" + std::to_string(b.bytes.size()) +
       (buffer_uri.empty() ? "" : R"(,"uri":")" + buffer_uri + "\"") + "}]}";
  return j;
}

Bytes glb(const std::string& json, const Bytes& bin) {
  Bytes j(json.begin(), json.end());
  while (j.size() % 4) j.push_back(' ');
  Bytes b = bin;
  while (b.size() % 4) b.push_back(0);
  Bytes out;
  append(out, uint32_t(0x46546C67));  // "glTF"
  append(out, uint32_t(2));
  append(out, uint32_t(12 + 8 + j.size() + 8 + b.size()));
  append(out, uint32_t(j.size()));
  append(out, uint32_t(0x4E4F534A));  // "JSON"
  out.insert(out.end(), j.begin(), j.end());
  append(out, uint32_t(b.size()));
  append(out, uint32_t(0x004E4942));  // "BIN\0"
  out.insert(out.end(), b.begin(), b.end());
  return out;
}

void gltf_seeds(const std::string& dir) {
  const BoxBuffer b = box_buffer();
  write(dir + "/scene_embedded.gltf", gltf_json(b, "data:application/octet-stream;base64," + base64(b.bytes)));
  write(dir + "/scene.glb", glb(gltf_json(b, ""), b.bytes));
  write(dir + "/external_buffer.gltf", gltf_json(b, "box.bin"));  // external: fails when loading from memory
  // The smallest scene: one triangle, no indices, no normals, no light.
  Bytes tri;
  for (float f : {0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f}) append(tri, f);
  write(
      dir + "/triangle.gltf",
      R"({"asset":{"version":"2.0"},"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)"
      R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],)"
      R"("bufferViews":[{"buffer":0,"byteLength":36}],"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,)" +
          base64(tri) + R"("}]})");
}

// ---- OpenVDB -----------------------------------------------------------------

openvdb::FloatGrid::Ptr float_box(int lo, int hi, float background, bool varying) {
  auto g = openvdb::FloatGrid::create(background);
  auto acc = g->getAccessor();
  for (int z = lo; z <= hi; ++z)
    for (int y = lo; y <= hi; ++y)
      for (int x = lo; x <= hi; ++x)
        acc.setValue({x, y, z}, varying ? 0.1f + 0.05f * float((x + 2 * y + 3 * z) % 9) : 1.0f);
  g->setName("density");
  g->setGridClass(openvdb::GRID_FOG_VOLUME);
  return g;
}

void write_vdb(const std::string& path, const openvdb::GridPtrVec& grids, uint32_t compression) {
  openvdb::io::File f(path);
  f.setCompression(compression);
  f.write(grids);
  f.close();
}

void vdb_seeds(const std::string& dir) {
  openvdb::initialize();
  using namespace openvdb::io;
  // One leaf of varying values (blosc).
  write_vdb(dir + "/leaf_blosc.vdb", {float_box(0, 5, 0.0f, true)}, COMPRESS_BLOSC | COMPRESS_ACTIVE_MASK);
  // Half floats, zip, a rotated and non-uniformly scaled transform, background 1.
  {
    auto g = float_box(0, 5, 1.0f, true);
    g->setSaveFloatAsHalf(true);
    openvdb::math::Transform::Ptr xf = openvdb::math::Transform::createLinearTransform(0.05);
    xf->preScale(openvdb::Vec3d(1.0, 2.0, 0.5));
    xf->postRotate(0.4, openvdb::math::Y_AXIS);
    xf->postTranslate(openvdb::Vec3d(0.5, 0.0, -0.25));
    g->setTransform(xf);
    write_vdb(dir + "/half_zip_rotated.vdb", {g}, COMPRESS_ZIP | COMPRESS_ACTIVE_MASK);
  }
  // Sparse: two distant leaves and an active tile, mask compression only.
  {
    auto g = float_box(0, 2, 0.0f, false);
    g->tree().setValue(openvdb::Coord(40, 3, 20), 0.5f);
    g->tree().addTile(1, openvdb::Coord(64, 0, 0), 0.25f, true);
    write_vdb(dir + "/sparse_tile_mask.vdb", {g}, COMPRESS_ACTIVE_MASK);
  }
  // A double grid (converted) beside a level set and a vector grid.
  {
    auto d = openvdb::DoubleGrid::create(0.0);
    d->tree().setValue(openvdb::Coord(1, 2, 3), 2.0);
    d->tree().setValue(openvdb::Coord(2, 2, 3), 1.0);
    d->setName("density");
    auto ls = openvdb::FloatGrid::create(0.1f);
    ls->tree().setValue(openvdb::Coord(0, 0, 0), -0.1f);
    ls->setName("surface");
    ls->setGridClass(openvdb::GRID_LEVEL_SET);
    auto vec = openvdb::Vec3SGrid::create();
    vec->tree().setValue(openvdb::Coord(0, 0, 0), openvdb::Vec3s(1, 0, 0));
    vec->setName("velocity");
    write_vdb(dir + "/double_and_others.vdb", {d, ls, vec}, COMPRESS_ACTIVE_MASK);
  }
  // Two grids named density (ambiguous) and an inactive non-background tile.
  {
    auto a = float_box(0, 1, 0.0f, false);
    auto b = float_box(2, 3, 0.0f, true);
    b->tree().addTile(1, openvdb::Coord(128, 128, 128), 0.75f, false);
    write_vdb(dir + "/two_density.vdb", {a, b}, COMPRESS_BLOSC);
  }
}

// ---- raw and render ------------------------------------------------------------

void raw_seeds(const std::string& dir) {
  // nx ny nz flags header, content (flags: 1 uint16, 2 big endian, 4 normalize, 32 fit).
  write(dir + "/u8_4x4x2.raw", Bytes{3,  3,  1,  4,  0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  10, 11, 12, 13, 14,
                                     15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 255});
  write(dir + "/u16_be_header.raw",
        Bytes{1, 1, 0, 1 | 2 | 4, 2, 0xAB, 0xCD, 0x00, 0x01, 0xFF, 0xFF, 0x12, 0x34, 0x80, 0x00});
  write(dir + "/fit_u16.raw", Bytes{7, 5, 3, 1 | 32, 8, 0x10, 0x20, 0x30});
  write(dir + "/wrong_size.raw", Bytes{1, 1, 1, 0, 0, 1, 2, 3});
}

void render_seeds(const std::string& dir) {
  std::mt19937 rng(20240601u);
  const size_t sizes[] = {24, 64, 128, 200, 256};
  for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; ++i) {
    Bytes b(sizes[i]);
    for (auto& x : b) x = uint8_t(rng());
    write(dir + "/random_" + std::to_string(i) + ".bin", b);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  gltf_seeds(dir + "/fuzz_gltf");
  vdb_seeds(dir + "/fuzz_vdb");
  raw_seeds(dir + "/fuzz_raw");
  render_seeds(dir + "/fuzz_render");
  return 0;
}
