// Raw scalar volumes (CT scans, simulations): 8- or 16-bit voxels, x fastest.
#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <memory>

#include "cdsm/error.h"
#include "cdsm/loaders.h"

namespace cdsm {
namespace {

// The voxel count of a valid descriptor.
uint64_t voxel_count(const std::string& path, const RawVolumeDesc& d) {
  if (d.nx < 1 || d.ny < 1 || d.nz < 1)
    throw Error(path, "raw volume dimensions must be >= 1 (got " + std::to_string(d.nx) + "x" + std::to_string(d.ny) +
                          "x" + std::to_string(d.nz) + ")");
  const uint64_t count = uint64_t(d.nx) * uint64_t(d.ny) * uint64_t(d.nz);
  if (count > (uint64_t(1) << 31)) throw Error(path, "raw volume has more than 2^31 voxels");
  return count;
}

uint64_t bytes_per_voxel(const RawVolumeDesc& d) { return d.format == RawFormat::UInt16 ? 2 : 1; }

// The file (or buffer) must hold exactly the header and the voxels.
void check_size(const std::string& path, const RawVolumeDesc& d, uint64_t count, uint64_t size) {
  const uint64_t bpv = bytes_per_voxel(d);
  const uint64_t expected = d.header_bytes + count * bpv;
  if (size != expected) {
    std::string msg = "raw volume is " + std::to_string(size) + " bytes, but " + std::to_string(d.nx) + "x" +
                      std::to_string(d.ny) + "x" + std::to_string(d.nz) + " voxels of " + std::to_string(bpv * 8) +
                      " bits" + (d.header_bytes ? " after a " + std::to_string(d.header_bytes) + "-byte header" : "") +
                      " need " + std::to_string(expected);
    // Name the likely cause when the size fits the other voxel format.
    if (size == d.header_bytes + count * (3 - bpv))
      msg += " (the file size fits " + std::to_string((3 - bpv) * 8) + "-bit voxels)";
    throw Error(path, msg);
  }
}

// The voxels (count * bytes_per_voxel bytes, after the header) as a dense grid.
std::shared_ptr<DenseGrid> decode(const RawVolumeDesc& d, uint64_t count, const unsigned char* bytes) {
  auto g = std::make_shared<DenseGrid>();
  g->nx = d.nx;
  g->ny = d.ny;
  g->nz = d.nz;
  g->background = 0.0f;
  g->values.resize(count);
  if (d.format == RawFormat::UInt8) {
    const float s = d.normalize ? 1.0f / 255.0f : 1.0f;
    for (uint64_t i = 0; i < count; ++i) g->values[i] = float(bytes[i]) * s;
  } else {
    const float s = d.normalize ? 1.0f / 65535.0f : 1.0f;
    const int hi = d.big_endian ? 0 : 1;  // which byte of a pair is the high one
    for (uint64_t i = 0; i < count; ++i) {
      unsigned v = (unsigned(bytes[2 * i + uint64_t(hi)]) << 8) | unsigned(bytes[2 * i + uint64_t(1 - hi)]);
      g->values[i] = float(v) * s;
    }
  }
  return g;
}

}  // namespace

std::shared_ptr<DenseGrid> load_raw(const std::string& path, const RawVolumeDesc& d) {
  const uint64_t count = voxel_count(path, d);
  const uint64_t bpv = bytes_per_voxel(d);
  struct stat st {};
  require_file(path, "raw volume");
  if (::stat(path.c_str(), &st) != 0) throw Error(path, "cannot open raw volume");
  check_size(path, d, count, uint64_t(st.st_size));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open raw volume");
  in.seekg(std::streamoff(d.header_bytes));
  std::vector<unsigned char> bytes(count * bpv);
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  if (!in || uint64_t(in.gcount()) != bytes.size()) throw Error(path, "raw volume could not be read completely");
  return decode(d, count, bytes.data());
}

std::shared_ptr<DenseGrid> load_raw_from_memory(const std::vector<unsigned char>& bytes, const std::string& name,
                                                const RawVolumeDesc& d) {
  const uint64_t count = voxel_count(name, d);
  // A header longer than the data could still pass the size check when
  // header + voxel bytes wraps around 2^64 (a file read would just fail).
  if (d.header_bytes > bytes.size())
    throw Error(name, "raw volume header of " + std::to_string(d.header_bytes) + " bytes is longer than the " +
                          std::to_string(bytes.size()) + "-byte data");
  check_size(name, d, count, bytes.size());
  return decode(d, count, bytes.data() + d.header_bytes);
}

}  // namespace cdsm
