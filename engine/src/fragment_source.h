// Chooses the fragment producer of a frame: the OpenGL rasterizer when a
// context can be created (and the build has GL), else the CPU ray caster.
#pragma once

#include <memory>
#include <string>

#include "cdsm/renderer.h"
#include "cpu/frame.h"

namespace cdsm {

class FragmentSourceSelector {
 public:
  FragmentSourceSelector();
  ~FragmentSourceSelector();
  // Returns the producer for `sb` (uploading its triangles to GL when GL is
  // used); `name` is "gl" or "cpu", `reason` says why.
  FragmentProducer select(FragmentSource want, const SceneBuffers& sb, std::string& name,
                          std::string& reason);

 private:
  struct Gl;
  std::unique_ptr<Gl> gl_;
  bool gl_tried_ = false;
  std::string gl_failure_;
};

}  // namespace cdsm
