// The .vdb loader of a build configured with CDSM_VDB=OFF: a clear error.
#include "cdsm/error.h"
#include "cdsm/loaders.h"

namespace cdsm {

bool vdb_supported() { return false; }

VdbVolume load_vdb(const std::string& path, const std::string&) {
  throw Error(path,
              "this build reads no .vdb files (configured with CDSM_VDB=OFF; rebuild with -DCDSM_VDB=ON "
              "and libopenvdb-dev installed)");
}

VdbVolume load_vdb_from_memory(const std::vector<unsigned char>&, const std::string& name, const std::string& grid) {
  return load_vdb(name, grid);
}

}  // namespace cdsm
