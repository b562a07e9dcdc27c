// The viewer's main view; see view_renderer.h.
#include "view_renderer.h"

#include "world/semantics.h"

#include <algorithm>

namespace icube::viewer {

ViewRenderer::ViewRenderer(gpu::Context& ctx)
    : ctx_(ctx),
      raycaster_(ctx),
      shade_(ctx.program("view_shade", gpu::SpecConstants{}.set(0, ctx.subgroup_size() /* local_size_x */))) {
  std::vector<uint32_t> pal(world::kNumSemanticClasses);
  for (int c = 0; c < world::kNumSemanticClasses; ++c) {
    const auto rgb = world::class_color(static_cast<uint8_t>(c));
    pal[static_cast<size_t>(c)] = 0xff000000u | (uint32_t{rgb[2]} << 16) | (uint32_t{rgb[1]} << 8) | rgb[0];
  }
  palette_ = gpu::upload_vector(ctx, pal, "view-palette");
}

void ViewRenderer::reserve(uint32_t w, uint32_t h) {
  const uint64_t n = std::max<uint64_t>(1, uint64_t{w} * h);
  if (n <= capacity_) return;
  hits_ = gpu::Buffer(ctx_, n * sizeof(shader::RaycastHit), gpu::MemoryUsage::DeviceLocal, "view-hits");
  rgba_ = gpu::Buffer(ctx_, n * 4, gpu::MemoryUsage::DeviceLocal, "view-rgba");
  capacity_ = n;
}

void ViewRenderer::record(gpu::CommandList& cmd, const render::RaycastWorld& w, const render::Camera& cam,
                          const ShadeSettings& s) {
  reserve(cam.K.width, cam.K.height);
  width_ = cam.K.width;
  height_ = cam.K.height;
  render::RaycastOptions opts;
  opts.t_max = s.max_distance;
  const shader::RaycastParams rp = raycaster_.camera_params(w, cam, opts);
  raycaster_.record_camera(cmd, w, cam, opts, hits_);
  cmd.barrier(gpu::deps::kComputeToCompute);  // shading reads the hits

  shader::ViewShadeParams p{};
  p.width = width_;
  p.height = height_;
  p.mode = static_cast<uint32_t>(s.mode);
  p.pixel_offset = rp.pixel_offset;
  const glm::dvec3 sun = glm::normalize(s.sun_dir);
  p.sun_x = static_cast<float>(sun.x);
  p.sun_y = static_cast<float>(sun.y);
  p.sun_z = static_cast<float>(sun.z);
  p.fog_density = static_cast<float>(s.fog_density);
  p.fx = static_cast<float>(cam.K.fx);
  p.fy = static_cast<float>(cam.K.fy);
  p.cx = static_cast<float>(cam.K.cx);
  p.cy = static_cast<float>(cam.K.cy);
  p.depth_max = static_cast<float>(s.depth_max);
  p.ambient = static_cast<float>(s.ambient);
  p.m00 = rp.m00; p.m01 = rp.m01; p.m02 = rp.m02;
  p.m10 = rp.m10; p.m11 = rp.m11; p.m12 = rp.m12;
  p.m20 = rp.m20; p.m21 = rp.m21; p.m22 = rp.m22;
  const uint64_t n = uint64_t{width_} * height_;
  cmd.dispatch(shade_, {n}, p,
               {hits_.binding(0, n * sizeof(shader::RaycastHit)), palette_.binding(), rgba_.binding(0, n * 4)});
}

std::vector<uint8_t> ViewRenderer::download_rgba() {
  std::vector<uint8_t> px(uint64_t{width_} * height_ * 4);
  if (!px.empty()) gpu::download(ctx_, rgba_, px.data(), px.size());
  return px;
}

}  // namespace icube::viewer
