// Raw scalar volumes (CT scans, simulations): 8- or 16-bit voxels, x fastest.
#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <memory>

#include "cdsm/error.h"
#include "cdsm/loaders.h"

namespace cdsm {

std::shared_ptr<DenseGrid> load_raw(const std::string& path, const RawVolumeDesc& d) {
  if (d.nx < 1 || d.ny < 1 || d.nz < 1)
    throw Error(path, "raw volume dimensions must be >= 1 (got " + std::to_string(d.nx) + "x" +
                          std::to_string(d.ny) + "x" + std::to_string(d.nz) + ")");
  const uint64_t count = uint64_t(d.nx) * uint64_t(d.ny) * uint64_t(d.nz);
  if (count > (uint64_t(1) << 31)) throw Error(path, "raw volume has more than 2^31 voxels");
  const uint64_t bpv = d.format == RawFormat::UInt16 ? 2 : 1;
  const uint64_t expected = d.header_bytes + count * bpv;
  struct stat st {};
  require_file(path, "raw volume");
  if (::stat(path.c_str(), &st) != 0) throw Error(path, "cannot open raw volume");
  const uint64_t size = uint64_t(st.st_size);
  if (size != expected) {
    std::string msg = "raw volume is " + std::to_string(size) + " bytes, but " + std::to_string(d.nx) + "x" +
                      std::to_string(d.ny) + "x" + std::to_string(d.nz) + " voxels of " +
                      std::to_string(bpv * 8) + " bits" +
                      (d.header_bytes ? " after a " + std::to_string(d.header_bytes) + "-byte header" : "") +
                      " need " + std::to_string(expected);
    // Name the likely cause when the size fits the other voxel format.
    if (size == d.header_bytes + count * (3 - bpv))
      msg += " (the file size fits " + std::to_string((3 - bpv) * 8) + "-bit voxels)";
    throw Error(path, msg);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open raw volume");
  in.seekg(std::streamoff(d.header_bytes));
  std::vector<unsigned char> bytes(count * bpv);
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  if (!in || uint64_t(in.gcount()) != bytes.size()) throw Error(path, "raw volume could not be read completely");

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

}  // namespace cdsm
