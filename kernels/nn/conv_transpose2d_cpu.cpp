// Plain-loop CPU reference of ConvTranspose2d; see nn/conv_transpose2d.h (double accumulation).
#include "kernels/nn/conv_transpose2d.h"

#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

CpuTensor conv_transpose2d(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias, int stride, int padding) {
  require(x.rank() == 4, "conv_transpose2d: input " + x.shape_text() + " is not [B, C, H, W]");
  require(w.rank() == 4 && w.dim(0) == x.dim(1),
          "conv_transpose2d: weight " + w.shape_text() + " does not fit input " + x.shape_text());
  require(stride >= 1 && padding >= 0, "conv_transpose2d: stride must be >= 1 and padding >= 0");
  const int64_t B = x.dim(0), Ci = x.dim(1), H = x.dim(2), W = x.dim(3);
  const int64_t Co = w.dim(1), KH = w.dim(2), KW = w.dim(3);
  require(!bias || bias->numel() == Co, "conv_transpose2d: bias does not have " + std::to_string(Co) + " values");
  const int64_t OH = (H - 1) * stride - 2 * padding + KH, OW = (W - 1) * stride - 2 * padding + KW;
  require(OH > 0 && OW > 0, "conv_transpose2d: output would be empty");
  // Gather form: output (oy, ox) receives input (iy, ix) through tap (ky, kx) when oy + p = iy s + ky.
  CpuTensor y({B, Co, OH, OW});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t o = 0; o < Co; ++o)
      for (int64_t oy = 0; oy < OH; ++oy)
        for (int64_t ox = 0; ox < OW; ++ox) {
          double s = bias ? D(bias->data[static_cast<size_t>(o)]) : 0.0;
          for (int64_t ky = 0; ky < KH; ++ky) {
            const int64_t ty = oy + padding - ky;
            if (ty < 0 || ty % stride) continue;
            const int64_t iy = ty / stride;
            if (iy >= H) continue;
            for (int64_t kx = 0; kx < KW; ++kx) {
              const int64_t tx = ox + padding - kx;
              if (tx < 0 || tx % stride) continue;
              const int64_t ix = tx / stride;
              if (ix >= W) continue;
              for (int64_t c = 0; c < Ci; ++c)
                s += D(w.data[static_cast<size_t>(((c * Co + o) * KH + ky) * KW + kx)]) *
                     D(x.data[static_cast<size_t>(((b * Ci + c) * H + iy) * W + ix)]);
            }
          }
          y.data[static_cast<size_t>(((b * Co + o) * OH + oy) * OW + ox)] = static_cast<float>(s);
        }
  return y;
}

}  // namespace icube::nn::cpu
