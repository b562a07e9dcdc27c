// Swapchain, frame submission and the ImGui Vulkan backend; see presenter.h.
#include "presenter.h"

#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_vulkan.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace icube::viewer {

namespace {

void imgui_check(VkResult r) {
  if (r != VK_SUCCESS) throw gpu::VulkanError(r, "ImGui Vulkan backend: VkResult " + std::to_string(static_cast<int>(r)));
}

void image_barrier(VkCommandBuffer cb, VkImage image, VkImageLayout from, VkImageLayout to, VkPipelineStageFlags2 src_stage,
                   VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  b.srcStageMask = src_stage;
  b.srcAccessMask = src_access;
  b.dstStageMask = dst_stage;
  b.dstAccessMask = dst_access;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  VkDependencyInfo di{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  di.imageMemoryBarrierCount = 1;
  di.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cb, &di);
}

uint32_t memory_type(const VkPhysicalDeviceMemoryProperties& props, uint32_t bits, VkMemoryPropertyFlags want) {
  for (uint32_t i = 0; i < props.memoryTypeCount; ++i)
    if ((bits & (1u << i)) && (props.memoryTypes[i].propertyFlags & want) == want) return i;
  throw std::runtime_error("no memory type for the view image");
}

}  // namespace

Presenter::Presenter(gpu::Context& ctx, GLFWwindow* window, bool vsync) : ctx_(ctx), window_(window), vsync_(vsync) {
  VK_CHECK(glfwCreateWindowSurface(ctx.instance(), window, nullptr, &surface_));
  VkBool32 present = VK_FALSE;
  VK_CHECK(vkGetPhysicalDeviceSurfaceSupportKHR(ctx.physical_device(), ctx.queue_family(), surface_, &present));
  uint32_t nq = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(ctx.physical_device(), &nq, nullptr);
  std::vector<VkQueueFamilyProperties> q(nq);
  vkGetPhysicalDeviceQueueFamilyProperties(ctx.physical_device(), &nq, q.data());
  if (!present || !(q[ctx.queue_family()].queueFlags & VK_QUEUE_GRAPHICS_BIT))
    throw std::runtime_error("the engine's queue (family " + std::to_string(ctx.queue_family()) +
                             ") cannot present to this window or draw (the viewer needs a universal queue)");

  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = ctx.queue_family();
  VK_CHECK(vkCreateCommandPool(ctx.device(), &pci, nullptr, &pool_));
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = pool_;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VK_CHECK(vkAllocateCommandBuffers(ctx.device(), &ai, &cb_));
  VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VK_CHECK(vkCreateFence(ctx.device(), &fci, nullptr, &fence_));
  VkSemaphoreCreateInfo sci{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  VK_CHECK(vkCreateSemaphore(ctx.device(), &sci, nullptr, &acquired_));
  if (q[ctx.queue_family()].timestampValidBits > 0) {
    VkPhysicalDeviceProperties props{};
    vkGetPhysicalDeviceProperties(ctx.physical_device(), &props);
    tick_ms_ = static_cast<double>(props.limits.timestampPeriod) * 1e-6;
    VkQueryPoolCreateInfo qci{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qci.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qci.queryCount = 4;
    VK_CHECK(vkCreateQueryPool(ctx.device(), &qci, nullptr, &queries_));
  }

  // Surface format: an 8-bit UNORM format the blit can write.
  uint32_t nf = 0;
  VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(ctx.physical_device(), surface_, &nf, nullptr));
  std::vector<VkSurfaceFormatKHR> formats(nf);
  VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(ctx.physical_device(), surface_, &nf, formats.data()));
  format_ = formats.at(0);
  for (const VkSurfaceFormatKHR& f : formats)
    if ((f.format == VK_FORMAT_B8G8R8A8_UNORM || f.format == VK_FORMAT_R8G8B8A8_UNORM) &&
        f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) {
      format_ = f;
      break;
    }
  VkFormatProperties fp{};
  vkGetPhysicalDeviceFormatProperties(ctx.physical_device(), format_.format, &fp);
  if (!(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT))
    throw std::runtime_error("the swapchain format cannot be a blit destination on this device");

  // Present mode: FIFO with vsync; otherwise mailbox or immediate when offered.
  uint32_t np = 0;
  VK_CHECK(vkGetPhysicalDeviceSurfacePresentModesKHR(ctx.physical_device(), surface_, &np, nullptr));
  std::vector<VkPresentModeKHR> modes(np);
  VK_CHECK(vkGetPhysicalDeviceSurfacePresentModesKHR(ctx.physical_device(), surface_, &np, modes.data()));
  present_mode_ = VK_PRESENT_MODE_FIFO_KHR;
  if (!vsync_)
    for (VkPresentModeKHR want : {VK_PRESENT_MODE_MAILBOX_KHR, VK_PRESENT_MODE_IMMEDIATE_KHR})
      if (std::find(modes.begin(), modes.end(), want) != modes.end()) {
        present_mode_ = want;
        break;
      }

  // ImGui's render pass: draws over the blitted view, then hands the image to presentation.
  VkAttachmentDescription att{};
  att.format = format_.format;
  att.samples = VK_SAMPLE_COUNT_1_BIT;
  att.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  att.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  att.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  att.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  att.initialLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  att.finalLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
  VkAttachmentReference ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription sub{};
  sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  sub.colorAttachmentCount = 1;
  sub.pColorAttachments = &ref;
  VkSubpassDependency dep{};
  dep.srcSubpass = VK_SUBPASS_EXTERNAL;
  dep.dstSubpass = 0;
  dep.srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  dep.dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  dep.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  dep.dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  VkRenderPassCreateInfo rpci{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  rpci.attachmentCount = 1;
  rpci.pAttachments = &att;
  rpci.subpassCount = 1;
  rpci.pSubpasses = &sub;
  rpci.dependencyCount = 1;
  rpci.pDependencies = &dep;
  VK_CHECK(vkCreateRenderPass(ctx.device(), &rpci, nullptr, &render_pass_));

  create_swapchain();
  init_imgui();
}

Presenter::~Presenter() {
  vkDeviceWaitIdle(ctx_.device());
  list_.reset();
  if (imgui_ready_) ImGui_ImplVulkan_Shutdown();
  destroy_swapchain();
  if (view_image_) vkDestroyImage(ctx_.device(), view_image_, nullptr);
  if (view_memory_) vkFreeMemory(ctx_.device(), view_memory_, nullptr);
  if (imgui_pool_) vkDestroyDescriptorPool(ctx_.device(), imgui_pool_, nullptr);
  vkDestroyRenderPass(ctx_.device(), render_pass_, nullptr);
  vkDestroySemaphore(ctx_.device(), acquired_, nullptr);
  if (queries_) vkDestroyQueryPool(ctx_.device(), queries_, nullptr);
  vkDestroyFence(ctx_.device(), fence_, nullptr);
  vkDestroyCommandPool(ctx_.device(), pool_, nullptr);
  vkDestroySurfaceKHR(ctx_.instance(), surface_, nullptr);
}

const char* Presenter::present_mode_name() const {
  switch (present_mode_) {
    case VK_PRESENT_MODE_MAILBOX_KHR: return "mailbox";
    case VK_PRESENT_MODE_IMMEDIATE_KHR: return "immediate";
    default: return "fifo (vsync)";
  }
}

void Presenter::create_swapchain() {
  VkSurfaceCapabilitiesKHR caps{};
  VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(ctx_.physical_device(), surface_, &caps));
  int fw = 0, fh = 0;
  glfwGetFramebufferSize(window_, &fw, &fh);
  extent_ = caps.currentExtent;
  if (extent_.width == UINT32_MAX) {
    extent_.width = std::clamp(static_cast<uint32_t>(fw), caps.minImageExtent.width, caps.maxImageExtent.width);
    extent_.height = std::clamp(static_cast<uint32_t>(fh), caps.minImageExtent.height, caps.maxImageExtent.height);
  }
  if (extent_.width == 0 || extent_.height == 0) return;
  const VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  if ((caps.supportedUsageFlags & usage) != usage)
    throw std::runtime_error("the surface does not offer transfer-destination swapchain images");
  uint32_t count = std::max(2u, caps.minImageCount + 1);
  if (caps.maxImageCount) count = std::min(count, caps.maxImageCount);
  VkSwapchainCreateInfoKHR ci{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  ci.surface = surface_;
  ci.minImageCount = count;
  ci.imageFormat = format_.format;
  ci.imageColorSpace = format_.colorSpace;
  ci.imageExtent = extent_;
  ci.imageArrayLayers = 1;
  ci.imageUsage = usage;
  ci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.preTransform = caps.currentTransform;
  ci.compositeAlpha = (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
                          ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                          : static_cast<VkCompositeAlphaFlagBitsKHR>(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha);
  ci.presentMode = present_mode_;
  ci.clipped = VK_TRUE;
  VK_CHECK(vkCreateSwapchainKHR(ctx_.device(), &ci, nullptr, &swapchain_));
  uint32_t n = 0;
  VK_CHECK(vkGetSwapchainImagesKHR(ctx_.device(), swapchain_, &n, nullptr));
  images_.resize(n);
  VK_CHECK(vkGetSwapchainImagesKHR(ctx_.device(), swapchain_, &n, images_.data()));
  for (VkImage img : images_) {
    VkImageViewCreateInfo vci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vci.image = img;
    vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vci.format = format_.format;
    vci.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VkImageView v = VK_NULL_HANDLE;
    VK_CHECK(vkCreateImageView(ctx_.device(), &vci, nullptr, &v));
    views_.push_back(v);
    VkFramebufferCreateInfo fci{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fci.renderPass = render_pass_;
    fci.attachmentCount = 1;
    fci.pAttachments = &v;
    fci.width = extent_.width;
    fci.height = extent_.height;
    fci.layers = 1;
    VkFramebuffer fb = VK_NULL_HANDLE;
    VK_CHECK(vkCreateFramebuffer(ctx_.device(), &fci, nullptr, &fb));
    framebuffers_.push_back(fb);
    VkSemaphoreCreateInfo sci{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    VkSemaphore s = VK_NULL_HANDLE;
    VK_CHECK(vkCreateSemaphore(ctx_.device(), &sci, nullptr, &s));
    render_done_.push_back(s);
  }
  if (imgui_ready_) ImGui_ImplVulkan_SetMinImageCount(std::max(2u, count));
}

void Presenter::destroy_swapchain() {
  for (VkFramebuffer f : framebuffers_) vkDestroyFramebuffer(ctx_.device(), f, nullptr);
  for (VkImageView v : views_) vkDestroyImageView(ctx_.device(), v, nullptr);
  for (VkSemaphore s : render_done_) vkDestroySemaphore(ctx_.device(), s, nullptr);
  framebuffers_.clear();
  views_.clear();
  render_done_.clear();
  images_.clear();
  if (swapchain_) vkDestroySwapchainKHR(ctx_.device(), swapchain_, nullptr);
  swapchain_ = VK_NULL_HANDLE;
}

void Presenter::init_imgui() {
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 16};
  VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
  dpci.maxSets = 16;
  dpci.poolSizeCount = 1;
  dpci.pPoolSizes = &size;
  VK_CHECK(vkCreateDescriptorPool(ctx_.device(), &dpci, nullptr, &imgui_pool_));
  ImGui_ImplVulkan_InitInfo info{};
  info.Instance = ctx_.instance();
  info.PhysicalDevice = ctx_.physical_device();
  info.Device = ctx_.device();
  info.QueueFamily = ctx_.queue_family();
  info.Queue = ctx_.queue();
  info.DescriptorPool = imgui_pool_;
  info.MinImageCount = 2;
  info.ImageCount = static_cast<uint32_t>(std::max<size_t>(2, images_.size()));
  info.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
  info.CheckVkResultFn = imgui_check;
  if (!ImGui_ImplVulkan_Init(&info, render_pass_)) throw std::runtime_error("ImGui Vulkan backend init failed");
  imgui_ready_ = true;
  // Font atlas upload.
  VK_CHECK(vkResetCommandBuffer(cb_, 0));
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VK_CHECK(vkBeginCommandBuffer(cb_, &bi));
  ImGui_ImplVulkan_CreateFontsTexture(cb_);
  VK_CHECK(vkEndCommandBuffer(cb_));
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cb_;
  VK_CHECK(vkQueueSubmit(ctx_.queue(), 1, &si, fence_));
  VK_CHECK(vkWaitForFences(ctx_.device(), 1, &fence_, VK_TRUE, UINT64_MAX));
  VK_CHECK(vkResetFences(ctx_.device(), 1, &fence_));
  ImGui_ImplVulkan_DestroyFontUploadObjects();
}

void Presenter::wait() {
  if (submitted_) {
    VK_CHECK(vkWaitForFences(ctx_.device(), 1, &fence_, VK_TRUE, UINT64_MAX));
    VK_CHECK(vkResetFences(ctx_.device(), 1, &fence_));
    submitted_ = false;
  }
}

namespace {
double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

bool Presenter::begin_frame() {
  const auto t0 = std::chrono::steady_clock::now();
  const bool had_frame = submitted_;
  wait();
  times_.fence_wait = ms_since(t0);
  if (had_frame && queries_written_) {
    uint64_t ts[4] = {};
    if (vkGetQueryPoolResults(ctx_.device(), queries_, 0, 4, sizeof ts, ts, sizeof(uint64_t), VK_QUERY_RESULT_64_BIT) ==
        VK_SUCCESS) {
      auto d = [&](int a, int b) { return ts[b] >= ts[a] ? static_cast<double>(ts[b] - ts[a]) * tick_ms_ : 0.0; };
      times_.gpu_compute = d(0, 1);
      times_.gpu_copy = d(1, 2);
      times_.gpu_ui = d(2, 3);
      times_.valid = true;
    }
    queries_written_ = false;
  }
  list_.reset();  // its descriptor pools (without push descriptors) are free now
  int fw = 0, fh = 0;
  glfwGetFramebufferSize(window_, &fw, &fh);
  if (fw == 0 || fh == 0) return false;
  if (!swapchain_ || static_cast<uint32_t>(fw) != extent_.width || static_cast<uint32_t>(fh) != extent_.height) {
    VK_CHECK(vkDeviceWaitIdle(ctx_.device()));
    destroy_swapchain();
    create_swapchain();
    if (!swapchain_) return false;
  }
  const auto t_acq = std::chrono::steady_clock::now();
  const VkResult r = vkAcquireNextImageKHR(ctx_.device(), swapchain_, UINT64_MAX, acquired_, VK_NULL_HANDLE, &image_index_);
  times_.acquire = ms_since(t_acq);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) {
    VK_CHECK(vkDeviceWaitIdle(ctx_.device()));
    destroy_swapchain();
    create_swapchain();
    return false;
  }
  if (r != VK_SUBOPTIMAL_KHR) VK_CHECK(r);
  VK_CHECK(vkResetCommandBuffer(cb_, 0));
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VK_CHECK(vkBeginCommandBuffer(cb_, &bi));
  if (queries_) {
    vkCmdResetQueryPool(cb_, queries_, 0, 4);
    vkCmdWriteTimestamp(cb_, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries_, 0);
  }
  list_ = std::make_unique<gpu::CommandList>(ctx_, cb_);
  return true;
}

void Presenter::ensure_view_image(uint32_t w, uint32_t h) {
  if (view_image_ && w <= view_w_ && h <= view_h_) return;  // grow only: adaptive resolution uses a corner
  w = std::max(w, view_w_);
  h = std::max(h, view_h_);
  VK_CHECK(vkDeviceWaitIdle(ctx_.device()));  // the previous frame may still blit from it (never: one frame in flight)
  if (view_image_) vkDestroyImage(ctx_.device(), view_image_, nullptr);
  if (view_memory_) vkFreeMemory(ctx_.device(), view_memory_, nullptr);
  VkImageCreateInfo ici{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = VK_FORMAT_R8G8B8A8_UNORM;
  ici.extent = {w, h, 1};
  ici.mipLevels = 1;
  ici.arrayLayers = 1;
  ici.samples = VK_SAMPLE_COUNT_1_BIT;
  ici.tiling = VK_IMAGE_TILING_OPTIMAL;
  ici.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  ici.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VK_CHECK(vkCreateImage(ctx_.device(), &ici, nullptr, &view_image_));
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(ctx_.device(), view_image_, &req);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = memory_type(ctx_.memory_properties(), req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  VK_CHECK(vkAllocateMemory(ctx_.device(), &mai, nullptr, &view_memory_));
  VK_CHECK(vkBindImageMemory(ctx_.device(), view_image_, view_memory_, 0));
  view_w_ = w;
  view_h_ = h;
}

void Presenter::end_frame(const gpu::Buffer* rgba, uint32_t w, uint32_t h, ImDrawData* ui) {
  const auto t_submit = std::chrono::steady_clock::now();
  const VkImage target = images_[image_index_];
  if (queries_) vkCmdWriteTimestamp(cb_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, 1);
  image_barrier(cb_, target, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                VK_ACCESS_2_TRANSFER_WRITE_BIT);  // after the acquire semaphore (waited at the transfer stage)
  if (rgba && w > 0 && h > 0) {
    ensure_view_image(w, h);
    list_->barrier(gpu::deps::kComputeToTransfer);  // the copy reads the shaded pixels
    image_barrier(cb_, view_image_, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                  VK_ACCESS_2_TRANSFER_WRITE_BIT);  // previous frame's blit read is fenced
    VkBufferImageCopy copy{};
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.imageExtent = {w, h, 1};
    vkCmdCopyBufferToImage(cb_, rgba->handle(), view_image_, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
    image_barrier(cb_, view_image_, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                  VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);  // the blit reads the copy
    VkImageBlit blit{};
    blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.srcOffsets[1] = {static_cast<int32_t>(w), static_cast<int32_t>(h), 1};
    blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.dstOffsets[1] = {static_cast<int32_t>(extent_.width), static_cast<int32_t>(extent_.height), 1};
    vkCmdBlitImage(cb_, view_image_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                   1, &blit, VK_FILTER_LINEAR);
  } else {
    VkClearColorValue c{{0.1f, 0.1f, 0.12f, 1.0f}};
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cb_, target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &c, 1, &range);
  }
  image_barrier(cb_, target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);  // ImGui draws over the view
  if (queries_) vkCmdWriteTimestamp(cb_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, 2);

  VkRenderPassBeginInfo rbi{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  rbi.renderPass = render_pass_;
  rbi.framebuffer = framebuffers_[image_index_];
  rbi.renderArea.extent = extent_;
  vkCmdBeginRenderPass(cb_, &rbi, VK_SUBPASS_CONTENTS_INLINE);
  if (ui) ImGui_ImplVulkan_RenderDrawData(ui, cb_);
  vkCmdEndRenderPass(cb_);
  if (queries_) {
    vkCmdWriteTimestamp(cb_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, 3);
    queries_written_ = true;
  }
  VK_CHECK(vkEndCommandBuffer(cb_));

  VkSemaphoreSubmitInfo wait_info{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  wait_info.semaphore = acquired_;
  wait_info.stageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT | VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
  VkSemaphoreSubmitInfo signal_info{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  signal_info.semaphore = render_done_[image_index_];
  signal_info.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  VkCommandBufferSubmitInfo cbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  cbi.commandBuffer = cb_;
  VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  si.waitSemaphoreInfoCount = 1;
  si.pWaitSemaphoreInfos = &wait_info;
  si.commandBufferInfoCount = 1;
  si.pCommandBufferInfos = &cbi;
  si.signalSemaphoreInfoCount = 1;
  si.pSignalSemaphoreInfos = &signal_info;
  VK_CHECK(vkQueueSubmit2(ctx_.queue(), 1, &si, fence_));
  submitted_ = true;
  times_.submit = ms_since(t_submit);
  const auto t_present = std::chrono::steady_clock::now();

  VkPresentInfoKHR pi{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
  pi.waitSemaphoreCount = 1;
  pi.pWaitSemaphores = &render_done_[image_index_];
  pi.swapchainCount = 1;
  pi.pSwapchains = &swapchain_;
  pi.pImageIndices = &image_index_;
  const VkResult r = vkQueuePresentKHR(ctx_.queue(), &pi);
  times_.present = ms_since(t_present);
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) {
    extent_ = {0, 0};  // recreate at the next begin_frame
  } else {
    VK_CHECK(r);
  }
}

}  // namespace icube::viewer
