// The procedural appearance renderer on the GPU; see appearance_gpu.h.
#include "render/appearance/appearance_gpu.h"

#include "gpu/context.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

namespace icube::render {

std::vector<uint8_t> AppearanceImage::rgb8() const {
  std::vector<uint8_t> out(rgba.size() * 3);
  for (size_t i = 0; i < rgba.size(); ++i) {
    out[3 * i] = static_cast<uint8_t>(rgba[i] & 255u);
    out[3 * i + 1] = static_cast<uint8_t>((rgba[i] >> 8) & 255u);
    out[3 * i + 2] = static_cast<uint8_t>((rgba[i] >> 16) & 255u);
  }
  return out;
}

std::vector<uint8_t> AppearanceImage::sky_mask8() const {
  std::vector<uint8_t> out(rgba.size());
  for (size_t i = 0; i < rgba.size(); ++i) out[i] = (rgba[i] >> 24) == 0u ? 255 : 0;
  return out;
}

std::vector<uint16_t> AppearanceImage::instance16() const {
  std::vector<uint16_t> out(labels.size());
  for (size_t i = 0; i < labels.size(); ++i) out[i] = static_cast<uint16_t>(labels[i] & 0xffffu);
  return out;
}

std::vector<uint8_t> AppearanceImage::class8() const {
  std::vector<uint8_t> out(labels.size());
  for (size_t i = 0; i < labels.size(); ++i) out[i] = static_cast<uint8_t>(labels[i] >> 16);
  return out;
}

shader::AppearanceParams frame_params(const shader::AppearanceParams& lighting, const shader::RaycastParams& cam,
                                      const RaycastWorld& w, const AppearanceOptions& o, uint32_t light_count) {
  shader::AppearanceParams p = lighting;
  p.m00 = cam.m00, p.m01 = cam.m01, p.m02 = cam.m02;
  p.m10 = cam.m10, p.m11 = cam.m11, p.m12 = cam.m12;
  p.m20 = cam.m20, p.m21 = cam.m21, p.m22 = cam.m22;
  p.pixel_offset = cam.pixel_offset;
  p.voxel_size = static_cast<float>(w.gpu.voxel_size);
  p.width = cam.width;
  p.height = cam.width ? cam.n / cam.width : 0;
  p.ref_x = cam.ref_x, p.ref_y = cam.ref_y, p.ref_z = cam.ref_z;
  p.off_x = cam.off_x, p.off_y = cam.off_y, p.off_z = cam.off_z;
  p.table_mask = w.gpu.table_mask;
  p.shadow_t_max = static_cast<float>(o.shadow_t_max);
  p.light_count = light_count;
  p.flags &= APPEARANCE_FLAG_SUN;
  if (o.shadows && (p.flags & APPEARANCE_FLAG_SUN)) p.flags |= APPEARANCE_FLAG_SHADOWS;
  if (o.ambient_occlusion) p.flags |= APPEARANCE_FLAG_AO;
  return p;
}

AppearanceRendererGpu::AppearanceRendererGpu(gpu::Context& ctx)
    : ctx_(ctx),
      caster_(ctx),
      shadow_rays_(ctx.program("appearance/shadow_rays")),
      shade_(ctx.program("appearance/shade")) {
  caster_.set_exact(false);  // colour frames do not need the guidance buffers' 1 cm chord decisions in double
}

glm::ivec3 AppearanceRendererGpu::camera_ref(const RaycastWorld& w, const Camera& cam) const {
  const shader::RaycastParams p = caster_.camera_params(w, cam, RaycastOptions{});
  return {p.ref_x, p.ref_y, p.ref_z};
}

void AppearanceRendererGpu::record(gpu::CommandList& cmd, const RaycastWorld& w, const Camera& cam,
                                   const shader::AppearanceParams& lighting, const std::vector<WorldLight>& lights,
                                   const AppearanceOptions& o) {
  RaycastOptions ro;
  ro.pixels = o.pixels;
  const shader::RaycastParams cp = caster_.camera_params(w, cam, ro);
  const glm::ivec3 ref(cp.ref_x, cp.ref_y, cp.ref_z);
  const std::vector<shader::AppearanceLight> frame_lights =
      lights_for_frame(lights, w.gpu.origin, w.gpu.voxel_size, ref, glm::dvec3(cam.c2w[3]));
  const shader::AppearanceParams p =
      frame_params(lighting, cp, w, o, static_cast<uint32_t>(frame_lights.size()));
  const uint64_t n = uint64_t{cam.K.width} * cam.K.height;
  const gpu::DeviceInfo& info = ctx_.info();
  // The hits are read as texels (3 per pixel), so a frame is bounded by maxTexelBufferElements; the
  // per-pixel outputs over one storage binding are written in windows of pixels.
  if (3 * n > info.max_texel_buffer_elements)
    throw std::invalid_argument("frames: a " + std::to_string(cam.K.width) + "x" + std::to_string(cam.K.height) +
                                " frame needs " + std::to_string(3 * n) + " texels of ray hits, over this device's " +
                                std::to_string(info.max_texel_buffer_elements) + "; render at most " +
                                std::to_string(info.max_texel_buffer_elements / 3) + " pixels");
  // Shadow rays (32 bytes a pixel) bound the window; starts aligned for them and the 4-byte outputs.
  const uint64_t unit = gpu::aligned_element_unit(info, 4);
  const uint64_t per_window = info.max_storage_buffer_range / 32 / unit * unit;
  width_ = cam.K.width;
  height_ = cam.K.height;
  gpu::ensure_capacity(ctx_, hits_, n * sizeof(shader::RaycastHit), "appearance-hits");
  gpu::ensure_capacity(ctx_, rgba_, n * 4, "appearance-rgba");
  gpu::ensure_capacity(ctx_, labels_, n * 4, "appearance-labels");
  gpu::ensure_capacity(ctx_, params_, sizeof(shader::AppearanceParams), "appearance-params");
  gpu::ensure_capacity(ctx_, lights_, std::max<size_t>(1, frame_lights.size()) * sizeof(shader::AppearanceLight),
                       "appearance-lights");
  const bool shadows = (p.flags & APPEARANCE_FLAG_SHADOWS) != 0u;
  if (shadows) {
    gpu::ensure_capacity(ctx_, shadow_hits_, n * sizeof(shader::RaycastHit), "appearance-shadow-hits");
    gpu::ensure_capacity(ctx_, shadow_rays_batch_.rays, n * 32, "appearance-shadow-rays");
    shadow_rays_batch_.count = static_cast<uint32_t>(n);
    shadow_rays_batch_.ref = ref;
  }
  cmd.update_buffer(params_.binding(0, sizeof(p)), &p, sizeof(p));
  if (!frame_lights.empty())
    cmd.update_buffer(lights_.binding(0, frame_lights.size() * sizeof(shader::AppearanceLight)), frame_lights.data(),
                      frame_lights.size() * sizeof(shader::AppearanceLight));
  cmd.barrier(gpu::deps::kTransferToCompute);
  caster_.record_camera(cmd, w, cam, ro, hits_);
  cmd.barrier(gpu::deps::kComputeToCompute);
  const gpu::BufferBinding hits = hits_.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::RaycastHit));
  const gpu::BufferBinding params = params_.binding(0, sizeof(p));
  if (shadows) {
    for (uint64_t first = 0; first < n; first += per_window) {
      const uint64_t count = std::min(per_window, n - first);
      const shader::AppearanceWindow win{static_cast<uint32_t>(first), static_cast<uint32_t>(first + count)};
      cmd.dispatch(shadow_rays_, {count}, win, {hits, params, shadow_rays_batch_.rays.binding(first * 32, count * 32)});
    }
    cmd.barrier(gpu::deps::kComputeToCompute);
    RaycastOptions so;
    so.t_max = o.shadow_t_max;
    caster_.record_rays(cmd, w, shadow_rays_batch_, so, shadow_hits_);
    cmd.barrier(gpu::deps::kComputeToCompute);
  }
  for (uint64_t first = 0; first < n; first += per_window) {
    const uint64_t count = std::min(per_window, n - first);
    const shader::AppearanceWindow win{static_cast<uint32_t>(first), static_cast<uint32_t>(first + count)};
    cmd.dispatch(shade_, {count}, win,
                 {hits, shadows ? shadow_hits_.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::RaycastHit))
                                : gpu::null_binding(VK_FORMAT_R32G32B32A32_UINT), params,
                  lights_.texel_binding(VK_FORMAT_R32G32B32A32_SFLOAT, 0, lights_.size() & ~VkDeviceSize{15}),
                  RaycasterGpu::table_texels(w), RaycasterGpu::brick_texels(w), rgba_.binding(first * 4, count * 4),
                  labels_.binding(first * 4, count * 4)});
  }
}

AppearanceImage AppearanceRendererGpu::render(const RaycastWorld& w, const Camera& cam,
                                              const shader::AppearanceParams& lighting,
                                              const std::vector<WorldLight>& lights, const AppearanceOptions& o) {
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) { record(cmd, w, cam, lighting, lights, o); });
  AppearanceImage img;
  img.width = width_;
  img.height = height_;
  const size_t n = size_t{width_} * height_;
  img.rgba = gpu::download_vector<uint32_t>(ctx_, rgba_, n);
  img.labels = gpu::download_vector<uint32_t>(ctx_, labels_, n);
  return img;
}

}  // namespace icube::render
