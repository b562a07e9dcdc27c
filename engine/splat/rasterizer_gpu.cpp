// GPU host module of the Gaussian splatting rasterizer; see rasterizer_gpu.h.
#include "splat/rasterizer_gpu.h"


#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <string>

namespace icube::splat {

namespace {
constexpr uint32_t kLocal = 64;  // non-cooperative kernels: any multiple of the subgroup size
constexpr uint64_t kBlendInvocationsPerTile = SPLAT_TILE_PIXELS / SPLAT_BLEND_PIXELS;  // splat/blend.comp

gpu::SpecConstants local_size() { return gpu::SpecConstants{}.set(0, kLocal /* local_size_x */); }
gpu::SpecConstants blend_spec(const gpu::Context& ctx, kernels::SubgroupOps votes, bool depth, bool carry = false) {
  // Ballots and votes by constant-index shuffles need the whole (at most 16-lane) subgroup
  // inside the tile's workgroup.
  const uint32_t sg = ctx.subgroup_size();
  const bool fits = sg <= 16 && kBlendInvocationsPerTile % sg == 0;
  return gpu::SpecConstants{}
      .set(0, static_cast<uint32_t>(kBlendInvocationsPerTile) /* local_size_x: one tile per workgroup */)
      .set(1, depth /* SPLAT_DEPTH */)
      .set(2, kernels::shuffle_lanes(ctx, votes, fits, "splat blend") /* SPLAT_LANES */)
      .set(3, carry /* SPLAT_CARRY */);
}

}  // namespace

SplatFrameBuffers::SplatFrameBuffers(gpu::Context& ctx)
    : incomplete(ctx, 16, gpu::MemoryUsage::DeviceLocal, "splat-bin-incomplete"),
      blend_status(ctx, 16, gpu::MemoryUsage::DeviceLocal, "splat-blend-status"),
      readback(ctx, 16, gpu::MemoryUsage::Readback, "splat-readback"),
      binning(ctx, kernels::KeyWidth::Bits32, "splat") {}

uint64_t SplatFrameBuffers::bytes() const {
  uint64_t s = 0;
  for (const gpu::Buffer* b : {&proj, &records, &rects, &bin_records, &depth_keys, &order, &values, &ranges, &rgba, &depth,
                               &sky, &carry_color, &carry_depth, &slice.gaussians, &slice.sh})
    s += b->valid() ? b->size() : 0;
  if (depth_sort_scratch)
    s += depth_sort_scratch->keys.size() + depth_sort_scratch->values.size() + depth_sort_scratch->histogram.size() +
         depth_sort_scratch->scan_scratch.size();
  return s + binning.bytes();
}

SplatRendererGpu::SplatRendererGpu(gpu::Context& ctx, SplatGpuVariant variant)
    : ctx_(ctx),
      counts_(ctx.program("splat/sorted_counts", local_size())),
      duplicate_(ctx.program("splat/duplicate", local_size())),
      ranges_(ctx.program("splat/ranges", local_size())),
      blend_(variant.tile_blend ? ctx.program("splat/blend", blend_spec(ctx, variant.votes, true))
                                : ctx.program("splat/blend_rows", local_size())),
      blend_color_(variant.tile_blend ? ctx.program("splat/blend", blend_spec(ctx, variant.votes, false)) : blend_),
      variant_(variant),
      counting_(variant.binning == TileBinning::Counting ||
                (variant.binning == TileBinning::Auto && ctx.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU)),
      depth_sort_(ctx, kernels::KeyWidth::Bits32),
      counting_binning_(ctx),
      slicer_(ctx),
      f_(std::make_unique<SplatFrameBuffers>(ctx)),
      t1_(std::make_unique<gpu::GpuTimer>(ctx, 4)),
      t2_(std::make_unique<gpu::GpuTimer>(ctx, 4)) {}

SplatRendererGpu::~SplatRendererGpu() = default;

glm::dvec3 gaussian_origin(const GaussianCloud& cloud) {
  if (cloud.positions.empty()) return glm::dvec3(0.0);
  glm::dvec3 lo = cloud.positions[0], hi = lo;
  for (const auto& p : cloud.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  return glm::floor(0.5 * (lo + hi));  // whole metres: exact in float for any planet-sized scene
}

uint32_t gpu_sh_stride(uint32_t sh_degree) {
  const uint32_t K = (sh_degree + 1) * (sh_degree + 1);
  return (3 * K + 3) / 4 * 4;
}

void pack_gaussians(const GaussianCloud& cloud, const glm::dvec3& origin, uint32_t sh_stride,
                    std::vector<shader::SplatGaussian>& rows, std::vector<float>& sh) {
  const uint32_t K = cloud.sh_coeffs();
  if (sh_stride < 3 * K) throw std::invalid_argument("splat: SH stride below the cloud's coefficients");
  rows.resize(cloud.size());
  sh.assign(cloud.size() * sh_stride, 0.0f);
  for (size_t i = 0; i < cloud.size(); ++i) {
    const glm::dvec3 d = cloud.positions[i] - origin;
    const auto cov = covariance3d(cloud.scales[i], cloud.rotations[i]);
    rows[i] = shader::SplatGaussian{static_cast<float>(d.x), static_cast<float>(d.y), static_cast<float>(d.z),
                                    cloud.opacities[i], cov[0], cov[1], cov[2], cov[3], cov[4], cov[5], 0.0f, 0.0f};
    std::memcpy(&sh[i * sh_stride], &cloud.sh[i * K * 3], K * 3 * sizeof(float));
  }
}

GpuGaussians SplatRendererGpu::upload(const GaussianCloud& cloud) {
  cloud.validate();
  if (cloud.size() > UINT32_MAX / 4) throw std::invalid_argument("splat: too many Gaussians");
  GpuGaussians g;
  g.count = static_cast<uint32_t>(cloud.size());
  g.sh_degree = cloud.sh_degree;
  g.sh_stride = gpu_sh_stride(cloud.sh_degree);
  g.origin = gaussian_origin(cloud);
  std::vector<shader::SplatGaussian> rows;
  std::vector<float> sh;
  pack_gaussians(cloud, g.origin, g.sh_stride, rows, sh);
  g.gaussians = gpu::upload_vector(ctx_, rows, "splat-gaussians");
  g.sh = gpu::upload_vector(ctx_, sh, "splat-sh");
  return g;
}

uint64_t SplatRendererGpu::gaussians_per_pass() const {
  const uint64_t limit = ctx_.info().max_storage_buffer_range;
  const uint64_t widest = std::max<uint64_t>({sizeof(shader::SplatProjected), sizeof(shader::SplatBlendRecord),
                                              sizeof(shader::SplatGaussian), sizeof(shader::SplatBinRecord), 16});
  const uint64_t device = std::min<uint64_t>({limit / widest, ctx_.info().max_texel_buffer_elements / 3,
                                              depth_sort_.max_elements(), UINT32_MAX / 4});
  return variant_.max_pass_gaussians ? std::min(device, variant_.max_pass_gaussians) : device;
}

uint64_t SplatRendererGpu::instances_per_pass() const {
  return std::min<uint64_t>({ctx_.info().max_storage_buffer_range / 4, ctx_.info().max_texel_buffer_elements,
                             f_->binning.max_instances()});
}

SplatFramePlan SplatRendererGpu::plan(const GpuGaussians& g, const render::Camera& cam, const SplatOptions& opts) {
  SplatFramePlan p;
  p.gaussians = &g;
  p.opts = opts;
  p.frame = make_frame(cam, opts, g.origin);
  if (band_rows_) restrict_to_band(p.frame, band_y0_, band_rows_);
  validate_sky(opts.sky);
  p.width = cam.K.width;
  p.height = band_rows_ ? std::min<uint32_t>(band_rows_ * SPLAT_TILE, cam.K.height - band_y0_ * SPLAT_TILE) : cam.K.height;
  p.tiles = p.frame.grid_x * p.frame.grid_y;
  p.n = g.count;
  const uint64_t n = p.n, W = p.width, H = p.height;
  SplatFrameBuffers& f = *f_;
  const uint64_t limit = ctx_.info().max_storage_buffer_range;
  const uint64_t texel_limit = ctx_.info().max_texel_buffer_elements;  // texels of one texel-buffer view
  if (W * H * 16 > limit)
    throw std::invalid_argument("splat: a " + std::to_string(W) + "x" + std::to_string(H) + " image (" +
                                std::to_string(W * H * 16 >> 20) + " MiB of RGBA floats) exceeds one storage binding (" +
                                std::to_string(limit >> 20) + " MiB); render at most " +
                                std::to_string(limit / 16 / std::max<uint64_t>(W, 1)) + " rows at this width");
  if (p.frame.grid_x > 0xFFFFu || p.frame.grid_y > 0xFFFFu)  // SplatBinRecord packs tile coordinates in 16 bits
    throw std::invalid_argument("splat: a " + std::to_string(W) + "x" + std::to_string(H) +
                                " image has more than 65,535 tile columns or rows");
  p.sliced = n > gaussians_per_pass();
  if (!p.sliced) {
    gpu::ensure_capacity(ctx_, f.proj, n * sizeof(shader::SplatProjected), "splat-proj");
    gpu::ensure_capacity(ctx_, f.records, n * sizeof(shader::SplatBlendRecord), "splat-blend-records");
    gpu::ensure_capacity(ctx_, f.rects, n * 16, "splat-rects");
    gpu::ensure_capacity(ctx_, f.bin_records, n * sizeof(shader::SplatBinRecord), "splat-bin-records");
    gpu::ensure_capacity(ctx_, f.depth_keys, n * 4, "splat-depth-keys");
    gpu::ensure_capacity(ctx_, f.order, n * 4, "splat-order");
    f.binning.reserve_items(n);
  }
  gpu::ensure_capacity(ctx_, f.ranges, uint64_t{p.tiles} * 8, "splat-ranges");
  gpu::ensure_capacity(ctx_, f.rgba, W * H * 16, "splat-rgba");
  // splat_blend_rows always writes depth; splat_blend only with opts.depth.
  if (opts.depth || !variant_.tile_blend) gpu::ensure_capacity(ctx_, f.depth, W * H * 8, "splat-depth");
  if (opts.sky.kind == SkyKind::Equirect && f.sky_image != opts.sky.image) {
    const SkyImage& im = *opts.sky.image;
    if (im.rgba.size() / 4 > texel_limit)  // read as R32_UINT texels only
      throw std::invalid_argument("splat sky: a " + std::to_string(im.width) + "x" + std::to_string(im.height) +
                                  " image exceeds this device's " + std::to_string(texel_limit) +
                                  " texels of one texel buffer; use a smaller sky image");
    gpu::Buffer sky = gpu::upload_vector(ctx_, im.rgba, "splat-sky");
    ctx_.retire(std::move(f.sky));
    f.sky = std::move(sky);
    f.sky_image = opts.sky.image;
  }
  if (n > 0 && !p.sliced && (!f.depth_sort_scratch || f.depth_sort_scratch->capacity < n))
    f.depth_sort_scratch = std::make_unique<kernels::RadixSortScratch>(ctx_, n + n / 2, kernels::KeyWidth::Bits32);

  shader::SplatBlendParams& bp = p.blend;
  bp.width = p.width;
  bp.height = cam.K.height;  // pixel rows are the whole image's (a band's start at 16 tile_y0)
  bp.grid_x = p.frame.grid_x;
  bp.grid_y = p.frame.grid_y;
  bp.tile_y0 = p.frame.tile_y0;
  bp.pixel_offset = static_cast<float>(render::pixel_offset(opts.pixels));
  bp.sky_kind = static_cast<uint32_t>(opts.sky.kind);
  if (opts.sky.kind == SkyKind::Equirect) {
    bp.sky_w = opts.sky.image->width;
    bp.sky_h = opts.sky.image->height;
  }
  bp.bg_r = opts.background.x;
  bp.bg_g = opts.background.y;
  bp.bg_b = opts.background.z;
  const SkyGradient& sg = opts.sky.gradient;
  bp.zen_r = sg.zenith.x;
  bp.zen_g = sg.zenith.y;
  bp.zen_b = sg.zenith.z;
  bp.hor_r = sg.horizon.x;
  bp.hor_g = sg.horizon.y;
  bp.hor_b = sg.horizon.z;
  bp.gnd_r = sg.ground.x;
  bp.gnd_g = sg.ground.y;
  bp.gnd_b = sg.ground.z;
  sky_ray_matrix(cam, &bp.m00);
  if (variant_.tile_blend)
    bp.loop_budget = variant_.blend_loop_budget >= 0 ? static_cast<uint32_t>(variant_.blend_loop_budget)
                     : ctx_.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU ? SPLAT_BLEND_LOOP_BUDGET
                                                                        : 0u;
  return p;
}

void SplatRendererGpu::record_preprocess(gpu::CommandList& cmd, const SplatFramePlan& p) {
  if (p.sliced) throw std::logic_error("splat: a frame over one pass is rendered in depth slices by render()");
  const uint64_t n = p.n;
  SplatFrameBuffers& f = *f_;
  t1_->reset(cmd);
  if (n == 0) {  // no Gaussians: an instance total of 0 for read_instances
    cmd.barrier(gpu::deps::kComputeToTransfer);  // an earlier frame's copy into the readback
    cmd.fill_buffer(f.readback.binding(0, 4), 0u);
    return;
  }
  const GpuGaussians& g = *p.gaussians;
  const uint64_t limit = ctx_.info().max_storage_buffer_range;
  const uint64_t texel_limit = ctx_.info().max_texel_buffer_elements;
  // SH windows: each a storage-sized range that one R32G32B32A32_UINT texel view can hold,
  // starting at a texel-offset-aligned byte offset (sh_stride is a multiple of 4).
  const uint64_t sh_bytes = uint64_t{g.sh_stride} * 4;
  const uint64_t texel_align = std::max<uint64_t>(1, ctx_.info().min_texel_buffer_offset_alignment);
  const auto windows = gpu::storage_windows(ctx_.info(), n, g.sh_stride * 4, texel_align / std::gcd(texel_align, sh_bytes),
                                            std::min(limit, texel_limit * 16));
  // A preprocess pipeline per SH degree (splat_preprocess's SPLAT_SH_DEGREE), made on first use.
  gpu::Program& preprocess =
      ctx_.program("splat/preprocess", gpu::SpecConstants{}.set(0, kLocal /* local_size_x */).set(1, g.sh_degree /* SPLAT_SH_DEGREE */));
  const int ti = t1_->begin(cmd, "preprocess");
  for (const auto& w : windows) {
    shader::SplatPreprocessParams pp = p.frame.pre;
    pp.n = static_cast<uint32_t>(w.count);
    pp.first = static_cast<uint32_t>(w.first);
    pp.sh_stride = g.sh_stride;
    cmd.dispatch(preprocess, {w.count}, pp,
                 {g.gaussians.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::SplatGaussian)),
                  g.sh.texel_binding(VK_FORMAT_R32G32B32A32_UINT, w.first * sh_bytes, w.count * sh_bytes),
                  f.proj.binding(0, n * sizeof(shader::SplatProjected)), f.rects.binding(0, n * 16),
                  f.depth_keys.binding(0, n * 4), f.order.binding(0, n * 4),
                  f.records.binding(0, n * sizeof(shader::SplatBlendRecord))});
  }
  t1_->end(cmd, ti);
  cmd.barrier(gpu::deps::kComputeToCompute);  // the sort reads the depth keys
  const int td = t1_->begin(cmd, "depth sort");
  depth_sort_.record(cmd, f.depth_keys, f.order, n, *f.depth_sort_scratch, p.opts.depth_key_bits);
  cmd.barrier(gpu::deps::kComputeToCompute);  // counts read the order
  const uint32_t cull = variant_.exact_cull ? 1u : 0u;
  cmd.dispatch(counts_, {n}, shader::SplatDuplicateParams{static_cast<uint32_t>(n), p.frame.grid_x, cull, p.frame.tile_y0},
               {f.order.binding(0, n * 4), f.binning.counts().binding(0, n * 4),
                f.rects.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * 16),
                f.records.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::SplatBlendRecord)),
                f.bin_records.binding(0, n * sizeof(shader::SplatBinRecord))});
  cmd.barrier(gpu::deps::kComputeToCompute);  // the scan reads the counts
  f.binning.record_scan(cmd, n, f.readback.binding(0, 4));
  t1_->end(cmd, td);
}

uint64_t SplatRendererGpu::read_instances(SplatFramePlan& p) {
  SplatFrameBuffers& f = *f_;
  uint32_t total = 0;
  std::memcpy(&total, f.readback.mapped(), 4);
  p.instances = total;
  const uint64_t inst = total;
  const uint64_t limit = ctx_.info().max_storage_buffer_range;
  const uint64_t texel_limit = ctx_.info().max_texel_buffer_elements;
  p.chunks = counting_ && inst > 0 ? counting_binning_.chunks_for(inst, p.tiles, variant_.bin_chunks) : 0u;
  p.counting = p.chunks > 0;  // else radix (also when the counters would not fit one binding)
  if (inst * 4 > limit || inst > texel_limit || (!p.counting && inst > f.binning.max_instances())) {
    p.sliced = true;  // render() blends the frame in depth slices
    return inst;
  }
  gpu::ensure_capacity(ctx_, f.values, std::max<uint64_t>(inst, 1) * 4, "splat-values");
  if (!p.counting) f.binning.reserve_instances(inst);
  return inst;
}

const gpu::Buffer& SplatRendererGpu::instance_values(const SplatFramePlan& p) const {
  return p.counting ? f_->values : f_->binning.values();
}

void SplatRendererGpu::record_bin(gpu::CommandList& cmd, const SplatFramePlan& p) {
  SplatFrameBuffers& f = *f_;
  const uint64_t n = p.n, inst = p.instances;
  t2_->reset(cmd);
  const int ts = t2_->begin(cmd, "sort");
  if (p.counting) {
    counting_binning_.record(cmd,
                             TileBinningGpu::Frame{f.order, f.binning.offsets(), f.bin_records, n, inst, p.frame.grid_x,
                                                   p.tiles, variant_.exact_cull, p.chunks, p.frame.tile_y0},
                             f.values, f.ranges, f.incomplete);
  } else {
    if (inst > 0) {
      const uint32_t cull = variant_.exact_cull ? 1u : 0u;
      cmd.dispatch(duplicate_, {n}, shader::SplatDuplicateParams{static_cast<uint32_t>(n), p.frame.grid_x, cull, p.frame.tile_y0},
                   {f.order.binding(0, n * 4),
                    f.bin_records.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::SplatBinRecord)),
                    f.binning.counts().binding(0, n * 4), f.binning.offsets().binding(0, n * 4),
                    f.binning.keys().binding(0, inst * 4), f.binning.values().binding(0, inst * 4)});
      cmd.barrier(gpu::deps::kComputeToCompute);  // the sort reads the keys and values
    }
    const uint32_t tile_bits = std::max<uint32_t>(1, static_cast<uint32_t>(std::bit_width(p.tiles - 1u)));
    f.binning.record_sort_ranges(cmd, inst, tile_bits, ranges_, f.ranges, p.tiles);
  }
  t2_->end(cmd, ts);
  cmd.barrier(gpu::deps::kComputeToCompute);  // the blend reads the ranges and the instance list
}

void SplatRendererGpu::record_blend(gpu::CommandList& cmd, const SplatFramePlan& p) {
  SplatFrameBuffers& f = *f_;
  const uint64_t n = p.n, inst = p.instances, pixels = uint64_t{p.width} * p.height;
  const bool tile_blend = variant_.tile_blend;
  const bool depth_out = p.opts.depth || !tile_blend;
  if (tile_blend) {
    cmd.barrier(gpu::deps::kComputeToTransfer);  // an earlier frame's blend and copy are done with it
    cmd.fill_buffer(f.blend_status.binding(0, 4), 0u);
    cmd.barrier(gpu::deps::kTransferToCompute);  // zeroed status before the blend counts into it
  }
  const int tb = t2_->begin(cmd, "blend");
  if (p.blend.carry & SPLAT_CARRY_IN) cmd.barrier(gpu::deps::kComputeToCompute);  // the nearer slice's blend wrote the state
  std::vector<gpu::BufferBinding> bindings = {
      f.ranges.binding(0, uint64_t{p.tiles} * 8),
      inst > 0 ? instance_values(p).texel_binding(VK_FORMAT_R32_UINT, 0, inst * 4) : gpu::null_binding(),
      n > 0 ? f.records.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::SplatBlendRecord))
            : gpu::null_binding(VK_FORMAT_R32G32B32A32_UINT),
      f.rgba.binding(0, pixels * 16),
      depth_out ? f.depth.binding(0, pixels * 8) : gpu::null_binding(),
      p.opts.sky.kind == SkyKind::Equirect
          ? f.sky.texel_binding(VK_FORMAT_R32_UINT, 0, p.opts.sky.image->rgba.size() & ~size_t{3})
          : gpu::null_binding()};
  if (tile_blend) {
    bindings.push_back(f.blend_status.binding(0, 4));
    const bool carry = p.blend.carry != 0;
    bindings.push_back(carry ? f.carry_color.binding(0, pixels * 16) : gpu::null_binding());
    bindings.push_back(carry && p.opts.depth ? f.carry_depth.binding(0, pixels * 8) : gpu::null_binding());
  }
  // Slices: the pipeline with the carried state (made on first use); one pass: without it.
  gpu::Program& blend = p.blend.carry != 0 ? ctx_.program("splat/blend", blend_spec(ctx_, variant_.votes, p.opts.depth, true))
                        : p.opts.depth     ? blend_
                                           : blend_color_;
  cmd.dispatch(blend, {uint64_t{p.tiles} * kBlendInvocationsPerTile}, p.blend, bindings);
  t2_->end(cmd, tb);
  if (tile_blend) {
    cmd.barrier(gpu::deps::kComputeToTransfer);  // the copy reads the blend's status
    cmd.copy_buffer(f.blend_status.binding(0, 4), f.readback.binding(8, 4));
  }
  if (p.counting) {
    cmd.barrier(gpu::deps::kComputeToTransfer);  // the copy reads the walks' flag
    cmd.copy_buffer(f.incomplete.binding(0, 4), f.readback.binding(4, 4));
  }
}

bool SplatRendererGpu::finish(SplatFramePlan& p) {
  const char* rb = static_cast<const char*>(f_->readback.mapped());
  if (p.counting) {
    uint32_t incomplete = 0;
    std::memcpy(&incomplete, rb + 4, 4);
    if (incomplete) return false;  // a walk was cut short (lavapipe's loop limit)
  }
  if (variant_.tile_blend) {
    uint32_t over = 0;
    std::memcpy(&over, rb + 8, 4);
    if (over > 0)
      throw std::runtime_error("splat: " + std::to_string(over) + " pixel block(s) of " + std::to_string(p.width) + "x" +
                               std::to_string(p.height) + " frame need more than " + std::to_string(p.blend.loop_budget) +
                               " blend loop iterations (lavapipe ends a shader's loops after 65,535), so the image "
                               "would be incomplete; too many Gaussians overlap one 16x16 tile (" +
                               std::to_string(p.instances) + " tile instances in all)");
  }
  return true;
}

void SplatRendererGpu::run_preprocess(SplatFramePlan& p, PassTimes& t, bool after_gather) {
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    if (after_gather) cmd.barrier(gpu::deps::kComputeToCompute);  // preprocess reads the gathered slice
    record_preprocess(cmd, p);
  });
  if (p.n > 0) {
    t.preprocess_ms += t1_->milliseconds(0);
    t.depth_sort_ms += t1_->milliseconds(1);
  }
  read_instances(p);
}

void SplatRendererGpu::run_bin_blend(SplatFramePlan& p, PassTimes& t) {
  auto bin_and_blend = [&](gpu::CommandList& cmd) {
    record_bin(cmd, p);
    record_blend(cmd, p);
  };
  ctx_.submit_and_wait(bin_and_blend);
  if (!finish(p)) {  // the counting walks were cut short: bin this frame with the radix path
    p.fallback = true;
    p.counting = false;
    f_->binning.reserve_instances(p.instances);
    ctx_.submit_and_wait(bin_and_blend);
    finish(p);
  }
  t.sort_ms += t2_->milliseconds(0);
  t.blend_ms += t2_->milliseconds(1);
  t.instances += p.instances;
  t.fallback = t.fallback || p.fallback;
}

uint32_t SplatRendererGpu::run_slices(const GpuGaussians& g, const render::Camera& cam, const SplatOptions& opts,
                                      PassTimes& t) {
  if (!variant_.tile_blend)
    throw std::invalid_argument("splat: a frame over one pass (depth slices) needs the tile blend (SplatGpuVariant::tile_blend)");
  SplatFrameBuffers& f = *f_;
  SplatFrame frame = make_frame(cam, opts, g.origin);
  if (band_rows_) restrict_to_band(frame, band_y0_, band_rows_);
  const std::vector<DepthSlice> slices =
      slicer_.plan(g, frame, opts.depth_key_bits, gaussians_per_pass(), instances_per_pass());
  const uint64_t pixels =
      uint64_t{cam.K.width} * (band_rows_ ? std::min<uint32_t>(band_rows_ * SPLAT_TILE, cam.K.height - band_y0_ * SPLAT_TILE)
                                          : cam.K.height);
  if (slices.size() > 1) {
    gpu::ensure_capacity(ctx_, f.carry_color, pixels * 16, "splat-carry-color");
    if (opts.depth) gpu::ensure_capacity(ctx_, f.carry_depth, pixels * 8, "splat-carry-depth");
  }
  const size_t passes = std::max<size_t>(slices.size(), 1);  // no visible Gaussian: one pass of none (the sky)
  for (size_t k = 0; k < passes; ++k) {
    if (slices.empty()) {
      f.slice.count = 0;
      f.slice.origin = g.origin;
      f.slice.sh_degree = g.sh_degree;
      f.slice.sh_stride = g.sh_stride;
    } else {
      slicer_.gather(g, slices[k], f.slice);
    }
    SplatFramePlan q = plan(f.slice, cam, opts);
    q.blend.carry = (k > 0 ? SPLAT_CARRY_IN : 0u) | (k + 1 < passes ? SPLAT_CARRY_OUT : 0u);
    run_preprocess(q, t, true);
    if (q.sliced)
      throw std::logic_error("splat: depth slice " + std::to_string(k) + " of " + std::to_string(q.n) + " Gaussians made " +
                             std::to_string(q.instances) + " tile instances, over one pass");
    run_bin_blend(q, t);
  }
  return static_cast<uint32_t>(slices.size());
}

SplatImage SplatRendererGpu::render_bands(const GpuGaussians& g, const render::Camera& cam, const SplatOptions& opts,
                                          SplatTimings* timings, SplatDebug* debug, bool download) {
  const auto t0 = std::chrono::steady_clock::now();
  const uint64_t W = cam.K.width, H = cam.K.height, limit = ctx_.info().max_storage_buffer_range;
  if (!download)
    throw std::invalid_argument("splat: a " + std::to_string(W) + "x" + std::to_string(H) +
                                " image exceeds one storage binding and is rendered in bands: download it");
  if (debug) throw std::invalid_argument("splat: stage-by-stage debug output is for frames of one pass");
  const uint64_t rows = limit / 16 / W / SPLAT_TILE * SPLAT_TILE;  // whole tile rows of RGBA floats per band
  if (rows == 0)
    throw std::invalid_argument("splat: one row of 16x16 tiles of a " + std::to_string(W) +
                                "-pixel-wide image exceeds one storage binding (" + std::to_string(limit) +
                                " bytes); render at most " + std::to_string(limit / 16 / SPLAT_TILE) + " pixels wide");
  SplatImage img;
  img.width = cam.K.width;
  img.height = cam.K.height;
  img.rgba.assign(W * H * 4, 0.0f);
  if (opts.depth) img.depth.assign(W * H * 2, 0.0f);
  SplatTimings sum;
  for (uint64_t y0 = 0; y0 < H; y0 += rows) {
    // Tile rows [y0 / 16, ...) of the whole image's frame (restrict_to_band): the same pixels.
    SplatTimings t;
    band_y0_ = static_cast<uint32_t>(y0 / SPLAT_TILE);
    band_rows_ = static_cast<uint32_t>(gpu::div_up(std::min(rows, H - y0), uint64_t{SPLAT_TILE}));
    SplatImage b;
    try {
      b = render(g, cam, opts, &t, nullptr, true);
    } catch (...) {
      band_rows_ = 0;
      throw;
    }
    band_rows_ = 0;
    std::copy(b.rgba.begin(), b.rgba.end(), img.rgba.begin() + static_cast<ptrdiff_t>(y0 * W * 4));
    if (opts.depth) std::copy(b.depth.begin(), b.depth.end(), img.depth.begin() + static_cast<ptrdiff_t>(y0 * W * 2));
    sum.preprocess_ms += t.preprocess_ms;
    sum.depth_sort_ms += t.depth_sort_ms;
    sum.sort_ms += t.sort_ms;
    sum.blend_ms += t.blend_ms;
    sum.instances += t.instances;
    sum.slices += t.slices;
    sum.binning_fallback = sum.binning_fallback || t.binning_fallback;
    sum.frame_bytes = std::max(sum.frame_bytes, t.frame_bytes);
    ++sum.bands;
  }
  sum.wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (timings) *timings = sum;
  return img;
}

SplatImage SplatRendererGpu::render(const GpuGaussians& g, const render::Camera& cam, const SplatOptions& opts,
                                    SplatTimings* timings, SplatDebug* debug, bool download) {
  if (band_rows_ == 0 && uint64_t{cam.K.width} * cam.K.height * 16 > ctx_.info().max_storage_buffer_range)
    return render_bands(g, cam, opts, timings, debug, download);
  const auto t0 = std::chrono::steady_clock::now();
  SplatFramePlan p = plan(g, cam, opts);
  PassTimes pt;
  // One pass: submission 1 (preprocess, depth sort, tiles touched in depth order, scan, total to
  // the host), submission 2 (binning by tile, blend). A frame whose Gaussians (plan) or tile
  // instances (read_instances) exceed one pass: depth slices.
  if (!p.sliced) run_preprocess(p, pt, false);
  uint32_t slices = 0;
  if (p.sliced) {
    if (debug) throw std::invalid_argument("splat: stage-by-stage debug output is for frames of one pass");
    slices = run_slices(g, cam, opts, pt);
  } else {
    run_bin_blend(p, pt);
  }

  const SplatFrameBuffers& f = *f_;
  const uint64_t n = p.n, inst = p.instances;
  SplatImage img;
  img.width = p.width;
  img.height = p.height;
  if (download) {
    img.rgba = gpu::download_vector<float>(ctx_, f.rgba, size_t{p.width} * p.height * 4);
    if (opts.depth) img.depth = gpu::download_vector<float>(ctx_, f.depth, size_t{p.width} * p.height * 2);
  }
  if (debug) {
    debug->proj = gpu::download_vector<shader::SplatProjected>(ctx_, f.proj, n);
    debug->values = inst ? gpu::download_vector<uint32_t>(ctx_, instance_values(p), inst) : std::vector<uint32_t>{};
    debug->ranges = gpu::download_vector<uint32_t>(ctx_, f.ranges, size_t{p.tiles} * 2);
    debug->counting = p.counting;
    debug->binning_fallback = p.fallback;
    std::vector<uint32_t> tile_ids;
    if (!p.counting) {
      tile_ids = inst ? gpu::download_vector<uint32_t>(ctx_, f.binning.keys(), inst) : std::vector<uint32_t>{};
    } else {  // the counting path keeps no tile ids: each instance's tile from the ranges (UINT32_MAX: none)
      tile_ids.assign(inst, UINT32_MAX);
      for (uint32_t t = 0; t < p.tiles; ++t)
        for (uint32_t k = debug->ranges[2 * t]; k < debug->ranges[2 * t + 1] && k < inst; ++k) tile_ids[k] = t;
    }
    debug->keys.resize(inst);
    for (size_t i = 0; i < inst; ++i) {
      const uint32_t zbits = depth_sort_key(debug->proj[debug->values[i]].depth, p.opts.depth_key_bits);
      debug->keys[i] = (uint64_t{tile_ids[i]} << 32) | zbits;
    }
  }
  if (timings) {
    timings->preprocess_ms = pt.preprocess_ms;
    timings->depth_sort_ms = pt.depth_sort_ms;
    timings->sort_ms = pt.sort_ms;
    timings->blend_ms = pt.blend_ms;
    timings->instances = p.sliced ? pt.instances : inst;
    timings->binning_chunks = p.counting && !p.sliced ? p.chunks : 0;
    timings->binning_fallback = pt.fallback;
    timings->slices = slices;
    timings->frame_bytes = f.bytes() + counting_binning_.bytes() + slicer_.bytes();
    timings->wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  return img;
}

}  // namespace icube::splat
