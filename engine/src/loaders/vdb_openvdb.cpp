// OpenVDB .vdb -> NanoVDB. The only file that includes OpenVDB (it compiles
// slowly); everything else samples the NanoVDB bytes this produces.
#include <openvdb/io/Compression.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>
#include <nanovdb/util/OpenToNanoVDB.h>
#include <blosc.h>
#include <zlib.h>

#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <new>
#include <sstream>

#include "cdsm/error.h"
#include "cdsm/loaders.h"

// OpenVDB 10 reads an uncompressed chunk of a blosc- or zip-compressed
// grid into its destination *before* checking the chunk's size against
// it, so a corrupt size field overflows the heap (found by flipping bytes
// of vpt_box_fog.vdb). These definitions take the place of the library's
// (it calls them through its PLT) and check every size before any read;
// the format is OpenVDB's: an int64 byte count, negative for uncompressed
// data, then the bytes.
#if OPENVDB_LIBRARY_MAJOR_VERSION_NUMBER == 10
namespace openvdb {
OPENVDB_USE_VERSION_NAMESPACE
namespace OPENVDB_VERSION_NAME {
namespace io {
namespace {

// The chunk's stored size, checked against what the caller expects.
int64_t read_chunk_size(std::istream& is, size_t expected, const char* codec) {
  int64_t n = 0;
  is.read(reinterpret_cast<char*>(&n), sizeof(n));
  if (!is.good()) OPENVDB_THROW(RuntimeError, std::string("stream failure reading the size of a ") + codec + " chunk");
  if (n <= 0) {
    if (n == std::numeric_limits<int64_t>::min() || uint64_t(-n) != expected)
      OPENVDB_THROW(RuntimeError, "expected a " + std::to_string(expected) +
                                      "-byte uncompressed chunk, the file says " +
                                      std::to_string(n == std::numeric_limits<int64_t>::min() ? 0 : -n));
  } else if (uint64_t(n) > uint64_t(expected) + (uint64_t(expected) >> 3) + 4096) {
    OPENVDB_THROW(RuntimeError, std::string("a ") + codec + " chunk of " + std::to_string(n) + " bytes cannot hold " +
                                    std::to_string(expected) + " bytes");
  }
  return n;
}

void read_exact(std::istream& is, char* data, size_t n) {
  is.read(data, std::streamsize(n));
  if (!is.good() || size_t(is.gcount()) != n) OPENVDB_THROW(RuntimeError, "the data end before the chunk does");
}

// A chunk stored uncompressed (n <= 0: numBytes raw bytes) or one without
// a destination (skipped): handled here, whatever its compression.
bool stored_or_skipped(std::istream& is, char* data, size_t numBytes, int64_t n) {
  if (n <= 0) {
    if (data)
      read_exact(is, data, numBytes);
    else
      is.seekg(std::streamoff(numBytes), std::ios_base::cur);
    return true;
  }
  if (!data) {
    is.seekg(std::streamoff(n), std::ios_base::cur);
    return true;
  }
  return false;
}

}  // namespace

void bloscFromStream(std::istream& is, char* data, size_t numBytes) {
  const int64_t n = read_chunk_size(is, numBytes, "blosc");
  if (stored_or_skipped(is, data, numBytes, n)) return;
  std::vector<char> packed(size_t(n) + BLOSC_MAX_OVERHEAD);
  read_exact(is, packed.data(), size_t(n));
  size_t nbytes = 0, cbytes = 0, blocksize = 0;
  if (n < BLOSC_MIN_HEADER_LENGTH || blosc_cbuffer_validate(packed.data(), size_t(n), &nbytes) != 0)
    OPENVDB_THROW(RuntimeError, "corrupt blosc chunk header");
  blosc_cbuffer_sizes(packed.data(), &nbytes, &cbytes, &blocksize);
  if (nbytes != numBytes || cbytes != size_t(n))
    OPENVDB_THROW(RuntimeError,
                  "blosc chunk header says " + std::to_string(nbytes) + " bytes, expected " + std::to_string(numBytes));
  if (blosc_decompress_ctx(packed.data(), data, numBytes, 1) != int(numBytes))
    OPENVDB_THROW(RuntimeError, "corrupt blosc chunk");
}

void unzipFromStream(std::istream& is, char* data, size_t numBytes) {
  const int64_t n = read_chunk_size(is, numBytes, "zip");
  if (stored_or_skipped(is, data, numBytes, n)) return;
  std::vector<char> packed(static_cast<size_t>(n));
  read_exact(is, packed.data(), size_t(n));
  uLongf out = uLongf(numBytes);
  if (uncompress(reinterpret_cast<Bytef*>(data), &out, reinterpret_cast<const Bytef*>(packed.data()), uLong(n)) !=
          Z_OK ||
      out != numBytes)
    OPENVDB_THROW(RuntimeError, "corrupt zip chunk");
}

}  // namespace io
}  // namespace OPENVDB_VERSION_NAME
}  // namespace openvdb
#endif

namespace cdsm {
namespace {

// Voxelizing tiles (active ones, and inactive ones whose value is not the
// background) into more leaves than this is refused: 2^16 leaves of 8^3
// float voxels are 2^25 voxels (about 320^3), about 140 MB once voxelized
// (and within the fuzzers' 2 GiB under ASan, whose heap costs 3-4x). A
// file of a few kilobytes can hold tiles that would voxelize to terabytes.
constexpr uint64_t kMaxTileLeaves = uint64_t(1) << 16;

std::string describe(const openvdb::GridBase& g) {
  std::string type = g.valueType();
  if (g.isType<openvdb::FloatGrid>() && g.saveFloatAsHalf()) type = "half";
  return "'" + g.getName() + "' (" + type + ", " + std::to_string(g.activeVoxelCount()) + " active voxels)";
}

// Parses "name[n]" into name and n; n = -1 without a suffix.
void split_index(const std::string& s, std::string& name, int& index) {
  name = s;
  index = -1;
  if (s.size() < 3 || s.back() != ']') return;
  size_t open = s.rfind('[');
  if (open == std::string::npos || open + 2 > s.size() - 1) return;
  int n = 0;
  for (size_t i = open + 1; i + 1 < s.size(); ++i) {
    if (s[i] < '0' || s[i] > '9' || n > 100000) return;
    n = n * 10 + (s[i] - '0');
  }
  name = s.substr(0, open);
  index = n;
}

// Where a .vdb's parts lie, and the metadata OpenVDB may read of them:
// the header up to the file metadata, and each grid's descriptor, its
// metadata (re-serialized, only entries whose size matches their type) and
// the rest of its bytes (transform, topology, buffers), as the descriptors'
// end offsets place them.
struct VdbLayout {
  uint64_t header_end = 0;  // magic, versions, offsets flag, UUID: [0, header_end)
  struct Grid {
    std::string name, parent;    // unique name; instance parent ("" if none)
    uint64_t begin = 0;          // descriptor [begin, grid_pos)
    uint64_t grid_pos = 0;       // + the compression flags (4 bytes)
    std::string metadata;        // the checked entries, serialized
    uint64_t rest = 0, end = 0;  // transform, topology, buffers: [rest, end)
  };
  std::vector<Grid> grids;
};

class Prologue {
 public:
  Prologue(const std::string& path, std::istream& in, uint64_t size) : path_(path), in_(in), size_(size) {}

  VdbLayout check() {
    if (size_ < 8 || u64() != 0x56444220u) throw Error(path_, "not a VDB file (no VDB magic number)");
    const uint32_t version = u32();
    if (version < 222 || version > 224)
      throw Error(path_, "VDB file version " + std::to_string(version) +
                             " is not supported (versions 222 to 224: OpenVDB 3 and later)");
    u32();  // library major, minor
    u32();
    if (u8() == 0)
      throw Error(path_,
                  "VDB file without grid offsets (written as a stream) is not supported; "
                  "save it with openvdb::io::File");
    skip(36);  // UUID
    VdbLayout layout;
    layout.header_end = uint64_t(in_.tellg());
    metadata("file metadata", nullptr);
    const uint32_t grids = u32();
    for (uint32_t g = 0; g < grids; ++g) {
      VdbLayout::Grid grid;
      grid.begin = uint64_t(in_.tellg());
      grid.name = str("grid name");
      const std::string type = str("grid type");
      grid.parent = str("instance parent");
      const uint64_t grid_pos = u64(), block_pos = u64(), end_pos = u64();
      // OpenVDB writes a grid right after its descriptor (and reads it from
      // there, whatever grid_pos says): the prologue checks what it will read.
      if (!(grid_pos == uint64_t(in_.tellg()) && grid_pos <= block_pos && block_pos <= end_pos))
        throw Error(path_, "corrupt VDB file: grid '" + grid.name + "' has inconsistent offsets");
      if (end_pos > size_)
        throw Error(path_, "truncated VDB file: grid '" + grid.name + "' (" + type + ") ends at byte " +
                               std::to_string(end_pos) + ", the file has " + std::to_string(size_) + " bytes");
      grid.grid_pos = grid_pos;
      u32();  // compression flags
      metadata("metadata of grid '" + grid.name + "'", &grid.metadata);
      grid.rest = uint64_t(in_.tellg());
      if (grid.rest > end_pos)
        throw Error(path_, "corrupt VDB file: the metadata of grid '" + grid.name + "' run past its end");
      str("transform of grid '" + grid.name + "'");  // the map's type name
      seek(end_pos);                                 // the next descriptor follows the grid
      grid.end = end_pos;
      layout.grids.push_back(std::move(grid));
    }
    return layout;
  }

 private:
  void need(uint64_t n, const std::string& what) {
    const uint64_t at = uint64_t(in_.tellg());
    if (n > size_ || at > size_ - n)
      throw Error(path_, "corrupt or truncated VDB file: " + what + " of " + std::to_string(n) + " bytes at byte " +
                             std::to_string(at) + " runs past the end of the file (" + std::to_string(size_) +
                             " bytes)");
  }
  template <class T>
  T pod(const char* what) {
    need(sizeof(T), what);
    T v{};
    in_.read(reinterpret_cast<char*>(&v), sizeof(T));
    return v;
  }
  uint8_t u8() { return pod<uint8_t>("header"); }
  uint32_t u32() { return pod<uint32_t>("a count"); }
  uint64_t u64() { return pod<uint64_t>("an offset"); }
  void skip(uint64_t n) {
    need(n, "header");
    in_.seekg(std::streamoff(n), std::ios::cur);
  }
  void seek(uint64_t at) {
    if (at > size_) throw Error(path_, "corrupt VDB file: offset " + std::to_string(at) + " beyond the end");
    in_.seekg(std::streamoff(at));
  }
  std::string str(const std::string& what) {
    const uint32_t n = u32();
    need(n, what);
    std::string s(n, '\0');
    if (n > 0) in_.read(&s[0], n);
    return s;
  }
  // A metadata block: a count, then (name, type, size, value) entries.
  // OpenVDB reads a typed value's own size whatever the size field says (a
  // "mat4d" of 12 bytes is read as 128, and the stream is lost), so those
  // must match; entries of other types (delayed-load tables, unregistered
  // types) are dropped. `keep` receives the checked entries, serialized.
  void metadata(const std::string& what, std::string* keep) {
    static const std::pair<const char*, uint32_t> kSizes[] = {
        {"bool", 1},   {"int32", 4},  {"int64", 8},  {"float", 4},  {"double", 8}, {"vec2i", 8},
        {"vec2s", 8},  {"vec2d", 16}, {"vec3i", 12}, {"vec3s", 12}, {"vec3d", 24}, {"vec4i", 16},
        {"vec4s", 16}, {"vec4d", 32}, {"mat4s", 64}, {"mat4d", 128}};
    const uint32_t count = u32();
    std::string entries;
    uint32_t kept = 0;
    for (uint32_t i = 0; i < count; ++i) {
      const std::string name = str(what + " name"), type = str(what + " type");
      const uint32_t n = u32();  // the value's size in bytes, then the value
      need(n, what + " value");
      bool known = type == "string";
      for (const auto& [t, size] : kSizes)
        if (type == t) {
          if (n != size)
            throw Error(path_, "corrupt VDB file: " + what + " '" + name + "' of type " + type + " has " +
                                   std::to_string(n) + " bytes, not " + std::to_string(size));
          known = true;
        }
      if (!known || !keep) {
        in_.seekg(std::streamoff(n), std::ios::cur);
        continue;
      }
      std::string value(n, '\0');
      if (n > 0) in_.read(&value[0], n);
      for (const std::string* part : std::initializer_list<const std::string*>{&name, &type, &value}) {
        const uint32_t len = uint32_t(part->size());
        entries.append(reinterpret_cast<const char*>(&len), sizeof len).append(*part);
      }
      ++kept;
    }
    if (keep) keep->assign(reinterpret_cast<const char*>(&kept), sizeof kept).append(entries);
  }

  std::string path_;
  std::istream& in_;
  uint64_t size_;
};

// Reads the bytes [begin, end) of `in` onto `out`.
void append_region(std::istream& in, uint64_t begin, uint64_t end, std::string& out) {
  const size_t at = out.size();
  out.resize(at + size_t(end - begin));
  in.seekg(std::streamoff(begin));
  in.read(&out[at], std::streamsize(end - begin));
}

// The grids of one stream (`bytes`, a header and its grids) read by OpenVDB.
openvdb::GridPtrVecPtr read_stream(const std::string& path, std::string bytes) {
  std::istringstream in(std::move(bytes), std::ios::binary);
  openvdb::GridPtrVecPtr grids;
  try {
    // OpenVDB does not check for short reads: a truncated or corrupt file
    // would go on "reading" garbage (and allocating nodes for it) past the
    // end. A stream that throws on the first failed read stops that.
    in.exceptions(std::ios::failbit | std::ios::badbit);
    openvdb::io::Stream stream(in, /*delayLoad=*/false);
    grids = stream.getGrids();
  } catch (const std::ios_base::failure&) {
    throw Error(path, "truncated or corrupt VDB file (a read went past the end of the data)");
  } catch (const std::bad_alloc&) {
    throw Error(path, "corrupt VDB file (a size field asks for an impossible allocation)");
  } catch (const std::exception& e) {
    throw Error(path, std::string("not a readable VDB file: ") + e.what());
  }
  if (in.fail()) throw Error(path, "truncated or corrupt VDB file (the data end before the file says)");
  return grids;
}

// Every grid of a .vdb held in the stream `in` of `size` bytes (a file or
// memory); `path` names it in messages. Each grid is read on its own, from
// the header and the bytes its descriptor's offsets give it (with its
// instance parent before it) and with only the metadata the prologue
// checked: OpenVDB's reader takes the next descriptor where the previous
// grid's data happened to end, so after a corrupt grid it would read a
// descriptor the prologue never checked.
openvdb::GridPtrVecPtr read_all_grids(const std::string& path, std::istream& in, uint64_t size) {
  const VdbLayout layout = Prologue(path, in, size).check();
  in.clear();
  auto grids = std::make_shared<openvdb::GridPtrVec>();
  for (size_t g = 0; g < layout.grids.size(); ++g) {
    std::vector<size_t> chain{g};  // the grid, then its instance parents
    while (!layout.grids[chain.back()].parent.empty()) {
      size_t p = 0;
      while (p < layout.grids.size() && layout.grids[p].name != layout.grids[chain.back()].parent) ++p;
      if (p == layout.grids.size() || chain.size() > layout.grids.size())
        throw Error(path, "corrupt VDB file: grid '" + layout.grids[g].name + "' is an instance of the missing grid '" +
                              layout.grids[chain.back()].parent + "'");
      chain.push_back(p);
    }
    // The header, no file metadata, the chain's grids with checked metadata.
    std::string bytes;
    append_region(in, 0, layout.header_end, bytes);
    const uint32_t no_metadata = 0, count = uint32_t(chain.size());
    bytes.append(reinterpret_cast<const char*>(&no_metadata), sizeof no_metadata);
    bytes.append(reinterpret_cast<const char*>(&count), sizeof count);
    for (size_t i = chain.size(); i-- > 0;) {
      const VdbLayout::Grid& gr = layout.grids[chain[i]];
      append_region(in, gr.begin, gr.grid_pos + 4, bytes);  // descriptor, compression flags
      bytes += gr.metadata;
      append_region(in, gr.rest, gr.end, bytes);
    }
    if (!in) throw Error(path, "cannot read VDB file (a read failed)");
    openvdb::GridPtrVecPtr one = read_stream(path, std::move(bytes));
    if (!one || one->size() != chain.size() || !one->back())
      throw Error(path, "corrupt VDB file: grid '" + layout.grids[g].name + "' could not be read");
    grids->push_back(one->back());
  }
  if (grids->empty()) throw Error(path, "VDB file holds no grids");
  return grids;
}

openvdb::GridPtrVecPtr read_all_grids(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open VDB file (missing or unreadable)");
  in.seekg(0, std::ios::end);
  const uint64_t size = uint64_t(in.tellg());
  in.seekg(0);
  return read_all_grids(path, in, size);
}

openvdb::GridBase::Ptr select_grid(const std::string& path, const openvdb::GridPtrVec& grids,
                                   const std::string& wanted) {
  std::string name;
  int index = -1;
  split_index(wanted, name, index);
  std::vector<openvdb::GridBase::Ptr> matches;
  for (const auto& g : grids)
    if (g && g->getName() == wanted) matches.push_back(g);
  if (matches.empty() && index >= 0)
    for (const auto& g : grids)
      if (g && g->getName() == name) matches.push_back(g);
  if (matches.size() == 1 && index < 0) return matches[0];
  if (index >= 0 && size_t(index) < matches.size() && matches[0]->getName() == name) return matches[size_t(index)];
  std::string list;
  for (const auto& g : grids) list += (list.empty() ? "" : ", ") + (g ? describe(*g) : std::string("(null)"));
  if (matches.empty()) throw Error(path, "no grid named '" + wanted + "'; the file has " + list);
  const std::string missing = index >= 0 ? "no grid '" + wanted + "': " : "";
  if (matches.size() == 1)
    throw Error(path, missing + "only one grid is named '" + name + "' (use '" + name + "' or '" + name +
                          "[0]'); the file has " + list);
  throw Error(path, missing + std::to_string(matches.size()) + " grids are named '" + name + "' (pick one as '" + name +
                        "[0]' to '" + name + "[" + std::to_string(matches.size() - 1) + "]'); the file has " + list);
}

openvdb::FloatGrid::Ptr as_float_grid(const std::string& path, const openvdb::GridBase::Ptr& g) {
  if (auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(g)) return f;
  if (auto d = openvdb::gridPtrCast<openvdb::DoubleGrid>(g)) {  // values converted to float
    // The value-converting deep copy keeps topology, tiles and states.
    auto f = openvdb::FloatGrid::create(std::make_shared<openvdb::FloatTree>(d->tree()));
    f->setTransform(d->transform().copy());
    f->setName(d->getName());
    f->setGridClass(d->getGridClass());
    return f;
  }
  throw Error(path, "grid " + describe(*g) +
                        " is not a scalar float grid; only float, half and double "
                        "density grids are volumes");
}

Mat4 index_to_object(const std::string& path, const std::string& grid, const openvdb::math::Transform& xf) {
  if (!xf.isLinear())
    throw Error(path, "grid '" + grid + "' has a non-linear transform (" + xf.mapType() +
                          "); only affine index-to-world transforms are supported");
  const openvdb::Vec3d o = xf.indexToWorld(openvdb::Vec3d(0, 0, 0));
  Mat4 m;
  for (int c = 0; c < 3; ++c) {
    openvdb::Vec3d e(0, 0, 0);
    e[c] = 1.0;
    const openvdb::Vec3d col = xf.indexToWorld(e) - o;
    for (int r = 0; r < 3; ++r) m.m[r][c] = float(col[r]);
  }
  for (int r = 0; r < 3; ++r) m.m[r][3] = float(o[r]);
  for (auto& row : m.m)
    for (float v : row)
      if (!std::isfinite(v)) throw Error(path, "grid '" + grid + "' has a NaN or infinite transform");
  Mat4 inv;
  if (!invert(m, inv)) throw Error(path, "grid '" + grid + "' has a singular transform");
  return m;
}

void initialize_once() {
  static std::once_flag init;
  std::call_once(init, [] { openvdb::initialize(); });
}

// The grid named `grid_name` of `grids` (read from `path`) as NanoVDB.
VdbVolume convert_grid(const std::string& path, const openvdb::GridPtrVec& grids, const std::string& grid_name) {
  openvdb::GridBase::Ptr base = select_grid(path, grids, grid_name);
  const std::string name = base->getName();
  if (base->getGridClass() == openvdb::GRID_LEVEL_SET)
    throw Error(path,
                "grid '" + name + "' is a level set (signed distances), not a density; convert it to a fog volume");
  openvdb::FloatGrid::Ptr grid = as_float_grid(path, base);
  openvdb::FloatTree& tree = grid->tree();
  const Mat4 xf = index_to_object(path, name, grid->transform());

  auto sg = std::make_shared<SparseGrid>();
  sg->name = name;
  sg->background = tree.background();
  if (!std::isfinite(sg->background)) throw Error(path, "grid '" + name + "' has a NaN or infinite background");
  // Every value finite; min and max of the active ones; inactive tiles
  // that differ from the background (voxelized below).
  float lo = 3e38f, hi = -3e38f;
  std::vector<openvdb::CoordBBox> odd_tiles;
  uint64_t tile_leaves = 0;  // leaves the voxelized tiles become
  for (auto it = tree.cbeginValueAll(); it; ++it) {
    const float v = *it;
    if (!std::isfinite(v)) {
      const openvdb::Coord c = it.getCoord();
      throw Error(path, "grid '" + name + "' has a NaN or infinite value at voxel " + std::to_string(c.x()) + "," +
                            std::to_string(c.y()) + "," + std::to_string(c.z()));
    }
    if (it.isValueOn()) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
      if (it.isTileValue()) tile_leaves += it.getVoxelCount() / 512;
    } else if (it.isTileValue() && v != sg->background) {
      openvdb::CoordBBox box;
      it.getBoundingBox(box);
      tile_leaves += it.getVoxelCount() / 512;
      odd_tiles.push_back(box);
    }
  }
  openvdb::CoordBBox active;
  if (!tree.evalActiveVoxelBoundingBox(active) || tree.activeVoxelCount() == 0)
    throw Error(path, "grid '" + name + "' has no active voxels");
  for (int a = 0; a < 3; ++a) {
    sg->active_min[a] = active.min()[a];
    sg->active_max[a] = active.max()[a];
  }
  sg->active_voxels = tree.activeVoxelCount();
  sg->min_value = lo;
  sg->max_value = hi;

  // Leaf-granular empty-space skipping (hd/scene_data.h) needs every value
  // that differs from the background in a leaf, and a leaf in each of the
  // 26 blocks around such a leaf (its trilinear apron).
  if (tile_leaves > kMaxTileLeaves)
    throw Error(path, "grid '" + name + "' has tiles (active, or inactive with a value other than the background) of " +
                          std::to_string(tile_leaves * 512) + " voxels; voxelized they would take about " +
                          std::to_string(tile_leaves * 2200 >> 20) + " MiB, more than the loader's limit of " +
                          std::to_string(kMaxTileLeaves * 512) + " tile voxels");
  tree.voxelizeActiveTiles();
  for (const openvdb::CoordBBox& box : odd_tiles)
    for (int z = box.min().z(); z <= box.max().z(); z += 8)
      for (int y = box.min().y(); y <= box.max().y(); y += 8)
        for (int x = box.min().x(); x <= box.max().x(); x += 8) tree.touchLeaf(openvdb::Coord(x, y, z));
  std::vector<openvdb::Coord> origins;
  origins.reserve(tree.leafCount());
  for (auto it = tree.cbeginLeaf(); it; ++it) origins.push_back(it->origin());
  for (const openvdb::Coord& o : origins)
    for (int dz = -8; dz <= 8; dz += 8)
      for (int dy = -8; dy <= 8; dy += 8)
        for (int dx = -8; dx <= 8; dx += 8) tree.touchLeaf(o.offsetBy(dx, dy, dz));

  nanovdb::GridHandle<nanovdb::HostBuffer> handle;
  try {
    handle = nanovdb::openToNanoVDB(*grid);
  } catch (const std::exception& e) {
    throw Error(path, "grid '" + name + "' could not be converted to NanoVDB: " + e.what());
  }
  if (!handle || !handle.grid<float>()) throw Error(path, "grid '" + name + "' could not be converted to NanoVDB");
  const uint64_t bytes = handle.size();
  sg->nanovdb.resize((bytes + sizeof(SparseGrid::Block) - 1) / sizeof(SparseGrid::Block));
  std::memcpy(sg->nanovdb.data(), handle.data(), bytes);
  sg->nanovdb_bytes = bytes;
  return {sg, xf};
}

}  // namespace

bool vdb_supported() { return true; }

VdbVolume load_vdb(const std::string& path, const std::string& grid_name) {
  initialize_once();
  struct stat st {};
  require_file(path, "VDB file");
  if (::stat(path.c_str(), &st) != 0) throw Error(path, "cannot open VDB file (missing)");
  openvdb::GridPtrVecPtr grids = read_all_grids(path);
  return convert_grid(path, *grids, grid_name);
}

VdbVolume load_vdb_from_memory(const std::vector<unsigned char>& bytes, const std::string& name,
                               const std::string& grid_name) {
  initialize_once();
  std::istringstream in(std::string(bytes.begin(), bytes.end()), std::ios::binary);
  openvdb::GridPtrVecPtr grids = read_all_grids(name, in, bytes.size());
  return convert_grid(name, *grids, grid_name);
}

}  // namespace cdsm
