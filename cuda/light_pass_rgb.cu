// The light pass's launches for RGB maps (cuda/instances.cuh).
#include "instances.cuh"

namespace cdsm::exec {
template DsmBuildStats build_map_exec<DsmNodeRgb, cuda::CudaExec>(cuda::CudaExec&, const SceneView&,
                                                                  const LightPassParams&, FragmentLists,
                                                                  const DsmLayoutParams&, const LightPassOptions&,
                                                                  KindStore<DsmNodeRgb, cuda::CudaExec>&, DsmMap&,
                                                                  LightPassScratch<cuda::CudaExec>&);
}  // namespace cdsm::exec
