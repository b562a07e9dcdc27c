// How a kernel forms its subgroup ballots and votes: with the subgroup
// intrinsics, or as ORs of constant-index shuffles (shaders/common/
// lane_shuffles.glsl). lavapipe runs subgroupBallot / subgroupAny as a scalar
// loop over the lanes with a store and a branch per lane, where a constant-lane
// shuffle is one vpermd; on GPUs the intrinsics are single instructions. Used
// by the radix sort (digit matches) and the splatting blend (ballots, votes).
#pragma once

#include "gpu/context.h"

#include <stdexcept>
#include <string>

namespace icube::kernels {

// Auto: shuffles on CPU devices (VK_PHYSICAL_DEVICE_TYPE_CPU) where the kernel's subgroup
// fits them, the intrinsics elsewhere. Tests force each path on any device.
enum class SubgroupOps { Auto, Intrinsics, Shuffles };

// The lane count to specialise a kernel's shuffle path with, or 0 for the intrinsics.
// `fits`: the device's subgroup suits the kernel's shuffle path (all lanes active, at most as
// many lanes as it reduces over); forcing Shuffles where it does not is an error naming `what`.
inline uint32_t shuffle_lanes(const gpu::Context& ctx, SubgroupOps ops, bool fits, const std::string& what) {
  const uint32_t sg = ctx.subgroup_size();
  if (ops == SubgroupOps::Shuffles && !fits)
    throw std::runtime_error(what + ": ballots and votes by shuffles do not suit this device's subgroup of " +
                             std::to_string(sg) + " lanes");
  const bool cpu = ctx.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  return ops == SubgroupOps::Shuffles || (ops == SubgroupOps::Auto && cpu && fits) ? sg : 0u;
}

}  // namespace icube::kernels
