// Which family of network kernels a device runs: lavapipe's (register tiles,
// texel gathers, no shared memory: conv3d.comp, sparse_conv.comp,
// attention.comp) or the GPUs' (shared-memory tiles, cooperative matrices:
// conv3d_tiled / conv3d_coopmat, sparse_conv_tiled, attention_tiled). CPU devices
// take lavapipe's, every other device the GPUs'. ICUBE_NN_KERNELS=lavapipe|gpu
// overrides it: benchmarks time the old kernels against the new on one GPU, and
// tests run the GPU family end to end on lavapipe. Each kernel's host module
// applies it to its own default (kernels/nn/conv3d.h, sparse_conv.h, attention.h).
#pragma once

namespace icube::gpu {
struct DeviceInfo;
}

namespace icube::kernels::nn {

enum class KernelFamily { kLavapipe, kGpu };

// std::invalid_argument on an ICUBE_NN_KERNELS value other than lavapipe or gpu.
KernelFamily kernel_family(const gpu::DeviceInfo& device);

}  // namespace icube::kernels::nn
