// The GSM's outputs in the package's conventions (splat/gaussians.h, splat/sky.h), for the learned lift
// (gsm_lift.h):
//   Gaussians  the model's activated values (voxel branch: mean, scale = min(exp(raw) * 0.1 m, 1 m),
//              unit quaternion w first, opacity = sigmoid, raw RGB; pixel branch alike) become a
//              GaussianCloud, which stores activated values too: position = `grid_to_target` * mean
//              (double), rotation = the transform's rotation times the quaternion (wxyz), scale and opacity
//              as they are, the colour as SH degree 0: (rgb - 0.5) / C0 (the official RGB2SH; the
//              renderer's 0.5 + C0 * f_dc gives the raw RGB back). Two guards keep the .ply finite: scales
//              below kMinGsmScale are raised to it (exp underflow; log 0 in the file), a quaternion whose
//              norm is not 1 (a raw zero quaternion, which F.normalize leaves zero) becomes the identity;
//              the writer clamps opacities to [1e-12, 1 - 1e-7] for their logit.
//   objects    the official dynamic pass (_extract_and_save_dynamic_gaussians): per key frame the Gaussians
//              of its dynamic pixels (instance >= 10000), per object of the frame those whose centre lies
//              inside its box (|x| <= l/2, |y| <= w/2, |z| <= h/2 in the box frame), the frame with the most
//              such Gaussians kept (the first on ties), moved into the box frame (the official moves the
//              means only; we rotate the Gaussians too, so the renderer's rigid placement gives them back
//              exactly at that frame).
//   sky        the model's panorama (GsmOutputs::sky_panorama: the modulator MLP on the official rows x
//              2 rows latitude-longitude grid) is splat/sky.h's equirect layout when the grid axes are the
//              world's (row 0 the zenith, the centre column along +x, longitude decreasing to the right):
//              the sky image is its colours clamped to [0, 1], times 255, rounded; alpha 255.
// Test: tests/lift/test_gsm_lift.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "splat/gaussians.h"
#include "splat/sky.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <map>
#include <vector>

namespace icube::lift {

inline constexpr float kMinGsmScale = 1e-8f;  // metres

// One branch's Gaussians, n of them (nn::VoxelGaussians and nn::PixelGaussians hold these tensors).
struct GsmGaussianTensors {
  const nn::CpuTensor* means = nullptr;      // [n, 3]
  const nn::CpuTensor* scales = nullptr;     // [n, 3]
  const nn::CpuTensor* rotations = nullptr;  // [n, 4], w first
  const nn::CpuTensor* opacities = nullptr;  // [n, 1]
  const nn::CpuTensor* colors = nullptr;     // [n, >= 3], raw RGB first
  size_t count() const;
};

template <class Branch>
GsmGaussianTensors gsm_gaussian_tensors(const Branch& b) {
  return {&b.means, &b.scales, &b.rotations, &b.opacities, &b.colors};
}

struct GsmConversionStats {
  size_t floored_scales = 0, identity_rotations = 0;
};

// Appends rows `rows` of `g` (every row when null), in that order, through the rigid `grid_to_target`.
void append_gsm_gaussians(splat::GaussianCloud& out, const GsmGaussianTensors& g, const glm::dmat4& grid_to_target,
                          const std::vector<size_t>* rows = nullptr, GsmConversionStats* stats = nullptr);

// A dynamic object of a key frame: its box in the grid frame.
struct GsmObjectBox {
  uint16_t id = 0;
  glm::dmat4 object_to_grid{1.0};
  glm::dvec3 lwh{0.0};
};

// The official choice of one key frame's Gaussians per object (header comment). Call add_frame for the key
// frames in order; rows = the frame's candidate Gaussians (those of its dynamic pixels).
class GsmObjectPicker {
 public:
  void add_frame(size_t frame, const GsmGaussianTensors& g, const std::vector<size_t>& rows,
                 const std::vector<GsmObjectBox>& boxes);
  struct Pick {
    size_t frame = 0;
    GsmGaussianTensors gaussians;
    std::vector<size_t> rows;
    glm::dmat4 grid_to_object{1.0};
  };
  const std::map<uint16_t, Pick>& picks() const { return picks_; }

 private:
  std::map<uint16_t, Pick> picks_;
};

// The sky image of a panorama [1, rows, cols, >= 3] (or [rows, cols, >= 3]).
splat::SkyImage gsm_sky_image(const nn::CpuTensor& panorama);

}  // namespace icube::lift
