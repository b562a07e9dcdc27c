// The camera of a camera-mode cast as double-float pairs, for
// shaders/raycast/exact_df.comp (binding 7), the exact pass of devices without
// shaderFloat64: the same quantities as RaycastCameraF64
// (shared/raycast_f64_params.h), each double d given as (hi, lo) = (float(d),
// float(d - hi)) (d to about 2^-48 relative; pixel_offset, eps_sem's 0.01 and
// the voxel size's 0.2 are not exact in binary anyway, the reference rounds them
// to 53 bits). t_max: FLT_MAX when >= FLT_MAX. Also the push constants of the
// df primitives' test kernel shaders/raycast/df_check.comp. Shared by GLSL (a
// pair is a vec2) and C++ (RaycastDf).
#ifndef ICUBE_RAYCAST_DF_PARAMS_H
#define ICUBE_RAYCAST_DF_PARAMS_H
#include "gpu_types.h"
#include "raycast_params.h"

#ifdef __cplusplus
ICUBE_SHADER_NAMESPACE_BEGIN
struct RaycastDf {
  float hi, lo;
};
ICUBE_SHADER_NAMESPACE_END
#else
#define RaycastDf vec2
#endif

// df_check ops: out[i] = op(in[i].xy, in[i].zw) as (hi, lo, 0, 0).
#define RAYCAST_DF_TWO_SUM 0u   // df_two_sum(a.hi, b.hi)
#define RAYCAST_DF_TWO_PROD 1u  // df_two_prod(a.hi, b.hi)
#define RAYCAST_DF_ADD 2u       // df_add(a, b)
#define RAYCAST_DF_MUL 3u       // df_mul(a, b)
#define RAYCAST_DF_DIV 4u       // df_div(a, b)
#define RAYCAST_DF_SQRT 5u      // df_sqrt(a)
#define RAYCAST_DF_SPLIT 6u     // df_split(a.hi)
// raycast_chord_df (raycast/chord_df.glsl) of the camera in binding 2 with the bounds of the
// push constants: in[i] = relative voxel (x, y, z) and pixel (u | v << 16) as int bits.
#define RAYCAST_DF_CHORD 7u

ICUBE_SHADER_NAMESPACE_BEGIN

struct RaycastCameraDf {
  RAYCAST_EXACT_CAMERA_FIELDS(RaycastDf)
};

struct RaycastDfCheckParams {
  uint n;   // values
  uint op;  // RAYCAST_DF_*
  int lo_x, lo_y, lo_z;  // RAYCAST_DF_CHORD: bounds relative to the reference voxel, inclusive
  int hi_x, hi_y, hi_z;  // exclusive
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(RaycastDf, 8);
ICUBE_CHECK_SIZE(RaycastCameraDf, 160);
ICUBE_CHECK_LAYOUT(RaycastCameraDf, fx, 72);
ICUBE_CHECK_LAYOUT(RaycastCameraDf, pixel_offset, 104);
ICUBE_CHECK_LAYOUT(RaycastCameraDf, off_x, 112);
ICUBE_CHECK_LAYOUT(RaycastCameraDf, t_max, 152);
ICUBE_CHECK_SIZE(RaycastDfCheckParams, 32);
ICUBE_CHECK_LAYOUT(RaycastDfCheckParams, hi_x, 20);

#endif
