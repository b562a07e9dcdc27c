// Push constants of the network layer's kernels (shaders/nn/*.comp,
// kernels/nn/*.cpp).
#ifndef ICUBE_NN_PARAMS_H
#define ICUBE_NN_PARAMS_H
#include "gpu_types.h"

// conv3d register tile: each invocation computes NN_CONV_CO_TILE output
// channels at NN_CONV_VOXELS voxels (strided by the workgroup width, so a
// warp's / SIMD row's loads of one input row are contiguous).
#define NN_CONV_GROUP 64
#define NN_CONV_VOXELS 4
#define NN_CONV_CO_TILE 8

ICUBE_SHADER_NAMESPACE_BEGIN

// conv3d: dense NCDHW float32, stride 1, padding kernel / 2 (sizes kept).
// Workgroup g: voxel tile g % voxel_tiles, then channel block, then batch.
struct Conv3dParams {
  uint batch;
  uint in_channels;
  uint out_channels;
  uint co_blocks;    // ceil(out_channels / NN_CONV_CO_TILE)
  uint size_x;
  uint size_y;
  uint size_z;
  uint kernel;       // 1 or 3
  uint voxel_tiles;  // ceil(X*Y*Z / (NN_CONV_GROUP * NN_CONV_VOXELS))
  uint has_bias;
  uint pad0;
  uint pad1;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(Conv3dParams, 48);
ICUBE_CHECK_LAYOUT(Conv3dParams, kernel, 28);
ICUBE_CHECK_LAYOUT(Conv3dParams, has_bias, 36);

#endif
