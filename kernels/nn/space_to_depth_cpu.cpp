// Plain-loop CPU reference of the 2x2 space-to-depth; see nn/space_to_depth.h.
#include "kernels/nn/space_to_depth.h"

namespace icube::nn::cpu {

using detail::require;

CpuTensor space_to_depth(const CpuTensor& x) {
  require(x.rank() == 4, "space_to_depth: input " + x.shape_text() + " is not [B, C, H, W]");
  const int64_t B = x.dim(0), C = x.dim(1), H = x.dim(2), W = x.dim(3), h = H / 2, w = W / 2;
  require(H % 2 == 0 && W % 2 == 0, "space_to_depth: input " + x.shape_text() + " has an odd height or width");
  CpuTensor y({B, C * 4, h, w});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t c = 0; c < C; ++c)
      for (int64_t dy = 0; dy < 2; ++dy)
        for (int64_t dx = 0; dx < 2; ++dx)
          for (int64_t i = 0; i < h; ++i)
            for (int64_t j = 0; j < w; ++j)
              y.data[static_cast<size_t>((((b * C + c) * 4 + dy * 2 + dx) * h + i) * w + j)] =
                  x.data[static_cast<size_t>(((b * C + c) * H + 2 * i + dy) * W + 2 * j + dx)];
  return y;
}

}  // namespace icube::nn::cpu
