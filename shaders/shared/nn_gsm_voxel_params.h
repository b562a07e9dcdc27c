// Push constants of the GSM voxel branch's own kernels
// (shaders/nn/gsm_project_features.comp, gsm_voxel_gaussians.comp; host
// modules kernels/nn/gsm_project_features.cpp, gsm_voxel_gaussians.cpp).
// Shared between GLSL and C++ (gpu_types.h); sizes and offsets checked below.
#ifndef ICUBE_NN_GSM_VOXEL_PARAMS_H
#define ICUBE_NN_GSM_VOXEL_PARAMS_H
#include "gpu_types.h"

#define NN_GSM_PROJECT_GROUP 64
#define NN_GSM_PROJECT_FLAG_MAX_FROM_ZERO 1u  // the maximum over the views starts from 0 (else -inf)
// Views one invocation loops over (lavapipe's 65,535 loop iterations; 4 taps each).
#define NN_GSM_PROJECT_MAX_VIEWS 4096u

#define NN_GSM_GAUSSIANS_GROUP 64

ICUBE_SHADER_NAMESPACE_BEGIN

// gsm_project_features: for each child voxel r of a grid (centre ijk[r] *
// voxel_size + origin) and feature channel c, the maximum over the views n of
// (seen[parent[r] * views + n] != 0 ? sample_n(c) : 0), starting from -inf
// (or 0 with NN_GSM_PROJECT_FLAG_MAX_FROM_ZERO), where sample_n is
// F.grid_sample(bilinear, zeros, align_corners=False) of the masked feature
// map features[n, c] * (mask[n] > 0) at the centre projected by view n's 3x4
// matrix (to (u w', v w', w'), u and v normalised by the image size: pixel
// x = u * width - 0.5). Doubles travel as float pairs (hi, lo = the rest):
// the matrices as proj[(n * 12 + k) * 2 + {0, 1}], voxel size and origin here;
// the float32 shader uses hi alone, the float64 one hi + lo. Features
// [views][channels][height][width], mask [views][height][width], y
// [channels][rows]. One invocation per output element.
struct GsmProjectParams {
  uint rows;
  uint channels;
  uint views;
  uint height;
  uint width;
  uint flags;
  uint pad0;
  uint pad1;
  float voxel_size_hi[4];  // x, y, z, unused
  float voxel_size_lo[4];
  float origin_hi[4];
  float origin_lo[4];
};

// gsm_voxel_gaussians: the voxel heads' raw values raw [per_voxel * gs_dim][rows]
// (channel-major) decoded into Gaussian g = first_gaussian + r * per_voxel + s
// (voxel r, sub s): mean = min corner (ijk * voxel_size + corner) + sigmoid(xyz)
// * voxel_size, scale = exp(raw) * scale_unit (clamped to max_scaling when
// > 0), rotation = quaternion / max(norm, 1e-12), opacity = sigmoid, colour =
// the remaining gs_dim - 11 raw values. Outputs row-major per Gaussian. One
// invocation per (voxel, sub).
struct GsmVoxelGaussiansParams {
  uint rows;
  uint per_voxel;
  uint gs_dim;
  uint first_gaussian;
  float voxel_size_x;
  float voxel_size_y;
  float voxel_size_z;
  float scale_unit;
  float corner_x;  // origin - voxel_size / 2
  float corner_y;
  float corner_z;
  float max_scaling;  // <= 0: none
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(GsmProjectParams, 96);
ICUBE_CHECK_LAYOUT(GsmProjectParams, voxel_size_hi, 32);
ICUBE_CHECK_LAYOUT(GsmProjectParams, origin_lo, 80);
ICUBE_CHECK_SIZE(GsmVoxelGaussiansParams, 48);
ICUBE_CHECK_LAYOUT(GsmVoxelGaussiansParams, scale_unit, 28);
ICUBE_CHECK_LAYOUT(GsmVoxelGaussiansParams, max_scaling, 44);
#endif
