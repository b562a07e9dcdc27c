// CPU reference of the procedural appearance renderer (appearance_gpu.h):
// the double-precision ray caster (raycast_cpu.h) for the camera and shadow
// rays, VoxelGrid lookups for the ambient-occlusion probes, and the shading
// model of shared/appearance_shading.h compiled as C++ (shading_cpu.h).
// Plain loops over pixels on `threads` threads; for tests.
#pragma once

#include "render/appearance/appearance_gpu.h"
#include "world/voxel_grid.h"

namespace icube::render {

AppearanceImage render_appearance_cpu(const world::VoxelGrid& grid, const Camera& cam,
                                      const shader::AppearanceParams& lighting, const std::vector<WorldLight>& lights,
                                      const AppearanceOptions& o, unsigned threads = 1);

}  // namespace icube::render
