// The bindings, push constants and workgroup decomposition every conv3d kernel
// shares (conv3d.glsl, conv3d_tiled.glsl, conv3d_coopmat.glsl: the host module
// kernels/nn/conv3d.cpp binds them alike for every path). NN_CONV_F16_WEIGHTS:
// fp16 packed weights (nn/conv_weights.glsl).
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

// The kernel size as a specialization constant (1 or 3; the host makes one
// pipeline each): with it known, the tap loops unroll and lavapipe runs the
// accumulation without loop masks (17 against 12-13 GFLOP/s with p.kernel).
layout(constant_id = 0) const int NN_K = 3;
layout(push_constant) uniform Push { Conv3dParams p; };
layout(binding = 0) uniform samplerBuffer x_tex;  // R32_SFLOAT
#define NN_CONV_WEIGHTS_BINDING 1
#include "conv_weights.glsl"
layout(std430, binding = 2) readonly buffer Bias { float bias[]; };
layout(std430, binding = 3) buffer Out { float y_out[]; };

// Workgroup g: voxel tile g % voxel_tiles, then output-channel block, then batch element
// (batch >= p.batch: past the end, uniform across the workgroup).
struct ConvBlock {
  uint tile, cob, batch;
};
ConvBlock conv_block() {
  const uint g = icube_group_linear();
  const uint rest = g / p.voxel_tiles;
  return ConvBlock(g % p.voxel_tiles, rest % p.co_blocks, rest / p.co_blocks);
}
