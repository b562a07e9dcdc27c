// Projected-feature sampling and maximum over the views; see gsm_project_features.h.
#include "kernels/nn/gsm_project_features.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_gsm_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

namespace {

// A double as float32 hi plus the float32 rest.
void split(double v, float& hi, float& lo) {
  hi = static_cast<float>(v);
  lo = static_cast<float>(v - static_cast<double>(hi));
}

}  // namespace

std::vector<float> gsm_projection_pairs(const std::vector<double>& proj) {
  std::vector<float> out(proj.size() * 2);
  for (size_t i = 0; i < proj.size(); ++i) split(proj[i], out[2 * i], out[2 * i + 1]);
  return out;
}

GsmProjectFeatures::GsmProjectFeatures(gpu::Context& ctx) : ctx_(ctx) {}

bool GsmProjectFeatures::projects_in_double() const { return ctx_.info().shader_float64 && !force_float32_; }

namespace {

void check_shape(const GsmProjectShape& s) {
  if (s.views == 0 || s.views > NN_GSM_PROJECT_MAX_VIEWS)
    throw std::invalid_argument("gsm_project_features: " + std::to_string(s.views) + " views (1 to " +
                                std::to_string(NN_GSM_PROJECT_MAX_VIEWS) + ")");
  if (s.height == 0 || s.width == 0 || s.height > (1u << 24) || s.width > (1u << 24))
    throw std::invalid_argument("gsm_project_features: image " + std::to_string(s.width) + " x " + std::to_string(s.height));
  if (s.parents == 0) throw std::invalid_argument("gsm_project_features: children without parents");
}

}  // namespace

std::vector<GsmProjectWindow> GsmProjectFeatures::windows(const GsmProjectShape& s) const {
  std::vector<GsmProjectWindow> out;
  if (uint64_t{s.rows} * s.channels == 0) return out;
  check_shape(s);
  const uint64_t E = window_elements(ctx_), plane = uint64_t{s.height} * s.width, R = s.rows, C = s.channels;
  if (plane > E)
    throw std::invalid_argument("gsm_project_features: one " + std::to_string(s.width) + " x " + std::to_string(s.height) +
                                " feature plane exceeds one storage binding; reduce the image size");
  require_one_binding(ctx_, "gsm_project_features", "seen table", uint64_t{s.parents} * s.views);
  // Children: the coordinates (3 per child) within a window; channels: the output's [channels][children]
  // window ((channels - 1) * all children + children) and one view's features; views: the rest.
  const uint64_t rows = std::min(R, E / 3);
  uint64_t channels = rows < R ? 1 : std::min(C, E / R);
  channels = std::max<uint64_t>(1, std::min(channels, E / plane));
  const uint64_t views = std::max<uint64_t>(1, std::min<uint64_t>(s.views, 1 + (E / plane - channels) / C));
  for (uint64_t v0 = 0; v0 < s.views; v0 += views) {
    bool first_of_views = true;
    for (uint64_t c0 = 0; c0 < C; c0 += channels)
      for (uint64_t r0 = 0; r0 < R; r0 += rows) {
        GsmProjectWindow w;
        w.view_first = static_cast<uint32_t>(v0);
        w.view_count = static_cast<uint32_t>(std::min<uint64_t>(views, s.views - v0));
        w.channel_first = static_cast<uint32_t>(c0);
        w.channel_count = static_cast<uint32_t>(std::min(channels, C - c0));
        w.row_first = static_cast<uint32_t>(r0);
        w.row_count = static_cast<uint32_t>(std::min(rows, R - r0));
        w.barrier_before = v0 > 0 && first_of_views;
        first_of_views = false;
        out.push_back(w);
      }
  }
  return out;
}

void GsmProjectFeatures::record(gpu::CommandList& cmd, const GsmProjectShape& s, const GsmProjectWindow& w,
                                const gpu::Buffer& features, const gpu::Buffer& mask, const gpu::Buffer& ijk,
                                const gpu::Buffer& parent, const gpu::Buffer& seen, const gpu::Buffer& proj,
                                const gpu::Buffer& y) {
  const uint64_t out = uint64_t{w.row_count} * w.channel_count;
  if (out == 0) return;
  check_shape(s);
  if (w.view_count == 0 || uint64_t{w.view_first} + w.view_count > s.views ||
      uint64_t{w.channel_first} + w.channel_count > s.channels || uint64_t{w.row_first} + w.row_count > s.rows)
    throw std::invalid_argument("gsm_project_features: a window outside the shape");
  const uint64_t plane = uint64_t{s.height} * s.width, C = s.channels, R = s.rows;
  require_buffer("gsm_project_features", "features", uint64_t{s.views} * C * plane * 4, features);
  require_buffer("gsm_project_features", "mask", uint64_t{s.views} * plane * 4, mask);
  require_buffer("gsm_project_features", "ijk", R * 12, ijk);
  require_buffer("gsm_project_features", "parent", R * 4, parent);
  require_buffer("gsm_project_features", "seen", uint64_t{s.parents} * s.views * 4, seen);
  require_buffer("gsm_project_features", "projection", uint64_t{s.views} * 96, proj);
  require_buffer("gsm_project_features", "output", C * R * 4, y);
  const uint64_t E = window_elements(ctx_);
  const uint64_t feature_count = ((uint64_t{w.view_count} - 1) * C + w.channel_count) * plane;
  const uint64_t out_count = (uint64_t{w.channel_count} - 1) * R + w.row_count;
  if (feature_count > E || out_count > E || uint64_t{w.row_count} * 3 > E)
    throw std::invalid_argument("gsm_project_features: a window past one storage binding (use windows())");
  require_one_binding(ctx_, "gsm_project_features", "seen table", uint64_t{s.parents} * s.views);
  const ElementWindow wf = element_window(ctx_, features, (uint64_t{w.view_first} * C + w.channel_first) * plane, feature_count);
  const ElementWindow wm = element_window(ctx_, mask, uint64_t{w.view_first} * plane, uint64_t{w.view_count} * plane);
  const ElementWindow wi = element_window(ctx_, ijk, uint64_t{w.row_first} * 3, uint64_t{w.row_count} * 3);
  const ElementWindow wp = element_window(ctx_, parent, w.row_first, w.row_count);
  const ElementWindow wy = element_window(ctx_, y, uint64_t{w.channel_first} * R + w.row_first, out_count);
  shader::GsmProjectParams pc{};
  pc.rows = w.row_count;
  pc.channels = w.channel_count;
  pc.views = s.views;
  pc.height = s.height;
  pc.width = s.width;
  pc.flags = (s.max_from_zero ? NN_GSM_PROJECT_FLAG_MAX_FROM_ZERO : 0u) | (w.view_first > 0 ? NN_GSM_PROJECT_FLAG_ACCUMULATE : 0u);
  pc.view_first = w.view_first;
  pc.view_count = w.view_count;
  pc.channel_stride = s.channels;
  pc.row_stride = s.rows;
  pc.features_offset = wf.offset;
  pc.mask_offset = wm.offset;
  pc.ijk_offset = wi.offset;
  pc.parent_offset = wp.offset;
  pc.out_offset = wy.offset;
  for (size_t a = 0; a < 3; ++a) {
    split(s.voxel_size[a], pc.voxel_size_hi[a], pc.voxel_size_lo[a]);
    split(s.origin[a], pc.origin_hi[a], pc.origin_lo[a]);
  }
  gpu::Program& program = ctx_.program(projects_in_double() ? "nn/gsm_project_features_f64" : "nn/gsm_project_features");
  cmd.dispatch(program, gpu::Threads{out}, pc,
               {wf.binding, wm.binding, wi.binding, wp.binding, seen.binding(0, uint64_t{s.parents} * s.views * 4),
                proj.binding(0, uint64_t{s.views} * 96), wy.binding});
}

}  // namespace icube::kernels::nn
