// The packed convolution weights every conv kernel binds ([k][output channels
// padded to 8], kernels/nn/conv3d.h: pack_conv3d_weights / _f16): fp32 vec4s,
// or with NN_CONV_F16_WEIGHTS uvec4s of 8 halves (unpacked in the shader: no
// 16-bit storage feature needed), at binding NN_CONV_WEIGHTS_BINDING (defined
// by the includer); and the register kernels' reads of 8 output channels.
// Expects the push constants `p` (co_begin, co_vec4s) declared before.
#ifdef NN_CONV_F16_WEIGHTS
layout(std430, binding = NN_CONV_WEIGHTS_BINDING) readonly buffer Weights { uvec4 w_packed[]; };
#else
layout(std430, binding = NN_CONV_WEIGHTS_BINDING) readonly buffer Weights { vec4 w_packed[]; };
#endif

// A packed weight row's length in w_packed elements.
uint conv_weight_row_len() {
#ifdef NN_CONV_F16_WEIGHTS
  return p.co_vec4s / 2u;
#else
  return p.co_vec4s;
#endif
}

// The element of 8-channel block `block` (from p.co_begin, a multiple of 8 with fp16 weights) in a row.
uint conv_weight_column(uint block) {
#ifdef NN_CONV_F16_WEIGHTS
  return p.co_begin / 8u + block;
#else
  return p.co_begin / 4u + 2u * block;
#endif
}

// The 8 output channels' weights at element i (from conv_weight_column), as two vec4s.
void conv_weights8(uint i, out vec4 lo, out vec4 hi) {
#ifdef NN_CONV_F16_WEIGHTS
  const uvec4 wh = w_packed[i];
  lo = vec4(unpackHalf2x16(wh.x), unpackHalf2x16(wh.y));
  hi = vec4(unpackHalf2x16(wh.z), unpackHalf2x16(wh.w));
#else
  lo = w_packed[i];
  hi = w_packed[i + 1u];
#endif
}
