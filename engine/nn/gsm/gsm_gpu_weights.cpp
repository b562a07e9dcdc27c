// The GSM's GPU-side weights; see gsm_gpu_weights.h.
#include "nn/gsm/sky_token_gpu.h"
#include "nn/gsm/gsm_gpu_weights.h"

#include "kernels/nn/batch_norm.h"
#include "nn/gsm/dav2_gpu.h"
#include "nn/gsm/xunet_gpu.h"
#include "nn/gsm/voxel_branch_gpu.h"

namespace icube::nn {

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

GsmGpuWeights gsm_gpu_weights(const GsmWeights& w) {
  GsmGpuWeights g;
  for (const auto& [name, t] : w.tensors) {
    if (ends_with(name, ".num_batches_tracked")) continue;
    g.tensors.emplace(name, t);
    if (ends_with(name, ".running_var")) {
      const std::string p = name.substr(0, name.size() - std::string("running_var").size());
      const kernels::nn::BatchNormAffine a =
          kernels::nn::batch_norm_affine(w.at(p + "weight").data, w.at(p + "bias").data, w.at(p + "running_mean").data, t.data, 1e-5);
      g.tensors.emplace(p + "bn_scale", CpuTensor(t.shape, a.scale));
      g.tensors.emplace(p + "bn_shift", CpuTensor(t.shape, a.shift));
    }
  }
  // Depth-Anything-V2 (nn/gsm/dav2_gpu.h): ImageNet normalisation vectors, the CLS token and position
  // table as flat vectors, the layer scales' zero shift, the reassemble up-projections packed for
  // conv_transpose2d.
  add_dav2_gpu_tensors(w, g.tensors);
  // The voxel branch (nn/gsm/voxel_branch_gpu.h): every fVDB 0.2.0 3x3x3 sparse kernel of backbone_3d in grid
  // order, as <conv>.grid_order.weight (the sparse convolution's packing takes grid order).
  add_voxel_branch_gpu_tensors(w, g.tensors);
  // The pixel branch's x-unet (nn/gsm/xunet_gpu.h): frame-kernel-1 conv weights squeezed to 2-D under
  // their names, Upsample weights packed for conv_transpose2d, Downsample 1x1s as 2x2 stride-2 kernels,
  // RMSNorm / LayerNorm gammas as vectors (and the LayerNorm's zero bias).
  add_xunet_gpu_tensors(w, g.tensors);
  // The sky token's encoder (nn/gsm/sky_token_gpu.h): in_proj as <layer>.self_attn.in_proj.{weight,bias}.
  add_sky_gpu_tensors(w, g.tensors);
  // What no device kernel reads in its given form stays on the host (ParameterStore's host_only): tables
  // of rank 3 (the sky query) and 5-D kernels that are not cubes of 1 or 3.
  for (const auto& [name, t] : g.tensors) {
    g.specs.push_back({name, t.shape});
    const std::vector<int64_t>& s = t.shape;
    const bool cube = s.size() == 5 && s[2] == s[3] && s[3] == s[4] && (s[2] == 1 || s[2] == 3);
    if (s.size() == 3 || (s.size() == 5 && !cube) || s.size() > 5) g.host_only.insert(name);
  }
  return g;
}

}  // namespace icube::nn
