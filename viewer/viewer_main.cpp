// icube-view: the interactive viewer (issue: drive through the voxel world).
//
// For now a window with a Vulkan surface on the engine's selected device: it
// proves that GLFW, the Vulkan loader and the device agree on presentation,
// and closes with Esc (or after --frames N, for smoke tests under Xvfb).
#include "gpu/context.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>

int main(int argc, char** argv) {
  CLI::App app{"InfiniCube-VK viewer (stub window; the ray-cast world view comes with the viewer issue)", "icube-view"};
  int frames = 0;
  app.add_option("--frames", frames, "Close after this many frames (0 = run until closed)");
  CLI11_PARSE(app, argc, argv);

  if (!glfwInit()) {
    std::fprintf(stderr, "icube-view: error: cannot initialise GLFW (no display? set DISPLAY or run under xvfb-run)\n");
    return 1;
  }
  if (!glfwVulkanSupported()) {
    std::fprintf(stderr, "icube-view: error: GLFW finds no Vulkan loader\n");
    glfwTerminate();
    return 1;
  }
  int rc = 0;
  try {
    icube::gpu::ContextOptions opts = icube::gpu::ContextOptions::from_env();
    uint32_t count = 0;
    const char** exts = glfwGetRequiredInstanceExtensions(&count);
    opts.extra_instance_extensions.assign(exts, exts + count);
    opts.headless = false;
    icube::gpu::Context ctx(opts);

    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    GLFWwindow* window = glfwCreateWindow(1280, 720, "icube-view", nullptr, nullptr);
    if (!window) throw std::runtime_error("cannot create a window");
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    VK_CHECK(glfwCreateWindowSurface(ctx.instance(), window, nullptr, &surface));
    VkBool32 present = VK_FALSE;
    VK_CHECK(vkGetPhysicalDeviceSurfaceSupportKHR(ctx.physical_device(), ctx.queue_family(), surface, &present));
    std::string title = "icube-view - " + ctx.info().name + (present ? "" : " (queue cannot present)");
    glfwSetWindowTitle(window, title.c_str());
    std::printf("icube-view: window open on %s, presentation %s\n", ctx.info().name.c_str(),
                present ? "supported" : "NOT supported");
    for (int frame = 0; !glfwWindowShouldClose(window) && (frames == 0 || frame < frames); ++frame) {
      glfwWaitEventsTimeout(1.0 / 60.0);
      if (glfwGetKey(window, GLFW_KEY_ESCAPE) == GLFW_PRESS) glfwSetWindowShouldClose(window, GLFW_TRUE);
    }
    vkDestroySurfaceKHR(ctx.instance(), surface, nullptr);
    glfwDestroyWindow(window);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-view: error: %s\n", e.what());
    rc = 1;
  }
  glfwTerminate();
  return rc;
}
