#define GL_GLEXT_PROTOTYPES 1
#include "script.h"
#include "script_commands.h"

#include "cdsm/error.h"
#include "cdsm/fields.h"

#include <GL/glcorearb.h>
#include <stb/stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <type_traits>
#include <fstream>
#include <sstream>

#include <sys/resource.h>

namespace cdsm::editor {
namespace {

void write_pfm(const Image& img, const std::string& path) {
  std::ofstream f(path, std::ios::binary);
  f << "PF\n" << img.width << " " << img.height << "\n-1.0\n";
  for (int y = img.height - 1; y >= 0; --y)
    f.write(reinterpret_cast<const char*>(img.rgb.data() + size_t(y) * img.width * 3), std::streamsize(img.width) * 12);
  if (!f) throw Error(path, "cannot write");
}

bool on_off(const std::string& v, const std::string& where) {
  if (v == "on" || v == "1" || v == "true") return true;
  if (v == "off" || v == "0" || v == "false") return false;
  throw Error(where, "expected on or off, got '" + v + "'");
}

// The field of S whose table key (cdsm/fields.h: the scene file's name) is
// `key`, read from the script's words as its type says — a number (an
// integer field takes an integer), three for a vector, on/off for a flag,
// a tag's name — and checked against the table's range. False when S has
// no field of that name.
template <class S>
bool read_field(S& s, const std::string& key, std::istream& in, const std::string& where) {
  bool found = false;
  for_each_field<S>([&](const auto& f) {
    if (found || key != f.key) return;
    found = true;
    using T = std::remove_cv_t<std::remove_reference_t<decltype(s.*f.member)>>;
    const auto number = [&] {
      double v;
      if (!(in >> v)) throw Error(where, key + ": expected a number");
      if (!(v >= f.lo && v <= f.hi))
        throw Error(where, key + " must lie within [" + format_number(f.lo) + ", " + format_number(f.hi) + "]");
      return v;
    };
    T& out = s.*f.member;
    if constexpr (std::is_same_v<T, bool>) {
      std::string w;
      in >> w;
      out = on_off(w, where);
    } else if constexpr (std::is_enum_v<T>) {
      std::string w;
      if (!(in >> w) || !parse_tag(w, out)) throw Error(where, key + ": expected " + tag_choices<T>());
    } else if constexpr (std::is_same_v<T, Vec3>) {
      const double x = number(), y = number(), z = number();
      out = Vec3{float(x), float(y), float(z)};
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (!(in >> out)) throw Error(where, key + ": expected a name");
    } else if constexpr (std::is_integral_v<T>) {
      if (zero_is_auto(f)) {  // `auto`, or a number
        std::string w;
        if (!(in >> w)) throw Error(where, key + ": expected an integer or auto");
        if (w == "auto") {
          out = T(0);
          return;
        }
        std::istringstream again(w);
        double v;
        if (!(again >> v) || !(v >= f.lo && v <= f.hi) || v != std::floor(v))
          throw Error(where, key + " must be an integer within [" + format_number(f.lo) + ", " + format_number(f.hi) +
                                 "] or auto, got '" + w + "'");
        out = T(v);
        return;
      }
      const double v = number();
      if (v != std::floor(v)) throw Error(where, key + " takes an integer");
      out = T(v);
    } else {
      out = T(number());
    }
  });
  return found;
}

}  // namespace

void write_window_png(const std::string& path, int width, int height) {
  std::vector<unsigned char> px(size_t(width) * height * 3), flipped(px.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, px.data());
  for (int y = 0; y < height; ++y)
    std::copy_n(px.data() + size_t(height - 1 - y) * width * 3, size_t(width) * 3,
                flipped.data() + size_t(y) * width * 3);
  if (!stbi_write_png(path.c_str(), width, height, 3, flipped.data(), width * 3))
    throw Error(path, "cannot write the screenshot");
}

namespace {
// CPU time of the whole process (every thread: the worker's, llvmpipe's).
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}
}  // namespace

ScriptRunner::ScriptRunner(const std::string& path) : file_(path) {
  std::ifstream f(path);
  if (!f) throw Error(path, "cannot open the script");
  for (std::string line; std::getline(f, line);) lines_.push_back(line);
}

bool ScriptRunner::step(Session& s, UiState& ui) {
  if (waiting_) {
    ++frames_waited_;
    bool done = false;
    if (waiting_for_ == "refined")
      done = s.refined();
    else if (waiting_for_ == "inspection")
      done = !s.inspection_pending() && s.refined();
    else if (waiting_for_ == "error")
      done = !s.error_view().running;
    if (!done) {
      if (frames_waited_ > 20000) throw Error(file_, "waited 20000 frames for " + waiting_for_);
      return true;
    }
    waiting_ = false;
    const double ms = (now_seconds() - changed_at_) * 1000.0;
    if (waiting_for_ == "refined") {
      const double cpu_ms = (cpu_seconds() - changed_cpu_) * 1000.0;
      const StageTimes& st = s.build_stats().times;
      std::printf(
          "  refined after %.0f ms (%d frames; last map build %.0f ms: fragments %.0f, light pass %.0f; viewport %.0f "
          "ms"
          " of which light grids %.0f ms; CPU %.0f ms, %.2f cores busy; maps rebuilt %u, viewport draws %llu)\n",
          ms, frames_waited_, s.last_build_ms(), st.fragments_ms, st.dsm_build_ms, s.last_draw_ms(),
          s.last_light_grid_ms(), cpu_ms, cpu_ms / std::max(ms, 1e-3), s.last_maps_rebuilt(),
          (unsigned long long)s.viewport_draws());
    } else if (waiting_for_ == "inspection") {
      const ShadowSystem::TexelInspection& t = s.inspection();
      if (t.found)
        std::printf("  inspected map %d texel (%d, %d): %zu nodes, %zu samples, max deviation %.5f (epsilon %.4f)\n",
                    t.map, t.tx, t.ty, t.nodes.size(), t.exact.size(), t.max_deviation, t.epsilon);
      else
        std::printf("  nothing inspected: %s\n", t.why.c_str());
    } else {
      const ErrorView& e = s.error_view();
      if (e.ready)
        std::printf("  error view: PSNR %.2f dB, map p99 %.4f, resolution p99 %.4f, total p99 %.4f (%.1f s)\n",
                    e.image.psnr, e.error.map.p99, e.error.resolution.p99, e.error.total.p99, e.seconds);
      else
        std::printf("  error view: %s\n", e.message.c_str());
    }
    std::fflush(stdout);
  }
  while (next_ < lines_.size()) {
    const size_t line_no = next_ + 1;
    const std::string line = lines_[next_++];
    std::istringstream in(line);
    std::string cmd;
    if (!(in >> cmd) || cmd[0] == '#') continue;
    const std::string where = file_ + ":" + std::to_string(line_no);
    std::printf("script: %s\n", line.c_str());
    std::fflush(stdout);
    if (!find_script_command(cmd))
      throw Error(where, "unknown command '" + cmd + "' (the commands: " + script_command_names() +
                             "; cdsm edit --script-help)");
    auto number = [&](const char* what) {
      double v;
      if (!(in >> v)) throw Error(where, std::string("expected a number (") + what + ")");
      return v;
    };
    auto word = [&](const char* what) {
      std::string w;
      if (!(in >> w)) throw Error(where, std::string("expected ") + what);
      return w;
    };
    const double now = now_seconds();
    if (cmd == "set") {
      const std::string field = word("a setting");
      ShadowSettings next = s.scene().shadows;
      if (!read_field(next, field, in, where)) throw Error(where, "unknown setting '" + field + "'");
      s.apply(set_settings(s.document(), next), now);
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
    } else if (cmd == "light") {
      const size_t li = size_t(number("light index"));
      if (li >= s.scene().lights.size()) throw Error(where, "no light " + std::to_string(li));
      Light l = s.scene().lights[li];
      const std::string field = word("a light field");
      if (field == "select") {  // its fields in the Lights panel
        s.selected_light = int(li);
        continue;
      }
      if (!read_field(l, field, in, where)) throw Error(where, "unknown light field '" + field + "'");
      s.apply(set_light(s.document(), li, l), now);
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
    } else if (cmd == "orbit") {
      const float yaw = float(number("yaw")), pitch = float(number("pitch"));
      s.orbit().orbit(-yaw / 0.3f, pitch / 0.3f);
      s.camera_changed();
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
    } else if (cmd == "zoom") {
      s.orbit().zoom(float(number("steps")));
      s.camera_changed();
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
    } else if (cmd == "frame") {
      s.frame_scene();
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
    } else if (cmd == "select") {
      const std::string name = word("an object");
      s.selected_object = -1;
      for (size_t i = 0; i < s.scene().objects.size(); ++i)
        if (s.scene().objects[i].name == name || std::to_string(i) == name) s.selected_object = int(i);
      if (s.selected_object < 0) throw Error(where, "no object '" + name + "'");
    } else if (cmd == "click") {
      const int x = int(number("x")), y = int(number("y"));
      s.click(x, y);
      ui.show_plot = true;
      std::printf("  picked object %d\n", s.selected_object);
      waiting_ = true;
      waiting_for_ = "inspection";
      frames_waited_ = 0;
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
      return true;
    } else if (cmd == "view") {
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
      const std::string what = word("clusters, map, plot or error");
      if (what == "clusters") {
        s.tint = on_off(word("on or off"), where) ? Tint::Clusters : Tint::None;
        double light;
        if (in >> light) s.tint_light = int(light);
      } else if (what == "map") {
        s.map_view = int(number("map index"));
        const std::string kind = word("nodes or alpha");
        s.map_view_kind = kind == "alpha" ? MapView::AlphaAtDepth : MapView::NodeCounts;
        double depth;
        if (in >> depth) s.map_view_depth = float(depth);
        ui.show_map = true;
      } else if (what == "plot") {
        ui.show_plot = on_off(word("on or off"), where);
      } else if (what == "error") {
        ui.show_error = true;
        ui.error_width = int(number("width"));
        s.start_error_view(ui.error_width);
        waiting_ = true;
        waiting_for_ = "error";
        frames_waited_ = 0;
        changed_at_ = now;
        changed_cpu_ = cpu_seconds();
        return true;
      } else {
        throw Error(where, "unknown view '" + what + "'");
      }
    } else if (cmd == "noop") {
      s.apply(set_settings(s.document(), s.scene().shadows), now);
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
    } else if (cmd == "undo") {
      if (!s.undo()) std::printf("  nothing to undo\n");
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
    } else if (cmd == "redo") {
      if (!s.redo()) std::printf("  nothing to redo\n");
      changed_at_ = now;
      changed_cpu_ = cpu_seconds();
    } else if (cmd == "wait") {
      waiting_ = true;
      waiting_for_ = "refined";
      frames_waited_ = 0;
      return true;
    } else if (cmd == "screenshot") {
      screenshot_ = word("a file");
      return true;  // taken after this frame is drawn
    } else if (cmd == "viewport") {
      const std::string file = word("a file");
      write_pfm(s.renderer().read_color(), file);
    } else if (cmd == "save") {
      const std::string file = word("a file");
      std::string flag;
      in >> flag;
      std::string why;
      if (!s.save(file, flag == "overwrite", &why)) {
        std::printf("  save refused: %s\n", why.c_str());
        ++failures_;
      } else {
        std::printf("  saved %s\n", file.c_str());
      }
    } else if (cmd == "quit") {
      next_ = lines_.size();
      return false;
    } else {
      CDSM_CHECK(false, "script command '" + cmd + "' is in kScriptCommands but script.cpp does not run it");
    }
  }
  return false;
}

void ScriptRunner::after_frame(Session& s, UiState& ui, int width, int height) {
  if (screenshot_.empty()) return;
  write_window_png(screenshot_, width, height);
  std::ofstream rect(screenshot_ + ".rect");
  rect << ui.viewport.x << " " << ui.viewport.y << " " << ui.viewport.w << " " << ui.viewport.h << "\n";
  std::printf("  wrote %s (%dx%d, viewport %d %d %d %d)\n", screenshot_.c_str(), width, height, ui.viewport.x,
              ui.viewport.y, ui.viewport.w, ui.viewport.h);
  std::fflush(stdout);
  screenshot_.clear();
  (void)s;
}

}  // namespace cdsm::editor
