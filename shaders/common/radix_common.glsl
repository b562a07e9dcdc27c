// Shared pieces of the LSD radix sort (8-bit digits, one subgroup per tile).
// Define KEY64 before including for uint64 keys stored as uvec2 (x = low word).
#ifndef ICUBE_RADIX_COMMON_GLSL
#define ICUBE_RADIX_COMMON_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require

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

// Ballot of the lanes whose digit equals this lane's digit (among valid lanes).
// Eight ballots, one per digit bit; ~ballot is masked by the valid ballot so
// bits past the subgroup never leak in. Works for any subgroup size <= 128.
uvec4 match_digit(uint d, bool valid) {
  uvec4 m = subgroupBallot(valid);
  for (uint b = 0u; b < RADIX_BITS; ++b) {
    bool bit = ((d >> b) & 1u) != 0u;
    uvec4 ballot = subgroupBallot(bit);
    m &= bit ? ballot : ~ballot;
  }
  return m;
}
#endif
