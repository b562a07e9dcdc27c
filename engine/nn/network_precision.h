// How a GPU network stores its numbers (UNetGpu and VaeGpu take it; the CLI's
// --precision names it):
//   F32         fp32 everywhere.
//   F16Weights  convolution and linear weights stored as fp16
//               (ParameterStoreOptions::f16_matrices: half the weight memory
//               and bandwidth, the kernels' fp16-weight paths, tensor cores
//               where the device has them).
//   F16         F16Weights, and the convolutions' input operands stored as fp16
//               too: the GroupNorm and LayerNorm outputs that every
//               convolution and linear of the UNet and VAE reads (half the
//               bytes of the GEMMs' gathered operand and of the norms'
//               stores; LayerRecorder::set_f16_conv_operands). The tensor-core
//               kernels round that operand to fp16 anyway, so there this
//               changes no result.
// Accumulation, norms' statistics, softmax, biases, the residual stream and
// every other activation stay fp32.
#pragma once

#include <stdexcept>
#include <string>

namespace icube::nn {

enum class NetworkPrecision { F32, F16Weights, F16 };

inline bool f16_weights(NetworkPrecision p) { return p != NetworkPrecision::F32; }
inline bool f16_conv_operands(NetworkPrecision p) { return p == NetworkPrecision::F16; }

// The command-line names: fp32, fp16-weights, fp16.
inline const char* network_precision_name(NetworkPrecision p) {
  return p == NetworkPrecision::F32 ? "fp32" : p == NetworkPrecision::F16Weights ? "fp16-weights" : "fp16";
}
inline NetworkPrecision parse_network_precision(const std::string& name) {
  for (const NetworkPrecision p : {NetworkPrecision::F32, NetworkPrecision::F16Weights, NetworkPrecision::F16})
    if (name == network_precision_name(p)) return p;
  throw std::invalid_argument("precision '" + name + "' (fp32, fp16-weights or fp16)");
}
// The same for a command with --backend gpu|cpu: anything but fp32 runs on the GPU backend only (the CPU
// reference is exact).
inline NetworkPrecision parse_network_precision(const std::string& name, const std::string& backend) {
  if (name != "fp32" && backend != "gpu")
    throw std::invalid_argument("--precision " + name + " runs on the GPU backend only (the CPU reference is exact)");
  return parse_network_precision(name);
}
// The --precision option's help text.
inline const char* network_precision_help() {
  return "fp32; fp16-weights: convolution and linear weights stored as fp16 (fp32 activations and accumulation); "
         "fp16: fp16 weights and fp16 convolution operands (the norms' outputs), fp32 accumulation and residuals";
}

}  // namespace icube::nn
