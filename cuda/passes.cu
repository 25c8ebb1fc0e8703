// The camera pass, the fragment producer and the store's launches
// (cuda/instances.cuh).
#include "instances.cuh"

namespace cdsm::exec {
template void shade_pixels<cuda::CudaExec>(cuda::CudaExec&, const SceneView&, const ShadowView&,
                                           const CameraPassParams&, FragmentLists, float*, uint32_t*);
template void cast_fragments_exec<cuda::CudaExec>(cuda::CudaExec&, const SceneView&, const PinholeView&, ObjectMask,
                                                  bool, ExecArray<uint32_t, cuda::CudaExec>&,
                                                  ExecArray<uint32_t, cuda::CudaExec>&,
                                                  ExecArray<Fragment, cuda::CudaExec>&,
                                                  ExecArray<unsigned long long, cuda::CudaExec>&);
template ExecStoredMap move_map_down_exec<DsmNode, cuda::CudaExec>(cuda::CudaExec&, const ExecStoredMap&, DsmLayout,
                                                                   KindStore<DsmNode, cuda::CudaExec>&, StoreCursor&,
                                                                   ExecArray<unsigned char, cuda::CudaExec>&);
template ExecStoredMap move_map_down_exec<DsmNodeRgb, cuda::CudaExec>(cuda::CudaExec&, const ExecStoredMap&, DsmLayout,
                                                                      KindStore<DsmNodeRgb, cuda::CudaExec>&,
                                                                      StoreCursor&,
                                                                      ExecArray<unsigned char, cuda::CudaExec>&);
template void read_map_exec<cuda::CudaExec>(cuda::CudaExec&, const DsmStorage&, const DsmMap&, uint32_t,
                                            std::vector<uint32_t>&, std::vector<DsmNode>&);
}  // namespace cdsm::exec
