// The GSM's sky token (sky_reference.h: sky_tokens) with its two layers of work on the GPU:
//   patch embedding   the patch-size, stride-patch conv2d of the [0, 1] images (LayerRecorder::conv2d)
//   encoder inputs    on the host (sky_token_inputs): the used-patch mask from the masks, the patch rays
//                     and their linear embedding (n x 3 x embed_dim), the gather of used patches behind
//                     the query — integer bookkeeping and a few kFLOP, as the reference does them
//   encoder           the post-norm GELU transformer on the GPU per batch element, tokens [1, E, n]:
//                     in_proj as one [3E, E] linear (attention_qkv takes q, k, v as its channel thirds),
//                     out_proj, add + LayerNorm (eps 1e-5), linear1, GELU, linear2, add + LayerNorm
// The encoder's in_proj weights are read under <layer>.self_attn.in_proj.{weight,bias}, copies of the
// official in_proj_weight / in_proj_bias (add_sky_gpu_tensors). Traces what sky_tokens traces.
// Test: tests/nn/test_gsm_sky_token_gpu.cpp; the forward: engine/nn/gsm/gsm_gpu.cpp step 2.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/device_tensor.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"
#include "nn/gsm/sky_reference.h"
#include "nn/layer_recorder.h"

#include <map>
#include <string>

namespace icube::nn {

// The sky token [B, embed_dim] of every batch element from the images on the device [B * N, 3, H, W];
// submits its own command lists on L's context (L must not be recording).
CpuTensor sky_tokens_gpu(LayerRecorder& L, const SkyConfig& c, const GsmWeights& w, const GsmInputs& in,
                         const DeviceTensor& images, GsmTrace* trace);

// The encoder's in_proj weights under the names the GPU layers read (see above).
void add_sky_gpu_tensors(const GsmWeights& w, std::map<std::string, CpuTensor>& tensors);

}  // namespace icube::nn
