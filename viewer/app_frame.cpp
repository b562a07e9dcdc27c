// icube-view: the frame loop; see app.h.
#include "app.h"

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
    const auto t_host = clock::now();
    update_residency();
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
    const VkExtent2D ext = presenter.extent();
    const uint32_t w = std::max(1u, static_cast<uint32_t>(std::lround(ext.width * eff_scale)));
    const uint32_t h = std::max(1u, static_cast<uint32_t>(std::lround(ext.height * eff_scale)));
    if (have_world) {
      last_cam = view_camera(w, h);
      renderer.record(presenter.cmd(), gpu_world().world(), last_cam, shade);
    }
    const auto t_submit = clock::now();
    presenter.end_frame(have_world ? &renderer.rgba() : nullptr, have_world ? w : 0, have_world ? h : 0,
                        ImGui::GetDrawData());
    const auto t_end = clock::now();
    if (frame > 3) {
      auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
      wait_ms.add(ms(t_wait, t_begun));
      host_ms.add(ms(t_host, t_wait) + ms(t_begun, t_submit));
      present_ms.add(ms(t_submit, t_end));
    }
    if (screenshot_pending && have_world) take_screenshot();
    screenshot_pending = false;
    ++frame;
    if (opt.frames > 0 && frame >= opt.frames) break;
  }
  presenter.wait();
  return failures;
}

}  // namespace icube::viewer
