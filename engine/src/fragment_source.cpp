#include "fragment_source.h"

#include "cdsm/error.h"

namespace cdsm {

struct FragmentSourceSelector::Gl {};

FragmentSourceSelector::FragmentSourceSelector() = default;
FragmentSourceSelector::~FragmentSourceSelector() = default;

FragmentProducer FragmentSourceSelector::select(FragmentSource want, const SceneBuffers& sb,
                                                std::string& name, std::string& reason) {
  if (want == FragmentSource::Gl)
    throw Error("--fragments gl", "this build has no OpenGL fragment rasterizer yet");
  name = "cpu";
  reason = want == FragmentSource::Cpu ? "requested" : "OpenGL rasterizer not available in this build";
  return cpu_fragment_producer(sb.view());
}

}  // namespace cdsm
