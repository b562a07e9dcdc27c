// GPU host module for shaders/raycast/cast.comp; see raycast_gpu.h.
#include "render/raycast_gpu.h"

#include "shared/raycast_f64_params.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <cfloat>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace icube::render {

namespace {

// Reference voxel and in-voxel offset of a world point, in double.
struct Split {
  glm::ivec3 ref{0};
  glm::dvec3 off{0.0};
};

Split split_point(const glm::dvec3& origin, double voxel_size, const glm::dvec3& p) {
  const glm::dvec3 q = (p - origin) / voxel_size;
  Split s;
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(q[a])) throw std::invalid_argument("raycast: non-finite ray origin");
    const double f = std::floor(q[a]);
    if (std::fabs(f) > double(1 << 30)) throw std::invalid_argument("raycast: ray origin more than 2^30 voxels from the grid origin");
    s.ref[a] = static_cast<int32_t>(f);
    s.off[a] = q[a] - f;
  }
  return s;
}

Split split_point(const RaycastWorld& w, const glm::dvec3& p) { return split_point(w.gpu.origin, w.gpu.voxel_size, p); }

float to_float_t(double t) { return t >= static_cast<double>(FLT_MAX) ? FLT_MAX : static_cast<float>(t); }

int32_t clamp_rel(int64_t v) { return static_cast<int32_t>(std::clamp<int64_t>(v, -RAYCAST_MAX_REL, RAYCAST_MAX_REL)); }

shader::RaycastParams base_params(const RaycastWorld& w, const glm::ivec3& ref, const RaycastOptions& opts) {
  if (!(opts.eps_sem >= 0.0 && opts.eps_depth >= 0.0 && opts.t_max >= 0.0 && std::isfinite(opts.gap_eps)))
    throw std::invalid_argument("raycast: eps_sem, eps_depth and t_max must be non-negative, gap_eps finite");
  shader::RaycastParams p{};
  p.table_mask = w.gpu.table_mask;
  p.pixel_offset = static_cast<float>(pixel_offset(opts.pixels));
  p.ref_x = ref.x;
  p.ref_y = ref.y;
  p.ref_z = ref.z;
  p.inv_voxel = static_cast<float>(1.0 / w.gpu.voxel_size);
  p.t_max = to_float_t(opts.t_max);
  p.eps_sem = static_cast<float>(opts.eps_sem);
  p.eps_depth = static_cast<float>(opts.eps_depth);
  p.gap_eps = static_cast<float>(opts.gap_eps);
  if (!w.bounds.empty()) {
    int32_t* lo[3] = {&p.lo_x, &p.lo_y, &p.lo_z};
    int32_t* hi[3] = {&p.hi_x, &p.hi_y, &p.hi_z};
    for (int a = 0; a < 3; ++a) {
      *lo[a] = clamp_rel(int64_t{w.bounds.min[a]} - ref[a]);
      *hi[a] = clamp_rel(int64_t{w.bounds.max[a]} + 1 - ref[a]);
    }
  }  // else lo = hi = 0: every ray misses
  return p;
}

// The occupancy index layout of raycast_params.h for the world's bounds; false when
// the world is empty, the relative bounds were clamped, the brick records pass the
// entries' 24-bit field or the index would pass max_words (the build writes it through one
// storage binding).
bool occupancy_layout(const RaycastWorld& w, const glm::ivec3& ref, uint64_t max_words, shader::RaycastOccupancyParams& op,
                      uint64_t& words) {
  if (w.bounds.empty()) return false;
  for (int a = 0; a < 3; ++a) {
    const int64_t l = int64_t{w.bounds.min[a]} - ref[a], h = int64_t{w.bounds.max[a]} + 1 - ref[a];
    if (l < -RAYCAST_MAX_REL || h > RAYCAST_MAX_REL) return false;
  }
  const glm::ivec3 smin = w.bounds.min >> RAYCAST_SUPER_SHIFT, smax = w.bounds.max >> RAYCAST_SUPER_SHIFT;
  const glm::u64vec3 sdim(smax - smin + 1);
  const uint64_t supers = sdim.x * sdim.y * sdim.z;
  const uint64_t records = w.gpu.brick_data.size() / (uint64_t{WORLD_BRICK_UINTS} * 4);
  if (records > RAYCAST_MAX_OCC_RECORDS) return false;
  // Every occupied super brick holds at least one brick record.
  const uint64_t max_blocks = std::min(supers, records);
  words = 2 * supers + 2 + max_blocks * RAYCAST_BLOCK_WORDS + records * RAYCAST_MASK_WORDS;
  if (words > max_words) return false;
  op = {};
  op.slots = w.gpu.table_mask + 1;
  op.supers = static_cast<uint32_t>(supers);
  op.smin_x = smin.x; op.smin_y = smin.y; op.smin_z = smin.z;
  op.sdim_x = static_cast<uint32_t>(sdim.x); op.sdim_y = static_cast<uint32_t>(sdim.y); op.sdim_z = static_cast<uint32_t>(sdim.z);
  op.block_word = static_cast<uint32_t>(2 * supers + 2);
  op.max_blocks = static_cast<uint32_t>(max_blocks);
  op.mask_word = static_cast<uint32_t>(2 * supers + 2 + max_blocks * RAYCAST_BLOCK_WORDS);
  return true;
}

}  // namespace

uint64_t new_raycast_world_id() {
  static std::atomic<uint64_t> next_id{1};
  return next_id++;
}

RaycastWorld upload_raycast_world(gpu::Context& ctx, const world::VoxelGrid& grid) {
  return {world::upload_gpu_world(ctx, grid), raycast_bounds(grid), new_raycast_world_id(), 0};
}

// Tile width for a workgroup of `lanes`: the smallest power of two whose square holds the lanes.
static uint32_t tile_width_for(uint32_t lanes) {
  uint32_t w = 1;
  while (w * w < lanes && w < lanes) w *= 2;
  while (lanes % w) w /= 2;
  return std::max<uint32_t>(1, w);
}

// Invocations per workgroup: several subgroups (fewer, larger workgroups cut lavapipe's per-group cost).
static uint32_t workgroup_lanes(const gpu::Context& ctx) { return std::max<uint32_t>(64, ctx.subgroup_size()); }

RaycasterGpu::RaycasterGpu(gpu::Context& ctx, bool skip_empty_bricks)
    : ctx_(ctx),
      occupancy_program_(ctx.program("raycast/occupancy")),
      tile_w_(tile_width_for(ctx.subgroup_size())),
      wg_w_(tile_width_for(workgroup_lanes(ctx))),
      wg_lanes_(workgroup_lanes(ctx)),
      skip_empty_(skip_empty_bricks),
      occupancy_(skip_empty_bricks),
      occ_(ctx, 16, gpu::MemoryUsage::DeviceLocal, "raycast-occupancy"),
      near_(ctx, 16, gpu::MemoryUsage::DeviceLocal, "raycast-near-list"),
      exact_camera_(ctx, std::max(sizeof(shader::RaycastCameraF64), sizeof(shader::RaycastCameraDf)),
                    gpu::MemoryUsage::DeviceLocal, "raycast-exact-camera") {}

bool RaycasterGpu::exact_float_only() const { return force_df_ || !ctx_.info().shader_float64; }

shader::RaycastCameraF64 camera_f64(const Camera& cam, const glm::dvec3& grid_origin, double voxel_size,
                                    const RaycastOptions& opts) {
  const Split s = split_point(grid_origin, voxel_size, camera_position(cam));
  shader::RaycastCameraF64 c{};
  const glm::dmat3 R(cam.c2w);  // column-major: R[c][r]
  double* r[9] = {&c.r00, &c.r01, &c.r02, &c.r10, &c.r11, &c.r12, &c.r20, &c.r21, &c.r22};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) *r[3 * i + j] = R[j][i];
  c.fx = cam.K.fx;
  c.fy = cam.K.fy;
  c.cx = cam.K.cx;
  c.cy = cam.K.cy;
  c.pixel_offset = pixel_offset(opts.pixels);
  c.off_x = s.off.x;
  c.off_y = s.off.y;
  c.off_z = s.off.z;
  c.voxel_size = voxel_size;
  c.eps_sem = opts.eps_sem;
  c.t_max = opts.t_max;
  return c;
}

shader::RaycastCameraDf camera_df(const shader::RaycastCameraF64& c) {
  auto pair = [](double d) {
    const float hi = to_float_t(d);
    return shader::RaycastDf{hi, hi == FLT_MAX ? 0.0f : static_cast<float>(d - static_cast<double>(hi))};
  };
  return {pair(c.r00), pair(c.r01), pair(c.r02), pair(c.r10), pair(c.r11), pair(c.r12), pair(c.r20),
          pair(c.r21), pair(c.r22), pair(c.fx), pair(c.fy), pair(c.cx), pair(c.cy), pair(c.pixel_offset),
          pair(c.off_x), pair(c.off_y), pair(c.off_z), pair(c.voxel_size), pair(c.eps_sem), pair(c.t_max)};
}

std::vector<glm::vec2> df_check_gpu(gpu::Context& ctx, const shader::RaycastDfCheckParams& params,
                                    const std::vector<glm::vec4>& values, const shader::RaycastCameraDf& cam) {
  if (values.empty()) return {};
  if (values.size() > UINT32_MAX) throw std::invalid_argument("df_check: too many values");
  const gpu::Buffer in = gpu::upload_vector(ctx, values, "df-check-in");
  const gpu::Buffer camera = gpu::upload_vector(ctx, std::vector<shader::RaycastCameraDf>{cam}, "df-check-camera");
  gpu::Buffer out(ctx, values.size() * sizeof(glm::vec4), gpu::MemoryUsage::DeviceLocal, "df-check-out");
  shader::RaycastDfCheckParams p = params;
  p.n = static_cast<uint32_t>(values.size());
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    cmd.dispatch(ctx.program("raycast/df_check"), {p.n}, p, {in.binding(), out.binding(), camera.binding()});
  });
  const std::vector<glm::vec4> r = gpu::download_vector<glm::vec4>(ctx, out, values.size());
  std::vector<glm::vec2> res;
  res.reserve(r.size());
  for (const glm::vec4& x : r) res.emplace_back(x.x, x.y);
  return res;
}

gpu::Program& RaycasterGpu::cast_program(bool tiled, bool occupancy, bool exact, bool mark_ties) const {
  // Created on first use and cached by the context: a world without an occupancy index (or
  // set_occupancy(false)) compiles the hash-table variant only when it is needed.
  gpu::SpecConstants spec;
  spec.set(0, wg_lanes_ /* local_size_x */)
      .set(1, skip_empty_ /* RAYCAST_SKIP_EMPTY */)
      .set(2, tiled ? tile_w_ : 0u /* RAYCAST_TILE_W: 0 = rows */)
      .set(5, occupancy /* RAYCAST_OCCUPANCY */);
  if (mark_ties) spec.set(6, true /* RAYCAST_MARK_TIES */);
  if (tiled) spec.set(3, ctx_.subgroup_size() /* RAYCAST_SUB_LANES */).set(4, wg_w_ /* RAYCAST_WG_W */);
  return ctx_.program(!exact ? "raycast/cast" : exact_float_only() ? "raycast/exact_df" : "raycast/exact", spec);
}

shader::RaycastParams RaycasterGpu::camera_params(const RaycastWorld& w, const Camera& cam,
                                                  const RaycastOptions& opts) const {
  validate_camera(cam);
  const uint64_t n = uint64_t{cam.K.width} * cam.K.height;
  if (n > UINT32_MAX) throw std::invalid_argument("raycast: image too large");
  const Split s = split_point(w, camera_position(cam));
  shader::RaycastParams p = base_params(w, s.ref, opts);
  p.n = static_cast<uint32_t>(n);
  p.width = cam.K.width;
  p.off_x = static_cast<float>(s.off.x);
  p.off_y = static_cast<float>(s.off.y);
  p.off_z = static_cast<float>(s.off.z);
  const glm::dmat3 M = camera_ray_matrix(cam);  // column-major: M[c][r]
  float* m[9] = {&p.m00, &p.m01, &p.m02, &p.m10, &p.m11, &p.m12, &p.m20, &p.m21, &p.m22};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) *m[3 * r + c] = static_cast<float>(M[c][r]);
  return p;
}

shader::RaycastParams RaycasterGpu::ray_params(const RaycastWorld& w, const GpuRayBatch& rays,
                                               const RaycastOptions& opts) const {
  shader::RaycastParams p = base_params(w, rays.ref, opts);
  p.n = rays.count;
  p.width = 0;
  return p;
}

GpuRayBatch RaycasterGpu::upload_rays(const RaycastWorld& w, const std::vector<Ray>& rays, bool normalise) {
  if (rays.size() > UINT32_MAX / 2) throw std::invalid_argument("raycast: too many rays");
  GpuRayBatch b;
  b.count = static_cast<uint32_t>(rays.size());
  if (!rays.empty()) b.ref = split_point(w, rays[0].origin).ref;
  std::vector<float> data;
  data.reserve(rays.size() * 8);
  for (const Ray& r : rays) {
    const glm::dvec3 q = (r.origin - w.gpu.origin) / w.gpu.voxel_size - glm::dvec3(b.ref);
    const double len = glm::length(r.dir);
    if (!std::isfinite(q.x + q.y + q.z) || !(len > 0.0) || !std::isfinite(len))
      throw std::invalid_argument("raycast: non-finite ray or zero direction");
    const glm::dvec3 d = normalise ? r.dir / len : r.dir;
    data.insert(data.end(), {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z), 0.0f,
                             static_cast<float>(d.x), static_cast<float>(d.y), static_cast<float>(d.z), 0.0f});
  }
  b.rays = gpu::upload_vector(ctx_, data, "raycast-rays");
  return b;
}

// Rays per window when the hits (48 bytes a ray) or the ray list (32) of a cast exceed one storage
// binding: a multiple of the rays whose hit and ray offsets meet the binding-offset alignment and,
// for tiled camera casts, of whole tile rows (width x tile height); 0 when one tile row does not fit.
static uint64_t rays_per_window(const gpu::DeviceInfo& info, uint64_t n, bool ray_list, uint64_t tile_row) {
  const uint64_t limit = info.max_storage_buffer_range;
  const uint64_t hit = sizeof(shader::RaycastHit), ray = 32;
  if (n * hit <= limit && (!ray_list || n * ray <= limit)) return n;
  uint64_t unit = std::lcm(gpu::aligned_element_unit(info, hit), gpu::aligned_element_unit(info, ray));
  if (tile_row) unit = std::lcm(unit, tile_row);
  return limit / hit / unit * unit;
}

void RaycasterGpu::record(gpu::CommandList& cmd, const RaycastWorld& w, const shader::RaycastParams& params,
                          const gpu::BufferBinding& rays, const gpu::Buffer& hits, const shader::RaycastCameraF64* cam64) {
  if (params.n == 0) return;
  const VkDeviceSize bytes = VkDeviceSize{params.n} * sizeof(shader::RaycastHit);
  if (hits.size() < bytes) throw std::invalid_argument("raycast: hits buffer too small");
  shader::RaycastParams p = params;
  p.first = 0;
  bool occupancy = false;
  shader::RaycastOccupancyParams op{};
  uint64_t words = 0;
  const uint64_t max_words = std::min<uint64_t>(kMaxOccupancyWords, ctx_.info().max_storage_buffer_range / 4);
  if (occupancy_ && skip_empty_ &&
      occupancy_layout(w, glm::ivec3(params.ref_x, params.ref_y, params.ref_z), max_words, op, words)) {
    const VkDeviceSize occ_bytes = words * 4;
    if (occ_.size() < occ_bytes) {
      gpu::Buffer grown(ctx_, std::max<VkDeviceSize>(occ_bytes, occ_.size() * 2), gpu::MemoryUsage::DeviceLocal,
                        "raycast-occupancy");
      ctx_.retire(std::move(occ_));  // recorded commands may still use it
      occ_ = std::move(grown);
      occ_cached_ = false;
    }
    const bool reuse = occ_cached_ && w.id != 0 && w.id == occ_id_ && w.revision == occ_revision_ &&
                       std::memcmp(&op, &occ_params_, sizeof op) == 0;
    if (reuse) {
      cmd.barrier(gpu::deps::kComputeToCompute);  // masks built by an earlier record before the ray caster reads them
    } else {
      // An earlier record (this command list or an earlier one) may still read or build the index.
      cmd.barrier(gpu::deps::kComputeToTransfer);
      // Zeroed super pairs and block counter, and word 2 supers + 1: where the kernel finds the masks.
      const VkDeviceSize mask_word_at = (2 * VkDeviceSize{op.supers} + 1) * 4;
      cmd.fill_buffer(occ_.binding(0, mask_word_at), 0u);
      cmd.update_buffer(occ_.binding(mask_word_at, 4), &op.mask_word, 4);
      cmd.barrier(gpu::deps::kTransferToCompute);  // both before marking
      const auto bindings = {table_texels(w), occ_.binding(0, occ_bytes), brick_texels(w)};
      shader::RaycastOccupancyParams pass = op;  // op (pass 0) is what the cache compares
      pass.pass = RAYCAST_OCC_MARK;
      cmd.dispatch(occupancy_program_, {op.slots}, pass, bindings);
      cmd.barrier(gpu::deps::kComputeToCompute);  // marks before the blocks are allocated
      pass.pass = RAYCAST_OCC_ALLOCATE;
      cmd.dispatch(occupancy_program_, {op.supers}, pass, bindings);
      cmd.barrier(gpu::deps::kComputeToCompute);  // block numbers and zeroed blocks before the entries
      pass.pass = RAYCAST_OCC_FILL;
      cmd.dispatch(occupancy_program_, {op.slots}, pass, bindings);
      cmd.barrier(gpu::deps::kComputeToCompute);  // index before the ray caster reads it
      ++occ_builds_;
      occ_cached_ = w.id != 0;
      occ_id_ = w.id;
      occ_revision_ = w.revision;
      occ_params_ = op;
    }
    occupancy = true;
  }
  const bool exact = cam64 != nullptr && exact_ && p.width != 0;
  const uint64_t lanes = wg_lanes_, th = lanes / wg_w_;
  // Windows of rays when the hits (or the ray list) exceed one binding: whole tile rows, or rows
  // without tiles (the same results) when one tile row does not fit.
  bool tiled = tiled_ && p.width != 0 && tile_w_ > 1;
  uint64_t per = rays_per_window(ctx_.info(), p.n, p.width == 0, tiled ? p.width * th : 0);
  if (per == 0 && tiled) {
    tiled = false;
    per = rays_per_window(ctx_.info(), p.n, false, 0);
  }
  if (per == 0)
    throw std::invalid_argument("raycast: one storage binding of " + std::to_string(ctx_.info().max_storage_buffer_range) +
                                " bytes holds no aligned window of ray hits");
  const bool mark_ties = mark_ties_ && p.width == 0;
  gpu::Program& prog = cast_program(tiled, occupancy, false, mark_ties);
  const gpu::BufferBinding occ_texels = occ_.texel_binding(VK_FORMAT_R32G32_UINT, 0, occ_.size() & ~VkDeviceSize{7});
  const gpu::BufferBinding mask_texels = occ_.texel_binding(VK_FORMAT_R32_UINT, 0, occ_.size() & ~VkDeviceSize{3});
  p.mark_near = exact || mark_ties ? 1u : 0u;
  if (exact) {
    const VkDeviceSize list_bytes = (VkDeviceSize{std::min<uint64_t>(per, p.n)} + 1) * 4;
    if (near_.size() < list_bytes) {
      ctx_.retire(std::move(near_));  // recorded commands may still use it
      near_ = gpu::Buffer(ctx_, list_bytes, gpu::MemoryUsage::DeviceLocal, "raycast-near-list");
    }
    cmd.barrier(gpu::deps::kComputeToTransfer);  // an earlier record's passes may still use the camera
    if (exact_float_only()) {
      const shader::RaycastCameraDf cdf = camera_df(*cam64);
      cmd.update_buffer(exact_camera_.binding(0, sizeof cdf), &cdf, sizeof cdf);
    } else {
      cmd.update_buffer(exact_camera_.binding(0, sizeof *cam64), cam64, sizeof *cam64);
    }
  }
  const uint64_t total = p.n;
  for (uint64_t first = 0; first < total; first += per) {
    const uint64_t count = std::min(per, total - first);
    p.first = static_cast<uint32_t>(first);
    p.n = static_cast<uint32_t>(first + count);
    uint64_t threads = count;
    if (tiled) threads = gpu::tiled_threads(p.width, count / p.width, wg_w_, th, lanes);
    const gpu::BufferBinding hb = hits.binding(first * sizeof(shader::RaycastHit), count * sizeof(shader::RaycastHit));
    gpu::BufferBinding rb = rays;
    if (!rays.null) {  // ray-list mode: this window's rays
      rb.offset += first * 32;
      rb.range = count * 32;
    }
    if (exact) {
      cmd.barrier(gpu::deps::kComputeToTransfer);  // an earlier window's or record's passes may still use the list
      cmd.fill_buffer(near_.binding(0, 4), 0u);
      cmd.barrier(gpu::deps::kTransferToCompute);  // empty list (and double camera) before the passes
    }
    const gpu::BufferBinding near = exact ? near_.binding(0, (count + 1) * 4) : near_.binding();
    cmd.dispatch(prog, {threads}, p, {table_texels(w), rb, hb, occ_texels, brick_texels(w), near, mask_texels});
    if (exact) {
      // Second pass: the rays flagged RAYCAST_FLAG_NEAR (listed by the first) are cast again with the
      // chords near eps_sem decided in double (or double-float); a fixed grid strides over the list.
      cmd.barrier(gpu::deps::kComputeToCompute);  // the float pass's hits and list before the exact pass
      cmd.dispatch(cast_program(false, occupancy, true), {std::min<uint64_t>(count, kExactPassThreads)}, p,
                   {table_texels(w), rb, hb, occ_texels, brick_texels(w), near, exact_camera_.binding(), mask_texels});
    }
  }
}

gpu::BufferBinding RaycasterGpu::table_texels(const RaycastWorld& w) {
  return w.gpu.brick_table.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, w.gpu.brick_table.size() & ~VkDeviceSize{15});
}

gpu::BufferBinding RaycasterGpu::brick_texels(const RaycastWorld& w) {
  return w.gpu.brick_data.texel_binding(VK_FORMAT_R32_UINT, 0, w.gpu.brick_data.size() & ~VkDeviceSize{3});
}

void RaycasterGpu::record_camera(gpu::CommandList& cmd, const RaycastWorld& w, const Camera& cam,
                                 const RaycastOptions& opts, const gpu::Buffer& hits) {
  const shader::RaycastParams p = camera_params(w, cam, opts);
  const shader::RaycastCameraF64 c = camera_f64(cam, w.gpu.origin, w.gpu.voxel_size, opts);
  record(cmd, w, p, gpu::null_binding() /* camera mode makes its rays */, hits, &c);
}

void RaycasterGpu::record_rays(gpu::CommandList& cmd, const RaycastWorld& w, const GpuRayBatch& rays,
                               const RaycastOptions& opts, const gpu::Buffer& hits) {
  record(cmd, w, ray_params(w, rays, opts), rays.rays.binding(), hits);
}

std::vector<shader::RaycastHit> RaycasterGpu::cast_camera(const RaycastWorld& w, const Camera& cam,
                                                          const RaycastOptions& opts) {
  const shader::RaycastParams p = camera_params(w, cam, opts);
  gpu::Buffer hits(ctx_, std::max<VkDeviceSize>(1, p.n) * sizeof(shader::RaycastHit), gpu::MemoryUsage::DeviceLocal,
                   "raycast-hits");
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) { record_camera(cmd, w, cam, opts, hits); });
  return gpu::download_vector<shader::RaycastHit>(ctx_, hits, p.n);
}

std::vector<shader::RaycastHit> RaycasterGpu::cast_rays(const RaycastWorld& w, const std::vector<Ray>& rays,
                                                        const RaycastOptions& opts) {
  if (rays.empty()) return {};
  const GpuRayBatch b = upload_rays(w, rays);
  gpu::Buffer hits(ctx_, VkDeviceSize{b.count} * sizeof(shader::RaycastHit), gpu::MemoryUsage::DeviceLocal,
                   "raycast-hits");
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) { record_rays(cmd, w, b, opts, hits); });
  return gpu::download_vector<shader::RaycastHit>(ctx_, hits, b.count);
}

}  // namespace icube::render
