// Push constants and the per-ray result of shaders/raycast.comp (host module:
// engine/render/raycast_gpu.{h,cpp}; CPU reference: engine/render/raycast_cpu.h).
// Shared by GLSL and C++.
//
// Index space: voxel ijk is the cube [ijk, ijk + 1) in voxel units, i.e. the
// world cube [origin + ijk·vs, origin + (ijk+1)·vs]. Everything the kernel
// sees is relative to a reference voxel `ref` (the camera's voxel): ray
// origins are floats in voxel units relative to ref's lower corner, bounds are
// ints relative to ref. Directions are unit vectors in world metres, so t is in
// metres along the ray; the kernel steps with d / vs.
#ifndef ICUBE_RAYCAST_PARAMS_H
#define ICUBE_RAYCAST_PARAMS_H
#include "gpu_types.h"

// RaycastHit.normal: 0 = none (the ray started inside the voxel), else
// ±(axis + 1) with the sign of the entry face's outward normal (against the ray).
#define RAYCAST_NORMAL_NONE 0
#define RAYCAST_FLAG_SEM 1u
#define RAYCAST_FLAG_DEPTH 2u
// Relative bounds are clamped to +-RAYCAST_MAX_REL voxels so that they stay exact in float.
#define RAYCAST_MAX_REL 4194304

ICUBE_SHADER_NAMESPACE_BEGIN

struct RaycastParams {
  uint n;              // rays
  uint width;          // camera mode: image width (ray i = pixel (i % width, i / width)); 0 = ray-list mode
  uint table_mask;     // world hash table capacity - 1
  float pixel_offset;  // 0 (InfiniCube: integer pixels) or 0.5 (pixel centres)
  int ref_x, ref_y, ref_z;  // reference voxel (absolute ijk); hit ijk = ref + relative voxel
  float inv_voxel;          // 1 / voxel size (m^-1)
  float off_x, off_y, off_z;  // camera mode: camera position - ref corner, voxel units (in [0, 1])
  float t_max;                // metres; rays stop there or where they leave the bounds
  int lo_x, lo_y, lo_z;       // world brick bounds relative to ref, voxel units, inclusive
  float eps_sem;              // metres: minimum chord of the semantic voxel
  int hi_x, hi_y, hi_z;       // exclusive (hi <= lo on an axis: empty world, every ray misses)
  float eps_depth;            // metres: minimum in-grid length of the depth run
  // Camera mode: d = normalize(M · (u + pixel_offset, v + pixel_offset, 1)), M = R_c2w · K^-1, row-major.
  float m00, m01, m02, m10, m11, m12, m20, m21, m22;
  float gap_eps;  // metres: empty length along the ray that ends a depth run (smaller gaps are bridged)
  // 1: the occupancy buffer (binding 4) holds the brick and super-brick bit masks over the bounds
  // (layout below); 0: every brick is looked up in the hash table.
  uint occupancy;
  uint pad0;
};

// Occupancy of the ray bounds (built on the GPU from the brick table by
// shaders/raycast_occupancy.comp). Brick level: bit per 8^3 brick over the bounds'
// bricks, absolute brick b (= ijk >> 3) at index of b - bmin in a dense x-fastest
// box of bdim bricks, bmin = (ref + lo) >> 3, bdim = (hi - lo) >> 3. Super level:
// bit per 4^3 bricks (32^3 voxels, s = ijk >> 5), s - smin in a box of sdim,
// smin = (ref + lo) >> 5, sdim = ((ref + hi - 1) >> 5) - smin + 1, starting at
// word ceil(bricks / 32). Bit n is bit n % 32 of word n / 32. Octant level: one
// byte per brick record r (4 per word, record r in byte r % 4 of word oct_word +
// r / 4, oct_word = super_word + ceil(supers / 32)), bit ox + 2 oy + 4 oz set
// when the record's 4³ octant (ox, oy, oz) holds an occupied voxel.
#define RAYCAST_SUPER_SHIFT 5
struct RaycastOccupancyParams {
  uint slots;            // brick table capacity
  uint super_word;       // first word of the super level
  int bmin_x, bmin_y, bmin_z;
  int smin_x, smin_y, smin_z;
  uint bdim_x, bdim_y, bdim_z;
  uint sdim_x, sdim_y, sdim_z;
  uint oct_word;         // first word of the octant bytes
  uint pad0;
};

// One ray's result (std430 stride 48).
struct RaycastHit {
  float t_sem;        // metres: entry t of the semantic voxel (0 when none)
  float t_depth;      // metres: entry t of the first run with in-grid length >= eps_depth; 0 = miss
  uint sem_class;     // class of the semantic voxel, 0 = no semantic hit
  uint sem_instance;  // its instance id
  int ijk_x, ijk_y, ijk_z;  // absolute ijk of the semantic voxel (0 when none)
  int normal;               // entry face of the semantic voxel (RAYCAST_NORMAL_NONE or ±(axis + 1))
  uint steps;               // traversal steps (voxel steps + brick steps), for benchmarks
  uint flags;               // RAYCAST_FLAG_SEM | RAYCAST_FLAG_DEPTH (a depth run may start at t = 0)
  uint pad1;
  uint pad2;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(RaycastParams, 128);
ICUBE_CHECK_LAYOUT(RaycastParams, occupancy, 120);
ICUBE_CHECK_SIZE(RaycastOccupancyParams, 64);
ICUBE_CHECK_LAYOUT(RaycastOccupancyParams, bdim_x, 32);
ICUBE_CHECK_LAYOUT(RaycastParams, ref_x, 16);
ICUBE_CHECK_LAYOUT(RaycastParams, off_x, 32);
ICUBE_CHECK_LAYOUT(RaycastParams, lo_x, 48);
ICUBE_CHECK_LAYOUT(RaycastParams, hi_x, 64);
ICUBE_CHECK_LAYOUT(RaycastParams, m00, 80);
ICUBE_CHECK_LAYOUT(RaycastParams, gap_eps, 116);
ICUBE_CHECK_SIZE(RaycastHit, 48);
ICUBE_CHECK_LAYOUT(RaycastHit, sem_class, 8);
ICUBE_CHECK_LAYOUT(RaycastHit, ijk_x, 16);
ICUBE_CHECK_LAYOUT(RaycastHit, normal, 28);
ICUBE_CHECK_LAYOUT(RaycastHit, steps, 32);
ICUBE_CHECK_LAYOUT(RaycastHit, flags, 36);

#endif
