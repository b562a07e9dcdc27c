// Plain-loop CPU references of the resampling; see nn/resample.h (double accumulation).
#include "kernels/nn/resample.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

CpuTensor avg_pool2(const CpuTensor& x) {
  require(x.rank() == 5, "avg_pool2: input " + x.shape_text() + " is not [B, C, X, Y, Z]");
  const int64_t BC = x.dim(0) * x.dim(1), X = x.dim(2), Y = x.dim(3), Z = x.dim(4);
  const int64_t OX = X / 2, OY = Y / 2, OZ = Z / 2;
  require(OX > 0 && OY > 0 && OZ > 0, "avg_pool2: input " + x.shape_text() + " has an axis shorter than 2");
  CpuTensor y({x.dim(0), x.dim(1), OX, OY, OZ});
  for (int64_t bc = 0; bc < BC; ++bc)
    for (int64_t i = 0; i < OX; ++i)
      for (int64_t j = 0; j < OY; ++j)
        for (int64_t l = 0; l < OZ; ++l) {
          double s = 0.0;
          for (int d = 0; d < 8; ++d)
            s += D(x.data[static_cast<size_t>(((bc * X + 2 * i + (d & 1)) * Y + 2 * j + ((d >> 1) & 1)) * Z + 2 * l + (d >> 2))]);
          y.data[static_cast<size_t>(((bc * OX + i) * OY + j) * OZ + l)] = static_cast<float>(s / 8.0);
        }
  return y;
}

CpuTensor upsample2(const CpuTensor& x) {
  require(x.rank() == 5, "upsample2: input " + x.shape_text() + " is not [B, C, X, Y, Z]");
  const int64_t BC = x.dim(0) * x.dim(1), X = x.dim(2), Y = x.dim(3), Z = x.dim(4);
  CpuTensor y({x.dim(0), x.dim(1), 2 * X, 2 * Y, 2 * Z});
  for (int64_t bc = 0; bc < BC; ++bc)
    for (int64_t i = 0; i < 2 * X; ++i)
      for (int64_t j = 0; j < 2 * Y; ++j)
        for (int64_t l = 0; l < 2 * Z; ++l)
          y.data[static_cast<size_t>(((bc * 2 * X + i) * 2 * Y + j) * 2 * Z + l)] =
              x.data[static_cast<size_t>(((bc * X + i / 2) * Y + j / 2) * Z + l / 2)];
  return y;
}

}  // namespace icube::nn::cpu
