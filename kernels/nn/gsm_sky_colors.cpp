// The GSM's sky colours on the GPU; see gsm_sky_colors.h.
#include "kernels/nn/gsm_sky_colors.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_gsm_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

std::vector<float> pack_gsm_sky_mlp(const std::vector<float>& pos_w, const std::vector<float>& pos_b,
                                    const std::vector<float>& out_w, const std::vector<float>& out_b) {
  if (pos_w.size() != 3 * pos_b.size() || out_b.empty() || out_w.size() != out_b.size() * pos_b.size())
    throw std::invalid_argument("gsm_sky_colors: MLP weights of inconsistent sizes");
  std::vector<float> out;
  out.reserve(pos_w.size() + pos_b.size() + out_w.size() + out_b.size());
  for (const std::vector<float>* v : {&pos_w, &pos_b, &out_w, &out_b}) out.insert(out.end(), v->begin(), v->end());
  return out;
}

GsmSkyColors::GsmSkyColors(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/gsm_sky_colors")) {}

void GsmSkyColors::record(gpu::CommandList& cmd, const GsmSkyColorsShape& s, const gpu::Buffer& dirs,
                          const gpu::Buffer& mlp, const gpu::Buffer& modulation, const gpu::Buffer& y) {
  last_dispatches_ = 0;
  if (s.rows == 0) return;
  if (s.hidden == 0 || s.hidden > NN_GSM_SKY_MAX_HIDDEN)
    throw std::invalid_argument("gsm_sky_colors: hidden width " + std::to_string(s.hidden) + " (1 to " +
                                std::to_string(NN_GSM_SKY_MAX_HIDDEN) + ")");
  if (s.out_channels == 0 || s.out_channels > NN_GSM_SKY_MAX_OUT)
    throw std::invalid_argument("gsm_sky_colors: " + std::to_string(s.out_channels) + " output channels (1 to " +
                                std::to_string(NN_GSM_SKY_MAX_OUT) + ")");
  if (s.element_rows == 0) throw std::invalid_argument("gsm_sky_colors: no rows per element");
  const uint64_t last_element = s.element_first + (uint64_t{s.rows} - 1) / s.element_rows;
  if (last_element >= s.elements)
    throw std::invalid_argument("gsm_sky_colors: rows of element " + std::to_string(last_element) + " but " +
                                std::to_string(s.elements) + " modulation rows");
  const uint64_t H = s.hidden, C = s.out_channels, mlp_count = 4 * H + C * H + C;
  require_buffer("gsm_sky_colors", "directions", uint64_t{s.rows} * 12, dirs);
  require_buffer("gsm_sky_colors", "mlp", mlp_count * 4, mlp);
  require_buffer("gsm_sky_colors", "modulation", uint64_t{s.elements} * 2 * H * 4, modulation);
  require_buffer("gsm_sky_colors", "colours", uint64_t{s.rows} * C * 4, y);
  require_one_binding(ctx_, "gsm_sky_colors", "mlp", mlp_count);
  require_one_binding(ctx_, "gsm_sky_colors", "modulation", uint64_t{s.elements} * 2 * H);
  // Windows of rows: directions (3 a row) and colours (out_channels a row) within one binding each.
  const uint64_t E = window_elements(ctx_);
  const uint64_t window = std::max<uint64_t>(1, E / std::max<uint64_t>(3, C));
  for (uint64_t r0 = 0; r0 < s.rows; r0 += window) {
    const uint64_t n = std::min<uint64_t>(window, s.rows - r0);
    const ElementWindow wd = element_window(ctx_, dirs, 3 * r0, 3 * n);
    const ElementWindow wy = element_window(ctx_, y, C * r0, C * n);
    shader::GsmSkyColorsParams pc{};
    pc.rows = static_cast<uint32_t>(n);
    pc.hidden = s.hidden;
    pc.out_channels = s.out_channels;
    pc.element_rows = s.element_rows;
    pc.first_row = static_cast<uint32_t>(r0);
    pc.element_first = s.element_first;
    pc.dir_offset = wd.offset;
    pc.out_offset = wy.offset;
    cmd.dispatch(program_, gpu::Threads{n}, pc,
                 {wd.binding, mlp.binding(0, mlp_count * 4), modulation.binding(0, uint64_t{s.elements} * 2 * H * 4), wy.binding});
    ++last_dispatches_;
  }
}

}  // namespace icube::kernels::nn
