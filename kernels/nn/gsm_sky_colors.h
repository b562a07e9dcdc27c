// The GSM's sky colours (InfiniCube skybox_mlp_modulator, the CPU model in
// engine/nn/gsm/sky_reference.cpp: sky_colors): for each unit direction d of
// a batch element with adaLN vectors (shift, scale) from its sky token,
//   h      = pos_w d + pos_b                          [hidden]
//   n      = (h - mean(h)) / sqrt(var(h) + 1e-6)      (LayerNorm without affine, biased variance)
//   colour = out_w (n (1 + scale) + shift) + out_b    [out_channels]
// GPU: GsmSkyColors::record (shaders/nn/gsm_sky_colors.comp), one invocation
// per direction, float32; directions and colours past one storage binding go
// in windows of rows, one dispatch each (independent: no barrier between
// them). No barrier inside.
// CPU reference: nn::cpu::gsm_sky_colors (double).
// Tests: tests/nn/test_gsm_sky_colors.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

struct GsmSkyColorsShape {
  uint32_t rows = 0;          // directions
  uint32_t hidden = 1;        // 1 to NN_GSM_SKY_MAX_HIDDEN
  uint32_t out_channels = 3;  // 1 to NN_GSM_SKY_MAX_OUT
  uint32_t element_rows = 1;  // directions per batch element (row g belongs to element element_first + g / element_rows)
  uint32_t element_first = 0;
  uint32_t elements = 1;      // rows of the modulation buffer
};

// The MLP buffer's content: pos_w [hidden][3], pos_b [hidden], out_w [out_channels][hidden], out_b [out_channels].
std::vector<float> pack_gsm_sky_mlp(const std::vector<float>& pos_w, const std::vector<float>& pos_b,
                                    const std::vector<float>& out_w, const std::vector<float>& out_b);

class GsmSkyColors {
 public:
  explicit GsmSkyColors(gpu::Context& ctx);
  // dirs float [rows][3], mlp (pack_gsm_sky_mlp), modulation float [elements][2 hidden] (shift, then scale)
  // -> y float [rows][out_channels]. The caller orders the inputs before and y after.
  void record(gpu::CommandList& cmd, const GsmSkyColorsShape& s, const gpu::Buffer& dirs, const gpu::Buffer& mlp,
              const gpu::Buffer& modulation, const gpu::Buffer& y);
  size_t last_dispatches() const { return last_dispatches_; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  size_t last_dispatches_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// dirs [rows * 3], mlp (pack_gsm_sky_mlp), modulation [elements * 2 hidden] -> [rows * out_channels]; row g
// under element element_first + g / element_rows. In double, rounded once.
std::vector<float> gsm_sky_colors(const std::vector<float>& dirs, const std::vector<float>& mlp,
                                  const std::vector<float>& modulation, uint32_t hidden, uint32_t out_channels,
                                  uint32_t element_rows, uint32_t element_first);

}  // namespace icube::nn::cpu
