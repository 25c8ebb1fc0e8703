// .vdb bytes -> cdsm::load_vdb_from_memory (OpenVDB -> NanoVDB) and both
// volume proxies of the grid it gives. Bad input must end in cdsm::Error;
// any other exception or a crash is a finding.
#include <cstdint>
#include <vector>

#include "cdsm/error.h"
#include "cdsm/loaders.h"
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::vector<unsigned char> bytes(data, data + size);
  try {
    cdsm::VdbVolume vdb = cdsm::load_vdb_from_memory(bytes, "fuzz.vdb", "density");
    cdsm::Volume v;
    v.sparse = vdb.grid;
    v.index_to_object = vdb.index_to_object;
    v.transfer.push_back(cdsm::TransferPoint{});
    cdsm::make_volume_proxy(v, cdsm::VolumeProxy::Box);
    cdsm::make_volume_proxy(v, cdsm::VolumeProxy::Leaves);
  } catch (const cdsm::Error&) {
  }
  return 0;
}
