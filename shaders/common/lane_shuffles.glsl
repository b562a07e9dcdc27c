// Subgroup reductions built from constant-index shuffles, for CPU devices: on
// lavapipe a subgroupShuffle with a constant (or uniform) lane is one vpermd,
// while subgroupBallot / subgroupAny are scalar loops over the lanes with a
// store and a branch per lane. `lanes` must be a constant (a spec constant,
// <= 32) so that the guards fold away after specialisation, and every lane
// 0 .. lanes-1 must be active. Kernels keep the intrinsics on GPUs (the host
// module picks the path: kernels/subgroup_ops.h). Used by splat/blend.comp and
// primitives/radix_common.glsl.
#ifndef ICUBE_LANE_SHUFFLES_GLSL
#define ICUBE_LANE_SHUFFLES_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle : require

// R = TERM(0) | TERM(1) | ... | TERM(lanes - 1), written out so no loop is left.
#define ICUBE_LANES_OR(TERM, LANES, R)                                                     \
  {                                                                                        \
    R = TERM(0u);                                                                          \
    if (LANES > 1u) R |= TERM(1u);                                                         \
    if (LANES > 2u) R |= TERM(2u) | TERM(3u);                                              \
    if (LANES > 4u) R |= TERM(4u) | TERM(5u) | TERM(6u) | TERM(7u);                        \
    if (LANES > 8u)                                                                        \
      R |= TERM(8u) | TERM(9u) | TERM(10u) | TERM(11u) | TERM(12u) | TERM(13u) | TERM(14u) | \
           TERM(15u);                                                                      \
    if (LANES > 16u)                                                                       \
      R |= TERM(16u) | TERM(17u) | TERM(18u) | TERM(19u) | TERM(20u) | TERM(21u) | TERM(22u) | \
           TERM(23u) | TERM(24u) | TERM(25u) | TERM(26u) | TERM(27u) | TERM(28u) | TERM(29u) | \
           TERM(30u) | TERM(31u);                                                          \
  }

// OR of v over the lanes.
uint lanes_shuffle_or(uint v, uint lanes) {
#define ICUBE_LANE_WORD(L) subgroupShuffle(v, L)
  uint r;
  ICUBE_LANES_OR(ICUBE_LANE_WORD, lanes, r)
#undef ICUBE_LANE_WORD
  return r;
}

// Bit l set where lane l's word equals v.
uint lanes_shuffle_equal(uint v, uint lanes) {
#define ICUBE_LANE_EQUAL(L) (subgroupShuffle(v, L) == v ? 1u << L : 0u)
  uint r;
  ICUBE_LANES_OR(ICUBE_LANE_EQUAL, lanes, r)
#undef ICUBE_LANE_EQUAL
  return r;
}

#endif
