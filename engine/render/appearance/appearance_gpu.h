// The procedural appearance renderer on the GPU (Stage 2's built-in stand-in
// for the video model): per frame one camera cast of the voxel ray caster
// (the guidance buffers' first-hit rule, without their exact pass), optionally
// a shadow ray per pixel towards the sun (shaders/appearance/shadow_rays.comp
// + a ray-list cast), then shaders/appearance/shade.comp (materials, sky,
// sun, ambient occlusion, lamps, headlights, weather, fog, tone curve; the
// model is shared/appearance_shading.h). One command list per frame; record()
// puts it into a caller's list. CPU reference: appearance_cpu.h.
// Tests: tests/appearance/; benchmark: bench/bench_frames.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "render/appearance/lights.h"
#include "render/raycast_gpu.h"
#include "shared/appearance_params.h"

#include <cstdint>
#include <vector>

namespace icube::render {

struct AppearanceOptions {
  bool shadows = true;
  bool ambient_occlusion = true;
  double shadow_t_max = 150.0;  // metres
  PixelConvention pixels = PixelConvention::Integer;
};

// One rendered frame: per pixel RGBA8 (R in the low byte; alpha 255 = a surface, 0 = sky) and
// class << 16 | instance of the hit voxel (0 for sky).
struct AppearanceImage {
  uint32_t width = 0, height = 0;
  std::vector<uint32_t> rgba;
  std::vector<uint32_t> labels;
  std::vector<uint8_t> rgb8() const;
  std::vector<uint8_t> sky_mask8() const;       // 255 = sky
  std::vector<uint16_t> instance16() const;     // instance id, 0 = none
  std::vector<uint8_t> class8() const;
};

// The camera and flag fields of `lighting` for one frame; the reference voxel is the camera's (as the ray caster's).
shader::AppearanceParams frame_params(const shader::AppearanceParams& lighting, const shader::RaycastParams& cam,
                                      const RaycastWorld& w, const AppearanceOptions& o, uint32_t light_count);

class AppearanceRendererGpu {
 public:
  explicit AppearanceRendererGpu(gpu::Context& ctx);

  // Records the whole frame into `cmd` (its own barriers between the passes; the caller orders
  // earlier uses of this renderer's buffers and submits). `lights` in world metres.
  void record(gpu::CommandList& cmd, const RaycastWorld& w, const Camera& cam, const shader::AppearanceParams& lighting,
              const std::vector<WorldLight>& lights, const AppearanceOptions& o);
  // record + submit + download.
  AppearanceImage render(const RaycastWorld& w, const Camera& cam, const shader::AppearanceParams& lighting,
                         const std::vector<WorldLight>& lights, const AppearanceOptions& o);
  // The reference voxel of a camera (lights and positions of the kernels are relative to its corner).
  glm::ivec3 camera_ref(const RaycastWorld& w, const Camera& cam) const;

 private:
  gpu::Context& ctx_;
  RaycasterGpu caster_;
  gpu::Program& shadow_rays_;
  gpu::Program& shade_;
  gpu::Buffer hits_, shadow_hits_, params_, lights_, rgba_, labels_;
  GpuRayBatch shadow_rays_batch_;
  uint32_t width_ = 0, height_ = 0;
};

}  // namespace icube::render
