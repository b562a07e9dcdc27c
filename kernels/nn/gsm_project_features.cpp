// Projected-feature sampling and maximum over the views; see gsm_project_features.h.
#include "kernels/nn/gsm_project_features.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_gsm_params.h"

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

void GsmProjectFeatures::record(gpu::CommandList& cmd, const GsmProjectShape& s, const gpu::Buffer& features,
                                const gpu::Buffer& mask, const gpu::Buffer& ijk, const gpu::Buffer& parent,
                                const gpu::Buffer& seen, const gpu::Buffer& proj, const gpu::Buffer& y) {
  const uint64_t out = uint64_t{s.rows} * s.channels;
  if (out == 0) return;
  if (s.views == 0 || s.views > NN_GSM_PROJECT_MAX_VIEWS)
    throw std::invalid_argument("gsm_project_features: " + std::to_string(s.views) + " views (1 to " +
                                std::to_string(NN_GSM_PROJECT_MAX_VIEWS) + ")");
  if (s.height == 0 || s.width == 0 || s.height > (1u << 24) || s.width > (1u << 24))
    throw std::invalid_argument("gsm_project_features: image " + std::to_string(s.width) + " x " + std::to_string(s.height));
  if (s.parents == 0) throw std::invalid_argument("gsm_project_features: children without parents");
  const uint64_t plane = uint64_t{s.height} * s.width;
  const uint64_t feature_count = uint64_t{s.views} * s.channels * plane;
  require_buffer("gsm_project_features", "features", feature_count * 4, features);
  require_buffer("gsm_project_features", "mask", uint64_t{s.views} * plane * 4, mask);
  require_buffer("gsm_project_features", "ijk", uint64_t{s.rows} * 12, ijk);
  require_buffer("gsm_project_features", "parent", uint64_t{s.rows} * 4, parent);
  require_buffer("gsm_project_features", "seen", uint64_t{s.parents} * s.views * 4, seen);
  require_buffer("gsm_project_features", "projection", uint64_t{s.views} * 96, proj);
  require_buffer("gsm_project_features", "output", out * 4, y);
  require_one_binding(ctx_, "gsm_project_features", "features", feature_count);
  require_one_binding(ctx_, "gsm_project_features", "output", out);
  require_one_binding(ctx_, "gsm_project_features", "coordinates", uint64_t{s.rows} * 3);
  require_one_binding(ctx_, "gsm_project_features", "seen table", uint64_t{s.parents} * s.views);
  shader::GsmProjectParams pc{};
  pc.rows = s.rows;
  pc.channels = s.channels;
  pc.views = s.views;
  pc.height = s.height;
  pc.width = s.width;
  pc.flags = s.max_from_zero ? NN_GSM_PROJECT_FLAG_MAX_FROM_ZERO : 0u;
  for (size_t a = 0; a < 3; ++a) {
    split(s.voxel_size[a], pc.voxel_size_hi[a], pc.voxel_size_lo[a]);
    split(s.origin[a], pc.origin_hi[a], pc.origin_lo[a]);
  }
  gpu::Program& program = ctx_.program(projects_in_double() ? "nn/gsm_project_features_f64" : "nn/gsm_project_features");
  cmd.dispatch(program, gpu::Threads{out}, pc,
               {features.binding(0, feature_count * 4), mask.binding(0, uint64_t{s.views} * plane * 4),
                ijk.binding(0, uint64_t{s.rows} * 12), parent.binding(0, uint64_t{s.rows} * 4),
                seen.binding(0, uint64_t{s.parents} * s.views * 4), proj.binding(0, uint64_t{s.views} * 96),
                y.binding(0, out * 4)});
}

}  // namespace icube::kernels::nn
