#version 460
#extension GL_GOOGLE_include_directive : require
// radix_count32: per-tile digit histogram for one LSD radix pass over uint32 keys.
//
// hist[d * num_tiles + t] = number of keys in tile t whose 8-bit digit at
// bit `shift` equals d. Digit-major layout, so one exclusive scan of hist
// gives every (digit, tile) its first output slot and the sort stays stable.
// One workgroup is one subgroup (local_size_x = subgroup size, pinned by the
// host). Per batch the lanes find equal digits with ballots; the highest lane
// of each group adds the group's count to a shared counter, so no atomics.
// Body: shaders/primitives/radix_count.glsl. Host module and CPU reference:
// kernels/radix_sort.{h,cpp}. Tests: tests/primitives/test_radix_sort.cpp.

#include "primitives/radix_count.glsl"
