#include "fragment_source.h"

#include "cdsm/error.h"

#if CDSM_HAVE_GL
#include "gl/context.h"
#include "gl/fragment_raster.h"
#endif

namespace cdsm {

#if CDSM_HAVE_GL
// One headless context and rasterizer per selector, made on first use and
// kept across frames (pools are reused); the scene is re-uploaded only when
// its triangles change.
struct FragmentSourceSelector::Gl {
  std::unique_ptr<gl::Context> context;
  std::unique_ptr<gl::FragmentRasterizer> raster;
};
#else
struct FragmentSourceSelector::Gl {};
#endif

FragmentSourceSelector::FragmentSourceSelector() = default;
FragmentSourceSelector::~FragmentSourceSelector() = default;

FragmentProducer FragmentSourceSelector::select(FragmentSource want, const SceneBuffers& sb,
                                                std::string& name, std::string& reason) {
  if (want == FragmentSource::Cpu) {
    name = "cpu";
    reason = "requested (exact ray casting)";
    return cpu_fragment_producer(sb.view());
  }
#if CDSM_HAVE_GL
  if (!gl_tried_) {
    gl_tried_ = true;
    std::string why;
    auto ctx = gl::create_headless_context({}, &why);
    if (ctx) {
      gl_ = std::make_unique<Gl>();
      gl_->context = std::move(ctx);
      gl_->raster = std::make_unique<gl::FragmentRasterizer>(*gl_->context);
    } else {
      gl_failure_ = why.empty() ? "no OpenGL 4.5 context" : why;
    }
  }
  if (gl_) {
    // select() is called once per compiled scene: upload its triangles.
    gl_->raster->upload_scene({sb.tri_vertices.data(), sb.tri_vertices.size()},
                              {sb.tri_object.data(), sb.tri_object.size()}, {sb.objects.data(), sb.objects.size()});
    name = "gl";
    reason = (want == FragmentSource::Gl ? "requested, " : "default when a context exists, ") +
             gl_->context->description();
    gl::FragmentRasterizer* r = gl_->raster.get();
    return [r](const PinholeView& view, ObjectMask mask, FragmentBuffers& out) { r->rasterize(view, mask, out); };
  }
  if (want == FragmentSource::Gl) throw Error("--fragments gl", "no OpenGL context: " + gl_failure_);
  name = "cpu";
  reason = "no OpenGL context (" + gl_failure_ + "), using the CPU ray caster";
  return cpu_fragment_producer(sb.view());
#else
  if (want == FragmentSource::Gl) throw Error("--fragments gl", "this build has no OpenGL (configured with CDSM_GL=OFF)");
  name = "cpu";
  reason = "built without OpenGL (CDSM_GL=OFF)";
  return cpu_fragment_producer(sb.view());
#endif
}

}  // namespace cdsm
