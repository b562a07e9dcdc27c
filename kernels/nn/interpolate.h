// 2-D resampling of [B, C, H, W] maps with PyTorch's F.interpolate semantics
// (to an output size; no antialiasing): bilinear with or without corner
// alignment, bicubic (a = -0.75, border-clamped taps, as PyTorch), and
// nearest (source index floor(dst * in / out)). The GSM resizes its images,
// Depth-Anything's position grid and features with them.
// GPU: Interpolate::record (shaders/nn/interpolate.comp, one thread per output
// element, exact integer source positions). x and y may exceed one storage
// binding: record() then runs windows of whole batch x channel planes, each
// bound at an aligned offset; a single plane (input or output) beyond one
// binding is refused with an std::invalid_argument naming its size (the GSM's
// planes are a few hundred KiB). No barrier inside.
// CPU reference: nn::cpu::resize_* (interpolate_cpu.cpp). Tests: tests/nn/test_interpolate.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>

namespace icube::kernels::nn {

enum class InterpolateMode : uint32_t { nearest = 0, bilinear = 1, bicubic = 2 };

struct InterpolateShape {
  uint32_t batch = 1, channels = 1;
  uint32_t in_h = 1, in_w = 1, out_h = 1, out_w = 1;
  InterpolateMode mode = InterpolateMode::bilinear;
  bool align_corners = false;  // bilinear and bicubic only (PyTorch refuses it for nearest; so does record())
};

class Interpolate {
 public:
  explicit Interpolate(gpu::Context& ctx);
  // y [B, C, out_h, out_w] = F.interpolate(x [B, C, in_h, in_w], (out_h, out_w), mode, align_corners).
  // x and y must not overlap. The caller orders x before and y after.
  void record(gpu::CommandList& cmd, const InterpolateShape& s, const gpu::Buffer& x, const gpu::Buffer& y);
  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit), to exercise the windows cheaply.
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  uint64_t max_binding_bytes_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// align_corners false: src = (dst + 0.5) * in / out - 0.5, clamped at 0 below; true: src = dst * (in - 1) / (out - 1).
CpuTensor resize_bilinear(const CpuTensor& x, int64_t out_h, int64_t out_w, bool align_corners);
CpuTensor resize_bicubic(const CpuTensor& x, int64_t out_h, int64_t out_w, bool align_corners);
CpuTensor resize_nearest(const CpuTensor& x, int64_t out_h, int64_t out_w);

}  // namespace icube::nn::cpu
