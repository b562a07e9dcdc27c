// GPU host module for the Stage-1 condition volume (conventions §7).
//
// Kernels: shaders/world/cond_boxes.comp (one invocation per latent voxel: position
// channels and box channels, float clipping) and shaders/world/cond_points.comp
// (scatter of map grid points into road_edge / road_line / road_surface).
// Inputs come from gather_condition_inputs() (engine/world/conditions.h):
// chunk-frame data computed in double on the host, uploaded as float; the
// road_surface points are the fitted surface's (RoadSurface::points()), so
// the kernel only scatters points and knows nothing of the fit.
// Lives in engine/world/ rather than kernels/ because kernels/CMakeLists.txt
// lists its files explicitly. CPU reference: build_conditions_cpu().
// Test: tests/world/test_conditions.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "world/conditions.h"

#include <cstdint>
#include <vector>

namespace icube::world {

// Tolerances of the float coplanar-face test in world/cond_boxes.comp.
inline constexpr float kGpuCoplanarCos = 1e-6f;
inline constexpr float kGpuCoplanarDist = 1e-5f;

// Device buffers for one chunk's inputs.
struct ConditionBuffers {
  gpu::Buffer points;  // edge, line, surface grid points back to back (3 floats each)
  gpu::Buffer boxes;   // COND_BOX_VEC4S vec4s per box
  uint32_t edge_count = 0, line_count = 0, surface_count = 0, box_count = 0;
};

// The float box records world/cond_boxes.comp reads (7 vec4s per box).
std::vector<float> pack_boxes(const std::vector<ChunkBox>& boxes);

class ConditionVolumeGpu {
 public:
  explicit ConditionVolumeGpu(gpu::Context& ctx);
  ConditionBuffers upload_inputs(const ConditionInputs& in);
  // Records the fill and both kernels writing all 8 channels of `volume`
  // (>= kCondChannels · 64³ floats). The caller orders earlier uses of
  // `volume` before this, and needs a barrier before reading it on the GPU
  // (submit_and_wait's final barrier suffices for the host).
  void record(gpu::CommandList& cmd, const ConditionBuffers& in, const gpu::Buffer& volume);
  // Upload, run, download: the [8, 64, 64, 64] volume.
  std::vector<float> build(const ConditionInputs& in);

 private:
  gpu::Context& ctx_;
  gpu::Program& points_;
  gpu::Program& boxes_;
};

}  // namespace icube::world
