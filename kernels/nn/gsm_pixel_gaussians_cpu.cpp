// The GSM pixel branch's Gaussian decoding as a plain loop (the CPU reference of
// shaders/nn/gsm_pixel_gaussians.comp), operation by operation as the pixel
// branch's reference decoder (engine/nn/gsm/pixel_branch_reference.cpp): the
// float32 ray, then depth, distance and mean in double. See gsm_pixel_gaussians.h.
// Tests: tests/nn/test_gsm_pixel_gaussians.cpp.
#include "kernels/nn/gsm_pixel_gaussians.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

namespace {

double sigmoid(double v) { return 1.0 / (1.0 + std::exp(-v)); }

}  // namespace

GsmPixelGaussiansDense gsm_pixel_gaussians(const kernels::nn::GsmPixelGaussiansShape& s, const CpuTensor& params,
                                           const std::vector<float>& foreground, const std::vector<float>& grid_foreground,
                                           const std::vector<float>& cameras) {
  const int64_t V = s.views, H = s.height, W = s.width, G = s.gs_per_pixel, GD = s.gs_dim, R = s.record_floats();
  const int64_t P = H * W, CF = kernels::nn::gsm_pixel_camera_floats();
  if (G < 1 || GD < 10) throw std::invalid_argument("gsm_pixel_gaussians: needs gs_per_pixel >= 1 and gs_dim >= 10");
  if (params.numel() != V * G * GD * P || params.rank() < 3 || params.dim(0) != V || params.dim(1) != G * GD)
    throw std::invalid_argument("gsm_pixel_gaussians: params " + params.shape_text() + " are not [views, gs_per_pixel * gs_dim, H, W]");
  if (static_cast<int64_t>(foreground.size()) != V * P || static_cast<int64_t>(grid_foreground.size()) != V * P)
    throw std::invalid_argument("gsm_pixel_gaussians: the masks need views x H x W values");
  if (static_cast<int64_t>(cameras.size()) != V * CF)
    throw std::invalid_argument("gsm_pixel_gaussians: the cameras need " + std::to_string(CF) + " floats per view");

  GsmPixelGaussiansDense out{CpuTensor({V, H, W, G, R}), CpuTensor({V, H, W})};
  const double depth_range = static_cast<double>(s.zfar) - static_cast<double>(s.znear);
  for (int64_t v = 0; v < V; ++v) {
    const float* P4 = cameras.data() + v * CF;  // pose row-major, then fx, fy, cx, cy
    const float* K = P4 + 16;
    for (int64_t p = 0; p < P; ++p) {
      const size_t pix = static_cast<size_t>(v * P + p);
      const float fg = foreground[pix], grid = grid_foreground[pix];
      out.mask.data[pix] = s.midground_only ? fg - fg * grid : fg;

      // The official ray: the camera point at depth 1 taken to the grid (float32), minus the centre, normalised.
      const int64_t row = p / W, col = p % W;
      const float uu = (static_cast<float>(col) - K[2]) / K[0];
      const float vv = (static_cast<float>(row) - K[3]) / K[1];
      const double local[4] = {uu, vv, 1.0, 1.0};
      float d[3];
      for (int i = 0; i < 3; ++i) {
        double sum = 0.0;
        for (int j = 0; j < 4; ++j) sum += static_cast<double>(P4[i * 4 + j]) * local[j];
        d[i] = static_cast<float>(sum) - P4[i * 4 + 3];
      }
      const double dx = d[0], dy = d[1], dz = d[2];
      const double norm = std::sqrt(dx * dx + dy * dy + dz * dz);
      float dir[3];
      for (int i = 0; i < 3; ++i) dir[i] = static_cast<float>(static_cast<double>(d[i]) / norm);
      const float cosine = P4[2] * dir[0] + P4[6] * dir[1] + P4[10] * dir[2];

      for (int64_t g = 0; g < G; ++g) {
        auto raw = [&](int64_t k) { return static_cast<double>(params.data[static_cast<size_t>((v * G * GD + g * GD + k) * P + p)]); };
        float* o = out.gaussians.data.data() + (pix * G + g) * R;
        const float weight = static_cast<float>(sigmoid(raw(0)));
        const double depth = s.inverse_metric_depth ? 1.0 / static_cast<double>(weight)
                                                    : static_cast<double>(weight) * depth_range + static_cast<double>(s.znear);
        const double distance = static_cast<double>(static_cast<float>(depth)) / static_cast<double>(cosine);
        for (int i = 0; i < 3; ++i) {
          o[i] = static_cast<float>(static_cast<double>(P4[i * 4 + 3]) + distance * static_cast<double>(dir[i]));
          o[3 + i] = std::min(static_cast<float>(std::exp(raw(1 + i) - 2.3)), s.max_scale);
        }
        double q2 = 0.0;
        for (int i = 0; i < 4; ++i) q2 += raw(4 + i) * raw(4 + i);
        const double qn = std::max(std::sqrt(q2), 1e-12);
        for (int i = 0; i < 4; ++i) o[6 + i] = static_cast<float>(raw(4 + i) / qn);
        o[10] = static_cast<float>(sigmoid(raw(8) - 1.0));
        for (int64_t k = 9; k < GD; ++k) o[2 + k] = static_cast<float>(raw(k));
      }
    }
  }
  return out;
}

}  // namespace icube::nn::cpu
