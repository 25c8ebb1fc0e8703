// The light pass's launches for scalar maps (cuda/instances.cuh).
#include "instances.cuh"

namespace cdsm::exec {
template DsmBuildStats build_map_exec<DsmNode, cuda::CudaExec>(cuda::CudaExec&, const SceneView&,
                                                               const LightPassParams&, FragmentLists,
                                                               const DsmLayoutParams&, const LightPassOptions&,
                                                               KindStore<DsmNode, cuda::CudaExec>&, DsmMap&,
                                                               LightPassScratch<cuda::CudaExec>&);
}  // namespace cdsm::exec
