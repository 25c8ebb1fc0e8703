// The light pass's launches for scalar maps (cuda/instances.cuh).
#include "instances.cuh"

namespace cdsm::exec {
template void walk_map_exec<DsmNode, cuda::CudaExec>(cuda::CudaExec&, const SceneView&, const LightPassParams&,
                                                     FragmentLists, const DsmLayoutParams&, const LightPassOptions&,
                                                     KindStore<DsmNode, cuda::CudaExec>&,
                                                     LightPassScratch<cuda::CudaExec>&, BatchEntry&, BuildCounters*,
                                                     const BuildCounters*);
template DsmBuildStats place_map_exec<DsmNode, cuda::CudaExec>(cuda::CudaExec&, const LightPassParams&,
                                                               const DsmLayoutParams&,
                                                               KindStore<DsmNode, cuda::CudaExec>&,
                                                               LightPassScratch<cuda::CudaExec>&, const BatchEntry&,
                                                               const BuildCounters&, DsmMap&);
}  // namespace cdsm::exec
