// The exec templates the cuda backend instantiates, split over several
// translation units (light_pass_grey.cu, light_pass_rgb.cu, passes.cu) so
// that nvcc and ptxas compile them in parallel: cuda_backend.cu sees only
// these declarations.
#pragma once

#include "backend/exec_backend.h"
#include "launch.cuh"

namespace cdsm::exec {

extern template void walk_map_exec<DsmNode, cuda::CudaExec>(cuda::CudaExec&, const SceneView&, const LightPassParams&,
                                                            FragmentLists, const DsmLayoutParams&,
                                                            const LightPassOptions&,
                                                            KindStore<DsmNode, cuda::CudaExec>&,
                                                            LightPassScratch<cuda::CudaExec>&, BatchEntry&,
                                                            BuildCounters*, const BuildCounters*);
extern template DsmBuildStats place_map_exec<DsmNode, cuda::CudaExec>(cuda::CudaExec&, const LightPassParams&,
                                                                      const DsmLayoutParams&,
                                                                      KindStore<DsmNode, cuda::CudaExec>&,
                                                                      LightPassScratch<cuda::CudaExec>&,
                                                                      const BatchEntry&, const BuildCounters&, DsmMap&);
extern template void walk_map_exec<DsmNodeRgb, cuda::CudaExec>(cuda::CudaExec&, const SceneView&,
                                                               const LightPassParams&, FragmentLists,
                                                               const DsmLayoutParams&, const LightPassOptions&,
                                                               KindStore<DsmNodeRgb, cuda::CudaExec>&,
                                                               LightPassScratch<cuda::CudaExec>&, BatchEntry&,
                                                               BuildCounters*, const BuildCounters*);
extern template DsmBuildStats place_map_exec<DsmNodeRgb, cuda::CudaExec>(
    cuda::CudaExec&, const LightPassParams&, const DsmLayoutParams&, KindStore<DsmNodeRgb, cuda::CudaExec>&,
    LightPassScratch<cuda::CudaExec>&, const BatchEntry&, const BuildCounters&, DsmMap&);
extern template void shade_pixels<cuda::CudaExec>(cuda::CudaExec&, const SceneView&, const ShadowView&,
                                                  const CameraPassParams&, FragmentLists, float*, uint32_t*);
extern template void cast_fragments_exec<cuda::CudaExec>(cuda::CudaExec&, const SceneView&, const PinholeView&,
                                                         ObjectMask, bool, ExecArray<uint32_t, cuda::CudaExec>&,
                                                         ExecArray<uint32_t, cuda::CudaExec>&,
                                                         ExecArray<Fragment, cuda::CudaExec>&,
                                                         ExecArray<unsigned long long, cuda::CudaExec>&);
extern template ExecStoredMap move_map_down_exec<DsmNode, cuda::CudaExec>(cuda::CudaExec&, const ExecStoredMap&,
                                                                          DsmLayout,
                                                                          KindStore<DsmNode, cuda::CudaExec>&,
                                                                          StoreCursor&,
                                                                          ExecArray<unsigned char, cuda::CudaExec>&);
extern template ExecStoredMap move_map_down_exec<DsmNodeRgb, cuda::CudaExec>(cuda::CudaExec&, const ExecStoredMap&,
                                                                             DsmLayout,
                                                                             KindStore<DsmNodeRgb, cuda::CudaExec>&,
                                                                             StoreCursor&,
                                                                             ExecArray<unsigned char, cuda::CudaExec>&);
extern template void read_map_exec<cuda::CudaExec>(cuda::CudaExec&, const DsmStorage&, const DsmMap&, uint32_t,
                                                   std::vector<uint32_t>&, std::vector<DsmNode>&);

}  // namespace cdsm::exec
