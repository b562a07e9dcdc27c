// Exact float32 <-> float16 / bfloat16 conversions on the host: the
// .safetensors reader's F16/BF16 tensors and the fp16 weight storage of the
// network kernels (pack_conv3d_weights_f16). Tests: tests/nn/test_safetensors.cpp.
#pragma once

#include <cstdint>

namespace icube::nn {

// float_to_half and float_to_bf16 round to nearest even (overflow to inf, NaN
// stays NaN); half_to_float and bf16_to_float are exact.
float half_to_float(uint16_t h);
float bf16_to_float(uint16_t b);
uint16_t float_to_half(float f);
uint16_t float_to_bf16(float f);

}  // namespace icube::nn
