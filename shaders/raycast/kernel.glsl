#ifndef RAYCAST_EXACT_F64
#define RAYCAST_EXACT_F64 0
#endif
#ifndef RAYCAST_EXACT_DF
#define RAYCAST_EXACT_DF 0
#endif
// raycast: one invocation per ray, the semantic hit and the depth of the ray
// in the GPU world (conventions §10.2) by the one-loop traversal of
// raycast/traverse.glsl (column-top, 32³ super-brick, 8³ brick and 4³
// octant skipping via the occupancy index of binding 4, built by
// raycast/occupancy.comp, or hash-table brick skipping in the RAYCAST_OCCUPANCY
// = false pipeline; exact voxel DDA steps in occupied octants; rules of the CPU
// reference engine/render/raycast_cpu.h).
// Camera mode (p.width > 0): ray i is pixel (i % width, i / width), origin
// (off_x, off_y, off_z) relative to the camera voxel p.ref, direction
// normalize(M · (u + pixel_offset, v + pixel_offset, 1)). Ray-list mode
// (p.width == 0): rays[2i] = (origin relative to p.ref in voxel units, 0),
// rays[2i + 1] = (unit world direction, 0). Output hits[i] (RaycastHit).
// Variants: shaders/raycast/cast.comp (float) and shaders/raycast/exact.comp
// (RAYCAST_EXACT_F64 = 1, for devices with shaderFloat64), a second pass over a
// camera cast: the float pass flags rays whose semantic decision met a chord
// within float rounding of eps_sem (p.mark_near, RAYCAST_FLAG_NEAR) and the exact
// pass re-casts only those, deciding such chords in double from the camera of
// binding 6 (RaycastCameraF64), so the decision is the CPU reference's. The double
// code lives in its own pipeline: inside the float loop it doubled the kernel's
// time on lavapipe (register pressure), as a second pass it costs one flag read per ray.
// shaders/raycast/exact_df.comp (RAYCAST_EXACT_DF = 1) is the same pass for devices without
// shaderFloat64: the chords in double-float from the camera of binding 7 as float pairs
// (RaycastCameraDf, shared/raycast_df_params.h; no double anywhere).
// Host module: engine/render/raycast_gpu.{h,cpp}; test: tests/render/test_raycast.cpp.
#include "shared/world_layout.h"
#include "shared/raycast_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
// Spec constant 1: skip empty bricks in one step (default); false walks them voxel by voxel.
layout(constant_id = 1) const bool RAYCAST_SKIP_EMPTY = true;
// Spec constant 2: camera mode sub-tile width (0 = rows: ray i = pixel i). With TILE_W > 0 each run of
// RAYCAST_SUB_LANES invocations (spec constant 3, the subgroup size) covers a TILE_W x (SUB_LANES /
// TILE_W) pixel sub-tile, and a workgroup (local_size_x invocations) covers a RAYCAST_WG_W (spec
// constant 4) x (local_size_x / RAYCAST_WG_W) pixel tile of sub-tiles, row-major; tiles row-major;
// the host dispatches whole tiles and lanes outside the image return.
layout(constant_id = 2) const uint RAYCAST_TILE_W = 0u;
layout(constant_id = 3) const uint RAYCAST_SUB_LANES = 8u;
layout(constant_id = 4) const uint RAYCAST_WG_W = 8u;
// Spec constant 5: cells come from the occupancy index (binding 4); false: every brick is looked
// up in the hash table (worlds without an index). A pipeline per path: lavapipe runs both sides of
// a runtime branch (masked), so the unused path would cost every step.
layout(constant_id = 5) const bool RAYCAST_OCCUPANCY = true;
// Spec constant 6: ray-list casts flag (RAYCAST_FLAG_NEAR in the hit, with p.mark_near) the rays whose
// walk, semantic chord or depth run came within float rounding of a decision a double walk of the same
// ray could take the other way (raycast/traverse.glsl, raycast_tie_eps); the caller re-casts those in
// double (the GSM's pixel rays: engine/nn/gsm/gsm_rays_gpu.h). A pipeline of its own, so camera casts
// pay nothing for it.
layout(constant_id = 6) const bool RAYCAST_MARK_TIES = false;
layout(push_constant) uniform Push { RaycastParams p; };
// The world is read through texel buffers only (the hash table as R32G32B32A32_UINT texels, the
// brick words as R32_UINT), so it is bounded by maxTexelBufferElements, not by one storage binding.
layout(binding = 0) uniform usamplerBuffer world_table_texels;
// Rays and hits of one window of rays [p.first, p.n): rays[2 (i - first)], hits[i - first].
layout(std430, binding = 2) readonly buffer Rays { vec4 rays[]; };
layout(std430, binding = 3) writeonly buffer Hits { RaycastHit hits[]; };
// Rays flagged RAYCAST_FLAG_NEAR: near_list[0] counts them, near_list[1 + k] = ray index
// (appended by the float pass when p.mark_near, read by the exact pass).
layout(std430, binding = 6) buffer NearList { uint near_list[]; };
layout(binding = 4) uniform usamplerBuffer occ_index;    // occupancy index (R32G32_UINT texels: word pairs)
layout(binding = 5) uniform usamplerBuffer brick_words;  // the brick records as R32_UINT texels
#define world_brick_texels brick_words
layout(binding = 8) uniform usamplerBuffer occ_masks;    // the occupancy index as R32_UINT texels (mask level)
#if RAYCAST_EXACT_F64
#include "shared/raycast_f64_params.h"
layout(std430, binding = 7) readonly buffer CameraF64 { RaycastCameraF64 cam64; };
#elif RAYCAST_EXACT_DF
#include "shared/raycast_df_params.h"
#include "common/df.glsl"
layout(std430, binding = 7) readonly buffer CameraDf { RaycastCameraDf camdf; };
#endif

#include "world/lookup_texel.glsl"
#include "raycast/traverse.glsl"

// Camera-mode pixel (px, py) of ray i.
uvec2 raycast_pixel(uint i) { return uvec2(i % p.width, i / p.width); }

vec3 raycast_camera_dir(uvec2 px) {
  const float u = float(px.x) + p.pixel_offset, v = float(px.y) + p.pixel_offset;
  return normalize(vec3(p.m00 * u + p.m01 * v + p.m02, p.m10 * u + p.m11 * v + p.m12, p.m20 * u + p.m21 * v + p.m22));
}

#if RAYCAST_EXACT_F64 || RAYCAST_EXACT_DF
// Exact pass: a grid-stride loop over the flagged rays of the float pass (camera mode).
void main() {
  const uint count = near_list[0];
  const uint stride = gl_NumWorkGroups.x * gl_NumWorkGroups.y * gl_NumWorkGroups.z * gl_WorkGroupSize.x;
  for (uint k = ICUBE_THREAD_LINEAR(); k < count; k += stride) {
    const uint i = near_list[1u + k];
    const uvec2 px = raycast_pixel(i);
    hits[i - p.first] = raycast_traverse(vec3(p.off_x, p.off_y, p.off_z), raycast_camera_dir(px), px);
  }
}
#else
void main() {
  uint i = p.first + ICUBE_THREAD_LINEAR();
  uint px = 0u, py = 0u;
  if (p.width != 0u && RAYCAST_TILE_W > 0u) {
    const uint g = icube_group_linear(), l = gl_LocalInvocationID.x;
    const uint wg_h = gl_WorkGroupSize.x / RAYCAST_WG_W, tpr = (p.width + RAYCAST_WG_W - 1u) / RAYCAST_WG_W;
    const uint sub = l / RAYCAST_SUB_LANES, lane = l % RAYCAST_SUB_LANES;
    const uint sub_h = RAYCAST_SUB_LANES / RAYCAST_TILE_W, subs_per_row = RAYCAST_WG_W / RAYCAST_TILE_W;
    // A window of whole tile rows starts at row p.first / width.
    px = (g % tpr) * RAYCAST_WG_W + (sub % subs_per_row) * RAYCAST_TILE_W + lane % RAYCAST_TILE_W;
    py = p.first / p.width + (g / tpr) * wg_h + (sub / subs_per_row) * sub_h + lane / RAYCAST_TILE_W;
    if (px >= p.width || py >= p.n / p.width) return;
    i = py * p.width + px;
  } else {
    if (i >= p.n) return;
    if (p.width != 0u) { px = i % p.width; py = i / p.width; }
  }
  vec3 o, d;
  if (p.width != 0u) {
    d = raycast_camera_dir(uvec2(px, py));
    o = vec3(p.off_x, p.off_y, p.off_z);
  } else {
    o = rays[2u * (i - p.first)].xyz;
    d = rays[2u * (i - p.first) + 1u].xyz;
  }
  const RaycastHit h = raycast_traverse(o, d, uvec2(px, py));
  hits[i - p.first] = h;
  // Camera mode lists the flagged rays for the exact pass; ray-list mode leaves them in the hits' flags.
  if (p.width != 0u && (h.flags & RAYCAST_FLAG_NEAR) != 0u) near_list[1u + atomicAdd(near_list[0], 1u)] = i;
}
#endif
