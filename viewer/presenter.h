// Presentation for icube-view: the GLFW window's swapchain, the per-frame
// command buffer, and Dear ImGui's Vulkan backend (Debian libimgui-dev 1.86,
// which draws in a render pass).
//
// One frame in flight: begin_frame() waits for the previous frame's fence, so
// buffers written by the previous frame may be reused and host uploads
// (ResidentWorld) may run between frames. Per frame, on the engine's queue
// (a universal queue on lavapipe and desktop GPUs; checked for graphics and
// present support):
//   compute (the caller, through cmd())           rgba buffer
//   buffer -> view image (R8G8B8A8) -> blit (scaled, linear) -> swapchain image
//   ImGui render pass (load, draw, -> PRESENT_SRC), submit, present.
// Timestamps at the start, after the compute, after the copy and after the UI
// pass (times(): the last finished frame's, read after its fence) and the host
// time of the fence wait, acquire, submit and present feed --stats.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <memory>
#include <vector>

struct ImDrawData;

namespace icube::viewer {

// Where the last finished frame's time went (ms): GPU timestamps (the device's
// queue; lavapipe runs them on the CPU) and host time spent in the presenter's calls.
struct PresentTimes {
  bool valid = false;          // timestamps of a finished frame are available
  double gpu_compute = 0.0;    // start of the command buffer -> end of the caller's compute (ray casting + shading)
  double gpu_copy = 0.0;       // the copy of the view into the swapchain image (scaled)
  double gpu_ui = 0.0;         // the ImGui render pass
  double fence_wait = 0.0;     // host: waiting for the previous frame in begin_frame
  double acquire = 0.0;        // host: vkAcquireNextImageKHR
  double submit = 0.0;         // host: recording the presenter's commands + vkQueueSubmit2
  double present = 0.0;        // host: vkQueuePresentKHR
};

class Presenter {
 public:
  Presenter(gpu::Context& ctx, GLFWwindow* window, bool vsync);
  ~Presenter();
  Presenter(const Presenter&) = delete;
  Presenter& operator=(const Presenter&) = delete;

  // Waits for the previous frame and acquires an image; false when the window
  // is minimised or the swapchain was just recreated (skip this frame).
  bool begin_frame();
  // The frame's command list (compute work goes here before end_frame).
  gpu::CommandList& cmd() { return *list_; }
  // Blits `rgba` (w·h packed RGBA8, written by compute in cmd()) over the
  // whole swapchain image (none: clear), draws `ui`, submits and presents.
  void end_frame(const gpu::Buffer* rgba, uint32_t w, uint32_t h, ImDrawData* ui);
  VkExtent2D extent() const { return extent_; }
  // Waits for the last submitted frame.
  void wait();
  const char* present_mode_name() const;
  // Timings of the last finished frame (begin_frame reads the timestamps after the fence).
  const PresentTimes& times() const { return times_; }

 private:
  void create_swapchain();
  void destroy_swapchain();
  void ensure_view_image(uint32_t w, uint32_t h);
  void init_imgui();

  gpu::Context& ctx_;
  GLFWwindow* window_;
  bool vsync_;
  VkSurfaceKHR surface_ = VK_NULL_HANDLE;
  VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
  VkSurfaceFormatKHR format_{};
  VkPresentModeKHR present_mode_ = VK_PRESENT_MODE_FIFO_KHR;
  VkExtent2D extent_{0, 0};
  std::vector<VkImage> images_;
  std::vector<VkImageView> views_;
  std::vector<VkFramebuffer> framebuffers_;
  std::vector<VkSemaphore> render_done_;  // per swapchain image
  VkSemaphore acquired_ = VK_NULL_HANDLE;
  VkRenderPass render_pass_ = VK_NULL_HANDLE;
  VkDescriptorPool imgui_pool_ = VK_NULL_HANDLE;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkCommandBuffer cb_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  bool submitted_ = false;
  uint32_t image_index_ = 0;
  std::unique_ptr<gpu::CommandList> list_;
  // The view image the rgba buffer is copied into before the blit.
  VkImage view_image_ = VK_NULL_HANDLE;
  VkDeviceMemory view_memory_ = VK_NULL_HANDLE;
  uint32_t view_w_ = 0, view_h_ = 0;
  bool imgui_ready_ = false;
  // Timestamps: 0 start, 1 after compute, 2 after the copy, 3 after the UI.
  VkQueryPool queries_ = VK_NULL_HANDLE;
  double tick_ms_ = 0.0;
  bool queries_written_ = false;
  PresentTimes times_;
};

}  // namespace icube::viewer
