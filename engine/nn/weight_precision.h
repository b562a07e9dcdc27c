// How a GPU network stores its convolution and linear weights: fp32, or fp16
// (ParameterStoreOptions::f16_matrices: half the weight memory and bandwidth,
// the kernels' fp16-weight paths, tensor cores where the device has them;
// accumulation, norms, softmax and biases stay fp32). UNetGpu and VaeGpu take it.
#pragma once

namespace icube::nn {

enum class WeightPrecision { F32, F16Weights };

}  // namespace icube::nn
