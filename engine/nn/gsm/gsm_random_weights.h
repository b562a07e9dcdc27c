// Seeded random weights of the GSM's official structure (gsm_params.h), for
// tests and benchmarks without the released checkpoint, drawn in the spirit of
// the reference case's oracle (gsm_small/config.json "weights.init") so that a
// random model's features and Gaussians stay well conditioned:
//   conv / linear weights and biases  U(-1/sqrt(fan_in), 1/sqrt(fan_in)) (torch's default bound)
//   norm weights (BatchNorm, GroupNorm, LayerNorm, RMSNorm gamma, DINOv2 layer scale) 1 + 0.1 N, biases 0.1 N
//   DINOv2 cls / mask tokens and position embeddings 0.5 N; the sky query N
//   BatchNorm running_mean 0.1 N, running_var U(0.5, 1.5) (positive), num_batches_tracked 0
//   the voxel heads' OutConv biases: the official apply_gs_init pattern per Gaussian (xyz offsets 0.5 N when
//   a voxel has several Gaussians, else 0; log-scale log(0.5); quaternion (1, 0, 0, 0); opacity logit(0.1);
//   colour 0.5), which keeps the raw quaternions away from 0
//   the pixel branch's linear_out bias: uniform, plus 1 on each Gaussian's quaternion w (raw channel 4 of
//   gs_dim), so that normalising the quaternion is well conditioned in float32
// One std::mt19937 draws every tensor in state-dict order. gsm_weight_file_tensors gives the tensors as a
// weight file holds them (state-dict order; num_batches_tracked as int64 of shape []).
// Test: tests/nn/test_gsm_params.cpp.
#pragma once

#include "nn/gsm/gsm_weights.h"
#include "nn/safetensors.h"

#include <cstdint>
#include <vector>

namespace icube::nn {

GsmWeights gsm_random_weights(const std::vector<GsmParamSpec>& specs, uint32_t seed);

// The weights as file tensors; each tensor is moved out of `weights` as it is converted (the memory of one copy).
std::vector<TensorToWrite> gsm_weight_file_tensors(GsmWeights&& weights, const std::vector<GsmParamSpec>& specs);

}  // namespace icube::nn
