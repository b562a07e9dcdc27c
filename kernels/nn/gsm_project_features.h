// The GSM voxel branch's projected image features (InfiniCube Pure3DUnet's
// "hybrid" head input, engine/nn/gsm/voxel_heads_reference.cpp): for every
// child voxel (a 0.1 m child of a first-hit voxel) and feature channel, the
// maximum over the views of
//   seen[parent, view] ? grid_sample(features[view] * (mask[view] > 0), centre projected into view) : 0
// with F.grid_sample's bilinear, zeros-outside, align_corners=False sampling
// (pixel x = u * width - 0.5 for the normalised image coordinate u), the
// maximum starting from -inf, or from 0 (max_from_zero: the official loop the
// model takes from 30 views on). A masked view thus takes part with 0.
// Projection: per view a 3x4 matrix from grid coordinates to (u w, v w, w),
// u and v normalised by the image size (the caller builds it, in double, from
// the pose and intrinsics).
// GPU: GsmProjectFeatures::record, one invocation per output element. The
// sample point is projected in double where the device has shaderFloat64
// (shaders/nn/gsm_project_features_f64.comp: the matrices, voxel size and
// origin travel as float pairs hi + lo), else in float32 with the hi parts
// (gsm_project_features.comp: ~1e-7 of the image width off, which moves a
// sample by that times the feature map's gradient); the bilinear sum is
// float32. Tensors past one storage binding (4 key frames of the released
// model's 64-channel 480 x 832 feature maps are 390 MiB; lavapipe binds 128
// MiB) go in windows of views, channels and children (GsmProjectFeatures::
// windows), one dispatch each; a window of later views takes the maximum
// with what the earlier ones wrote, so the caller puts a compute barrier
// before each window marked barrier_before. One view's feature plane and mask
// and the seen table must fit one binding (checked). No barrier inside.
// CPU reference: nn::cpu::gsm_project_features (double).
// Tests: tests/nn/test_gsm_project_features.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <array>
#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

struct GsmProjectShape {
  uint32_t rows = 0;      // children
  uint32_t parents = 0;   // rows of the seen table
  uint32_t channels = 1;  // feature channels
  uint32_t views = 1, height = 1, width = 1;
  std::array<double, 3> voxel_size{1.0, 1.0, 1.0};  // the children grid: centre = ijk * voxel_size + origin
  std::array<double, 3> origin{0.0, 0.0, 0.0};
  bool max_from_zero = false;
};

// The projection matrices ([views][12] row-major 3x4, double) as the kernel's buffer: (hi, lo) float pairs.
std::vector<float> gsm_projection_pairs(const std::vector<double>& proj);

// One dispatch's part of the output: views [view_first, + view_count) of channels [channel_first, + count)
// at children [row_first, + count).
struct GsmProjectWindow {
  uint32_t view_first = 0, view_count = 0;
  uint32_t channel_first = 0, channel_count = 0;
  uint32_t row_first = 0, row_count = 0;
  bool barrier_before = false;  // the first window of later views: order the earlier windows' writes before it
};

class GsmProjectFeatures {
 public:
  explicit GsmProjectFeatures(gpu::Context& ctx);
  // The windows of `s` in recording order (one when every tensor fits one binding); std::invalid_argument
  // when one view's plane or the seen table exceed one binding.
  std::vector<GsmProjectWindow> windows(const GsmProjectShape& s) const;
  // One window: features float [views][channels][height][width], mask float [views][height][width], ijk int32
  // [rows][3], parent int32 [rows] (rows of `seen`), seen uint32 [parents][views], proj from
  // gsm_projection_pairs -> y float [channels][rows] (channel-major). The caller orders inputs before, y after,
  // and the windows among themselves (barrier_before).
  void record(gpu::CommandList& cmd, const GsmProjectShape& s, const GsmProjectWindow& w, const gpu::Buffer& features,
              const gpu::Buffer& mask, const gpu::Buffer& ijk, const gpu::Buffer& parent, const gpu::Buffer& seen,
              const gpu::Buffer& proj, const gpu::Buffer& y);
  // Whether the projection runs in double (the device has shaderFloat64 and float32 is not forced).
  bool projects_in_double() const;
  // Tests: the float32 projection even where double is available.
  void force_float32(bool on) { force_float32_ = on; }

 private:
  gpu::Context& ctx_;
  bool force_float32_ = false;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// features [N, C, h, w], mask [N, h, w], ijk [R * 3], parent [R], seen [P * N], proj [N * 12] (row-major 3x4
// per view) -> [R, C]. Centres, projection and sampling in double.
CpuTensor gsm_project_features(const CpuTensor& features, const CpuTensor& mask, const std::vector<int32_t>& ijk,
                               const std::vector<int32_t>& parent, const std::vector<uint32_t>& seen,
                               const std::vector<double>& proj, const std::array<double, 3>& voxel_size,
                               const std::array<double, 3>& origin, bool max_from_zero);

}  // namespace icube::nn::cpu
