// A splatting frame in depth slices; see depth_slices.h.
#include "splat/depth_slices.h"

#include "splat/rasterizer_cpu.h"
#include "splat/rasterizer_gpu.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <stdexcept>
#include <string>

namespace icube::splat {

namespace {
constexpr uint32_t kLocal = 64;
constexpr uint64_t kHistWords = 3;  // per bucket: count, tile total low and high word

gpu::SpecConstants local_size() { return gpu::SpecConstants{}.set(0, kLocal /* local_size_x */); }

// Appends the slices of `h` to `out`, extending `cur` (the open slice) bucket by bucket.
void cut(const SliceHistogram& h, uint64_t max_g, uint64_t max_t,
         const std::function<SliceHistogram(uint32_t, uint32_t)>& refine, std::vector<DepthSlice>& out,
         DepthSlice& cur, bool& open) {
  const uint64_t width = uint64_t{1} << h.shift;
  for (size_t b = 0; b < h.buckets.size(); ++b) {
    const SliceBucket& k = h.buckets[b];
    if (k.gaussians == 0) continue;
    const uint64_t lo = uint64_t{h.key_lo} + b * width;
    const uint64_t hi = std::min<uint64_t>(lo + width - 1, h.key_hi);
    if (k.gaussians > max_g || k.tiles > max_t) {
      if (lo == hi)
        throw std::runtime_error("splat: " + std::to_string(k.gaussians) + " Gaussians (" + std::to_string(k.tiles) +
                                 " tiles) share one depth sort key (" + std::to_string(lo) +
                                 ") and exceed one pass of the rasterizer (" + std::to_string(max_g) +
                                 " Gaussians, " + std::to_string(max_t) +
                                 " tile instances); spread them in depth or use 32-bit depth keys");
      const SliceHistogram fine = refine(static_cast<uint32_t>(lo), static_cast<uint32_t>(hi));
      if (fine.shift >= h.shift && fine.key_lo == h.key_lo)
        throw std::logic_error("plan_depth_slices: the refinement is no finer than its bucket");
      cut(fine, max_g, max_t, refine, out, cur, open);
      continue;
    }
    if (open && (cur.gaussians + k.gaussians > max_g || cur.tiles + k.tiles > max_t)) {
      out.push_back(cur);
      open = false;
    }
    if (!open) {
      cur = DepthSlice{static_cast<uint32_t>(lo), static_cast<uint32_t>(hi), 0, 0};
      open = true;
    }
    cur.key_hi = static_cast<uint32_t>(hi);
    cur.gaussians += k.gaussians;
    cur.tiles += k.tiles;
  }
}
}  // namespace

std::vector<DepthSlice> plan_depth_slices(const SliceHistogram& h, uint64_t max_gaussians, uint64_t max_tiles,
                                          const std::function<SliceHistogram(uint32_t, uint32_t)>& refine) {
  if (max_gaussians == 0 || max_tiles == 0) throw std::invalid_argument("plan_depth_slices: a limit of 0");
  std::vector<DepthSlice> out;
  DepthSlice cur;
  bool open = false;
  cut(h, max_gaussians, max_tiles, refine, out, cur, open);
  if (open) out.push_back(cur);
  return out;
}

void slice_keys_cpu(const std::vector<shader::SplatProjected>& proj, uint32_t grid_x, uint32_t grid_y,
                    uint32_t key_bits, std::vector<uint32_t>& keys, std::vector<uint32_t>& tiles) {
  keys.assign(proj.size(), SPLAT_SLICE_CULLED);
  tiles.assign(proj.size(), 0u);
  for (size_t i = 0; i < proj.size(); ++i) {
    const shader::SplatProjected& g = proj[i];
    if (g.radius <= 0.0f) continue;  // culled (preprocess_cpu zeroes it)
    keys[i] = depth_sort_key(g.depth, key_bits);
    tiles[i] = tile_rect(g.mean_x, g.mean_y, g.radius, grid_x, grid_y).area();
  }
}

SliceHistogram slice_histogram_cpu(const std::vector<uint32_t>& keys, const std::vector<uint32_t>& tiles,
                                   uint32_t key_lo, uint32_t key_hi, uint32_t shift) {
  SliceHistogram h;
  h.key_lo = key_lo;
  h.key_hi = key_hi;
  h.shift = shift;
  h.buckets.assign(((uint64_t{key_hi} - key_lo) >> shift) + 1, SliceBucket{});
  for (size_t i = 0; i < keys.size(); ++i) {
    if (keys[i] == SPLAT_SLICE_CULLED || keys[i] < key_lo || keys[i] > key_hi) continue;
    SliceBucket& b = h.buckets[(keys[i] - key_lo) >> shift];
    ++b.gaussians;
    b.tiles += tiles[i];
  }
  return h;
}

std::vector<uint32_t> slice_members_cpu(const std::vector<uint32_t>& keys, const DepthSlice& s) {
  std::vector<uint32_t> out;
  for (size_t i = 0; i < keys.size(); ++i)
    if (keys[i] != SPLAT_SLICE_CULLED && keys[i] >= s.key_lo && keys[i] <= s.key_hi) out.push_back(static_cast<uint32_t>(i));
  return out;
}

DepthSlicer::DepthSlicer(gpu::Context& ctx)
    : ctx_(ctx),
      keys_(ctx.program("splat/slice_keys", local_size())),
      hist_(ctx.program("splat/slice_histogram", local_size())),
      flags_(ctx.program("splat/slice_flags", local_size())),
      gather_(ctx.program("splat/slice_gather", local_size())),
      scan_(ctx) {
  const uint64_t limit = ctx.info().max_storage_buffer_range;
  while (bucket_bits_ > 1 && (kHistWords * 4 << bucket_bits_) > limit) --bucket_bits_;
}

uint64_t DepthSlicer::bytes() const {
  uint64_t s = 0;
  for (const gpu::Buffer* b : {&keys_buf_, &tiles_buf_, &ranks_, &scan_scratch_, &hist_buf_, &readback_})
    s += b->valid() ? b->size() : 0;
  return s;
}

void DepthSlicer::download_keys(std::vector<uint32_t>& keys, std::vector<uint32_t>& tiles) const {
  keys = n_ ? gpu::download_vector<uint32_t>(ctx_, keys_buf_, n_) : std::vector<uint32_t>{};
  tiles = n_ ? gpu::download_vector<uint32_t>(ctx_, tiles_buf_, n_) : std::vector<uint32_t>{};
}

std::vector<gpu::ElementWindow> DepthSlicer::windows(const GpuGaussians& g) const {
  const gpu::DeviceInfo& info = ctx_.info();
  const uint64_t sh_bytes = uint64_t{g.sh_stride} * 4;
  const uint64_t row_bytes = std::max<uint64_t>(sizeof(shader::SplatGaussian), sh_bytes);
  const uint64_t align = std::max<uint64_t>({1, info.min_storage_buffer_offset_alignment,
                                             info.min_texel_buffer_offset_alignment});
  // The gather's destinations start up to `align` places before the window's first member.
  const uint64_t limit = std::min<uint64_t>(info.max_storage_buffer_range, info.max_texel_buffer_elements * 16);
  if (limit <= align * row_bytes * 2)
    throw std::invalid_argument("splat: one storage binding of " + std::to_string(limit) +
                                " bytes cannot hold a window of Gaussian rows of " + std::to_string(row_bytes) + " bytes");
  return gpu::storage_windows(info, g.count, static_cast<uint32_t>(row_bytes), align, limit - align * row_bytes);
}

SliceHistogram DepthSlicer::histogram(uint32_t key_lo, uint32_t key_hi) {
  SliceHistogram h;
  h.key_lo = key_lo;
  h.key_hi = key_hi;
  const uint64_t keys = uint64_t{key_hi} - key_lo + 1;
  const uint32_t key_bits = static_cast<uint32_t>(std::bit_width(keys - 1));
  h.shift = key_bits > bucket_bits_ ? key_bits - bucket_bits_ : 0u;
  const uint64_t buckets = ((keys - 1) >> h.shift) + 1;
  h.buckets.assign(buckets, SliceBucket{});
  gpu::ensure_capacity(ctx_, hist_buf_, buckets * kHistWords * 4, "splat-slice-hist");
  gpu::ensure_capacity(ctx_, readback_, buckets * kHistWords * 4, "splat-slice-readback", gpu::MemoryUsage::Readback);
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    cmd.fill_buffer(hist_buf_.binding(0, buckets * kHistWords * 4), 0u);
    cmd.barrier(gpu::deps::kTransferToCompute);  // zeroed buckets before the atomics
    // bucket_bits_ keeps every bucket in one binding: one bucket window, [0, buckets).
    for (const gpu::ElementWindow& w : windows_) {
      shader::SplatSliceParams sp{};
      sp.n = static_cast<uint32_t>(w.count);
      sp.key_lo = key_lo;
      sp.key_hi = key_hi;
      sp.shift = h.shift;
      sp.bucket_first = 0;
      sp.bucket_count = static_cast<uint32_t>(buckets);
      cmd.dispatch(hist_, {w.count}, sp,
                   {keys_buf_.binding(w.first * 4, w.count * 4), tiles_buf_.binding(w.first * 4, w.count * 4),
                    hist_buf_.binding(0, buckets * kHistWords * 4)});
    }
    cmd.barrier(gpu::deps::kComputeToTransfer);  // the copy reads the buckets
    cmd.copy_buffer(hist_buf_.binding(0, buckets * kHistWords * 4), readback_.binding(0, buckets * kHistWords * 4));
    cmd.barrier(gpu::deps::kTransferToHost);
  });
  const auto* words = static_cast<const uint32_t*>(readback_.mapped());
  for (uint64_t b = 0; b < buckets; ++b)
    h.buckets[b] = {words[kHistWords * b], words[kHistWords * b + 1] | (uint64_t{words[kHistWords * b + 2]} << 32)};
  return h;
}

std::vector<DepthSlice> DepthSlicer::plan(const GpuGaussians& g, const SplatFrame& frame, uint32_t key_bits,
                                          uint64_t max_gaussians, uint64_t max_tiles) {
  n_ = g.count;
  windows_ = n_ ? windows(g) : std::vector<gpu::ElementWindow>{};
  if (n_ == 0) return {};
  gpu::ensure_capacity(ctx_, keys_buf_, n_ * 4, "splat-slice-keys");
  gpu::ensure_capacity(ctx_, tiles_buf_, n_ * 4, "splat-slice-tiles");
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    for (const gpu::ElementWindow& w : windows_) {
      shader::SplatPreprocessParams pp = frame.pre;
      pp.n = static_cast<uint32_t>(w.count);
      pp.first = 0;  // every binding starts at the window
      pp.depth_key16 = key_bits == 16 ? 1u : 0u;
      cmd.dispatch(keys_, {w.count}, pp,
                   {g.gaussians.texel_binding(VK_FORMAT_R32G32B32A32_UINT, w.first * sizeof(shader::SplatGaussian),
                                              w.count * sizeof(shader::SplatGaussian)),
                    keys_buf_.binding(w.first * 4, w.count * 4), tiles_buf_.binding(w.first * 4, w.count * 4)});
    }
  });
  const uint32_t key_hi = key_bits == 16 ? 0xFFFFu : SPLAT_SLICE_CULLED - 1u;
  return plan_depth_slices(histogram(0, key_hi), max_gaussians, max_tiles,
                           [&](uint32_t lo, uint32_t hi) { return histogram(lo, hi); });
}

void DepthSlicer::gather(const GpuGaussians& g, const DepthSlice& s, GpuGaussians& out) {
  if (g.count != n_) throw std::logic_error("DepthSlicer::gather: not the planned frame's Gaussians");
  const uint64_t n = n_, sh_bytes = uint64_t{g.sh_stride} * 4;
  const uint64_t nw = windows_.size();
  // Places: the exclusive scan of the flags over n + 1 elements (the last flag 0), so
  // ranks[n] is the slice's size; the window starts' places go to the host.
  gpu::ensure_capacity(ctx_, ranks_, (n + 1) * 4, "splat-slice-ranks");
  gpu::ensure_capacity(ctx_, scan_scratch_, std::max<uint64_t>(kernels::PrefixScan::scratch_elements(n + 1), 1) * 4,
                       "splat-slice-scan-scratch");
  gpu::ensure_capacity(ctx_, readback_, (nw + 1) * 4, "splat-slice-readback", gpu::MemoryUsage::Readback);
  shader::SplatSliceParams sp{};
  sp.key_lo = s.key_lo;
  sp.key_hi = s.key_hi;
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    cmd.fill_buffer(ranks_.binding(n * 4, 4), 0u);
    for (const gpu::ElementWindow& w : windows_) {
      sp.n = static_cast<uint32_t>(w.count);
      cmd.dispatch(flags_, {w.count}, sp, {keys_buf_.binding(w.first * 4, w.count * 4), ranks_.binding(w.first * 4, w.count * 4)});
    }
    cmd.barrier(gpu::deps::kComputeToCompute);  // the scan reads the flags
    cmd.barrier(gpu::deps::kTransferToCompute);  // and the zeroed last one
    scan_.record(cmd, ranks_, ranks_, n + 1, kernels::ScanKind::Exclusive, &scan_scratch_);
    cmd.barrier(gpu::deps::kComputeToTransfer);  // the copies read the places
    for (uint64_t k = 0; k < nw; ++k) cmd.copy_buffer(ranks_.binding(windows_[k].first * 4, 4), readback_.binding(k * 4, 4));
    cmd.copy_buffer(ranks_.binding(n * 4, 4), readback_.binding(nw * 4, 4));
    cmd.barrier(gpu::deps::kTransferToHost);
  });
  std::vector<uint32_t> first(nw + 1);
  std::memcpy(first.data(), readback_.mapped(), (nw + 1) * 4);
  const uint64_t members = first[nw];
  if (members != s.gaussians)
    throw std::logic_error("DepthSlicer::gather: the slice holds " + std::to_string(members) + " Gaussians, its plan " +
                           std::to_string(s.gaussians));

  out.count = static_cast<uint32_t>(members);
  out.sh_degree = g.sh_degree;
  out.sh_stride = g.sh_stride;
  out.origin = g.origin;
  gpu::ensure_capacity(ctx_, out.gaussians, std::max<uint64_t>(members, 1) * sizeof(shader::SplatGaussian), "splat-slice-gaussians");
  gpu::ensure_capacity(ctx_, out.sh, std::max<uint64_t>(members, 1) * sh_bytes, "splat-slice-sh");
  const uint64_t align = std::max<uint64_t>({1, ctx_.info().min_storage_buffer_offset_alignment,
                                             ctx_.info().min_texel_buffer_offset_alignment});
  sp.sh_texels = g.sh_stride / 4;
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    for (uint64_t k = 0; k < nw; ++k) {
      const gpu::ElementWindow& w = windows_[k];
      const uint64_t lo = first[k], hi = first[k + 1];
      if (hi == lo) continue;  // no member in this window
      const uint64_t dst = lo / align * align;
      sp.n = static_cast<uint32_t>(w.count);
      sp.dst_first = static_cast<uint32_t>(dst);
      cmd.dispatch(gather_, {w.count}, sp,
                   {g.gaussians.texel_binding(VK_FORMAT_R32G32B32A32_UINT, w.first * sizeof(shader::SplatGaussian),
                                              w.count * sizeof(shader::SplatGaussian)),
                    g.sh.texel_binding(VK_FORMAT_R32G32B32A32_UINT, w.first * sh_bytes, w.count * sh_bytes),
                    keys_buf_.binding(w.first * 4, w.count * 4), ranks_.binding(w.first * 4, w.count * 4),
                    out.gaussians.binding(dst * sizeof(shader::SplatGaussian), (hi - dst) * sizeof(shader::SplatGaussian)),
                    out.sh.binding(dst * sh_bytes, (hi - dst) * sh_bytes)});
    }
  });
}

}  // namespace icube::splat
