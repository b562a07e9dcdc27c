// Plain-loop CPU references of the convolution and linear layers; see nn/conv3d.h (double accumulation).
#include "kernels/nn/conv3d.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

namespace {

using detail::D;
using detail::require;
using detail::spatial_of;

// 1x1 convolution over any spatial rank: w [Co, Ci, 1...].
CpuTensor pointwise(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias) {
  const int64_t B = x.dim(0), Ci = x.dim(1), Co = w.dim(0), S = spatial_of(x);
  require(w.dim(1) == Ci, "conv: weight " + w.shape_text() + " does not take " + std::to_string(Ci) + " channels");
  std::vector<int64_t> shape = x.shape;
  shape[1] = Co;
  CpuTensor y(shape);
  std::vector<double> acc(static_cast<size_t>(S));
  for (int64_t b = 0; b < B; ++b)
    for (int64_t co = 0; co < Co; ++co) {
      std::fill(acc.begin(), acc.end(), bias ? D(bias->data[static_cast<size_t>(co)]) : 0.0);
      for (int64_t ci = 0; ci < Ci; ++ci) {
        const double wv = D(w.data[static_cast<size_t>(co * Ci + ci)]);
        const float* xp = &x.data[static_cast<size_t>((b * Ci + ci) * S)];
        for (int64_t s = 0; s < S; ++s) acc[static_cast<size_t>(s)] += wv * D(xp[s]);
      }
      float* yp = &y.data[static_cast<size_t>((b * Co + co) * S)];
      for (int64_t s = 0; s < S; ++s) yp[s] = static_cast<float>(acc[static_cast<size_t>(s)]);
    }
  return y;
}

}  // namespace

CpuTensor conv3d(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias, int stride, int padding) {
  require(x.rank() >= 3, "conv3d: input " + x.shape_text() + " has no spatial axes");
  if (w.rank() != 5 || (w.dim(2) == 1 && w.dim(3) == 1 && w.dim(4) == 1 && stride == 1)) {
    require(w.rank() == 2 || w.rank() == 3 || w.rank() == 5, "conv: weight " + w.shape_text() + " is not a conv weight");
    return pointwise(x, w, bias);
  }
  require(x.rank() == 5, "conv3d: input " + x.shape_text() + " is not [B, C, X, Y, Z]");
  const int64_t B = x.dim(0), Ci = x.dim(1), X = x.dim(2), Y = x.dim(3), Z = x.dim(4);
  const int64_t Co = w.dim(0), K = w.dim(2);
  require(w.dim(1) == Ci && w.dim(3) == K && w.dim(4) == K,
          "conv3d: weight " + w.shape_text() + " does not fit input " + x.shape_text());
  const int64_t OX = (X + 2 * padding - K) / stride + 1, OY = (Y + 2 * padding - K) / stride + 1,
                OZ = (Z + 2 * padding - K) / stride + 1;
  require(OX > 0 && OY > 0 && OZ > 0, "conv3d: input " + x.shape_text() + " is smaller than the kernel");
  CpuTensor y({B, Co, OX, OY, OZ});
  std::vector<double> acc(static_cast<size_t>(OX * OY * OZ));
  for (int64_t b = 0; b < B; ++b)
    for (int64_t co = 0; co < Co; ++co) {
      std::fill(acc.begin(), acc.end(), bias ? D(bias->data[static_cast<size_t>(co)]) : 0.0);
      for (int64_t ci = 0; ci < Ci; ++ci) {
        const float* xp = &x.data[static_cast<size_t>(((b * Ci + ci) * X) * Y * Z)];
        for (int64_t kx = 0; kx < K; ++kx)
          for (int64_t ky = 0; ky < K; ++ky)
            for (int64_t kz = 0; kz < K; ++kz) {
              const double wv = D(w.data[static_cast<size_t>((((co * Ci + ci) * K + kx) * K + ky) * K + kz)]);
              for (int64_t ox = 0; ox < OX; ++ox) {
                const int64_t ix = ox * stride - padding + kx;
                if (ix < 0 || ix >= X) continue;
                for (int64_t oy = 0; oy < OY; ++oy) {
                  const int64_t iy = oy * stride - padding + ky;
                  if (iy < 0 || iy >= Y) continue;
                  double* ap = &acc[static_cast<size_t>((ox * OY + oy) * OZ)];
                  const float* row = xp + (ix * Y + iy) * Z;
                  for (int64_t oz = 0; oz < OZ; ++oz) {
                    const int64_t iz = oz * stride - padding + kz;
                    if (iz >= 0 && iz < Z) ap[oz] += wv * D(row[iz]);
                  }
                }
              }
            }
      }
      float* yp = &y.data[static_cast<size_t>((b * Co + co) * OX * OY * OZ)];
      for (size_t i = 0; i < acc.size(); ++i) yp[i] = static_cast<float>(acc[i]);
    }
  return y;
}

CpuTensor linear(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias) {
  require(w.rank() == 2 && w.dim(1) == x.shape.back(),
          "linear: weight " + w.shape_text() + " does not take input " + x.shape_text());
  const int64_t In = w.dim(1), Out = w.dim(0), rows = x.numel() / In;
  std::vector<int64_t> shape = x.shape;
  shape.back() = Out;
  CpuTensor y(shape);
  for (int64_t r = 0; r < rows; ++r)
    for (int64_t o = 0; o < Out; ++o) {
      double acc = bias ? D(bias->data[static_cast<size_t>(o)]) : 0.0;
      const float* xp = &x.data[static_cast<size_t>(r * In)];
      const float* wp = &w.data[static_cast<size_t>(o * In)];
      for (int64_t i = 0; i < In; ++i) acc += D(xp[i]) * D(wp[i]);
      y.data[static_cast<size_t>(r * Out + o)] = static_cast<float>(acc);
    }
  return y;
}

}  // namespace icube::nn::cpu
