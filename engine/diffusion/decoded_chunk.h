// A VAE decode as a generated chunk (world/generator.h ChunkVoxels): every
// finest voxel takes the argmax of its 23 class logits (ties to the lower
// class); class 0 ("undefined") is left out, as the engine's 0 is empty. The
// lattice is the decoder's (fVDB centres ijk * vs + origin) placed by
// `chunk_to_world` (the chunk frame; identity leaves it in the VAE's frame).
#pragma once

#include "nn/vae_reference.h"
#include "world/generator.h"

#include <cstdint>

namespace icube::diffusion {

world::ChunkVoxels decoded_chunk(const nn::VaeDecoded& d, const glm::dmat4& chunk_to_world, uint64_t* undefined = nullptr);

}  // namespace icube::diffusion
