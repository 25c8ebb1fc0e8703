// Raw volume bytes -> cdsm::load_raw_from_memory and cdsm::load_raw (the
// same bytes written to a temporary file), which must agree. The first
// bytes make the RawVolumeDesc, the rest is the file's content. Bad input
// must end in cdsm::Error; any other exception or a crash is a finding.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#define CDSM_FUZZ_OWN_INITIALIZE 1
#include "fuzz_util.h"

namespace {

std::string g_temp_path;

void remove_temp() { std::remove(g_temp_path.c_str()); }

// Both loaders' outcome: the grid, or the error message.
struct Outcome {
  std::shared_ptr<cdsm::DenseGrid> grid;
  std::string error;
};

template <class F>
Outcome attempt(F&& load) {
  Outcome o;
  try {
    o.grid = load();
  } catch (const cdsm::Error& e) {
    o.error = e.problem();
  }
  return o;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  cdsm_fuzz::quiet_and_hermetic();
  g_temp_path = "/tmp/cdsm_fuzz_raw_" + std::to_string(getpid()) + ".raw";
  std::atexit(remove_temp);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  cdsm_fuzz::ByteReader in(data, size);
  cdsm::RawVolumeDesc d;
  d.nx = in.range(1, 64);
  d.ny = in.range(1, 64);
  d.nz = in.range(1, 64);
  const uint8_t flags = in.byte();
  d.format = (flags & 1) ? cdsm::RawFormat::UInt16 : cdsm::RawFormat::UInt8;
  d.big_endian = (flags & 2) != 0;
  d.normalize = (flags & 4) != 0;
  d.header_bytes = in.byte() % 64;
  if (flags & 8) d.header_bytes = ~uint64_t(0) - in.u32();  // near 2^64: the size sum wraps
  if (flags & 16) d.nx = -d.nx;                             // invalid dimensions
  std::vector<unsigned char> content = in.rest();
  if (flags & 32) {  // fit: exactly the size the descriptor needs (cycling the bytes)
    const uint64_t need =
        (d.header_bytes < 64 ? d.header_bytes : 0) + uint64_t(d.nx > 0 ? d.nx : -d.nx) * uint64_t(d.ny) *
                                                         uint64_t(d.nz) * (d.format == cdsm::RawFormat::UInt16 ? 2 : 1);
    std::vector<unsigned char> fit(need);
    for (size_t i = 0; i < fit.size(); ++i) fit[i] = content.empty() ? uint8_t(i) : content[i % content.size()];
    content.swap(fit);
  }

  const Outcome mem = attempt([&] { return cdsm::load_raw_from_memory(content, g_temp_path, d); });
  FILE* f = std::fopen(g_temp_path.c_str(), "wb");
  if (!f) std::abort();
  if (!content.empty() && std::fwrite(content.data(), 1, content.size(), f) != content.size()) std::abort();
  std::fclose(f);
  const Outcome file = attempt([&] { return cdsm::load_raw(g_temp_path, d); });

  // The file and memory paths agree: both fail, or both give the same grid.
  if (bool(mem.grid) != bool(file.grid)) std::abort();
  if (mem.grid) {
    const cdsm::DenseGrid &a = *mem.grid, &b = *file.grid;
    if (a.nx != d.nx || a.ny != d.ny || a.nz != d.nz || a.values.size() != size_t(d.nx) * d.ny * d.nz) std::abort();
    if (a.nx != b.nx || a.ny != b.ny || a.nz != b.nz || a.values != b.values) std::abort();
    const float top = d.normalize ? 1.0f : 65535.0f;
    for (float v : a.values)
      if (!(v >= 0.0f && v <= top)) std::abort();
  } else if (mem.error.empty() || file.error.empty()) {
    std::abort();
  }
  return 0;
}
