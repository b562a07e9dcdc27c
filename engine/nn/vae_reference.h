// Plain CPU reference of InfiniCube's sparse structure VAE (the official
// StructPredictionNet with its input Encoder; conventions §8.1), built from
// the sparse layer references of kernels/nn/sparse_cpu.h: the oracle of the
// GPU VAE and of any reduced configuration. Weights are the official names
// with every 3^3 convolution already in grid order (vae_weights.h).
//
// decode: post-KL ResBlocks on the latent grid, then per level (coarsest
// first) subdivide the kept voxels (not at the latent level), the level's
// decoder ResBlocks, its structure head (keep iff logit0 > logit1); the last
// decision prunes, and the semantic head gives 23 class logits per voxel.
// An all-empty decision gives an empty result with `warning` set (the official
// code fails there).
// encode: NeRF position embedding of the voxel centres (float32, as upstream)
// and the class embedding -> mix_fc -> pre_conv -> encoder blocks (max-pool
// at every level but the first) -> the dense neck box [-b, b) -> pre-KL
// blocks -> GroupNorm -> conv to (mu, log sigma); returns mu (the mode, as
// inference uses it) on the neck grid.
// Tests: tests/nn/test_vae_reference.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "kernels/nn/sparse_cpu.h"
#include "nn/vae_config.h"

#include <map>
#include <string>
#include <vector>

namespace icube::nn {

struct VaeLevel {
  SparseGrid grid;            // before pruning
  std::vector<float> logits;  // [N, 2] structure logits
};

struct VaeDecoded {
  std::vector<VaeLevel> levels;  // index = depth: 0 finest .. num_blocks - 1 the latent level
  SparseTensor semantic;         // the kept finest voxels and their class logits [N, classes]
  std::string warning;           // set when a level kept nothing
};

class VaeReference {
 public:
  VaeReference(const VaeConfig& config, std::map<std::string, CpuTensor> weights);

  VaeDecoded decode(const SparseTensor& latent) const;
  // fine_grid: the 0.2 m voxels of a chunk in the VAE's frame; classes: one id per row.
  SparseTensor encode(const SparseGrid& fine_grid, const std::vector<int32_t>& classes) const;
  // The encoder's input features [N, in_channels] (position embedding, class embedding, mix_fc).
  SparseTensor input_features(const SparseGrid& fine_grid, const std::vector<int32_t>& classes) const;

  const VaeConfig& config() const { return config_; }

 private:
  const CpuTensor& w(const std::string& name) const;
  const CpuTensor* maybe(const std::string& name) const;
  SparseTensor conv_block(const std::string& name, SparseTensor x) const;
  SparseTensor res_block(const std::string& name, SparseTensor x) const;
  SparseTensor head(const std::string& name, const SparseTensor& x) const;

  VaeConfig config_;
  std::map<std::string, CpuTensor> weights_;
};

// The NeRF position embedding of base_encoder.py in float32: [p, sin(p), cos(p), sin(2p), cos(2p), ...,
// sin(2^(freqs-1) p), cos(2^(freqs-1) p)] (3 + 6 freqs values).
std::vector<float> position_embedding(const std::array<float, 3>& p, int freqs);

}  // namespace icube::nn
