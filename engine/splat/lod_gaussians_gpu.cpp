#include "splat/lod_gaussians_gpu.h"

#include <chrono>
#include <stdexcept>
#include <string>

namespace icube::splat {

LodGaussiansGpu::LodGaussiansGpu(gpu::Context& ctx, const ChunkedGaussians& chunks, uint32_t sh_degree)
    : ctx_(ctx), chunks_(chunks.chunks) {
  if (sh_degree < chunks.fine.sh_degree || sh_degree > 3)
    throw std::invalid_argument("splat: frame SH degree " + std::to_string(sh_degree) + " below the chunks' " +
                                std::to_string(chunks.fine.sh_degree) + " or above 3");
  chunks.fine.validate();
  chunks.coarse.validate();
  if (chunks.fine.size() > UINT32_MAX / 4) throw std::invalid_argument("splat: too many Gaussians");
  frame_.sh_degree = sh_degree;
  frame_.sh_stride = gpu_sh_stride(sh_degree);
  frame_.origin = gaussian_origin(chunks.fine);
  std::vector<shader::SplatGaussian> rows;
  std::vector<float> sh;
  pack_gaussians(chunks.fine, frame_.origin, frame_.sh_stride, rows, sh);
  fine_rows_ = gpu::upload_vector(ctx, rows, "lod-fine-rows");
  fine_sh_ = gpu::upload_vector(ctx, sh, "lod-fine-sh");
  pack_gaussians(chunks.coarse, frame_.origin, frame_.sh_stride, rows, sh);
  coarse_rows_ = gpu::upload_vector(ctx, rows, "lod-coarse-rows");
  coarse_sh_ = gpu::upload_vector(ctx, sh, "lod-coarse-sh");
}

uint64_t LodGaussiansGpu::resident_bytes() const {
  return fine_rows_.size() + fine_sh_.size() + coarse_rows_.size() + coarse_sh_.size();
}

void LodGaussiansGpu::set_extra(const GaussianCloud& extra) {
  if (extra.sh_degree > frame_.sh_degree)
    throw std::invalid_argument("splat: extra Gaussians of SH degree " + std::to_string(extra.sh_degree) +
                                " above the frame set's " + std::to_string(frame_.sh_degree));
  extra.validate();
  pack_gaussians(extra, frame_.origin, frame_.sh_stride, extra_rows_, extra_sh_);
  extra_dirty_ = true;
}

const GpuGaussians& LodGaussiansGpu::assemble(const std::vector<ChunkPick>& picks, LodAssembleStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  LodAssembleStats st;
  uint64_t n_static = 0;
  for (const ChunkPick& p : picks) {
    if (p.chunk >= chunks_.size()) throw std::out_of_range("splat: chunk pick out of range");
    const GaussianChunk& c = chunks_[p.chunk];
    n_static += p.coarse ? c.coarse_count : c.count;
  }
  const uint64_t total = n_static + extra_rows_.size();
  if (total > UINT32_MAX / 4) throw std::invalid_argument("splat: too many Gaussians in the view");
  const uint64_t row_bytes = sizeof(shader::SplatGaussian), sh_bytes = uint64_t{frame_.sh_stride} * 4;
  const VkBuffer before_rows = frame_.gaussians.handle(), before_sh = frame_.sh.handle();
  gpu::ensure_capacity(ctx_, frame_.gaussians, std::max<uint64_t>(1, total) * row_bytes, "lod-frame-rows");
  gpu::ensure_capacity(ctx_, frame_.sh, std::max<uint64_t>(1, total) * sh_bytes, "lod-frame-sh");
  const bool grown = frame_.gaussians.handle() != before_rows || frame_.sh.handle() != before_sh;
  const bool copy_static = grown || !have_picks_ || picks != picks_;
  const bool upload_extra = grown || extra_dirty_ || n_static != static_count_;
  if (copy_static && n_static > 0) {
    // Merged [src, src + len) -> dst ranges per level, in pick order.
    struct Range { bool coarse; uint64_t src, dst, len; };
    std::vector<Range> ranges;
    uint64_t dst = 0;
    for (const ChunkPick& p : picks) {
      const GaussianChunk& c = chunks_[p.chunk];
      const uint64_t src = p.coarse ? c.coarse_first : c.first, len = p.coarse ? c.coarse_count : c.count;
      if (len == 0) continue;
      if (!ranges.empty() && ranges.back().coarse == p.coarse && ranges.back().src + ranges.back().len == src)
        ranges.back().len += len;
      else
        ranges.push_back({p.coarse, src, dst, len});
      dst += len;
    }
    ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
      for (const Range& r : ranges) {
        const gpu::Buffer& rows = r.coarse ? coarse_rows_ : fine_rows_;
        const gpu::Buffer& sh = r.coarse ? coarse_sh_ : fine_sh_;
        cmd.copy_buffer(rows.binding(r.src * row_bytes, r.len * row_bytes),
                        frame_.gaussians.binding(r.dst * row_bytes, r.len * row_bytes));
        cmd.copy_buffer(sh.binding(r.src * sh_bytes, r.len * sh_bytes),
                        frame_.sh.binding(r.dst * sh_bytes, r.len * sh_bytes));
      }
      cmd.barrier(gpu::deps::kTransferToCompute);  // the rasterizer's preprocess reads them
    });
    st.static_copied = true;
    st.copy_regions = static_cast<uint32_t>(ranges.size());
  }
  picks_ = picks;
  have_picks_ = true;
  static_count_ = static_cast<uint32_t>(n_static);
  if (upload_extra && !extra_rows_.empty()) {
    gpu::upload(ctx_, frame_.gaussians, extra_rows_.data(), extra_rows_.size() * row_bytes, n_static * row_bytes);
    gpu::upload(ctx_, frame_.sh, extra_sh_.data(), extra_sh_.size() * 4, n_static * sh_bytes);
    st.extra_uploaded = true;
  }
  extra_dirty_ = false;
  frame_.count = static_cast<uint32_t>(total);
  st.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats = st;
  return frame_;
}

}  // namespace icube::splat
