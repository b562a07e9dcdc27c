// The voxel lifter's scatter-mean host module; see scatter_mean.h.
#include "kernels/nn/scatter_mean.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_gsm_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

namespace {

// uint32 elements [first, first + count) of `buf` as an R32_UINT texel buffer bound from the texel-offset
// alignment at or below `first` (texel_window's, for integer data).
ElementWindow uint_texel_window(const gpu::Context& ctx, const gpu::Buffer& buf, uint64_t first, uint64_t count) {
  const uint64_t align = std::max<uint64_t>(4, ctx.info().min_texel_buffer_offset_alignment);
  const uint64_t byte = first * 4, base = byte / align * align;
  return {buf.texel_binding(VK_FORMAT_R32_UINT, base, byte - base + count * 4),
          static_cast<uint32_t>((byte - base) / 4)};
}

// A window of the features: views [view_begin, view_end), channels [channel_begin, channel_begin + channels)
// (all channels when it holds several views).
struct FeatureWindow {
  uint32_t view_begin, view_end, channel_begin, channels;
};

std::vector<FeatureWindow> feature_windows(const ScatterMeanShape& s, uint64_t plane, uint64_t fit) {
  const uint64_t per_view = uint64_t{s.channels} * plane;
  std::vector<FeatureWindow> out;
  if (per_view <= fit) {
    const uint64_t views = std::max<uint64_t>(1, fit / per_view);
    for (uint64_t n = 0; n < s.views; n += views)
      out.push_back({static_cast<uint32_t>(n), static_cast<uint32_t>(std::min<uint64_t>(s.views, n + views)), 0, s.channels});
    return out;
  }
  if (plane > fit)
    throw std::invalid_argument("scatter_mean: one channel of a " + std::to_string(s.height) + " x " + std::to_string(s.width) +
                                " image exceeds one binding (" + std::to_string(fit * 4) + " bytes); reduce the image size");
  const uint64_t channels = fit / plane;
  for (uint32_t n = 0; n < s.views; ++n)
    for (uint64_t c = 0; c < s.channels; c += channels)
      out.push_back({n, n + 1, static_cast<uint32_t>(c), static_cast<uint32_t>(std::min<uint64_t>(channels, s.channels - c))});
  return out;
}

}  // namespace

VoxelPixelLists build_voxel_pixel_lists(const std::vector<int32_t>& first_voxel, const std::vector<float>& effective_mask,
                                        uint32_t voxels) {
  if (first_voxel.size() != effective_mask.size())
    throw std::invalid_argument("scatter_mean: " + std::to_string(first_voxel.size()) + " first-voxel rows for " +
                                std::to_string(effective_mask.size()) + " mask values");
  if (first_voxel.size() > UINT32_MAX / 2)
    throw std::invalid_argument("scatter_mean: " + std::to_string(first_voxel.size()) + " pixels exceed 2^31; use fewer views");
  VoxelPixelLists l;
  l.voxels = voxels;
  l.pixels = first_voxel.size();
  l.offsets.assign(uint64_t{voxels} + 1, 0);
  auto effective_row = [&](size_t q) -> int64_t {
    const int32_t row = first_voxel[q];
    if (row < 0 || !(effective_mask[q] > 0.0f)) return -1;
    if (static_cast<uint32_t>(row) >= voxels)
      throw std::invalid_argument("scatter_mean: pixel " + std::to_string(q) + " gives its feature to voxel " +
                                  std::to_string(row) + " of " + std::to_string(voxels));
    return row;
  };
  // Stable counting sort: counts, exclusive prefix sums, then the pixels in ascending order.
  for (size_t q = 0; q < first_voxel.size(); ++q)
    if (const int64_t row = effective_row(q); row >= 0) ++l.offsets[static_cast<size_t>(row) + 1];
  for (uint32_t v = 0; v < voxels; ++v) {
    l.max_count = std::max(l.max_count, l.offsets[v + 1]);
    l.offsets[v + 1] += l.offsets[v];
  }
  l.pixel_ids.resize(l.offsets[voxels]);
  std::vector<uint32_t> next(l.offsets.begin(), l.offsets.end() - 1);
  for (size_t q = 0; q < first_voxel.size(); ++q)
    if (const int64_t row = effective_row(q); row >= 0) l.pixel_ids[next[static_cast<size_t>(row)]++] = static_cast<uint32_t>(q);
  return l;
}

ScatterMean::ScatterMean(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/scatter_mean")) {}

void ScatterMean::record(gpu::CommandList& cmd, const ScatterMeanShape& s, const gpu::Buffer& features,
                         const VoxelPixelLists& lists, const gpu::Buffer& offsets, const gpu::Buffer& pixel_ids,
                         const gpu::Buffer& y) {
  const uint64_t plane = uint64_t{s.height} * s.width, V = lists.voxels, C = s.channels;
  if (lists.offsets.size() != V + 1 || lists.pixel_ids.size() != lists.offsets.back())
    throw std::invalid_argument("scatter_mean: malformed voxel pixel lists (build them with build_voxel_pixel_lists)");
  if (lists.pixels != uint64_t{s.views} * plane)
    throw std::invalid_argument("scatter_mean: the lists cover " + std::to_string(lists.pixels) + " pixels, the features " +
                                std::to_string(s.views) + " x " + std::to_string(s.height) + " x " + std::to_string(s.width));
  if (V == 0 || C == 0) return;
  require_buffer("scatter_mean", "features", uint64_t{s.views} * C * plane * 4, features);
  require_buffer("scatter_mean", "offsets", (V + 1) * 4, offsets);
  require_buffer("scatter_mean", "pixel ids", lists.pixel_ids.size() * 4, pixel_ids);
  require_buffer("scatter_mean", "output", V * C * 4, y);
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  const uint32_t entries = pixel_window_ ? pixel_window_ : NN_SM_PIXEL_WINDOW;
  const uint32_t passes = std::max<uint32_t>(1, static_cast<uint32_t>(gpu::div_up(lists.max_count, entries)));
  const std::vector<FeatureWindow> fws = feature_windows(s, plane, fit);
  if (C > fit)
    throw std::invalid_argument("scatter_mean: one voxel's " + std::to_string(C) + " channels exceed one binding; reduce the channels");

  shader::ScatterMeanParams pc{};
  pc.channels_total = s.channels;
  pc.plane = static_cast<uint32_t>(plane);
  pc.pixel_window = entries;
  bool first_dispatch = true;
  for (uint64_t v0 = 0; v0 < V;) {
    // A voxel window: y rows, offsets and the pixel ids of its lists within one binding each.
    uint64_t rows = std::min({V - v0, fit / C, fit - 1});
    const auto last_fitting = std::upper_bound(lists.offsets.begin() + static_cast<std::ptrdiff_t>(v0 + 1),
                                               lists.offsets.begin() + static_cast<std::ptrdiff_t>(v0 + rows + 1),
                                               uint64_t{lists.offsets[v0]} + fit);
    rows = static_cast<uint64_t>(last_fitting - lists.offsets.begin()) - 1 - v0;
    if (rows == 0)
      throw std::invalid_argument("scatter_mean: voxel " + std::to_string(v0) + " receives " +
                                  std::to_string(lists.offsets[v0 + 1] - lists.offsets[v0]) +
                                  " pixels, more ids than one binding holds; use fewer views");
    const uint32_t list_first = lists.offsets[v0], list_count = lists.offsets[v0 + rows] - list_first;
    const ElementWindow ow = uint_texel_window(ctx_, offsets, v0, rows + 1);
    // (No pixel ids when every list of the window is empty: the kernel then reads none.)
    const ElementWindow pw = list_count ? uint_texel_window(ctx_, pixel_ids, list_first, list_count)
                                        : ElementWindow{gpu::null_binding(VK_FORMAT_R32_UINT), 0};
    const ElementWindow yw = element_window(ctx_, y, v0 * C, rows * C);
    pc.voxels = static_cast<uint32_t>(rows);
    pc.offsets_offset = ow.offset;
    pc.pixel_first = list_first;
    pc.pixels_offset = pw.offset;
    pc.y_offset = yw.offset;
    for (const FeatureWindow& fw : fws) {
      const uint64_t first = (uint64_t{fw.view_begin} * C + fw.channel_begin) * plane;
      const uint64_t count = ((uint64_t{fw.view_end} - fw.view_begin - 1) * C + fw.channels) * plane;
      const ElementWindow xw = texel_window(ctx_, features, first, count);
      pc.view_begin = fw.view_begin;
      pc.view_end = fw.view_end;
      pc.channel_begin = fw.channel_begin;
      pc.channels = fw.channels;
      pc.x_offset = xw.offset;
      for (uint32_t pass = 0; pass < passes; ++pass) {
        pc.pass = pass;
        pc.flags = (fw.view_begin == 0 && fw.view_end == s.views ? NN_SM_FLAG_ALL_VIEWS : 0u) |
                   (fw.view_begin == 0 && pass == 0 ? NN_SM_FLAG_FIRST : 0u);
        // Later dispatches continue the partial sums in y.
        if (!first_dispatch) cmd.barrier(gpu::deps::kComputeToCompute);
        first_dispatch = false;
        cmd.dispatch(program_, gpu::Threads{rows * fw.channels}, pc, {xw.binding, ow.binding, pw.binding, yw.binding});
      }
    }
    v0 += rows;
  }
}

}  // namespace icube::kernels::nn
