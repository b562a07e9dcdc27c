// The viewer's main view; see view_renderer.h.
#include "view_renderer.h"

#include "world/semantics.h"

#include <algorithm>
#include <cmath>

namespace icube::viewer {

ViewRenderer::ViewRenderer(gpu::Context& ctx)
    : ctx_(ctx),
      raycaster_(ctx),
      shade_(ctx.program("view/shade", gpu::SpecConstants{}.set(0, ctx.subgroup_size() /* local_size_x */))),
      rays_(ctx.program("view/rays", gpu::SpecConstants{}.set(0, ctx.subgroup_size()))) {
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
  vis_ = gpu::Buffer(ctx_, n * 4, gpu::MemoryUsage::DeviceLocal, "view-vis");
  capacity_ = n;
  prev_ = gpu::Buffer();  // the ray-pass buffers grow on their first use
  batch_.rays = gpu::Buffer();
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
  const bool vis = s.mode == RenderMode::Shaded && (s.shadows || s.ao_samples > 0);
  if (vis) {
    record_visibility(cmd, w, rp, s, sun);
    cmd.barrier(gpu::deps::kComputeToCompute);  // shading reads the visibility words
  }
  p.use_vis = vis ? 1u : 0u;
  p.ao_scale = s.ao_samples > 0 ? static_cast<float>(s.ao_strength / s.ao_samples) : 0.0f;
  cmd.dispatch(shade_, {n}, p,
               {hits_.binding(0, n * sizeof(shader::RaycastHit)), palette_.binding(), rgba_.binding(0, n * 4),
                vis_.binding(0, n * 4)});
}

// One ray pass per kind and sample: view_rays (sum the previous pass, write this pass's rays),
// the ray caster over them into prev_, and a last view_rays that sums the final pass.
void ViewRenderer::record_visibility(gpu::CommandList& cmd, const render::RaycastWorld& w,
                                     const shader::RaycastParams& rp, const ShadeSettings& s, const glm::dvec3& sun) {
  const uint64_t n = uint64_t{width_} * height_;
  if (prev_.size() < capacity_ * sizeof(shader::RaycastHit)) {
    ctx_.wait_idle();
    prev_ = gpu::Buffer(ctx_, capacity_ * sizeof(shader::RaycastHit), gpu::MemoryUsage::DeviceLocal, "view-ray-hits");
    batch_.rays = gpu::Buffer(ctx_, capacity_ * 32, gpu::MemoryUsage::DeviceLocal, "view-rays");
  }
  batch_.count = static_cast<uint32_t>(n);
  batch_.ref = glm::ivec3(rp.ref_x, rp.ref_y, rp.ref_z);

  shader::ViewRaysParams q{};
  q.width = width_;
  q.height = height_;
  q.ref_x = rp.ref_x; q.ref_y = rp.ref_y; q.ref_z = rp.ref_z;
  q.pixel_offset = rp.pixel_offset;
  q.off_x = rp.off_x; q.off_y = rp.off_y; q.off_z = rp.off_z;
  q.inv_voxel = rp.inv_voxel;
  q.sun_x = static_cast<float>(sun.x);
  q.sun_y = static_cast<float>(sun.y);
  q.sun_z = static_cast<float>(sun.z);
  q.samples = static_cast<uint32_t>(std::clamp(s.ao_samples, 0, 16));
  q.m00 = rp.m00; q.m01 = rp.m01; q.m02 = rp.m02;
  q.m10 = rp.m10; q.m11 = rp.m11; q.m12 = rp.m12;
  q.m20 = rp.m20; q.m21 = rp.m21; q.m22 = rp.m22;
  struct PassSpec { uint32_t kind, sample; };
  std::vector<PassSpec> passes;
  if (s.shadows) passes.push_back({VIEW_RAYS_KIND_SHADOW, 0});
  for (uint32_t k = 0; k < q.samples; ++k) passes.push_back({VIEW_RAYS_KIND_AO, k});

  for (size_t j = 0; j <= passes.size(); ++j) {
    q.flags = 0;
    if (j == 0) q.flags |= VIEW_RAYS_INIT;
    if (j > 0) {
      q.flags |= VIEW_RAYS_ACCUMULATE;
      if (passes[j - 1].kind == VIEW_RAYS_KIND_SHADOW) q.flags |= VIEW_RAYS_PREV_SHADOW;
    }
    if (j < passes.size()) {
      q.flags |= VIEW_RAYS_GENERATE;
      q.kind = passes[j].kind;
      q.sample_index = passes[j].sample;
    }
    cmd.dispatch(rays_, {n}, q,
                 {hits_.binding(0, n * sizeof(shader::RaycastHit)), prev_.binding(0, n * sizeof(shader::RaycastHit)),
                  vis_.binding(0, n * 4), batch_.rays.binding(0, n * 32)});
    if (j == passes.size()) break;
    cmd.barrier(gpu::deps::kComputeToCompute);  // the ray caster reads the rays (and prev_ was read)
    render::RaycastOptions opts;
    opts.t_max = passes[j].kind == VIEW_RAYS_KIND_SHADOW ? std::min(s.shadow_distance, s.max_distance) : s.ao_radius;
    raycaster_.record_rays(cmd, w, batch_, opts, prev_);
    cmd.barrier(gpu::deps::kComputeToCompute);  // the next view_rays reads prev_ and rewrites the rays
  }
}

glm::dvec3 ao_direction(uint32_t x, uint32_t y, uint32_t s, uint32_t k, int normal) {
  uint32_t h = (x * 73856093u) ^ (y * 19349663u);
  h ^= h >> 16u;
  h *= 0x7feb352du;
  h ^= h >> 15u;
  h *= 0x846ca68bu;
  h ^= h >> 16u;
  const double r1 = (h & 0xffffu) / 65536.0, r2 = (h >> 16u) / 65536.0;
  const double u = (s + r2) / k;
  double ip = 0.0;
  const double phi = 6.28318530718 * std::modf(r1 + 0.618034 * s, &ip);
  const int a = std::abs(normal) - 1;
  glm::dvec3 n(0.0), t1(0.0), t2(0.0);
  n[a] = normal > 0 ? 1.0 : -1.0;
  t1[(a + 1) % 3] = 1.0;
  t2[(a + 2) % 3] = 1.0;
  const double r = std::sqrt(u);
  return glm::normalize(r * std::cos(phi) * t1 + r * std::sin(phi) * t2 + std::sqrt(std::max(0.0, 1.0 - u)) * n);
}

std::vector<uint8_t> ViewRenderer::download_rgba() {
  std::vector<uint8_t> px(uint64_t{width_} * height_ * 4);
  if (!px.empty()) gpu::download(ctx_, rgba_, px.data(), px.size());
  return px;
}

}  // namespace icube::viewer
