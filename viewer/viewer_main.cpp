// icube-view: the interactive viewer. Drive a car (or fly) through a semantic
// voxel world rendered by the compute ray caster, or through a package's
// Gaussians drawn by the splatting rasterizer, record camera trajectories
// for Stage 2, replay them. GLFW + Vulkan swapchain + Dear ImGui (presenter.h);
// the voxel view is shaders/raycast/cast.comp + shaders/view/shade.comp
// (view_renderer.h), the Gaussian view gaussian_view.h;
// the application state and its jobs: app.h; the car, recorder, teleport,
// scripts and checks are CPU code in icube_viewer_core.
//
//   icube-view world.icw [--scene scene.json]   a world (and its scene: ego track, cars, camera)
//   icube-view --scene scene.json               builds the scene's world with the procedural prior
//   icube-view OUTPUT_DIR                        a folder holding world.icw (+ scene.json)
//   icube-view PACKAGE                           an icube generate package: its Gaussians (G: voxels), world, scene
//   icube-view gaussians.ply|scene.json          Gaussians alone (fly)
//   --script FILE | --autopilot, --record-out, --screenshot-out, --stats, --frames N (smoke tests)
//   --verify FILE, --compare-semantic A B, --compare-rgb A B   window-less checks (options.h)
#include "app.h"
#include "options.h"

#include <imgui.h>
#include <imgui_impl_glfw.h>

#include <cstdio>
#include <stdexcept>

namespace icube::viewer {
namespace {

// GLFW, the window and Dear ImGui's GLFW backend, torn down in reverse order.
struct Window {
  GLFWwindow* window = nullptr;
  bool imgui = false;
  ~Window() {
    if (imgui) {
      ImGui_ImplGlfw_Shutdown();
      ImGui::DestroyContext();
    }
    if (window) glfwDestroyWindow(window);
    glfwTerminate();
  }
};

int run_window(const Options& o) {
  if (!glfwInit()) {
    std::fprintf(stderr, "icube-view: error: cannot initialise GLFW (no display? set DISPLAY or run under xvfb-run)\n");
    return 1;
  }
  Window win;
  if (!glfwVulkanSupported()) {
    std::fprintf(stderr, "icube-view: error: GLFW finds no Vulkan loader\n");
    return 1;
  }
  gpu::ContextOptions opts = gpu::ContextOptions::from_env();
  uint32_t count = 0;
  const char** exts = glfwGetRequiredInstanceExtensions(&count);
  opts.extra_instance_extensions.assign(exts, exts + count);
  opts.extra_device_extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  opts.headless = false;
  gpu::Context ctx(opts);

  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  win.window = glfwCreateWindow(o.width, o.height, "icube-view", nullptr, nullptr);
  if (!win.window) throw std::runtime_error("cannot create a window");
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForVulkan(win.window, true);
  win.imgui = true;

  int rc = 0;
  {
    App v(o, ctx, win.window);
    glfwSetWindowTitle(win.window, ("icube-view - " + ctx.info().name).c_str());
    v.load();
    if (!o.script.empty()) {
      v.script.emplace(load_script(o.script));
      v.scripted = true;
    }
    if (o.autopilot) {
      v.scripted = true;
      v.autopilot_on = !v.autopilot.path.empty();
      if (!v.autopilot_on) throw std::runtime_error("--autopilot needs a scene with an ego track (--scene)");
      if (o.script.empty()) v.recorder.start_continuous(0.0);
    }
    std::printf("icube-view: %s on %s, %dx%d, presentation %s\n", v.world_name.c_str(), ctx.info().name.c_str(),
                o.width, o.height, v.presenter.present_mode_name());
    rc = v.run() > 0 ? 1 : 0;
    if (ctx.validation_enabled() && ctx.message_count() > 0) {
      std::fprintf(stderr, "icube-view: error: %llu validation message(s)\n",
                   static_cast<unsigned long long>(ctx.message_count()));
      rc = 1;
    }
    if (o.stats) {
      std::printf("icube-view: stats %dx%d scale %.2f%s: %s\n", o.width, o.height, o.scale,
                  o.adaptive ? " adaptive" : "", v.stats.summary().c_str());
      std::printf("icube-view: frame parts (p50 ms): %s\n", v.parts.summary().c_str());
      if (v.residency && v.residency->radius() > 0.0) {
        const ResidencyStats& st = v.residency->stats();
        std::printf("icube-view: residency: %zu change(s) (the first at load), %zu slice(s) between frames, slowest %.1f ms on "
                    "the main thread; "
                    "device compute p50 %.1f ms in the %zu frames after a slice (occupancy masks rebuilt), %.1f ms in the others\n",
                    st.swaps, st.steps, st.max_upload_ms, v.parts.gpu_compute_sliced.percentile(50),
                    v.parts.gpu_compute_sliced.ms.size(), v.parts.gpu_compute.percentile(50));
      }
    }
  }
  return rc;
}

}  // namespace
}  // namespace icube::viewer

int main(int argc, char** argv) {
  using namespace icube::viewer;
  Options o;
  if (const int rc = parse_options(argc, argv, o); rc >= 0) return rc;
  if (!o.verify.empty()) return run_verify(o);
  if (!o.compare.empty()) return run_compare(o);
  if (!o.compare_rgb.empty()) return run_compare_rgb(o);
  try {
    return run_window(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-view: error: %s\n", e.what());
    return 1;
  }
}
