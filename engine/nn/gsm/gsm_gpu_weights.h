// The GSM's weights prepared for its GPU stages (one ParameterStore): the
// model's float tensors under their official names, plus what the GPU layers
// read in another form (each stage's block in gsm_gpu_weights.cpp says which):
//   <bn>.bn_scale, <bn>.bn_shift   each inference BatchNorm folded into a per-channel affine
//                                  (kernels/nn/batch_norm.h's batch_norm_affine, in double)
//   Depth-Anything-V2              normalisation vectors, the CLS token and position table as flat
//                                  vectors (replacing the official tables), layer-scale shifts, the
//                                  reassemble up-projections packed for conv_transpose2d (dav2_gpu.h)
//   voxel branch                   fVDB sparse kernels in grid order, <conv>.grid_order.weight
//                                  (voxel_branch_gpu.h)
//   x-unet                         frame-kernel-1 convs squeezed to 2-D (replacing the 5-D originals),
//                                  Upsample weights packed for conv_transpose2d, Downsample 1x1s as
//                                  2x2 stride-2 kernels, norm gammas as vectors (xunet_gpu.h)
//   sky token encoder              in_proj_weight / in_proj_bias as <layer>.self_attn.in_proj.{weight,bias}
//                                  (sky_token_gpu.h)
// BatchNorm's num_batches_tracked counters are left out; tensors no kernel reads in their given form
// (rank-3 tables, non-cubic 5-D kernels) are listed in host_only. Tests: through the GPU stages
// (tests/nn/test_gsm_*gpu.cpp).
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/gsm/gsm_weights.h"
#include "nn/param_spec.h"

#include <map>
#include <set>
#include <string>
#include <vector>

namespace icube::nn {

struct GsmGpuWeights {
  std::map<std::string, CpuTensor> tensors;
  std::vector<ParamSpec> specs;  // the tensors' names and shapes
  std::set<std::string> host_only;  // for ParameterStoreOptions::host_only
};

GsmGpuWeights gsm_gpu_weights(const GsmWeights& w);

}  // namespace icube::nn
