// The viewer's main view on the GPU: the voxel ray caster (camera mode,
// engine/render/raycast_gpu.h) into a hit buffer, then shaders/view_shade.comp
// into packed RGBA8 (mode, sun, fog: shared/view_params.h). The presenter
// copies the RGBA buffer to an image and blits it to the swapchain.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "render/raycast_gpu.h"
#include "shared/view_params.h"

#include <cstdint>
#include <vector>

namespace icube::viewer {

enum class RenderMode : uint32_t {
  Shaded = VIEW_MODE_SHADED,
  Semantic = VIEW_MODE_SEMANTIC,
  Depth = VIEW_MODE_DEPTH,
  Instance = VIEW_MODE_INSTANCE,
  Coords = VIEW_MODE_COORDS,
};
inline constexpr const char* kRenderModeNames[] = {"shaded", "semantic", "depth", "instance", "coords"};

struct ShadeSettings {
  RenderMode mode = RenderMode::Shaded;
  glm::dvec3 sun_dir{0.35, 0.25, 0.9};  // towards the sun (normalised by the renderer)
  double fog_density = 1.0 / 250.0;     // 1/m
  double depth_max = 80.0;              // m
  double ambient = 0.45;
  double max_distance = 400.0;          // m: rays stop here
};

class ViewRenderer {
 public:
  explicit ViewRenderer(gpu::Context& ctx);

  // Records ray casting + shading of `cam` (its K sets the resolution) into rgba().
  // The caller orders earlier reads of rgba() before this (one frame in flight does)
  // and puts a compute-to-transfer barrier before copying it.
  void record(gpu::CommandList& cmd, const render::RaycastWorld& w, const render::Camera& cam, const ShadeSettings& s);
  const gpu::Buffer& rgba() const { return rgba_; }
  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }
  // Makes room for w·h pixels (call between frames, with the GPU idle).
  void reserve(uint32_t w, uint32_t h);
  // The last frame's pixels (RGBA8, after it finished).
  std::vector<uint8_t> download_rgba();

 private:
  gpu::Context& ctx_;
  render::RaycasterGpu raycaster_;
  gpu::Program& shade_;
  gpu::Buffer palette_, hits_, rgba_;
  uint64_t capacity_ = 0;
  uint32_t width_ = 0, height_ = 0;
};

}  // namespace icube::viewer
