// The light pass's launches for RGB maps (cuda/instances.cuh).
#include "instances.cuh"

namespace cdsm::exec {
template void walk_map_exec<DsmNodeRgb, cuda::CudaExec>(cuda::CudaExec&, const SceneView&, const LightPassParams&,
                                                        FragmentLists, const DsmLayoutParams&, const LightPassOptions&,
                                                        KindStore<DsmNodeRgb, cuda::CudaExec>&,
                                                        LightPassScratch<cuda::CudaExec>&, BatchEntry&, BuildCounters*,
                                                        const BuildCounters*);
template DsmBuildStats place_map_exec<DsmNodeRgb, cuda::CudaExec>(cuda::CudaExec&, const LightPassParams&,
                                                                  const DsmLayoutParams&,
                                                                  KindStore<DsmNodeRgb, cuda::CudaExec>&,
                                                                  LightPassScratch<cuda::CudaExec>&, const BatchEntry&,
                                                                  const BuildCounters&, DsmMap&);
}  // namespace cdsm::exec
