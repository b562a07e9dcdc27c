// Plain-loop CPU reference of the GSM's sky colours; see nn/gsm_sky_colors.h.
#include "kernels/nn/gsm_sky_colors.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

std::vector<float> gsm_sky_colors(const std::vector<float>& dirs, const std::vector<float>& mlp,
                                  const std::vector<float>& modulation, uint32_t hidden, uint32_t out_channels,
                                  uint32_t element_rows, uint32_t element_first) {
  const size_t H = hidden, C = out_channels, rows = dirs.size() / 3;
  if (H == 0 || C == 0 || element_rows == 0 || dirs.size() != rows * 3 || mlp.size() != 4 * H + C * H + C)
    throw std::invalid_argument("gsm_sky_colors (cpu): inconsistent sizes");
  const float *pos_w = mlp.data(), *pos_b = pos_w + 3 * H, *out_w = pos_b + H, *out_b = out_w + C * H;
  std::vector<float> y(rows * C);
  std::vector<double> h(H);
  for (size_t g = 0; g < rows; ++g) {
    const size_t e = element_first + g / element_rows;
    if ((e + 1) * 2 * H > modulation.size()) throw std::invalid_argument("gsm_sky_colors (cpu): modulation too short");
    const double d[3] = {double(dirs[3 * g]), double(dirs[3 * g + 1]), double(dirs[3 * g + 2])};
    double mean = 0.0;
    for (size_t k = 0; k < H; ++k) {
      h[k] = double(pos_b[k]) + double(pos_w[3 * k]) * d[0] + double(pos_w[3 * k + 1]) * d[1] + double(pos_w[3 * k + 2]) * d[2];
      mean += h[k];
    }
    mean /= double(H);
    double var = 0.0;
    for (size_t k = 0; k < H; ++k) var += (h[k] - mean) * (h[k] - mean);
    const double inv_std = 1.0 / std::sqrt(var / double(H) + 1e-6);
    const float* shift = modulation.data() + e * 2 * H;
    const float* scale = shift + H;
    for (size_t c = 0; c < C; ++c) {
      double acc = double(out_b[c]);
      for (size_t k = 0; k < H; ++k)
        acc += double(out_w[c * H + k]) * ((h[k] - mean) * inv_std * (1.0 + double(scale[k])) + double(shift[k]));
      y[g * C + c] = static_cast<float>(acc);
    }
  }
  return y;
}

}  // namespace icube::nn::cpu
