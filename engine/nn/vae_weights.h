// Loading the structure VAE's weights (official names, vae_config.h's
// parameter list) from a .safetensors file: a standalone VAE file (`unet.*`,
// `encoder.*`) or one converted from the diffusion checkpoint (the same names
// under `vae.`). Checks and errors as weights.h; tensors of the other part
// (the encoder's when decoding) are skipped, not reported.
//
// THE ONE PLACE where fVDB's kernel-axis order is handled: fVDB 0.2.0 (the
// version InfiniCube pins, fvdb-core e2895a5f) stores a k^3 SparseConv3d
// weight as (out, in, K0, K1, K2) with the kernel axes in reverse grid order,
//   out[i,j,k] = sum W[:, :, dk+1, dj+1, di+1] * in[i+di, j+dj, k+dk]
// (its kernel map walks Coord(kz, ky, kx) and flattens the weight with
// permute(4,3,2,1,0); conventions §8.1). The engine's sparse kernels take the
// weight in grid order [out, in, di, dj, dk], so every 3^3 weight is
// transposed here once. Later fVDB releases (0.4.2) put K0 along i; a
// checkpoint trained with them would need FvdbKernelOrder::GridOrder.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/safetensors.h"
#include "nn/vae_config.h"
#include "nn/weights.h"

#include <map>
#include <string>

namespace icube::nn {

enum class FvdbKernelOrder { Fvdb020Reversed, GridOrder };

// W[o][c][a][b][e] (stored, fVDB 0.2.0) -> G[o][c][e][b][a] (grid order): the first and last kernel axes swap.
CpuTensor fvdb020_kernel_to_grid_order(const CpuTensor& w);

std::map<std::string, CpuTensor> load_vae_weights_cpu(const SafetensorsFile& file, const VaeConfig& config, VaePart part,
                                                      WeightOptions options = {},
                                                      FvdbKernelOrder order = FvdbKernelOrder::Fvdb020Reversed);

}  // namespace icube::nn
