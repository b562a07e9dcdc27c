// Push constants and the per-ray result of shaders/raycast/cast.comp (host module:
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
#define RAYCAST_FLAG_NEAR 4u  // see RaycastParams.mark_near; cleared by the exact pass
// Relative bounds are clamped to +-RAYCAST_MAX_REL voxels so that they stay exact in float.
#define RAYCAST_MAX_REL 4194304

// The fields of the exact pass's camera (shared/raycast_f64_params.h, shared/raycast_df_params.h)
// in type T: the camera-to-world rotation r00..r22 (row-major), the intrinsics fx, fy, cx, cy,
// pixel_offset (0 or 0.5), the camera position - reference voxel corner off_x, off_y, off_z
// (voxel units), voxel_size, eps_sem and t_max (metres).
#define RAYCAST_EXACT_CAMERA_FIELDS(T) \
  T r00, r01, r02, r10, r11, r12, r20, r21, r22; \
  T fx, fy, cx, cy; \
  T pixel_offset; \
  T off_x, off_y, off_z; \
  T voxel_size, eps_sem, t_max;

ICUBE_SHADER_NAMESPACE_BEGIN

struct RaycastParams {
  uint n;              // rays: the end of this dispatch's window (all rays without windows)
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
  // The first ray of this dispatch's window of rays [first, n): hits (and, in ray-list mode,
  // rays) are bound from it. Camera mode with tiles: a multiple of width x the tile height.
  uint first;
  // Camera mode, 1: flag rays (RAYCAST_FLAG_NEAR) whose semantic decision met a chord within float
  // rounding of eps_sem, for the exact pass (shaders/raycast/exact.comp), which re-casts only those.
  uint mark_near;
};

// Occupancy index of the ray bounds (built on the GPU from the brick table by
// shaders/raycast/occupancy.comp in three passes), in pairs of words (the kernel
// reads one pair per level with one R32G32_UINT texel fetch). Super level: pair
// s of the dense x-fastest box of super bricks (4^3 bricks = 32^3 voxels,
// s = ijk >> 5) smin = (ref + lo) >> 5, sdim = ((ref + hi - 1) >> 5) - smin + 1
// (`supers` pairs from word 0): x = 0 for an empty super brick, else 1 + its
// block; y = the height word of its 32 x 32 voxel column (every super brick of
// the column holds it): 0 = no occupied voxel in the column, else 1 + the
// column's highest occupied voxel z relative to 32 smin.z; a ray above it skips
// the rest of the column in one step. Word 2 supers counts the blocks (word
// 2 supers + 1 is padding). Block level: block k is RAYCAST_BLOCK_WORDS words
// (64 pairs) from word block_word + RAYCAST_BLOCK_WORDS k (block_word =
// 2 supers + 2), pair (bx & 3) + 4 (by & 3) + 16 (bz & 3) for brick (bx, by, bz)
// of the super brick: x = 0 for no brick, else ((record + 1) << 8) | octants,
// octant bit ox + 2 oy + 4 oz set when the record's 4^3 octant (ox, oy, oz)
// holds an occupied voxel; y = the height word of the brick's 8 x 8 voxel
// column (as above, over the whole column; kept in every brick entry of the
// column in every block). Mask level: from word mask_word = block_word +
// RAYCAST_BLOCK_WORDS max_blocks (also written by the host into word 2 supers + 1, where the
// kernel reads it), RAYCAST_MASK_WORDS words per brick record: a copy of the
// record's occupancy mask (shared/world_layout.h), 64 bytes per brick instead of
// one cache line in every 1.6 KB record. So a cell costs three dependent fetches
// (super pair, brick pair, mask word), no hashing.
#define RAYCAST_SUPER_SHIFT 5
#define RAYCAST_BLOCK_WORDS 128u  // 64 (entry, column height) pairs
#define RAYCAST_MASK_WORDS 16u    // mask words per brick record (512 voxel bits)
// Brick records must stay below this for the block entries' 24-bit record field.
#define RAYCAST_MAX_OCC_RECORDS 16777215u
#define RAYCAST_OCC_MARK 0u      // pass 0, per table slot: mark the brick's super brick
#define RAYCAST_OCC_ALLOCATE 1u  // pass 1, per super brick: give a marked one a zeroed block
#define RAYCAST_OCC_FILL 2u      // pass 2, per table slot: write the brick's entry into its block
struct RaycastOccupancyParams {
  uint slots;       // brick table capacity (passes 0 and 2)
  uint supers;      // super bricks in the box (pass 1)
  int smin_x, smin_y, smin_z;
  uint sdim_x, sdim_y, sdim_z;
  uint block_word;  // first word of block 0 (= 2 supers + 2)
  uint max_blocks;  // blocks allocated (>= the box's occupied super bricks)
  uint pass;        // RAYCAST_OCC_MARK, _ALLOCATE or _FILL
  uint mask_word;   // first word of the mask level (= block_word + RAYCAST_BLOCK_WORDS max_blocks)
  uint pad0, pad1, pad2, pad3;
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
  uint flags;               // RAYCAST_FLAG_SEM | RAYCAST_FLAG_DEPTH (a depth run may start at t = 0) | RAYCAST_FLAG_NEAR
  uint pad1;
  uint pad2;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(RaycastParams, 128);
ICUBE_CHECK_LAYOUT(RaycastParams, first, 120);
ICUBE_CHECK_SIZE(RaycastOccupancyParams, 64);
ICUBE_CHECK_LAYOUT(RaycastOccupancyParams, sdim_x, 20);
ICUBE_CHECK_LAYOUT(RaycastOccupancyParams, pass, 40);
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
