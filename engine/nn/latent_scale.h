// The latent `scale_factor` at the boundary between the diffusion model and
// the VAE (InfiniCube's LDM: the diffusion model samples scale_factor * mu;
// decode divides by it, encode multiplies). Where it comes from, in order:
// the user's --scale-factor, the weight file's __metadata__ "scale_factor"
// (tools/convert_checkpoint.py writes the diffusion checkpoint's value into
// unet.safetensors and vae.safetensors), else 1 — a standalone VAE
// checkpoint has none, and its own encode/decode pair is consistent at 1.
// A metadata value that is not one positive finite number is a
// scene::InputError naming the file.
#pragma once

#include "nn/safetensors.h"

#include <optional>
#include <string>

namespace icube::nn {

struct LatentScale {
  double value = 1.0;
  std::string source;  // "--scale-factor", "<file> metadata" or "none given (1)"
  bool given() const { return source != "none given (1)"; }
};

// flag: the command line's value when given (validated positive and finite).
LatentScale resolve_latent_scale(std::optional<double> flag, const SafetensorsFile& weights);

}  // namespace icube::nn
