// GPU host module of the Gaussian splatting rasterizer; see rasterizer_gpu.h.
#include "splat/rasterizer_gpu.h"

#include "splat/tile_ranges_gpu.h"

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
gpu::SpecConstants blend_spec(const gpu::Context& ctx, kernels::SubgroupOps votes, bool depth) {
  // Ballots and votes by constant-index shuffles need the whole (at most 16-lane) subgroup
  // inside the tile's workgroup.
  const uint32_t sg = ctx.subgroup_size();
  const bool fits = sg <= 16 && kBlendInvocationsPerTile % sg == 0;
  return gpu::SpecConstants{}
      .set(0, static_cast<uint32_t>(kBlendInvocationsPerTile) /* local_size_x: one tile per workgroup */)
      .set(1, depth /* SPLAT_DEPTH */)
      .set(2, kernels::shuffle_lanes(ctx, votes, fits, "splat blend") /* SPLAT_LANES */);
}

}  // namespace

struct SplatRendererGpu::Frame {
  gpu::Buffer proj, records, rects, bin_records, depth_keys, order, counts, offsets, scan_scratch, keys, values, ranges, rgba,
      depth, total, sky, incomplete, blend_status;
  std::shared_ptr<const SkyImage> sky_image;  // the image currently in `sky`
  std::unique_ptr<kernels::RadixSortScratch> sort_scratch;
  std::unique_ptr<gpu::GpuTimer> t1, t2;
  uint64_t binning_bytes = 0;  // TileBinningGpu's counters (counting path)
  uint64_t bytes() const {
    uint64_t s = 0;
    for (const gpu::Buffer* b : {&proj, &records, &rects, &bin_records, &depth_keys, &order, &counts, &offsets, &scan_scratch, &keys,
                                 &values, &ranges, &rgba, &depth, &sky})
      s += b->valid() ? b->size() : 0;
    if (sort_scratch)
      s += sort_scratch->keys.size() + sort_scratch->values.size() + sort_scratch->histogram.size() +
           sort_scratch->scan_scratch.size();
    return s + binning_bytes;
  }
};

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
      scan_(ctx),
      sort_(ctx, kernels::KeyWidth::Bits32),
      binning_(ctx),
      f_(std::make_unique<Frame>()) {
  f_->t1 = std::make_unique<gpu::GpuTimer>(ctx, 4);
  f_->t2 = std::make_unique<gpu::GpuTimer>(ctx, 4);
  f_->total = gpu::Buffer(ctx, 16, gpu::MemoryUsage::Readback, "splat-total");
  f_->incomplete = gpu::Buffer(ctx, 16, gpu::MemoryUsage::DeviceLocal, "splat-bin-incomplete");
  f_->blend_status = gpu::Buffer(ctx, 16, gpu::MemoryUsage::DeviceLocal, "splat-blend-status");
}

SplatRendererGpu::~SplatRendererGpu() = default;

GpuGaussians SplatRendererGpu::upload(const GaussianCloud& cloud) {
  cloud.validate();
  if (cloud.size() > UINT32_MAX / 4) throw std::invalid_argument("splat: too many Gaussians");
  GpuGaussians g;
  g.count = static_cast<uint32_t>(cloud.size());
  g.sh_degree = cloud.sh_degree;
  const uint32_t K = cloud.sh_coeffs();
  g.sh_stride = (3 * K + 3) / 4 * 4;
  if (!cloud.positions.empty()) {
    glm::dvec3 lo = cloud.positions[0], hi = lo;
    for (const auto& p : cloud.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    g.origin = glm::floor(0.5 * (lo + hi));  // whole metres: exact in float for any planet-sized scene
  }
  std::vector<shader::SplatGaussian> rows(cloud.size());
  std::vector<float> sh(cloud.size() * g.sh_stride, 0.0f);
  for (size_t i = 0; i < cloud.size(); ++i) {
    const glm::dvec3 d = cloud.positions[i] - g.origin;
    const auto cov = covariance3d(cloud.scales[i], cloud.rotations[i]);
    rows[i] = shader::SplatGaussian{static_cast<float>(d.x), static_cast<float>(d.y), static_cast<float>(d.z),
                                    cloud.opacities[i], cov[0], cov[1], cov[2], cov[3], cov[4], cov[5], 0.0f, 0.0f};
    std::memcpy(&sh[i * g.sh_stride], &cloud.sh[i * K * 3], K * 3 * sizeof(float));
  }
  g.gaussians = gpu::upload_vector(ctx_, rows, "splat-gaussians");
  g.sh = gpu::upload_vector(ctx_, sh, "splat-sh");
  return g;
}

SplatImage SplatRendererGpu::render(const GpuGaussians& g, const render::Camera& cam, const SplatOptions& opts,
                                    SplatTimings* timings, SplatDebug* debug, bool download) {
  const auto t0 = std::chrono::steady_clock::now();
  SplatFrame frame = make_frame(cam, opts, g.origin);
  validate_sky(opts.sky);
  const uint32_t W = cam.K.width, H = cam.K.height;
  const uint32_t tiles = frame.grid_x * frame.grid_y;
  const uint64_t n = g.count;
  Frame& f = *f_;
  const uint64_t limit = ctx_.info().max_storage_buffer_range;
  const uint64_t texel_limit = ctx_.info().max_texel_buffer_elements;  // texels of one texel-buffer view
  if (n * sizeof(shader::SplatProjected) > limit)
    throw std::invalid_argument("splat: " + std::to_string(n) + " Gaussians exceed one storage binding");
  if (n * 3 > texel_limit)
    throw std::invalid_argument("splat: " + std::to_string(n) + " Gaussians exceed one texel-buffer view of blend records");
  if (uint64_t{W} * H * 16 > limit)
    throw std::invalid_argument("splat: a " + std::to_string(W) + "x" + std::to_string(H) +
                                " image exceeds one storage binding");
  if (frame.grid_x > 0xFFFFu || frame.grid_y > 0xFFFFu)  // SplatBinRecord packs tile coordinates in 16 bits
    throw std::invalid_argument("splat: a " + std::to_string(W) + "x" + std::to_string(H) +
                                " image has more than 65,535 tile columns or rows");
  gpu::ensure_capacity(ctx_, f.proj, n * sizeof(shader::SplatProjected), "splat-proj");
  gpu::ensure_capacity(ctx_, f.records, n * sizeof(shader::SplatBlendRecord), "splat-blend-records");
  gpu::ensure_capacity(ctx_, f.rects, n * 16, "splat-rects");
  gpu::ensure_capacity(ctx_, f.bin_records, n * sizeof(shader::SplatBinRecord), "splat-bin-records");
  gpu::ensure_capacity(ctx_, f.depth_keys, n * 4, "splat-depth-keys");
  gpu::ensure_capacity(ctx_, f.order, n * 4, "splat-order");
  gpu::ensure_capacity(ctx_, f.counts, n * 4, "splat-counts");
  gpu::ensure_capacity(ctx_, f.offsets, n * 4, "splat-offsets");
  gpu::ensure_capacity(ctx_, f.scan_scratch, kernels::PrefixScan::scratch_elements(n) * 4, "splat-scan-scratch");
  gpu::ensure_capacity(ctx_, f.ranges, uint64_t{tiles} * 8, "splat-ranges");
  gpu::ensure_capacity(ctx_, f.rgba, uint64_t{W} * H * 16, "splat-rgba");
  // splat_blend_rows always writes depth; splat_blend only with opts.depth.
  const bool depth_out = opts.depth || !variant_.tile_blend;
  gpu::ensure_capacity(ctx_, f.depth, depth_out ? uint64_t{W} * H * 8 : 16, "splat-depth");
  if (opts.sky.kind == SkyKind::Equirect && f.sky_image != opts.sky.image) {
    const SkyImage& im = *opts.sky.image;
    if (im.rgba.size() > limit || im.rgba.size() / 4 > texel_limit)
      throw std::invalid_argument("splat sky: a " + std::to_string(im.width) + "x" + std::to_string(im.height) +
                                  " image exceeds one storage binding");
    f.sky = gpu::upload_vector(ctx_, im.rgba, "splat-sky");
    f.sky_image = opts.sky.image;
  }
  auto ensure_sort_scratch = [&](uint64_t count) {
    if (!f.sort_scratch || f.sort_scratch->capacity < count)
      f.sort_scratch = std::make_unique<kernels::RadixSortScratch>(ctx_, count + count / 2, kernels::KeyWidth::Bits32);
  };
  if (n > sort_.max_elements())
    throw std::invalid_argument("splat: " + std::to_string(n) + " Gaussians exceed the radix sort limit of " +
                                std::to_string(sort_.max_elements()));

  const uint32_t cull = variant_.exact_cull ? 1u : 0u;
  // Submission 1: preprocess, depth sort of the Gaussians, scan of the tile counts in depth
  // order, total to the host.
  uint32_t total = 0;
  double pre_ms = 0.0, depth_sort_ms = 0.0;
  if (n > 0) {
    ensure_sort_scratch(n);
    // SH windows: each a storage-sized range that one R32G32B32A32_UINT texel view can hold,
    // starting at a texel-offset-aligned byte offset (sh_stride is a multiple of 4).
    const uint64_t sh_bytes = uint64_t{g.sh_stride} * 4;
    const uint64_t texel_align = std::max<uint64_t>(1, ctx_.info().min_texel_buffer_offset_alignment);
    const auto windows = gpu::storage_windows(ctx_.info(), n, g.sh_stride * 4, texel_align / std::gcd(texel_align, sh_bytes),
                                              std::min(limit, texel_limit * 16));
    // A preprocess pipeline per SH degree (splat_preprocess's SPLAT_SH_DEGREE), made on first use.
    gpu::Program& preprocess =
        ctx_.program("splat/preprocess", gpu::SpecConstants{}.set(0, kLocal /* local_size_x */).set(1, g.sh_degree /* SPLAT_SH_DEGREE */));
    ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
      f.t1->reset(cmd);
      const int ti = f.t1->begin(cmd, "preprocess");
      for (const auto& w : windows) {
        shader::SplatPreprocessParams p = frame.pre;
        p.n = static_cast<uint32_t>(w.count);
        p.first = static_cast<uint32_t>(w.first);
        p.sh_stride = g.sh_stride;
        cmd.dispatch(preprocess, {w.count}, p,
                     {g.gaussians.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::SplatGaussian)),
                      g.sh.texel_binding(VK_FORMAT_R32G32B32A32_UINT, w.first * sh_bytes, w.count * sh_bytes),
                      f.proj.binding(0, n * sizeof(shader::SplatProjected)), f.rects.binding(0, n * 16),
                      f.depth_keys.binding(0, n * 4), f.order.binding(0, n * 4),
                      f.records.binding(0, n * sizeof(shader::SplatBlendRecord))});
      }
      f.t1->end(cmd, ti);
      cmd.barrier(gpu::deps::kComputeToCompute);  // the sort reads the depth keys
      const int td = f.t1->begin(cmd, "depth sort");
      sort_.record(cmd, f.depth_keys, f.order, n, *f.sort_scratch, 32);
      cmd.barrier(gpu::deps::kComputeToCompute);  // counts read the order
      cmd.dispatch(counts_, {n}, shader::SplatDuplicateParams{static_cast<uint32_t>(n), frame.grid_x, cull, 0},
                   {f.order.binding(0, n * 4), f.counts.binding(0, n * 4), f.rects.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * 16),
                    f.records.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::SplatBlendRecord)),
                    f.bin_records.binding(0, n * sizeof(shader::SplatBinRecord))});
      cmd.barrier(gpu::deps::kComputeToCompute);  // the scan reads counts[]
      scan_.record(cmd, f.counts, f.offsets, n, kernels::ScanKind::Inclusive, &f.scan_scratch);
      cmd.barrier(gpu::deps::kComputeToTransfer);  // the copy reads the last offset
      cmd.copy_buffer(f.offsets.binding((n - 1) * 4, 4), f.total.binding(0, 4));
      f.t1->end(cmd, td);
    });
    std::memcpy(&total, f.total.mapped(), 4);
    pre_ms = f.t1->milliseconds(0);
    depth_sort_ms = f.t1->milliseconds(1);
  }

  // Submission 2: binning by tile (counting sort, or instances in depth order + stable radix
  // sort by tile id + ranges), blend.
  const uint64_t inst = total;
  const uint32_t chunks = counting_ && inst > 0 ? binning_.chunks_for(inst, tiles, variant_.bin_chunks) : 0u;
  bool counting = chunks > 0;  // else radix (also when the counters would not fit one binding)
  if (inst * 4 > limit || inst > texel_limit || (!counting && inst > sort_.max_elements()))
    throw std::runtime_error("splat: " + std::to_string(inst) + " tile instances exceed one storage binding, one " +
                             "texel-buffer view or the radix sort limit of " + std::to_string(sort_.max_elements()));
  auto prepare_radix = [&] {
    if (inst == 0) return;
    gpu::ensure_capacity(ctx_, f.keys, inst * 4, "splat-keys");
    ensure_sort_scratch(inst);
  };
  if (inst > 0) gpu::ensure_capacity(ctx_, f.values, inst * 4, "splat-values");
  if (!counting) prepare_radix();
  const uint32_t tile_bits = std::max<uint32_t>(1, static_cast<uint32_t>(std::bit_width(tiles - 1u)));
  shader::SplatBlendParams bp{};
  bp.width = W;
  bp.height = H;
  bp.grid_x = frame.grid_x;
  bp.grid_y = frame.grid_y;
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
  const bool tile_blend = variant_.tile_blend;
  if (tile_blend)
    bp.loop_budget = variant_.blend_loop_budget >= 0 ? static_cast<uint32_t>(variant_.blend_loop_budget)
                     : ctx_.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU ? SPLAT_BLEND_LOOP_BUDGET
                                                                        : 0u;
  auto submit2 = [&](gpu::CommandList& cmd) {
    if (tile_blend) {
      cmd.barrier(gpu::deps::kComputeToTransfer);  // an earlier frame's blend and copy are done with it
      cmd.fill_buffer(f.blend_status.binding(0, 4), 0u);
      cmd.barrier(gpu::deps::kTransferToCompute);  // zeroed status before the blend counts into it
    }
    f.t2->reset(cmd);
    const int ts = f.t2->begin(cmd, "sort");
    if (counting) {
      binning_.record(cmd,
                      TileBinningGpu::Frame{f.order, f.offsets, f.bin_records, n, inst, frame.grid_x, tiles,
                                            variant_.exact_cull, chunks},
                      f.values, f.ranges, f.incomplete);
    } else if (inst > 0) {
      cmd.dispatch(duplicate_, {n}, shader::SplatDuplicateParams{static_cast<uint32_t>(n), frame.grid_x, cull, 0},
                   {f.order.binding(0, n * 4),
                    f.bin_records.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::SplatBinRecord)),
                    f.counts.binding(0, n * 4), f.offsets.binding(0, n * 4), f.keys.binding(0, inst * 4),
                    f.values.binding(0, inst * 4)});
      cmd.barrier(gpu::deps::kComputeToCompute);  // the sort reads the keys and values
      sort_.record(cmd, f.keys, f.values, inst, *f.sort_scratch, tile_bits);
    }
    if (!counting) record_tile_ranges(cmd, ranges_, f.keys, 1, inst, f.ranges, tiles);
    f.t2->end(cmd, ts);
    cmd.barrier(gpu::deps::kComputeToCompute);  // blend reads the ranges
    const int tb = f.t2->begin(cmd, "blend");
    std::vector<gpu::BufferBinding> blend_bindings = {
        f.ranges.binding(0, uint64_t{tiles} * 8),
        inst > 0 ? f.values.texel_binding(VK_FORMAT_R32_UINT, 0, inst * 4)
                 : f.ranges.texel_binding(VK_FORMAT_R32_UINT, 0, 8),
        n > 0 ? f.records.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::SplatBlendRecord))
              : f.rgba.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, 16),
        f.rgba.binding(0, uint64_t{W} * H * 16), f.depth.binding(0, depth_out ? uint64_t{W} * H * 8 : 16),
        opts.sky.kind == SkyKind::Equirect
            ? f.sky.texel_binding(VK_FORMAT_R32_UINT, 0, opts.sky.image->rgba.size() & ~size_t{3})
            : f.ranges.texel_binding(VK_FORMAT_R32_UINT, 0, 8)};
    if (tile_blend) blend_bindings.push_back(f.blend_status.binding(0, 4));
    cmd.dispatch_raw(opts.depth ? blend_ : blend_color_, {uint64_t{tiles} * kBlendInvocationsPerTile}, &bp, sizeof bp, blend_bindings.data(),
                     blend_bindings.size());
    f.t2->end(cmd, tb);
    if (tile_blend) {
      cmd.barrier(gpu::deps::kComputeToTransfer);  // the copy reads the blend's status
      cmd.copy_buffer(f.blend_status.binding(0, 4), f.total.binding(8, 4));
    }
    if (counting) {
      cmd.barrier(gpu::deps::kComputeToTransfer);  // the copy reads the walks' flag
      cmd.copy_buffer(f.incomplete.binding(0, 4), f.total.binding(4, 4));
    }
  };
  ctx_.submit_and_wait(submit2);
  bool fallback = false;
  if (counting) {
    uint32_t incomplete = 0;
    std::memcpy(&incomplete, static_cast<const char*>(f.total.mapped()) + 4, 4);
    if (incomplete) {  // a walk was cut short (lavapipe's loop limit): bin this frame with the radix path
      fallback = true;
      counting = false;
      prepare_radix();
      ctx_.submit_and_wait(submit2);
    }
  }

  if (tile_blend) {
    uint32_t over = 0;
    std::memcpy(&over, static_cast<const char*>(f.total.mapped()) + 8, 4);
    if (over > 0)
      throw std::runtime_error("splat: " + std::to_string(over) + " pixel block(s) of " + std::to_string(W) + "x" +
                               std::to_string(H) + " frame need more than " + std::to_string(bp.loop_budget) +
                               " blend loop iterations (lavapipe ends a shader's loops after 65,535), so the image "
                               "would be incomplete; too many Gaussians overlap one 16x16 tile (" +
                               std::to_string(inst) + " tile instances in all)");
  }

  SplatImage img;
  img.width = W;
  img.height = H;
  if (download) {
    img.rgba = gpu::download_vector<float>(ctx_, f.rgba, size_t{W} * H * 4);
    if (opts.depth) img.depth = gpu::download_vector<float>(ctx_, f.depth, size_t{W} * H * 2);
  }
  if (debug) {
    debug->proj = gpu::download_vector<shader::SplatProjected>(ctx_, f.proj, n);
    debug->values = inst ? gpu::download_vector<uint32_t>(ctx_, f.values, inst) : std::vector<uint32_t>{};
    debug->ranges = gpu::download_vector<uint32_t>(ctx_, f.ranges, size_t{tiles} * 2);
    debug->counting = counting;
    debug->binning_fallback = fallback;
    std::vector<uint32_t> tile_ids;
    if (!counting) {
      tile_ids = inst ? gpu::download_vector<uint32_t>(ctx_, f.keys, inst) : std::vector<uint32_t>{};
    } else {  // the counting path keeps no tile ids: each instance's tile from the ranges (UINT32_MAX: none)
      tile_ids.assign(inst, UINT32_MAX);
      for (uint32_t t = 0; t < tiles; ++t)
        for (uint32_t k = debug->ranges[2 * t]; k < debug->ranges[2 * t + 1] && k < inst; ++k) tile_ids[k] = t;
    }
    debug->keys.resize(inst);
    for (size_t i = 0; i < inst; ++i) {
      uint32_t zbits;
      std::memcpy(&zbits, &debug->proj[debug->values[i]].depth, 4);
      debug->keys[i] = (uint64_t{tile_ids[i]} << 32) | zbits;
    }
  }
  if (timings) {
    timings->preprocess_ms = pre_ms;
    timings->depth_sort_ms = depth_sort_ms;
    timings->sort_ms = f.t2->milliseconds(0);
    timings->blend_ms = f.t2->milliseconds(1);
    timings->instances = inst;
    timings->binning_chunks = counting ? chunks : 0;
    timings->binning_fallback = fallback;
    f.binning_bytes = binning_.bytes();
    timings->frame_bytes = f.bytes();
    timings->wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  return img;
}

}  // namespace icube::splat
