// The configuration of InfiniCube's sparse structure VAE: the official
// `StructPredictionNet` constructor's keyword arguments under their official
// names (voxelgen/modules/autoencoding/sunet.py), read from a JSON object or
// from its "vae_kwargs" member (as ../shared/data/models/vae_small/config.json
// holds it), plus the input encoder's settings (base_encoder.py, from the
// training config: 23 semantic classes embedded in 32 channels, no normals,
// intensity or colour) under an optional "encoder_kwargs" member.
// Arguments that do not change inference (use_checkpoint) are accepted; an
// unknown key, a wrong type or a value the engine does not implement
// (attention blocks, normal or colour heads, non-residual blocks, is_add_dec
// false, unstable_cutoff) is a scene::InputError naming the file and the key.
// Preset "infinicube-vae" is the released model (vae.tsv's kwargs).
//
// The module tree it implies (conventions §8.1), with n = [in_channels,
// f_maps * 2^0, ..., f_maps * 2^(num_blocks - 1)] and latent channels
// n[-1] / cut_ratio: param_specs() lists every parameter under its official
// name ("unet.<...>" for the StructPredictionNet, "encoder.<...>" for the
// input encoder) with its fVDB shape.
#pragma once

#include "kernels/nn/sparse_cpu.h"
#include "nn/param_spec.h"

#include <string>
#include <vector>

namespace icube::nn {

struct VaeConfig {
  int in_channels = 32;
  int num_blocks = 3;
  int f_maps = 64;
  std::string order = "gcs";  // ConvBlock layers: g GroupNorm, c conv 3^3, s SiLU, r ReLU
  int num_groups = 8;
  std::vector<int> pooling_level{2};  // encoder levels pooled [2,2,2]; the others [2,2,1]
  bool neck_dense = true;              // neck_dense_type "HAND_CRAFTED" (false: "UNCHANGED")
  int cut_ratio = 32;
  Ijk neck_bound{32, 32, 32};          // dense neck box [-b, b) at the latent level
  bool with_semantic_branch = true;
  int num_semantic_classes = 23;
  int num_res_blocks = 1;
  // Encoder (base_encoder.py).
  int num_semantic = 23;
  int dim_semantic = 32;
  int pos_freqs = 5;  // NeRF embedding 2^0 .. 2^(pos_freqs - 1), input included

  std::vector<int> features() const;  // n above
  int latent_channels() const { return features().back() / cut_ratio; }
  // Pooling factor of encoder level l (l >= 1) and subdivision factor of decoder level l (the level it
  // produces, num_blocks - 2 .. 0).
  Ijk pool_factor(int level) const;
  Ijk subdivide_factor(int level) const;
  int encoder_input_dim() const { return 3 + 6 * pos_freqs + dim_semantic; }
};

VaeConfig parse_vae_config(const std::string& json_text, const std::string& source);
// A file path, or a preset name: "infinicube-vae" (the released model) or "infinicube-vae-tiny" (its
// structure at f_maps 8: the same levels and latent, for smoke tests and benchmarks).
VaeConfig load_vae_config(const std::string& path_or_preset);
VaeConfig infinicube_vae_config();

enum class VaePart { Encoder, Decoder, All };
// Every parameter of `part` (Encoder: encoder.*, pre_conv, encoders, pre_kl_bottleneck; Decoder:
// post_kl_bottleneck, struct_convs, decoders, semantic_head) in module order.
std::vector<ParamSpec> vae_param_specs(const VaeConfig& config, VaePart part);

}  // namespace icube::nn
