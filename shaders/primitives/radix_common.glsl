// Shared pieces of the LSD radix sort (8-bit digits, one subgroup per tile).
// Define KEY64 before including for uint64 keys stored as uvec2 (x = low word).
#ifndef ICUBE_RADIX_COMMON_GLSL
#define ICUBE_RADIX_COMMON_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
#include "common/lane_shuffles.glsl"

#define RADIX_BITS 8u
#define RADIX_SIZE 256u

#ifdef KEY64
#define KEY_T uvec2
uint key_digit(uvec2 k, uint shift) {
  return shift >= 32u ? (k.y >> (shift - 32u)) & 0xffu : (k.x >> shift) & 0xffu;
}
#else
#define KEY_T uint
uint key_digit(uint k, uint shift) { return (k >> shift) & 0xffu; }
#endif

// CPU devices (lavapipe): the subgroup size (<= 32), and match_digit compares the lanes'
// digits fetched by constant-index shuffles (one vpermd each on lavapipe, where a
// subgroupBallot is a scalar loop over the lanes). 0 (GPUs): eight ballots.
layout(constant_id = 2) const uint RADIX_LANES = 0;

// Ballot of the lanes whose digit equals this lane's digit (among valid lanes).
// GPUs: eight ballots, one per digit bit; ~ballot is masked by the valid ballot so
// bits past the subgroup never leak in. Works for any subgroup size <= 128.
// CPU devices (RADIX_LANES > 0): lanes_shuffle_equal of the digit, invalid lanes carrying
// a value no digit has.
uvec4 match_digit(uint d, bool valid) {
  if (RADIX_LANES > 0u) {
    const uint m = lanes_shuffle_equal(valid ? d : 0xFFFFFFFFu, RADIX_LANES);
    return uvec4(valid ? m : 0u, 0u, 0u, 0u);
  }
  uvec4 m = subgroupBallot(valid);
  for (uint b = 0u; b < RADIX_BITS; ++b) {
    bool bit = ((d >> b) & 1u) != 0u;
    uvec4 ballot = subgroupBallot(bit);
    m &= bit ? ballot : ~ballot;
  }
  return m;
}
#endif
