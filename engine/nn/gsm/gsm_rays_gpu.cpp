// The GSM's pixel rays on the engine's voxel ray caster; see gsm_rays_gpu.h.
#include "nn/gsm/gsm_rays_gpu.h"

#include "gpu/buffer.h"
#include "render/raycast_gpu.h"
#include "world/voxel_grid.h"

#include <chrono>
#include <limits>
#include <stdexcept>
#include <vector>

namespace icube::nn {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// The input voxels as a world grid on the GSM's lattice (any class: the caster reads occupancy).
world::VoxelGrid gsm_world_grid(const SparseGrid& g) {
  const double origin = kGsmVoxelOrigin - 0.5 * kGsmVoxelSize;
  world::VoxelGrid grid(glm::dvec3(origin), kGsmVoxelSize);
  // (VoxelRayGrid has checked the coordinates: within +-2^20.)
  for (const Ijk& v : g.ijk) grid.set(glm::ivec3(v[0], v[1], v[2]), 1);
  return grid;
}

}  // namespace

GsmPixelRays cast_gsm_pixel_rays_gpu(gpu::Context& ctx, const GsmInputs& in, int64_t batch_element,
                                     GsmRayCastStats* stats, bool recheck_ties) {
  const int64_t b = batch_element, N = in.views, H = in.height, W = in.width;
  const SparseGrid input = gsm_input_grid(in, b);
  const VoxelRayGrid ref_grid(input);  // rows of hit voxels; the double walk of marked rays
  check_gsm_ray_intrinsics(in, b);
  const Clock::time_point t_gpu = Clock::now();
  const render::RaycastWorld world = render::upload_raycast_world(ctx, gsm_world_grid(input));
  render::RaycasterGpu caster(ctx);
  caster.set_mark_ties(true);
  render::RaycastOptions fg_opts;
  fg_opts.eps_sem = 0.0;  // the first voxel entered
  fg_opts.eps_depth = kGsmGridMaskMinSegment;
  fg_opts.gap_eps = -1.0;  // every empty voxel entered ends a run
  fg_opts.t_max = std::numeric_limits<double>::infinity();
  render::RaycastOptions depth_opts = fg_opts;
  depth_opts.eps_depth = kGsmDepthMinSegment;

  GsmPixelRays out;
  out.views = N;
  out.height = H;
  out.width = W;
  const int64_t per_view = H * W;
  const size_t n = static_cast<size_t>(N * per_view);
  out.first_voxel.assign(n, -1);
  out.grid_foreground.assign(n, 0);
  out.voxel_depth.assign(n, 0.0f);
  std::vector<int64_t> marked;  // pixels (view-major) to march again in double
  double host_ms = 0.0;
  const gpu::Buffer fg_hits(ctx, static_cast<VkDeviceSize>(per_view) * sizeof(shader::RaycastHit),
                            gpu::MemoryUsage::DeviceLocal, "gsm-ray-fg-hits");
  const gpu::Buffer depth_hits(ctx, static_cast<VkDeviceSize>(per_view) * sizeof(shader::RaycastHit),
                               gpu::MemoryUsage::DeviceLocal, "gsm-ray-depth-hits");
  std::vector<render::Ray> rays(static_cast<size_t>(per_view));
  for (int64_t view = 0; view < N; ++view) {
    const std::array<float, 16>& pose = in.poses[static_cast<size_t>(b * N + view)];
    const std::array<float, 6>& k = in.intrinsics[static_cast<size_t>(b * N + view)];
    const glm::dvec3 centre(pose[3], pose[7], pose[11]);
    gsm_parallel_for(H, 16, [&](int64_t v) {
      for (int64_t u = 0; u < W; ++u) {
        const std::array<float, 3> d = gsm_pixel_ray_direction(pose, k, u, v);
        rays[static_cast<size_t>(v * W + u)] = {centre, glm::dvec3(d[0], d[1], d[2])};
      }
    });
    const render::GpuRayBatch batch = caster.upload_rays(world, rays, /*normalise=*/false);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      caster.record_rays(cmd, world, batch, fg_opts, fg_hits);
      caster.record_rays(cmd, world, batch, depth_opts, depth_hits);
    });
    const std::vector<shader::RaycastHit> fg = gpu::download_vector<shader::RaycastHit>(ctx, fg_hits, per_view);
    const std::vector<shader::RaycastHit> dp = gpu::download_vector<shader::RaycastHit>(ctx, depth_hits, per_view);
    const Clock::time_point t_host = Clock::now();
    const std::array<float, 3> axis = gsm_optical_axis(pose);
    for (int64_t i = 0; i < per_view; ++i) {
      const shader::RaycastHit& f = fg[static_cast<size_t>(i)];
      const shader::RaycastHit& d = dp[static_cast<size_t>(i)];
      const size_t p = static_cast<size_t>(view * per_view + i);
      if (((f.flags | d.flags) & RAYCAST_FLAG_NEAR) != 0u) {
        marked.push_back(view * per_view + i);
        if (recheck_ties) continue;
      }
      if (f.flags & RAYCAST_FLAG_SEM) {
        out.first_voxel[p] = ref_grid.row_of(f.ijk_x, f.ijk_y, f.ijk_z);
        if (out.first_voxel[p] < 0) throw std::logic_error("gsm pixel rays: the ray caster hit a voxel not in the grid");
      }
      out.grid_foreground[p] = (f.flags & RAYCAST_FLAG_DEPTH) ? 1 : 0;
      if (d.flags & RAYCAST_FLAG_DEPTH) {
        const glm::vec3 dir(rays[static_cast<size_t>(i)].dir);
        const float cosine = axis[0] * dir.x + axis[1] * dir.y + axis[2] * dir.z;
        out.voxel_depth[p] = d.t_depth * cosine;
      }
    }
    host_ms += ms_since(t_host);
  }
  const double gpu_ms = ms_since(t_gpu) - host_ms;
  // The marked pixels, marched in double as the reference does.
  const Clock::time_point t_host = Clock::now();
  gsm_parallel_for(recheck_ties ? static_cast<int64_t>(marked.size()) : 0, 64, [&](int64_t m) {
    const int64_t p = marked[static_cast<size_t>(m)], view = p / per_view, i = p % per_view;
    const GsmPixelRay r = march_gsm_pixel(ref_grid, in.poses[static_cast<size_t>(b * N + view)],
                                          in.intrinsics[static_cast<size_t>(b * N + view)], i % W, i / W);
    out.first_voxel[static_cast<size_t>(p)] = r.first_voxel;
    out.grid_foreground[static_cast<size_t>(p)] = r.grid_foreground;
    out.voxel_depth[static_cast<size_t>(p)] = r.voxel_depth;
  });
  host_ms += ms_since(t_host);
  if (stats) {
    stats->rays += n;
    stats->rechecked += marked.size();
    stats->gpu_ms += gpu_ms;
    stats->host_ms += host_ms;
  }
  return out;
}

}  // namespace icube::nn
