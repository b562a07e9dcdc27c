// icube-view: the frame loop; see app.h.
#include "app.h"

#include "scene/frames.h"

#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_vulkan.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace icube::viewer {

int App::run() {
  using clock = std::chrono::steady_clock;
  auto last = clock::now();
  int frame = 0;
  bool sliced_prev = false;  // the frame before this one applied a residency slice
  while (!glfwWindowShouldClose(window) && !quit) {
    glfwPollEvents();
    const auto now = clock::now();
    const double wall_dt = std::chrono::duration<double>(now - last).count();
    last = now;
    if (frame > 0) {
      last_frame_ms = wall_dt * 1000.0;
      avg_ms = 0.8 * avg_ms + 0.2 * last_frame_ms;
      if (frame > 3) stats.add(last_frame_ms);
      frame_graph.push_back(static_cast<float>(last_frame_ms));
      if (frame_graph.size() > 240) frame_graph.pop_front();
    }
    const double dt = scripted ? kScriptDt : std::min(wall_dt, 0.1);
    if (script)
      for (const ScriptEvent& e : script->due(sim_time)) run_event(e);
    shortcuts();
    simulate(dt);
    sim_time += dt;
    if (opt.autopilot && !script && autopilot.finished && std::fabs(car.speed) < 0.05) finish_autopilot();
    if (script && script->done() && !screenshot_pending) quit = true;
    if (scripted && sim_time > opt.max_seconds) {
      std::fprintf(stderr, "icube-view: error: the session passed --max-seconds %.0f\n", opt.max_seconds);
      ++failures;
      quit = true;
    }
    const auto t_res = clock::now();
    const size_t steps_before = residency ? residency->stats().steps : 0;
    update_residency();
    const bool sliced = residency && residency->stats().steps != steps_before;
    const auto t_cars = clock::now();
    update_cars();
    adapt_resolution();

    const auto t_wait = clock::now();
    if (!presenter.begin_frame()) continue;
    const auto t_begun = clock::now();
    ImGui_ImplVulkan_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    ui();
    ImGui::Render();
    const auto t_ui = clock::now();
    const VkExtent2D ext = presenter.extent();
    const uint32_t w = std::max(1u, static_cast<uint32_t>(std::lround(ext.width * eff_scale)));
    const uint32_t h = std::max(1u, static_cast<uint32_t>(std::lround(ext.height * eff_scale)));
    if (gaussian_mode()) {
      const glm::dmat4 pose = view_pose();
      if (pose != last_view_pose || time_index != last_view_time) view_changed_at = sim_time;
      last_view_pose = pose;
      last_view_time = time_index;
      last_cam = view_camera(w, h);
      // Drawn now (two waited submissions: the rasterizer reads its instance count back), converted to
      // RGBA8 in the frame's command list; an unchanged view is not drawn again.
      const GaussianDetail detail = gaussian_detail();
      const glm::dmat4 own = scene::box_to_world(own_car_box());
      const glm::dmat4* own_car = own_car_visible() ? &own : nullptr;
      if (gauss->draw(last_cam, static_cast<size_t>(std::max(0, time_index)), detail, own_car) && frame > 3) {
        const GaussianViewStats& gs = gauss->stats();
        (detail == GaussianDetail::Moving ? parts.splat_moving : parts.splat_still).add(gs.render_ms);
        parts.splat_drawn.add(double(gs.drawn));
        parts.splat_assemble.add(gs.assemble_ms);
      }
      gauss->record_present(presenter.cmd());
    } else if (have_world) {
      last_cam = view_camera(w, h);
      renderer.record(presenter.cmd(), gpu_world().world(), last_cam, shade);
    }
    const auto t_submit = clock::now();
    const gpu::Buffer* shown = view_rgba();
    presenter.end_frame(shown, shown ? view_width() : 0, shown ? view_height() : 0, ImGui::GetDrawData());
    if (frame > 3) {
      auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
      parts.sim.add(ms(now, t_res));
      parts.scale.add(eff_scale);
      parts.residency.add(ms(t_res, t_cars));
      parts.cars.add(ms(t_cars, t_wait));
      parts.ui.add(ms(t_begun, t_ui));
      parts.record.add(ms(t_ui, t_submit));
      const PresentTimes& pt = presenter.times();
      parts.fence.add(pt.fence_wait);
      parts.acquire.add(pt.acquire);
      parts.submit.add(pt.submit);
      parts.present.add(pt.present);
      if (pt.valid) {  // the previous frame's
        (sliced_prev ? parts.gpu_compute_sliced : parts.gpu_compute).add(pt.gpu_compute);
        parts.gpu_copy.add(pt.gpu_copy);
        parts.gpu_ui.add(pt.gpu_ui);
      }
    }
    sliced_prev = sliced;
    if (screenshot_pending && view_rgba()) take_screenshot();
    screenshot_pending = false;
    ++frame;
    if (opt.frames > 0 && frame >= opt.frames) break;
  }
  presenter.wait();
  return failures;
}

std::string App::FrameParts::gaussian_summary() const {
  if (splat_moving.ms.empty() && splat_still.ms.empty()) return "";
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "; Gaussian views drawn: %zu moving (p50 %.1f ms), %zu still (p50 %.1f ms); per drawn view p50: %.0f "
                "Gaussians, assembly %.2f ms",
                splat_moving.ms.size(), splat_moving.percentile(50), splat_still.ms.size(), splat_still.percentile(50),
                splat_drawn.percentile(50), splat_assemble.percentile(50));
  return buf;
}

std::string App::FrameParts::summary() const {
  char buf[768];
  std::snprintf(buf, sizeof buf,
                "host: sim %.2f, residency %.2f, cars %.2f, ui %.2f, record %.2f; presenter: wait %.2f, acquire %.2f, "
                "submit %.2f, present %.2f; device: compute %.2f, copy %.2f, ui %.2f; render scale p10/p50/p90 "
                "%.2f/%.2f/%.2f%s",
                sim.percentile(50), residency.percentile(50), cars.percentile(50), ui.percentile(50),
                record.percentile(50), fence.percentile(50), acquire.percentile(50), submit.percentile(50),
                present.percentile(50), gpu_compute.percentile(50), gpu_copy.percentile(50), gpu_ui.percentile(50),
                scale.percentile(10), scale.percentile(50), scale.percentile(90), gaussian_summary().c_str());
  return buf;
}

}  // namespace icube::viewer
