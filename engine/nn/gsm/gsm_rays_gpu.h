// The GSM's pixel rays (gsm_rays.h: first voxel, grid-foreground mask, voxel depth) on the engine's
// voxel ray caster (shaders/raycast/cast.comp in ray-list mode, engine/render/raycast_gpu.h), with the
// same results as the double reference cast_gsm_pixel_rays for every pixel:
//   world     the batch element's input voxels as a world grid whose lattice is the GSM's (voxel ijk
//             = [ijk, ijk + 1) in (x - 0.1) / 0.2 + 0.5, i.e. world origin 0.1 - 0.1 = 0 m)
//   rays      per view, the camera centre and the float32 pixel directions of gsm_pixel_ray_direction,
//             uploaded as they are (not renormalised), relative to the camera's voxel
//   casts     two per view, eps_sem 0 (the first voxel entered) and no bridged gaps (gap_eps < 0:
//             an empty voxel the walk enters ends a run, as fVDB's segments): eps_depth 1 mm gives
//             the grid-foreground mask, 0.1 m the start of the depth run (times the cosine to the
//             optical axis, in float32 as the reference)
//   ties      the casts mark the rays whose walk or run decision came within float rounding of a
//             double walk's other choice (RaycasterGpu::set_mark_ties); those pixels are marched
//             again on the host in double (march_gsm_pixel), so every pixel is the reference's
//   first     the hit voxel's ijk mapped to its row of the input list
// Test: tests/nn/test_gsm_rays_gpu.cpp; the forward: engine/nn/gsm/gsm_gpu.cpp step 3.
#pragma once

#include "gpu/context.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_rays.h"

#include <cstdint>

namespace icube::nn {

struct GsmRayCastStats {
  uint64_t rays = 0;        // pixels cast
  uint64_t rechecked = 0;   // of them marked near a tie and marched again in double on the host
  double gpu_ms = 0.0;      // world upload, ray upload, the casts and the download
  double host_ms = 0.0;     // the re-checks and the row lookups
};

// recheck_ties = false keeps the float walk's results for marked rays too (for tests and benchmarks:
// what the marking and the double re-check change).
GsmPixelRays cast_gsm_pixel_rays_gpu(gpu::Context& ctx, const GsmInputs& in, int64_t batch_element,
                                     GsmRayCastStats* stats = nullptr, bool recheck_ties = true);

}  // namespace icube::nn
