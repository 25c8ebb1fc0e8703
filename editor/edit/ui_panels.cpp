// The editor's left column: shadow settings, lights, objects (with a
// volume's transfer function over its histogram) and views; and the
// widgets the UI shares.
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "ui_parts.h"

namespace cdsm::editor {
namespace {

const char* receiver_names[] = {"receiver plane", "slope bias (baseline)"};

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

}  // namespace

bool color_edit(const char* label, Vec3& c) {
  float v[3] = {c.x, c.y, c.z};
  if (!ImGui::ColorEdit3(label, v, ImGuiColorEditFlags_Float)) return false;
  c = {v[0], v[1], v[2]};
  return true;
}

bool drag3(const char* label, Vec3& v, float speed, float lo, float hi) {
  float a[3] = {v.x, v.y, v.z};
  if (!ImGui::DragFloat3(label, a, speed, lo, hi, "%.3f")) return false;
  v = {a[0], a[1], a[2]};
  return true;
}

void shadows_panel(Session& s) {
  ShadowSettings next = s.scene().shadows;
  bool changed = false;
  bool exact = next.epsilon == 0.0f;
  if (exact) next.epsilon = 1e-4f;
  ImGui::BeginDisabled(exact);
  changed |= field_slider("epsilon", next, &ShadowSettings::epsilon, 1e-4f, 0.5f, "%.4f", ImGuiSliderFlags_Logarithmic);
  if (exact) next.epsilon = 0.0f;
  ImGui::EndDisabled();
  ImGui::SameLine();
  if (ImGui::Checkbox("0", &exact)) {
    next.epsilon = exact ? 0.0f : 0.01f;
    changed = true;
  }
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("epsilon exactly 0: every sample a node");
  static const int resolutions[] = {kAutoResolution, 64, 128, 256, 512, 1024, 2048};
  int ri = 4;
  for (int i = 0; i < 7; ++i)
    if (resolutions[i] == next.resolution) ri = i;
  const char* res_names[] = {"auto", "64", "128", "256", "512", "1024", "2048"};
  if (ImGui::Combo("resolution", &ri, res_names, 7)) {
    next.resolution = resolutions[ri];
    changed = true;
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("auto: each map sized from the screen (the Stats window's map list shows what it chose)");
  if (next.auto_resolution()) {
    changed |= field_slider("texels per pixel", next, &ShadowSettings::texels_per_pixel, 0.25f, 4.0f, "%.2f",
                            ImGuiSliderFlags_Logarithmic);
    changed |= field_slider("max resolution", next, &ShadowSettings::max_resolution, 64, 4096);
  }
  bool auto_m = next.auto_clusters();
  if (ImGui::Checkbox("auto clusters", &auto_m)) {
    next.max_clusters = auto_m ? kAutoClusters : 1;
    changed = true;
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "per light, the fewest clusters whose maps reach the density (the Stats window shows the counts "
        "tried)");
  if (auto_m)
    changed |= field_slider("max clusters", next, &ShadowSettings::cluster_limit, 1, kMaxMapsPerLight);
  else
    changed |= field_slider("clusters m", next, &ShadowSettings::max_clusters, 1, kMaxMapsPerLight);
  changed |= field_slider("d0", next, &ShadowSettings::d0, 0.0f, 1.0f, "%.3f");
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
  changed |= field_slider("penumbra taps", next, &ShadowSettings::penumbra_taps, 5, 32);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("filter taps across a penumbra: the soft lookup costs about its square; fewer band wide ones");
  changed |= field_slider("bias constant", next, &ShadowSettings::bias_constant, 0.0f, 0.01f, "%.5f");
  changed |= field_slider("bias slope", next, &ShadowSettings::bias_slope, 0.0f, 2.0f, "%.3f");
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
  if (ImGui::Combo("type", &type, TagNames<LightType>::names, int(tag_count<LightType>()))) {
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
    changed |= field_slider("angular diameter", next, &Light::angular_diameter_deg, 0.0f, 10.0f, "%.2f deg");
  } else {
    changed |= drag3("position", next.position, 0.02f);
    changed |= field_slider("radius", next, &Light::radius, 0.0f, 2.0f, "%.3f");  // a sphere light: soft shadows
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("the light's size: penumbrae estimated from the maps (0: a point)");
  }
  if (next.type == LightType::Spot) {
    if (drag3("direction", next.direction, 0.01f, -1.0f, 1.0f)) {
      if (length(next.direction) > 1e-4f) next.direction = normalize(next.direction);
      changed = true;
    }
    changed |= field_slider("outer cone", next, &Light::outer_cone_deg, 1.0f, 89.5f, "%.1f deg");
    changed |= field_slider("inner cone", next, &Light::inner_cone_deg, 0.0f, next.outer_cone_deg, "%.1f deg");
  }
  changed |= color_edit("colour", next.color);
  changed |= field_slider("intensity", next, &Light::intensity, 0.0f, 10.0f, "%.2f");
  if (changed) s.apply(set_light(s.document(), size_t(li), next), now_seconds());
  if (ImGui::Button("remove light")) {
    s.apply(remove_light(s.document(), size_t(li)), now_seconds());
    s.selected_light = -1;
  }
  if (next.type != LightType::Directional) ImGui::TextDisabled("shift + drag in the viewport moves it");
}

// The transfer function over a histogram of the grid's values.
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
  surf |= field_slider("opacity", m, &SurfaceMaterial::opacity, 0.0f, 1.0f, "%.3f");
  surf |= color_edit("transmission", m.transmission_color);
  m.transmission_color = vmin(vmax(m.transmission_color, vec3(0.0f)), vec3(1.0f));
  surf |= field_slider("specular", m, &SurfaceMaterial::specular, 0.0f, 1.0f, "%.2f");
  surf |= field_slider("shininess", m, &SurfaceMaterial::shininess, 1.0f, 200.0f, "%.0f");
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

}  // namespace cdsm::editor
