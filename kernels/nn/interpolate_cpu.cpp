// Plain-loop CPU references of the 2-D resampling; see nn/interpolate.h (double arithmetic).
#include "kernels/nn/interpolate.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

namespace {

void require_map(const CpuTensor& x, int64_t out_h, int64_t out_w, const char* op) {
  require(x.rank() == 4, std::string(op) + ": input " + x.shape_text() + " is not [B, C, H, W]");
  require(x.dim(2) > 0 && x.dim(3) > 0 && out_h > 0 && out_w > 0, std::string(op) + ": empty input or output");
}

// PyTorch's area_pixel_compute_source_index with the scale in / out.
double source_index(int64_t dst, int64_t in, int64_t out, bool align_corners, bool cubic) {
  if (align_corners) return out > 1 ? static_cast<double>(dst) * static_cast<double>(in - 1) / static_cast<double>(out - 1) : 0.0;
  const double src = (static_cast<double>(dst) + 0.5) * static_cast<double>(in) / static_cast<double>(out) - 0.5;
  return cubic ? src : std::max(src, 0.0);
}

double cubic_near(double t, double a) { return ((a + 2.0) * t - (a + 3.0)) * t * t + 1.0; }            // |t| <= 1
double cubic_far(double t, double a) { return ((a * t - 5.0 * a) * t + 8.0 * a) * t - 4.0 * a; }      // 1 < |t| < 2

struct Taps {
  int64_t index[4];
  double weight[4];
};

Taps cubic_taps(int64_t dst, int64_t in, int64_t out, bool align_corners) {
  const double src = source_index(dst, in, out, align_corners, true);
  const double f = std::floor(src);
  const double t = src - f;
  constexpr double a = -0.75;
  Taps taps;
  const double w[4] = {cubic_far(t + 1.0, a), cubic_near(t, a), cubic_near(1.0 - t, a), cubic_far(2.0 - t, a)};
  for (int k = 0; k < 4; ++k) {
    taps.index[k] = std::clamp<int64_t>(static_cast<int64_t>(f) - 1 + k, 0, in - 1);
    taps.weight[k] = w[k];
  }
  return taps;
}

}  // namespace

CpuTensor resize_bilinear(const CpuTensor& x, int64_t out_h, int64_t out_w, bool align_corners) {
  require_map(x, out_h, out_w, "resize_bilinear");
  const int64_t BC = x.dim(0) * x.dim(1), H = x.dim(2), W = x.dim(3);
  CpuTensor y({x.dim(0), x.dim(1), out_h, out_w});
  for (int64_t oy = 0; oy < out_h; ++oy) {
    const double sy = source_index(oy, H, out_h, align_corners, false);
    const int64_t y0 = std::min<int64_t>(static_cast<int64_t>(sy), H - 1), y1 = std::min<int64_t>(y0 + 1, H - 1);
    const double ly = sy - static_cast<double>(y0);
    for (int64_t ox = 0; ox < out_w; ++ox) {
      const double sx = source_index(ox, W, out_w, align_corners, false);
      const int64_t x0 = std::min<int64_t>(static_cast<int64_t>(sx), W - 1), x1 = std::min<int64_t>(x0 + 1, W - 1);
      const double lx = sx - static_cast<double>(x0);
      for (int64_t bc = 0; bc < BC; ++bc) {
        const float* p = x.data.data() + bc * H * W;
        const double v = (1.0 - ly) * ((1.0 - lx) * D(p[y0 * W + x0]) + lx * D(p[y0 * W + x1])) +
                         ly * ((1.0 - lx) * D(p[y1 * W + x0]) + lx * D(p[y1 * W + x1]));
        y.data[static_cast<size_t>((bc * out_h + oy) * out_w + ox)] = static_cast<float>(v);
      }
    }
  }
  return y;
}

CpuTensor resize_bicubic(const CpuTensor& x, int64_t out_h, int64_t out_w, bool align_corners) {
  require_map(x, out_h, out_w, "resize_bicubic");
  const int64_t BC = x.dim(0) * x.dim(1), H = x.dim(2), W = x.dim(3);
  CpuTensor y({x.dim(0), x.dim(1), out_h, out_w});
  for (int64_t oy = 0; oy < out_h; ++oy) {
    const Taps ty = cubic_taps(oy, H, out_h, align_corners);
    for (int64_t ox = 0; ox < out_w; ++ox) {
      const Taps tx = cubic_taps(ox, W, out_w, align_corners);
      for (int64_t bc = 0; bc < BC; ++bc) {
        const float* p = x.data.data() + bc * H * W;
        double v = 0.0;
        for (int r = 0; r < 4; ++r) {
          double row = 0.0;
          for (int c = 0; c < 4; ++c) row += tx.weight[c] * D(p[ty.index[r] * W + tx.index[c]]);
          v += ty.weight[r] * row;
        }
        y.data[static_cast<size_t>((bc * out_h + oy) * out_w + ox)] = static_cast<float>(v);
      }
    }
  }
  return y;
}

CpuTensor resize_nearest(const CpuTensor& x, int64_t out_h, int64_t out_w) {
  require_map(x, out_h, out_w, "resize_nearest");
  const int64_t BC = x.dim(0) * x.dim(1), H = x.dim(2), W = x.dim(3);
  CpuTensor y({x.dim(0), x.dim(1), out_h, out_w});
  for (int64_t bc = 0; bc < BC; ++bc)
    for (int64_t oy = 0; oy < out_h; ++oy) {
      const int64_t iy = std::min<int64_t>(oy * H / out_h, H - 1);
      for (int64_t ox = 0; ox < out_w; ++ox) {
        const int64_t ix = std::min<int64_t>(ox * W / out_w, W - 1);
        y.data[static_cast<size_t>((bc * out_h + oy) * out_w + ox)] = x.data[static_cast<size_t>((bc * H + iy) * W + ix)];
      }
    }
  return y;
}

}  // namespace icube::nn::cpu
