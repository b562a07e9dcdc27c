// The output element of the normalisation kernels (group_norm_apply, layer_norm):
// float, or float16_t with NN_NORM_F16_OUTPUT (the including .comp enables
// GL_EXT_shader_16bit_storage). norm_store_t(v) converts an fp32 value to it.
#ifdef NN_NORM_F16_OUTPUT
#define norm_store_t float16_t
#else
#define norm_store_t float
#endif
