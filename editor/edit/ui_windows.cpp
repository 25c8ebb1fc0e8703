// The editor's windows around the viewport: stats with the frame-time
// graph, a pixel's alpha(z) plot, the map viewer and the error view.
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
  ImGui::Text("memory: index %.2f MiB, nodes %.2f MiB, tags %.2f MiB, slack %.2f MiB, blocker pyramids %.2f MiB",
              double(st.memory.index_bytes) / 1048576.0, double(st.memory.node_bytes) / 1048576.0,
              double(st.memory.tag_bytes) / 1048576.0, double(st.memory.slack_bytes) / 1048576.0,
              double(st.memory.pyramid_bytes) / 1048576.0);
  if (ImGui::BeginTable("maps", 5, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingStretchProp)) {
    ImGui::TableSetupColumn("map");
    ImGui::TableSetupColumn("texels");
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
      // Its resolution, and with auto resolution why and the density reached.
      ImGui::Text("%d^2", m.res);
      if (k < st.map_resolutions.size() && st.map_resolutions[k].limit != "fixed" && ImGui::IsItemHovered()) {
        const MapResolutionStats& r = st.map_resolutions[k];
        ImGui::SetTooltip("auto: %s; %.2f texels per pixel (5th percentile %.2f) over %u sampled receivers",
                          r.limit.c_str(), r.texels_per_pixel_median, r.texels_per_pixel_p5, r.receivers);
      }
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
  for (size_t li = 0; li < st.clusters.size(); ++li) {
    if (!st.clusters[li].clustered && !st.clusters[li].fallback_reason.empty())
      ImGui::TextWrapped("light %zu unclustered: %s", li, st.clusters[li].fallback_reason.c_str());
    const std::string count = cluster_count_text(st.clusters[li]);
    if (!count.empty()) ImGui::TextWrapped("light %zu %s", li, count.c_str());
  }
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

}  // namespace cdsm::editor
