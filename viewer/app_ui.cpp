// icube-view: the Dear ImGui panels and the recorded-path preview; see app.h.
#include "app.h"

#include <imgui.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>

namespace icube::viewer {

namespace {

bool contains_nocase(const std::string& hay, const char* needle) {
  if (!needle[0]) return true;
  std::string h = hay, n = needle;
  for (char& c : h) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (char& c : n) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return h.find(n) != std::string::npos;
}

}  // namespace

void App::ui() {
  if (!show_ui) {
    if (show_path) draw_paths();
    return;
  }
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(340, 0), ImGuiCond_FirstUseEver);
  ImGui::Begin("icube-view");
  view_panel();
  world_panel();
  chunk_panel();
  drive_panel();
  teleport_panel();
  record_panel();
  ImGui::TextDisabled("WASD/arrows drive or fly, Tab drive/fly, RMB look, Q/E down/up, 1-5 modes, G Gaussians, T play "
                      "time, F1 panels, Esc quit");
  ImGui::End();
  if (show_path) draw_paths();
}

void App::view_panel() {
  if (!ImGui::CollapsingHeader("View", ImGuiTreeNodeFlags_DefaultOpen)) return;
  ImGui::Text("%.1f fps  %.1f ms  (%s)", last_frame_ms > 0 ? 1000.0 / last_frame_ms : 0.0, last_frame_ms,
              presenter.present_mode_name());
  std::vector<float> g(frame_graph.begin(), frame_graph.end());
  ImGui::PlotLines("##ft", g.data(), static_cast<int>(g.size()), 0, "frame ms", 0.0f, 100.0f, ImVec2(0, 50));
  ImGui::Text("render %ux%u of %ux%u", view_width(), view_height(), presenter.extent().width,
              presenter.extent().height);
  if (gauss && have_world) {
    int v = show_gaussians ? 1 : 0;
    ImGui::RadioButton("voxels", &v, 0);
    ImGui::SameLine();
    ImGui::RadioButton("Gaussians (G)", &v, 1);
    show_gaussians = v == 1;
  }
  if (gaussian_mode()) {
    gaussian_panel();
    return;
  }
  int mode = static_cast<int>(shade.mode);
  if (ImGui::Combo("mode", &mode, kRenderModeNames, static_cast<int>(std::size(kRenderModeNames))))
    shade.mode = static_cast<RenderMode>(mode);
  float s = static_cast<float>(scale);
  if (ImGui::SliderFloat("res scale", &s, 0.25f, 1.0f)) scale = eff_scale = s;
  ImGui::Checkbox("adaptive while moving", &adaptive);
  float fog = static_cast<float>(shade.fog_density * 1000.0);
  if (ImGui::SliderFloat("fog /km", &fog, 0.0f, 20.0f)) shade.fog_density = double(fog) / 1000.0;
  if (shade.mode == RenderMode::Shaded) {
    ImGui::Checkbox("sun shadows", &shade.shadows);
    ImGui::SliderInt("AO rays", &shade.ao_samples, 0, 16);
    if (shade.ao_samples > 0) {
      float r = static_cast<float>(shade.ao_radius), k = static_cast<float>(shade.ao_strength);
      if (ImGui::SliderFloat("AO radius m", &r, 0.2f, 4.0f)) shade.ao_radius = r;
      if (ImGui::SliderFloat("AO strength", &k, 0.0f, 1.0f)) shade.ao_strength = k;
    }
  }
  ImGui::Checkbox("path preview", &show_path);
  if (!gauss) ImGui::TextDisabled("Gaussians: open a package (icube-view PACKAGE)");
}

// The Gaussian view's figures and its level of detail (gaussian_view.h).
void App::gaussian_panel() {
  const GaussianViewStats& gs = gauss->stats();
  ImGui::Text("%zu static Gaussians, %zu chunks, %zu objects", gs.static_gaussians, gs.chunks, gs.objects);
  ImGui::Text("drawn %zu (%s): chunks %zu fine, %zu coarse, %zu out", gs.drawn,
              gs.detail == GaussianDetail::Moving ? "moving" : gs.detail == GaussianDetail::Still ? "still" : "whole",
              gs.chunks_fine, gs.chunks_coarse, gs.chunks_out);
  ImGui::Text("draw %.1f ms, %llu tile instances, assembly %.1f ms; %zu drawn, %zu reused", gs.render_ms,
              static_cast<unsigned long long>(gs.timings.instances), gs.assemble_ms, gs.renders, gs.reused);
  float s = static_cast<float>(scale);
  if (ImGui::SliderFloat("res scale", &s, 0.25f, 1.0f)) scale = eff_scale = s;
  ImGui::Checkbox("adaptive while moving", &adaptive);
  GaussianViewOptions& o = gauss->options();
  auto distance = [](const char* label, double& v, float hi) {
    float f = static_cast<float>(v);
    if (ImGui::SliderFloat(label, &f, 0.0f, hi, f == 0.0f ? "off" : "%.0f m")) v = f;
  };
  distance("moving: fine within", o.moving.coarse_distance, 100.0f);
  distance("moving: cut beyond", o.moving.max_distance, 400.0f);
  distance("still: fine within", o.still.coarse_distance, 200.0f);
  distance("still: cut beyond", o.still.max_distance, 400.0f);
  ImGui::Checkbox("path preview", &show_path);
}

void App::world_panel() {
  if (!ImGui::CollapsingHeader("World and scene", ImGuiTreeNodeFlags_DefaultOpen)) return;
  ImGui::TextWrapped("world: %s", world_name.c_str());
  if (have_world) {
    const world::IjkBounds& b = grid_bounds;
    ImGui::Text("%llu voxels, %zu bricks", static_cast<unsigned long long>(grid.voxel_count()), grid.brick_count());
    ImGui::Text("extent %.0f x %.0f x %.0f m, %zu chunks", (b.max.x - b.min.x + 1) * grid.voxel_size(),
                (b.max.y - b.min.y + 1) * grid.voxel_size(), (b.max.z - b.min.z + 1) * grid.voxel_size(),
                chunk_targets.size());
  }
  if (scene) {
    ImGui::TextWrapped("scene: %s (%s)", scene->provenance.scenario_id.c_str(), scene->provenance.source_format.c_str());
    ImGui::Text("%zu tracks, %zu ego poses, %zu lanes", scene->tracks.size(), scene->ego.size(), scene->map.lanes.size());
  }
  if (gauss) ImGui::TextWrapped("Gaussians: %s", gauss->source().c_str());
  if (timeline_frames() > 0) {
    ImGui::SliderInt("time", &time_index, 0, timeline_frames() - 1);
    ImGui::Checkbox("play cars (10 Hz)", &play_time);
  }
}

void App::drive_panel() {
  if (!ImGui::CollapsingHeader("Drive", ImGuiTreeNodeFlags_DefaultOpen)) return;
  int c = static_cast<int>(control);
  ImGui::RadioButton("drive", &c, 0);
  ImGui::SameLine();
  ImGui::RadioButton("fly", &c, 1);
  ImGui::SameLine();
  ImGui::RadioButton("replay", &c, 2);
  control = static_cast<Control>(c);
  if (control == Control::Drive) {
    ImGui::Checkbox("chase camera (C)", &chase);
    const double kmh = std::fabs(car.speed) * 3.6;
    ImGui::Text("%5.1f km/h %s", kmh, car.reversing ? "R" : "D");
    ImGui::ProgressBar(static_cast<float>(kmh / (limits.max_speed * 3.6)), ImVec2(-1, 0), "");
    ImGui::Text("steer %+.1f deg  pitch %+.1f deg", car.steer * 180 / kPi, car.pitch * 180 / kPi);
    if (ImGui::Checkbox("always zero height (Z)", &ground.zero_height)) ground.zero_z = car.position.z;
    if (!autopilot.path.empty()) ImGui::Checkbox("autopilot (ego track)", &autopilot_on);
  }
  const glm::dvec3 p = glm::dvec3(view_pose()[3]);
  ImGui::Text("camera %.1f %.1f %.1f m", p.x, p.y, p.z);
}

// Chunk status: the residency radius, what is on the GPU, the slice stalls; each tile resident or not.
void App::chunk_panel() {
  if (!residency || !ImGui::CollapsingHeader("Chunks")) return;
  const ResidencyStats& st = residency->stats();
  if (residency->radius() > 0.0)
    ImGui::Text("resident within %.0f m: %zu of %zu bricks%s", residency->radius(), st.resident_bricks,
                grid.brick_count(), residency->pending() ? " (loading)" : "");
  else
    ImGui::Text("all %zu bricks resident (--resident-radius 0)", grid.brick_count());
  ImGui::Text("changes %zu in %zu slices, slice last %.1f ms, max %.1f ms, background %.0f ms", st.swaps, st.steps,
              st.last_upload_ms, st.max_upload_ms, st.last_build_ms);
  std::optional<std::string> go;
  if (ImGui::BeginListBox("##chunks", ImVec2(-1, 120))) {
    for (const auto& [k, bricks] : residency->index().tiles()) {
      const std::string label = "chunk (" + std::to_string(k.first) + ", " + std::to_string(k.second) + ")";
      const bool res = residency->resident(k);
      ImGui::PushStyleColor(ImGuiCol_Text, res ? IM_COL32(120, 230, 120, 255) : IM_COL32(150, 150, 150, 255));
      if (ImGui::Selectable((label + (res ? "  resident  " : "  -  ") + std::to_string(bricks.size()) + " bricks").c_str()))
        go = label;
      ImGui::PopStyleColor();
    }
    ImGui::EndListBox();
  }
  if (go)
    for (const TeleportTarget& t : chunk_targets)
      if (t.label == *go) teleport_to(t);
}

// Teleport: the ego start, the world centre, and a filtered list of map features and chunks.
void App::teleport_panel() {
  if (!ImGui::CollapsingHeader("Teleport")) return;
  if (scene && ImGui::Button("ego track start")) teleport("ego");
  if (scene) ImGui::SameLine();
  if (ImGui::Button("world centre")) teleport("origin");
  ImGui::InputTextWithHint("##filter", "search: lane 12, crosswalk, chunk (0", teleport_filter, sizeof teleport_filter);
  std::optional<TeleportTarget> go;
  if (ImGui::BeginListBox("##targets", ImVec2(-1, 160))) {
    int shown = 0;
    for (const std::vector<TeleportTarget>* list : {&map_targets, &chunk_targets})
      for (const TeleportTarget& t : *list) {
        if (!contains_nocase(t.label, teleport_filter) || shown >= 500) continue;
        ++shown;
        ImGui::PushID(shown);
        if (ImGui::Selectable(t.label.c_str(), false)) go = t;
        ImGui::PopID();
      }
    ImGui::EndListBox();
  }
  ImGui::TextDisabled("%zu map features, %zu chunks", map_targets.size(), chunk_targets.size());
  if (go) teleport_to(*go);
}

void App::record_panel() {
  if (!ImGui::CollapsingHeader("Record", ImGuiTreeNodeFlags_DefaultOpen)) return;
  if (ImGui::Button(recorder.continuous() ? "stop 10 Hz (R)" : "record 10 Hz (R)")) toggle_continuous();
  ImGui::SameLine();
  if (ImGui::Button("keyframe (K)")) keyframe();
  ImGui::SameLine();
  if (ImGui::Button("end pass (P)")) end_pass();
  ImGui::Text("current %zu poses, %zu pass(es)", recorder.current().size(), recorder.passes().size());
  ImGui::InputInt("frames", &interp_frames);
  interp_frames = std::clamp(interp_frames, 2, 10000);
  ImGui::InputText("out", out_path, sizeof out_path);
  if (ImGui::Button("save .npy + .json")) save("");
  ImGui::SameLine();
  if (ImGui::Button("clear")) recorder.clear();
  ImGui::InputText("load", load_path, sizeof load_path);
  if (ImGui::Button("load + replay")) load_recording(load_path);
  if (!replay.empty()) {
    ImGui::SameLine();
    ImGui::SliderInt("pass", &replay_pass, 0, static_cast<int>(replay.size()) - 1);
  }
  ImGui::InputText("png", shot_path, sizeof shot_path);
  if (ImGui::Button("screenshot (F12)")) request_screenshot("");
  if (!status.empty()) ImGui::TextWrapped("%s", status.c_str());
}

// Recorded passes (and the current one) projected into the view.
void App::draw_paths() {
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  const VkExtent2D ext = presenter.extent();
  const render::Camera cam = view_camera(ext.width, ext.height);
  const glm::dmat4 w2c = glm::inverse(cam.c2w);
  auto draw = [&](const Pass& p, ImU32 color, bool dots) {
    std::optional<ImVec2> prev;
    for (const glm::dmat4& m : p) {
      const glm::dvec3 x = glm::dvec3(w2c * glm::dvec4(glm::dvec3(m[3]) - glm::dvec3(0, 0, 1.5), 1.0));
      if (x.z < 0.5) {
        prev.reset();
        continue;
      }
      const ImVec2 q(static_cast<float>(cam.K.fx * x.x / x.z + cam.K.cx), static_cast<float>(cam.K.fy * x.y / x.z + cam.K.cy));
      if (prev) dl->AddLine(*prev, q, color, 2.0f);
      if (dots) dl->AddCircleFilled(q, 2.5f, color);
      prev = q;
    }
  };
  for (const Pass& p : recorder.passes()) draw(p, IM_COL32(255, 80, 40, 255), false);
  draw(recorder.current(), IM_COL32(255, 230, 0, 255), true);
  if (control != Control::Replay)
    for (const Pass& p : replay) draw(p, IM_COL32(60, 200, 255, 255), false);
}

}  // namespace icube::viewer
