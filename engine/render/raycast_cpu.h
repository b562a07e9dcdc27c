// CPU reference of the voxel ray caster (conventions §10.2): a brute-force
// Amanatides–Woo walk over every voxel the ray crosses, in double precision.
//
// World lattice: voxel ijk is the cube [origin + ijk·vs, origin + (ijk+1)·vs]
// (half-open in index space: a point on a face belongs to the voxel above it).
// The ray is expressed relative to its origin's voxel (integer voxel + in-voxel
// fraction) so far-away cameras keep full precision. Directions are unit, so
// t is in metres.
//
// Per ray, walking voxels in order with chord = in-voxel length (clipped to the
// traversal interval):
//  (a) semantic hit: the first occupied voxel whose chord >= eps_sem (class,
//      instance, ijk, entry t, entry face normal). The voxel containing the
//      origin counts with its chord from t = 0 (normal: none).
//  (b) depth: the entry t of the first run of occupied voxels whose summed
//      chords reach eps_depth (fVDB segments_along_rays semantics). A run is
//      contiguous in t: empty space shorter than gap_eps (rays through an
//      edge or corner visit zero-length voxels) does not end it.
// Traversal is clipped to the world's brick bounds (every allocated 8³ brick)
// and to [0, t_max]. Ties between axes step x before y before z. Ray starting
// voxel = the voxel containing the entry point, with the entry axis fixed by
// the slab that was entered and the other axes corrected so the entry point
// lies in [entry plane, exit plane) in t.
// The GPU kernel (shaders/raycast/cast.comp) follows the same rules in float.
// Tests: tests/render/test_raycast.cpp.
#pragma once

#include "render/camera.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <limits>
#include <vector>

namespace icube::render {

struct RaycastOptions {
  double eps_sem = 0.01;    // metres
  double eps_depth = 0.1;   // metres
  double gap_eps = 1e-4;    // metres; negative: every empty voxel the walk enters ends a run, even at zero length
  double t_max = std::numeric_limits<double>::infinity();
  PixelConvention pixels = PixelConvention::Integer;
};

struct RayResult {
  bool sem_hit = false;
  bool depth_hit = false;
  double t_sem = 0.0;    // entry t of the semantic voxel
  double t_depth = 0.0;  // entry t of the depth run (0 on a miss)
  uint8_t class_id = 0;
  uint16_t instance = 0;
  glm::ivec3 ijk{0};     // semantic voxel
  int normal = 0;        // 0 = none, else ±(axis + 1): outward normal of the entry face
  uint32_t steps = 0;    // voxels visited
};

// The voxel range a ray may cross: the bounds of every allocated brick
// (inclusive, multiples of 8). Empty for an empty grid.
world::IjkBounds raycast_bounds(const world::VoxelGrid& grid);

RayResult cast_ray_cpu(const world::VoxelGrid& grid, const world::IjkBounds& bounds, const Ray& ray,
                       const RaycastOptions& opts);
// All rays, on `threads` std::threads (chunks of 64 rays interleaved across threads).
std::vector<RayResult> cast_rays_cpu(const world::VoxelGrid& grid, const std::vector<Ray>& rays,
                                     const RaycastOptions& opts, unsigned threads = 1);
// The camera's W·H rays (row-major) with opts.pixels.
std::vector<RayResult> cast_camera_cpu(const world::VoxelGrid& grid, const Camera& cam, const RaycastOptions& opts,
                                       unsigned threads = 1);

}  // namespace icube::render
