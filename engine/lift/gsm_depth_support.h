// The part of a GSM input grid that its pixel branch's depth prior depends on,
// for the learned lift's dynamic pass (gsm_lift.h): the official pass runs the
// pixel branch alone, the engine's model runs both branches, so the pass hands
// the model only these voxels and its voxel branch (whose Gaussians the pass
// drops) stays small. Same prior, because every quantity the pixel branch
// reads from the grid (nn/gsm/gsm_rays.h) is a prefix of a pixel's walk:
//   voxel depth   where the first run of consecutively entered voxels at least 0.1 m long starts. The
//                 support holds, for each pixel whose ray has such a run starting at t0, every grid voxel
//                 the ray meets for t in [0, t0 + 0.1 m + one voxel] (by a 3-D DDA in double that also
//                 takes both cells of a crossing within 1e-9 voxel of a tie). A sub-grid's runs along a
//                 ray are pieces of the grid's runs, so the earlier (short) runs stay short, the run at t0
//                 keeps its first voxel and at least 0.1 m, and the depth is the same; pixels without such
//                 a run get none either way.
//   grid mask     (the mid-ground rule) is not read: the dynamic pass decodes every pixel.
// Test: tests/lift/test_gsm_lift.cpp (the voxel depth of every pixel on the support equals the grid's).
#pragma once

#include "kernels/nn/sparse_cpu.h"
#include "nn/gsm/gsm_inputs.h"

#include <vector>

namespace icube::lift {

// The support of batch element b's grid (in.voxel_ijk[b]) for its views (in.poses, in.intrinsics, H x W),
// sorted.
std::vector<nn::Ijk> gsm_depth_support(const nn::GsmInputs& in, int64_t b);

}  // namespace icube::lift
