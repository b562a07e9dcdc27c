// The viewer's main view on the GPU: the voxel ray caster (camera mode,
// engine/render/raycast_gpu.h) into a hit buffer, then shaders/view/shade.comp
// into packed RGBA8 (mode, sun, fog: shared/view_params.h). The presenter
// copies the RGBA buffer to an image and blits it to the swapchain.
// Shaded mode with shadows / ambient occlusion: extra ray passes through the
// ray caster's ray-list mode, one per kind and sample (sun ray: t_max
// shadow_distance; AO rays: t_max ao_radius), generated from the camera hits
// and summed into a per-pixel visibility word by shaders/view/rays.comp; the
// other modes never run them, so they stay exactly the camera hits' picture.
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
  bool shadows = false;                 // shaded: sun shadows (one ray per pixel)
  double shadow_distance = 120.0;       // m: sun rays stop here
  int ao_samples = 0;                   // shaded: ambient-occlusion rays per pixel (0 = off, <= 16)
  double ao_radius = 1.0;               // m: AO rays stop here
  double ao_strength = 0.6;             // ambient · (1 - strength · blocked / samples)
};

// The AO ray direction of view/rays.comp (same hash, pattern and basis) in
// double, for CPU references: pixel (x, y), sample s of k, entry-face normal
// ±(axis + 1).
glm::dvec3 ao_direction(uint32_t x, uint32_t y, uint32_t s, uint32_t k, int normal);

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
  // The camera / ray passes' ray caster (e.g. set_occupancy for measurements).
  render::RaycasterGpu& raycaster() { return raycaster_; }

 private:
  gpu::Context& ctx_;
  void record_visibility(gpu::CommandList& cmd, const render::RaycastWorld& w, const shader::RaycastParams& rp,
                         const ShadeSettings& s, const glm::dvec3& sun);

  render::RaycasterGpu raycaster_;
  gpu::Program& shade_;
  gpu::Program& rays_;
  gpu::Buffer palette_, hits_, rgba_, vis_, prev_;
  render::GpuRayBatch batch_;  // shadow / AO rays, reused by every pass
  uint64_t capacity_ = 0;
  uint32_t width_ = 0, height_ = 0;
};

}  // namespace icube::viewer
