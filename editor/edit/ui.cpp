#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>

#include "ui.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace cdsm::editor {
namespace {

constexpr float kLeftWidth = 340.0f;
constexpr float kRightWidth = 320.0f;
constexpr float kStatusHeight = 24.0f;

ImTextureID texture_id(GLuint t) { return reinterpret_cast<ImTextureID>(static_cast<uintptr_t>(t)); }

std::string config_dir() {
  if (const char* x = std::getenv("XDG_CONFIG_HOME"); x && *x) return std::string(x) + "/cdsm";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.config/cdsm";
  return "";
}

bool color_edit(const char* label, Vec3& c) {
  float v[3] = {c.x, c.y, c.z};
  if (!ImGui::ColorEdit3(label, v, ImGuiColorEditFlags_Float)) return false;
  c = {v[0], v[1], v[2]};
  return true;
}

bool drag3(const char* label, Vec3& v, float speed, float lo = 0.0f, float hi = 0.0f) {
  float a[3] = {v.x, v.y, v.z};
  if (!ImGui::DragFloat3(label, a, speed, lo, hi, "%.3f")) return false;
  v = {a[0], a[1], a[2]};
  return true;
}

const char* receiver_names[] = {"receiver plane", "slope bias (baseline)"};

void shadows_panel(Session& s) {
  ShadowSettings next = s.scene().shadows;
  bool changed = false;
  bool exact = next.epsilon == 0.0f;
  float eps = exact ? 1e-4f : next.epsilon;
  ImGui::BeginDisabled(exact);
  if (ImGui::SliderFloat("epsilon", &eps, 1e-4f, 0.5f, "%.4f", ImGuiSliderFlags_Logarithmic)) {
    next.epsilon = eps;
    changed = true;
  }
  ImGui::EndDisabled();
  ImGui::SameLine();
  if (ImGui::Checkbox("0", &exact)) {
    next.epsilon = exact ? 0.0f : 0.01f;
    changed = true;
  }
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("epsilon exactly 0: every sample a node");
  static const int resolutions[] = {64, 128, 256, 512, 1024, 2048};
  int ri = 3;
  for (int i = 0; i < 6; ++i)
    if (resolutions[i] == next.resolution) ri = i;
  const char* res_names[] = {"64", "128", "256", "512", "1024", "2048"};
  if (ImGui::Combo("resolution", &ri, res_names, 6)) {
    next.resolution = resolutions[ri];
    changed = true;
  }
  changed |= ImGui::SliderInt("clusters m", &next.max_clusters, 1, 8);
  changed |= ImGui::SliderFloat("d0", &next.d0, 0.0f, 1.0f, "%.3f");
  int layout = int(next.layout);
  if (ImGui::Combo("layout", &layout, TagNames<DsmLayout>::names, int(tag_count<DsmLayout>()))) {
    next.layout = DsmLayout(layout);
    changed = true;
  }
  changed |= ImGui::Checkbox("bilinear filtering", &next.filtering);
  int receiver = int(next.receiver);
  if (ImGui::Combo("receivers", &receiver, receiver_names, 2)) {
    next.receiver = ReceiverLookup(receiver);
    changed = true;
  }
  int penumbra = int(next.penumbra);
  if (ImGui::Combo("penumbra", &penumbra, TagNames<Penumbra>::names, int(tag_count<Penumbra>()))) {
    next.penumbra = Penumbra(penumbra);
    changed = true;
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "lights with a radius (or the sun's angular diameter): blockers estimated from the maps,\n"
        "a fixed-kernel PCF (baseline), or hard shadows");
  changed |= ImGui::SliderFloat("bias constant", &next.bias_constant, 0.0f, 0.01f, "%.5f");
  changed |= ImGui::SliderFloat("bias slope", &next.bias_slope, 0.0f, 2.0f, "%.3f");
  changed |= color_edit("ambient light", next.ambient_light);
  if (changed) s.apply(set_settings(s.document(), next), now_seconds());
}

void lights_panel(Session& s) {
  if (ImGui::Button("add spot")) {
    Light l;
    l.name = "spot " + std::to_string(s.scene().lights.size());
    l.position = s.orbit().target + Vec3{0, 3, 0};
    l.direction = {0, -1, 0};
    s.apply(add_light(s.document(), l), now_seconds());
  }
  ImGui::SameLine();
  if (ImGui::Button("add omni")) {
    Light l;
    l.name = "omni " + std::to_string(s.scene().lights.size());
    l.type = LightType::Point;
    l.position = s.orbit().target + Vec3{0, 2, 0};
    s.apply(add_light(s.document(), l), now_seconds());
  }
  ImGui::SameLine();
  if (ImGui::Button("add sun")) {  // 35 degrees above the horizon
    Light l;
    l.name = "sun " + std::to_string(s.scene().lights.size());
    l.type = LightType::Directional;
    const float e = 35.0f * 3.14159265f / 180.0f;
    l.direction = normalize(Vec3{-std::cos(e) * 0.6f, -std::sin(e), -std::cos(e) * 0.8f});
    l.angular_diameter_deg = 0.53f;
    s.apply(add_light(s.document(), l), now_seconds());
  }
  for (size_t i = 0; i < s.scene().lights.size(); ++i) {
    const Light& l = s.scene().lights[i];
    const std::string label = (l.name.empty() ? "light " + std::to_string(i) : l.name) + "##light" + std::to_string(i);
    if (ImGui::Selectable(label.c_str(), s.selected_light == int(i))) s.selected_light = int(i);
  }
  const int li = s.selected_light;
  if (li < 0 || size_t(li) >= s.scene().lights.size()) return;
  Light next = s.scene().lights[size_t(li)];
  bool changed = false;
  int type = int(next.type);
  const char* types[] = {"spot", "omni", "sun"};
  if (ImGui::Combo("type", &type, types, 3)) {
    next.type = LightType(type);
    if (next.type == LightType::Directional && !(length(next.direction) > 0.0f)) next.direction = {0, -1, 0};
    changed = true;
  }
  if (next.type == LightType::Directional) {
    // Aim by the sun's elevation above the horizon and its azimuth (the
    // light travels toward -elevation).
    const Vec3 d = length(next.direction) > 0.0f ? normalize(next.direction) : Vec3{0, -1, 0};
    float elevation = std::asin(std::clamp(-d.y, -1.0f, 1.0f)) * 180.0f / 3.14159265f;
    float azimuth = std::atan2(-d.x, -d.z) * 180.0f / 3.14159265f;
    bool aimed = ImGui::SliderFloat("elevation", &elevation, 1.0f, 90.0f, "%.1f deg");
    aimed |= ImGui::SliderFloat("azimuth", &azimuth, -180.0f, 180.0f, "%.1f deg");
    if (aimed) {
      const float e = elevation * 3.14159265f / 180.0f, a = azimuth * 3.14159265f / 180.0f;
      next.direction = Vec3{-std::cos(e) * std::sin(a), -std::sin(e), -std::cos(e) * std::cos(a)};
      changed = true;
    }
    changed |= ImGui::SliderFloat("angular diameter", &next.angular_diameter_deg, 0.0f, 10.0f, "%.2f deg");
  } else {
    changed |= drag3("position", next.position, 0.02f);
    changed |= ImGui::SliderFloat("radius", &next.radius, 0.0f, 2.0f, "%.3f");  // a sphere light: soft shadows
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("the light's size: penumbrae estimated from the maps (0: a point)");
  }
  if (next.type == LightType::Spot) {
    if (drag3("direction", next.direction, 0.01f, -1.0f, 1.0f)) {
      if (length(next.direction) > 1e-4f) next.direction = normalize(next.direction);
      changed = true;
    }
    changed |= ImGui::SliderFloat("outer cone", &next.outer_cone_deg, 1.0f, 89.5f, "%.1f deg");
    changed |= ImGui::SliderFloat("inner cone", &next.inner_cone_deg, 0.0f, next.outer_cone_deg, "%.1f deg");
  }
  changed |= color_edit("colour", next.color);
  changed |= ImGui::SliderFloat("intensity", &next.intensity, 0.0f, 10.0f, "%.2f");
  if (changed) s.apply(set_light(s.document(), size_t(li), next), now_seconds());
  if (ImGui::Button("remove light")) {
    s.apply(remove_light(s.document(), size_t(li)), now_seconds());
    s.selected_light = -1;
  }
  if (next.type != LightType::Directional) ImGui::TextDisabled("shift + drag in the viewport moves it");
}

// The transfer function over a histogram of the grid's values.
void transfer_editor(Session& s, size_t vi) {
  const Volume& v = s.scene().volumes[vi];
  if (v.grid) {
    static std::vector<float> hist;
    static const DenseGrid* hist_of = nullptr;
    static float lo = 0, hi = 1;
    if (hist_of != v.grid.get()) {
      hist_of = v.grid.get();
      hist.assign(64, 0.0f);
      lo = 1e30f;
      hi = -1e30f;
      for (float x : v.grid->values) lo = std::min(lo, x), hi = std::max(hi, x);
      if (!(hi > lo)) hi = lo + 1.0f;
      for (float x : v.grid->values) hist[size_t(std::min(63.0f, (x - lo) / (hi - lo) * 64.0f))] += 1.0f;
      for (float& h : hist) h = std::log1p(h);
    }
    const ImVec2 at = ImGui::GetCursorScreenPos();
    const ImVec2 size(ImGui::GetContentRegionAvail().x, 80.0f);
    ImGui::PlotHistogram("##hist", hist.data(), int(hist.size()), 0, nullptr, 0.0f, FLT_MAX, size);
    // The extinction curve (channel mean) over it, and the control points.
    float emax = 1e-6f;
    for (const TransferPoint& p : v.transfer) emax = std::max(emax, max_channel(p.extinction));
    ImDrawList* dl = ImGui::GetWindowDrawList();
    auto to_screen = [&](float d, float e) {
      return ImVec2(at.x + (d - lo) / (hi - lo) * size.x, at.y + size.y - e / emax * (size.y - 4.0f) - 2.0f);
    };
    // Each point can be dragged on the histogram: right / left moves its
    // density (between its neighbours), up / down its extinction (all
    // channels in proportion, as the extinction field does).
    std::vector<TransferPoint> dragged = v.transfer;
    bool moved = false;
    const ImVec2 after = ImGui::GetCursorScreenPos();
    for (size_t i = 0; i < dragged.size(); ++i) {
      const ImVec2 p = to_screen(dragged[i].density, max_channel(dragged[i].extinction));
      ImGui::SetCursorScreenPos(ImVec2(p.x - 6.0f, p.y - 6.0f));
      ImGui::PushID(int(1000 + i));
      ImGui::InvisibleButton("##point", ImVec2(12.0f, 12.0f));
      const bool hot = ImGui::IsItemActive() || ImGui::IsItemHovered();
      if (ImGui::IsItemActive()) {
        const ImVec2 d = ImGui::GetIO().MouseDelta;
        if (d.x != 0.0f || d.y != 0.0f) {
          dragged = drag_transfer_point(dragged, i, d.x / size.x * (hi - lo), -d.y / (size.y - 4.0f) * emax);
          moved = true;
        }
      }
      ImGui::PopID();
      if (i > 0)
        dl->AddLine(to_screen(v.transfer[i - 1].density, max_channel(v.transfer[i - 1].extinction)), p,
                    IM_COL32(255, 160, 40, 255), 2.0f);
      dl->AddCircleFilled(p, hot ? 6.0f : 4.0f, IM_COL32(255, 220, 80, 255));
    }
    ImGui::SetCursorScreenPos(after);
    ImGui::Text("values %.3g .. %.3g (log histogram; drag the points)", lo, hi);
    if (moved) {
      s.apply(set_transfer(s.document(), vi, dragged), now_seconds());
      return;
    }
  }
  std::vector<TransferPoint> next = v.transfer;
  bool changed = false;
  for (size_t i = 0; i < next.size(); ++i) {
    ImGui::PushID(int(i));
    const float dmin = i > 0 ? next[i - 1].density : -1e6f, dmax = i + 1 < next.size() ? next[i + 1].density : 1e6f;
    ImGui::SetNextItemWidth(80);
    changed |= ImGui::DragFloat("density", &next[i].density, 0.005f, dmin, dmax, "%.3f");
    ImGui::SameLine();
    ImGui::SetNextItemWidth(80);
    float e = max_channel(next[i].extinction);
    if (ImGui::DragFloat("extinction", &e, 0.1f, 0.0f, 1e4f, "%.2f")) {
      const float old = max_channel(next[i].extinction);
      next[i].extinction = old > 0.0f ? next[i].extinction * (e / old) : vec3(e);
      changed = true;
    }
    ImGui::SameLine();
    changed |= color_edit("##c", next[i].color);
    ImGui::PopID();
  }
  if (ImGui::Button("add point") && next.size() < 16) {
    TransferPoint p = next.back();
    p.density += 0.1f;
    next.push_back(p);
    changed = true;
  }
  ImGui::SameLine();
  if (ImGui::Button("remove last") && next.size() > 1) {
    next.pop_back();
    changed = true;
  }
  if (changed) s.apply(set_transfer(s.document(), vi, next), now_seconds());
}

void objects_panel(Session& s) {
  const Scene& scene = s.scene();
  if (ImGui::BeginListBox("##objects", ImVec2(-1, 120))) {
    for (size_t i = 0; i < scene.objects.size(); ++i) {
      const std::string label =
          (scene.objects[i].name.empty() ? "object " + std::to_string(i) : scene.objects[i].name) + "##obj" +
          std::to_string(i);
      if (ImGui::Selectable(label.c_str(), s.selected_object == int(i))) s.selected_object = int(i);
    }
    ImGui::EndListBox();
  }
  const int oi = s.selected_object;
  if (oi < 0 || size_t(oi) >= scene.objects.size()) {
    ImGui::TextDisabled("click an object in the viewport or the list");
    return;
  }
  const Object& o = scene.objects[size_t(oi)];
  // The angles the panel showed last stay (a matrix has several TRS forms).
  static Trs shown;
  static int shown_for = -1;
  Trs trs = shown_for == oi ? decompose(o.transform, shown) : decompose(o.transform);
  bool moved = drag3("translate", trs.translate, 0.01f);
  moved |= drag3("rotate", trs.rotate_deg, 0.5f);
  moved |= drag3("scale", trs.scale, 0.01f);
  if (moved && trs.scale.x != 0.0f && trs.scale.y != 0.0f && trs.scale.z != 0.0f)
    s.apply(set_transform(s.document(), size_t(oi), compose(trs)), now_seconds());
  shown = trs;
  shown_for = oi;
  SurfaceMaterial m = o.surface;
  bool surf = color_edit("colour", m.color);
  surf |= ImGui::SliderFloat("opacity", &m.opacity, 0.0f, 1.0f, "%.3f");
  surf |= color_edit("transmission", m.transmission_color);
  m.transmission_color = vmin(vmax(m.transmission_color, vec3(0.0f)), vec3(1.0f));
  surf |= ImGui::SliderFloat("specular", &m.specular, 0.0f, 1.0f, "%.2f");
  surf |= ImGui::SliderFloat("shininess", &m.shininess, 1.0f, 200.0f, "%.0f");
  if (surf) s.apply(set_surface(s.document(), size_t(oi), m), now_seconds());
  bool casts = o.casts_shadows;
  if (ImGui::Checkbox("casts shadows", &casts))
    s.apply(set_casts_shadows(s.document(), size_t(oi), casts), now_seconds());
  int kind = int(o.interior);
  const char* kinds[] = {"none", "constant medium", "volume"};
  const bool has_volume = o.volume >= 0 && size_t(o.volume) < scene.volumes.size();
  if (ImGui::Combo("interior", &kind, kinds, has_volume ? 3 : 2)) {
    Vec3 sigma = o.sigma;
    if (kind == 1 && max_channel(sigma) <= 0.0f) sigma = vec3(1.0f);
    s.apply(set_interior(s.document(), size_t(oi), InteriorKind(kind), sigma, o.volume), now_seconds());
  }
  if (o.interior == InteriorKind::Constant) {
    Vec3 sigma = o.sigma;
    if (drag3("sigma", sigma, 0.05f, 0.0f, 1e4f))
      s.apply(set_interior(s.document(), size_t(oi), InteriorKind::Constant, sigma, o.volume), now_seconds());
  }
  if (o.interior == InteriorKind::Volume && has_volume) {
    ImGui::Separator();
    ImGui::Text("transfer function");
    transfer_editor(s, size_t(o.volume));
  }
}

void views_panel(Session& s, UiState& ui) {
  bool clusters = s.tint == Tint::Clusters;
  if (ImGui::Checkbox("objects coloured by cluster", &clusters)) s.tint = clusters ? Tint::Clusters : Tint::None;
  if (s.scene().lights.size() > 1) ImGui::SliderInt("of light", &s.tint_light, 0, int(s.scene().lights.size()) - 1);
  ImGui::Checkbox("map frusta", &s.show_frusta);
  ImGui::Checkbox("map viewer", &ui.show_map);
  ImGui::Checkbox("alpha(z) of a clicked pixel", &ui.show_plot);
  ImGui::Checkbox("error against the reference", &ui.show_error);
  ImGui::Checkbox("stats", &ui.show_stats);
}

void menu_bar(Session& s, UiState& ui) {
  if (!ImGui::BeginMainMenuBar()) return;
  if (ImGui::BeginMenu("File")) {
    if (ImGui::MenuItem("Open...")) ui.pending_path_action = "open", ui.path_field = s.document().path;
    if (ImGui::MenuItem("Save", nullptr, false, !s.document().path.empty())) {
      std::string why;
      if (!s.save(s.document().path, false, &why))
        ui.confirm_overwrite = true;
      else
        ui.status = "saved " + s.document().path;
    }
    if (ImGui::MenuItem("Save as..."))
      ui.pending_path_action = "save_as", ui.path_field = s.document().path + ".edited.json";
    if (ImGui::MenuItem("Screenshot...")) ui.pending_path_action = "screenshot", ui.path_field = "cdsm-edit.png";
    if (ImGui::BeginMenu("Recent", !ui.recent.empty())) {
      for (const std::string& r : ui.recent)
        if (ImGui::MenuItem(r.c_str())) {
          try {
            s.open(r);
            remember_recent(ui.recent, r);
            ui.status = "opened " + r;
          } catch (const std::exception& e) {
            ui.status = e.what();
          }
        }
      ImGui::EndMenu();
    }
    if (ImGui::MenuItem("Quit")) ui.quit = true;
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Edit")) {
    if (ImGui::MenuItem("Undo", "Ctrl+Z", false, s.history().can_undo())) s.undo();
    if (ImGui::MenuItem("Redo", "Ctrl+Y", false, s.history().can_redo())) s.redo();
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("View")) {
    if (ImGui::MenuItem("Frame scene", "F")) s.frame_scene();
    ImGui::EndMenu();
  }
  ImGui::EndMainMenuBar();

  if (!ui.pending_path_action.empty()) ImGui::OpenPopup("path");
  if (ImGui::BeginPopupModal("path", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::Text("%s", ui.pending_path_action == "open"      ? "Open scene (JSON, glTF, GLB):"
                      : ui.pending_path_action == "save_as" ? "Save as JSON:"
                                                            : "Screenshot PNG:");
    char buf[1024];
    std::snprintf(buf, sizeof buf, "%s", ui.path_field.c_str());
    if (ImGui::InputText("##path", buf, sizeof buf)) ui.path_field = buf;
    if (ImGui::Button("OK")) {
      try {
        if (ui.pending_path_action == "open") {
          s.open(ui.path_field);
          remember_recent(ui.recent, ui.path_field);
          ui.status = "opened " + ui.path_field;
        } else if (ui.pending_path_action == "save_as") {
          std::string why;
          if (s.save(ui.path_field, false, &why))
            ui.status = "saved " + ui.path_field;
          else
            ui.status = why;
        } else {
          ui.screenshot_request = ui.path_field;
        }
      } catch (const std::exception& e) {
        ui.status = e.what();
      }
      ui.pending_path_action.clear();
      ImGui::CloseCurrentPopup();
    }
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) {
      ui.pending_path_action.clear();
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }
  if (ui.confirm_overwrite) ImGui::OpenPopup("overwrite");
  if (ImGui::BeginPopupModal("overwrite", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::Text("Overwrite the opened file\n%s ?", s.document().path.c_str());
    if (ImGui::Button("Overwrite")) {
      std::string why;
      ui.status = s.save(s.document().path, true, &why) ? "saved " + s.document().path : why;
      ui.confirm_overwrite = false;
      ImGui::CloseCurrentPopup();
    }
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) {
      ui.confirm_overwrite = false;
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }
}

void stats_window(Session& s, UiState& ui, float x, float y, float h) {
  ImGui::SetNextWindowPos(ImVec2(x, y));
  ImGui::SetNextWindowSize(ImVec2(kRightWidth, h));
  ImGui::Begin("Stats", &ui.show_stats,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  const FrameStats& st = s.build_stats();
  ImGui::Text("viewport %.1f ms (volume light grids %.1f ms), last map build %.0f ms", s.last_draw_ms(),
              s.last_light_grid_ms(), s.last_build_ms());
  std::vector<float> ft(s.frame_ms().begin(), s.frame_ms().end());
  if (!ft.empty())
    ImGui::PlotLines("##frames", ft.data(), int(ft.size()), 0, "frame ms", 0.0f, FLT_MAX, ImVec2(-1, 50));
  if (s.building()) {
    const ShadowSystem::BuildProgress p = s.progress();
    ImGui::ProgressBar(p.to_build ? float(p.built) / float(p.to_build) : 0.0f, ImVec2(-1, 0), "building maps");
  }
  ImGui::Text("fragments %.1f ms | DSM build %.1f ms | clusters %.1f ms", st.times.fragments_ms, st.times.dsm_build_ms,
              st.cluster_ms);
  ImGui::Text("maps rebuilt %u (%u from kept fragment lists, %.1f MiB kept), reused %u", st.maps_rebuilt,
              st.update.fragment_lists_reused, double(st.update.fragment_cache_bytes) / 1048576.0, st.maps_reused);
  for (const MapRebuild& r : st.update.rebuilds)
    ImGui::BulletText("light %u map %u: %s", r.light, r.map, to_string(r.reason));
  ImGui::Text("nodes/texel avg %.2f, max %u", st.memory.avg_nodes_per_texel, st.memory.max_nodes_per_texel);
  ImGui::Text("memory: index %.2f MiB, nodes %.2f MiB, tags %.2f MiB, slack %.2f MiB",
              double(st.memory.index_bytes) / 1048576.0, double(st.memory.node_bytes) / 1048576.0,
              double(st.memory.tag_bytes) / 1048576.0, double(st.memory.slack_bytes) / 1048576.0);
  if (ImGui::BeginTable("maps", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingStretchProp)) {
    ImGui::TableSetupColumn("map");
    ImGui::TableSetupColumn("nodes");
    ImGui::TableSetupColumn("KiB idx/nod/slk");
    ImGui::TableSetupColumn("objects");
    ImGui::TableHeadersRow();
    for (size_t k = 0; k < s.maps().size(); ++k) {
      const ShadowSystem::MapInfo& m = s.maps()[k];
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextColored(ImVec4(Session::cluster_color(m.slot).x, Session::cluster_color(m.slot).y,
                                Session::cluster_color(m.slot).z, 1.0f),
                         "L%d/%d%s", m.light, m.slot, m.rgb ? " rgb" : "");
      ImGui::TableNextColumn();
      ImGui::Text("%llu (max %u)", (unsigned long long)m.nodes, m.max_nodes);
      ImGui::TableNextColumn();
      ImGui::Text("%.0f/%.0f/%.0f", double(m.index_bytes) / 1024.0, double(m.node_bytes) / 1024.0,
                  double(m.slack_bytes) / 1024.0);
      ImGui::TableNextColumn();
      std::string names;
      for (int o : m.members)
        if (size_t(o) < s.scene().objects.size())
          names += (names.empty() ? "" : ", ") +
                   (s.scene().objects[size_t(o)].name.empty() ? std::to_string(o) : s.scene().objects[size_t(o)].name);
      ImGui::TextWrapped("%s", names.c_str());
    }
    ImGui::EndTable();
  }
  for (size_t li = 0; li < st.clusters.size(); ++li)
    if (!st.clusters[li].clustered && !st.clusters[li].fallback_reason.empty())
      ImGui::TextWrapped("light %zu unclustered: %s", li, st.clusters[li].fallback_reason.c_str());
  for (const std::string& n : s.notes()) ImGui::TextWrapped("note: %s", n.c_str());
  ImGui::End();
}

void plot_window(Session& s, UiState& ui) {
  // Floating views sit in the viewport's corners, apart from each other.
  const Rect& v = ui.viewport;
  ImGui::SetNextWindowSize(ImVec2(std::min(460.0f, float(v.w) - 20.0f), 280), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowPos(ImVec2(float(v.x) + 10, float(v.y) + 10), ImGuiCond_FirstUseEver);
  ImGui::Begin("alpha(z) of the clicked pixel", &ui.show_plot);
  const ShadowSystem::TexelInspection& t = s.inspection();
  if (s.scene().lights.size() > 1) ImGui::SliderInt("light", &s.inspect_light, 0, int(s.scene().lights.size()) - 1);
  if (s.inspection_pending()) {
    ImGui::Text("waiting for the maps...");
  } else if (!t.found) {
    ImGui::TextWrapped("%s", t.why.empty() ? "click a surface in the viewport" : t.why.c_str());
  } else {
    ImGui::Text("map %d (light %d, slot %d), texel (%d, %d): %zu nodes, %zu samples at eps 0", t.map, t.light, t.slot,
                t.tx, t.ty, t.nodes.size(), t.exact.size());
    ImGui::Text("max deviation %.5f (epsilon %.4f)", t.max_deviation, t.epsilon);
    if (t.receiver) {
      const float a = (t.received.x + t.received.y + t.received.z) / 3.0f;
      if (t.own_node >= 0)
        ImGui::Text("the surface reads alpha %.4f: its own step (blue ring) left out", a);
      else
        ImGui::Text("the surface reads alpha %.4f at its plane (no step of its own here)", a);
    }
    const ImVec2 at = ImGui::GetCursorScreenPos();
    const ImVec2 size(ImGui::GetContentRegionAvail().x, std::max(ImGui::GetContentRegionAvail().y - 4.0f, 80.0f));
    ImDrawList* dl = ImGui::GetWindowDrawList();
    dl->AddRectFilled(at, ImVec2(at.x + size.x, at.y + size.y), IM_COL32(20, 22, 28, 255));
    float z0 = 1e30f, z1 = -1e30f, top = 0.05f;
    auto grey = [](const Vec3& a) { return (a.x + a.y + a.z) / 3.0f; };
    for (const auto& v : {&t.exact, &t.nodes})
      for (const ShadowSystem::AlphaSample& a : *v) {
        z0 = std::min(z0, a.z);
        z1 = std::max(z1, a.z);
        top = std::max(top, grey(a.alpha) * 1.1f);
      }
    z0 = std::min(z0, t.depth);
    z1 = std::max(z1, t.depth);
    if (!(z1 > z0)) z1 = z0 + 1.0f;
    top = std::min(top, 1.0f);
    auto pt = [&](float z, float a) {
      return ImVec2(at.x + (z - z0) / (z1 - z0) * size.x, at.y + size.y - a / top * (size.y - 8.0f) - 4.0f);
    };
    // The stored nodes (orange, with markers), the epsilon-0 ray over them (white).
    for (size_t i = 0; i < t.nodes.size(); ++i) {
      const ImVec2 p = pt(t.nodes[i].z, grey(t.nodes[i].alpha));
      if (i > 0) dl->AddLine(pt(t.nodes[i - 1].z, grey(t.nodes[i - 1].alpha)), p, IM_COL32(255, 150, 30, 255), 3.0f);
      dl->AddCircleFilled(p, 3.5f, IM_COL32(255, 200, 60, 255));
      if (int(i) == t.own_node) dl->AddCircle(p, 7.0f, IM_COL32(90, 160, 255, 255), 0, 2.0f);
    }
    for (size_t i = 1; i < t.exact.size(); ++i)
      dl->AddLine(pt(t.exact[i - 1].z, grey(t.exact[i - 1].alpha)), pt(t.exact[i].z, grey(t.exact[i].alpha)),
                  IM_COL32(235, 235, 235, 255), 1.0f);
    dl->AddLine(pt(t.depth, 0.0f), pt(t.depth, top), IM_COL32(90, 160, 255, 200), 1.0f);
    if (t.receiver) {  // what the surface reads: a blue mark at its plane's depth on the texel's ray
      const float a = (t.received.x + t.received.y + t.received.z) / 3.0f;
      dl->AddCircleFilled(pt(t.receiver_depth, a), 4.0f, IM_COL32(90, 160, 255, 255));
    }
    char axis[96];
    std::snprintf(axis, sizeof axis, "alpha 0 .. %.3g   z %.3g .. %.3g (blue: the point)", top, z0, z1);
    dl->AddText(ImVec2(at.x + 4, at.y + 2), IM_COL32(160, 160, 170, 255), axis);
    ImGui::Dummy(size);
  }
  ImGui::End();
}

void map_window(Session& s, UiState& ui) {
  const Rect& v = ui.viewport;
  ImGui::SetNextWindowSize(ImVec2(300, 360), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowPos(ImVec2(float(v.x) + 10, float(v.y + v.h) - 370), ImGuiCond_FirstUseEver);
  ImGui::Begin("Map viewer", &ui.show_map);
  const auto& maps = s.maps();
  if (maps.empty()) {
    ImGui::Text("no maps yet");
    ImGui::End();
    return;
  }
  if (s.map_view < 0) s.map_view = 0;
  std::string current = "light " + std::to_string(maps[size_t(s.map_view)].light) + " map " +
                        std::to_string(maps[size_t(s.map_view)].slot);
  if (ImGui::BeginCombo("map", current.c_str())) {
    for (size_t k = 0; k < maps.size(); ++k) {
      const std::string l =
          "light " + std::to_string(maps[k].light) + " map " + std::to_string(maps[k].slot) + "##m" + std::to_string(k);
      if (ImGui::Selectable(l.c_str(), int(k) == s.map_view)) s.map_view = int(k);
    }
    ImGui::EndCombo();
  }
  int kind = int(s.map_view_kind);
  ImGui::RadioButton("nodes per texel", &kind, 0);
  ImGui::SameLine();
  ImGui::RadioButton("transmittance at depth", &kind, 1);
  s.map_view_kind = MapView(kind);
  if (s.map_view_kind == MapView::AlphaAtDepth) ImGui::SliderFloat("depth", &s.map_view_depth, 0.0f, 1.0f, "%.3f");
  const GLuint tex = s.map_texture();
  if (tex) {
    const float side = std::min(ImGui::GetContentRegionAvail().x, ImGui::GetContentRegionAvail().y);
    ImGui::Image(texture_id(tex), ImVec2(side, side));
  }
  ImGui::End();
}

void error_window(Session& s, UiState& ui) {
  const Rect& v = ui.viewport;
  ImGui::SetNextWindowSize(ImVec2(400, 440), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowPos(ImVec2(float(v.x + v.w) - 410, float(v.y + v.h) - 450), ImGuiCond_FirstUseEver);
  ImGui::Begin("Error against the reference", &ui.show_error);
  ErrorView& e = s.error_view();
  ImGui::SliderInt("width", &ui.error_width, 64, 480);
  if (!e.running) {
    if (ImGui::Button("compute")) s.start_error_view(ui.error_width);
  } else {
    ImGui::ProgressBar(e.progress ? e.progress->fraction.load() : 0.0f, ImVec2(-80, 0), "reference");
    ImGui::SameLine();
    if (ImGui::Button("cancel")) s.cancel_error_view();
  }
  if (!e.message.empty()) ImGui::TextWrapped("%s", e.message.c_str());
  if (e.ready && !e.running) {
    const TransmittanceError& t = e.error;
    ImGui::Text("image PSNR %.2f dB (%.1f s)", e.image.psnr, e.seconds);
    ImGui::Text("map error    mean %.4f p99 %.4f max %.4f", t.map.mean, t.map.p99, t.map.max);
    ImGui::Text("resolution   mean %.4f p99 %.4f max %.4f", t.resolution.mean, t.resolution.p99, t.resolution.max);
    ImGui::Text("total        mean %.4f p99 %.4f max %.4f", t.total.mean, t.total.p99, t.total.max);
    ImGui::Text("edge points %.1f%%: total p99 %.4f; interior p99 %.4f", 100.0 * t.edge.share, t.edge.total.p99,
                t.interior.total.p99);
    static GLuint heat = 0;
    static const void* uploaded = nullptr;
    if (uploaded != e.heatmap.rgb.data()) {
      if (heat) glDeleteTextures(1, &heat);
      glCreateTextures(GL_TEXTURE_2D, 1, &heat);
      glTextureStorage2D(heat, 1, GL_RGB32F, e.heatmap.width, e.heatmap.height);
      glTextureSubImage2D(heat, 0, 0, 0, e.heatmap.width, e.heatmap.height, GL_RGB, GL_FLOAT, e.heatmap.rgb.data());
      uploaded = e.heatmap.rgb.data();
    }
    const float w = ImGui::GetContentRegionAvail().x;
    ImGui::Image(texture_id(heat), ImVec2(w, w * float(e.heatmap.height) / float(std::max(e.heatmap.width, 1))));
    ImGui::TextDisabled("|DSM - reference| per pixel, full scale 0.1 (sRGB)");
  }
  ImGui::End();
}

}  // namespace

std::vector<std::string> load_recent() {
  std::vector<std::string> r;
  const std::string dir = config_dir();
  if (dir.empty()) return r;
  std::ifstream f(dir + "/recent");
  for (std::string line; std::getline(f, line) && r.size() < 10;)
    if (!line.empty()) r.push_back(line);
  return r;
}

void remember_recent(std::vector<std::string>& recent, const std::string& path) {
  recent.erase(std::remove(recent.begin(), recent.end(), path), recent.end());
  recent.insert(recent.begin(), path);
  if (recent.size() > 10) recent.resize(10);
  const std::string dir = config_dir();
  if (dir.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return;  // no place for the list: it stays this session's
  std::ofstream f(dir + "/recent");
  for (const std::string& r : recent) f << r << "\n";
}

void draw_ui(Session& s, UiState& ui, int width, int height) {
  menu_bar(s, ui);
  const float top = ImGui::GetFrameHeight();
  const float h = float(height) - top - kStatusHeight;
  // Left: the editing panels.
  ImGui::SetNextWindowPos(ImVec2(0, top));
  ImGui::SetNextWindowSize(ImVec2(kLeftWidth, h));
  ImGui::Begin("Scene", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  if (ImGui::CollapsingHeader("Shadows", ImGuiTreeNodeFlags_DefaultOpen)) shadows_panel(s);
  if (ImGui::CollapsingHeader("Lights", ImGuiTreeNodeFlags_DefaultOpen)) lights_panel(s);
  if (ImGui::CollapsingHeader("Objects", ImGuiTreeNodeFlags_DefaultOpen)) objects_panel(s);
  if (ImGui::CollapsingHeader("Views", ImGuiTreeNodeFlags_DefaultOpen)) views_panel(s, ui);
  ImGui::End();
  // Right: stats.
  const float right = ui.show_stats ? kRightWidth : 0.0f;
  if (ui.show_stats) stats_window(s, ui, float(width) - kRightWidth, top, h);
  // Middle: the viewport (the renderer's colour texture, GL rows bottom first).
  ui.viewport = {int(kLeftWidth), int(top), std::max(int(float(width) - kLeftWidth - right), 16), std::max(int(h), 16)};
  ImGui::SetNextWindowPos(ImVec2(float(ui.viewport.x), float(ui.viewport.y)));
  ImGui::SetNextWindowSize(ImVec2(float(ui.viewport.w), float(ui.viewport.h)));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(0, 0));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowBorderSize, 0.0f);
  ImGui::Begin("Viewport", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoBringToFrontOnFocus |
                   ImGuiWindowFlags_NoScrollWithMouse);
  ImGui::Image(texture_id(s.renderer().display_texture()), ImVec2(float(ui.viewport.w), float(ui.viewport.h)),
               ImVec2(0, 1), ImVec2(1, 0));
  ui.viewport_hovered = ImGui::IsItemHovered();
  ImGui::End();
  ImGui::PopStyleVar(2);
  if (ui.show_plot) plot_window(s, ui);
  if (ui.show_map) map_window(s, ui);
  if (ui.show_error) error_window(s, ui);
  // Status line.
  ImGui::SetNextWindowPos(ImVec2(0, float(height) - kStatusHeight));
  ImGui::SetNextWindowSize(ImVec2(float(width), kStatusHeight));
  ImGui::Begin("status", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove);
  const ShadowSystem::BuildProgress p = s.progress();
  if (!s.refusal().empty()) ui.status = s.refusal();
  ImGui::Text("%s%s | %s | undo %zu | %s", s.document().path.c_str(), s.document().dirty ? " *" : "",
              s.building() ? ("building " + std::to_string(p.built) + "/" + std::to_string(p.to_build)).c_str()
                           : (s.refined() ? "refined" : "refining"),
              s.history().size(), ui.status.c_str());
  ImGui::End();
  ui.interacting = ImGui::IsAnyItemActive();
}

void handle_viewport_input(Session& s, UiState& ui) {
  ImGuiIO& io = ImGui::GetIO();
  static bool dragging = false;
  static ImVec2 press;
  const bool in_view = ui.viewport_hovered;
  bool moved = false;
  if (in_view && !io.WantTextInput) {
    if (io.MouseWheel != 0.0f) {
      s.orbit().zoom(io.MouseWheel);
      moved = true;
    }
    if (ImGui::IsMouseClicked(ImGuiMouseButton_Left) || ImGui::IsMouseClicked(ImGuiMouseButton_Middle) ||
        ImGui::IsMouseClicked(ImGuiMouseButton_Right)) {
      dragging = true;
      press = io.MousePos;
    }
    if (ImGui::IsKeyPressed(GLFW_KEY_F)) s.frame_scene();
  }
  if (!io.WantTextInput && io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_Z)) s.undo();
  if (!io.WantTextInput && io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_Y)) s.redo();
  if (dragging) {
    const ImVec2 d = io.MouseDelta;
    if (ImGui::IsMouseDown(ImGuiMouseButton_Left) && io.KeyShift && s.selected_light >= 0 &&
        size_t(s.selected_light) < s.scene().lights.size()) {
      // Move the selected light in the view plane.
      Light l = s.scene().lights[size_t(s.selected_light)];
      const Camera& c = s.scene().camera;
      const Vec3 f = normalize(c.target - c.position), r = normalize(cross(f, Vec3{0, 1, 0})), u = cross(r, f);
      const float per_px = 2.0f * length(l.position - c.position) *
                           std::tan(0.5f * c.fov_y_deg * 3.14159265f / 180.0f) / float(std::max(ui.viewport.h, 1));
      l.position = l.position + r * (d.x * per_px) - u * (d.y * per_px);
      if (d.x != 0.0f || d.y != 0.0f) s.apply(set_light(s.document(), size_t(s.selected_light), l), now_seconds());
    } else if (ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
      if (d.x != 0.0f || d.y != 0.0f) s.orbit().orbit(d.x, d.y), moved = true;
    } else if (ImGui::IsMouseDown(ImGuiMouseButton_Middle)) {
      if (d.x != 0.0f || d.y != 0.0f) s.orbit().pan(d.x, d.y, s.scene().camera.fov_y_deg, ui.viewport.h), moved = true;
    } else if (ImGui::IsMouseDown(ImGuiMouseButton_Right)) {
      // Fly: right button held, W/A/S/D/Q/E, speed by the distance.
      const float step = 0.02f * s.orbit().distance;
      Vec3 f{0, 0, 0};
      if (ImGui::IsKeyDown(GLFW_KEY_W)) f.z += step;
      if (ImGui::IsKeyDown(GLFW_KEY_S)) f.z -= step;
      if (ImGui::IsKeyDown(GLFW_KEY_D)) f.x += step;
      if (ImGui::IsKeyDown(GLFW_KEY_A)) f.x -= step;
      if (ImGui::IsKeyDown(GLFW_KEY_E)) f.y += step;
      if (ImGui::IsKeyDown(GLFW_KEY_Q)) f.y -= step;
      if (f.x != 0.0f || f.y != 0.0f || f.z != 0.0f) s.orbit().fly(f), moved = true;
      if (d.x != 0.0f || d.y != 0.0f) s.orbit().orbit(d.x, d.y), moved = true;
    } else {
      dragging = false;
      // A click (press and release in place): select and inspect.
      const float dx = io.MousePos.x - press.x, dy = io.MousePos.y - press.y;
      if (ImGui::IsMouseReleased(ImGuiMouseButton_Left) && dx * dx + dy * dy < 9.0f) {
        const forward::ForwardRenderer& r = s.renderer();
        const int x = int((io.MousePos.x - float(ui.viewport.x)) * float(r.width()) / float(ui.viewport.w));
        const int y = int((io.MousePos.y - float(ui.viewport.y)) * float(r.height()) / float(ui.viewport.h));
        s.click(x, y);
        ui.show_plot = true;
      }
    }
    ui.interacting = true;
  }
  if (moved) s.camera_changed();
}

}  // namespace cdsm::editor
